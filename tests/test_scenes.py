"""Rooms and kitchens: determinism, occupancy vs footprints, reachability, item placement."""
from functools import lru_cache

import networkx as nx
import numpy as np
import pytest

from hoi_tutorial.world.scenes import FOOTPRINT_BAND, Room, make_kitchen, make_room


@lru_cache(maxsize=None)
def room(seed=0):
    return make_room(seed)


@lru_cache(maxsize=None)
def kitchen(seed=0):
    return make_kitchen(seed)


def _poses(scene):
    return np.stack([o.pose for o in scene.objects])


def test_room_is_deterministic_for_a_seed():
    a, b = make_room(4), make_room(4)
    assert [o.category for o in a.objects] == [o.category for o in b.objects]
    assert np.array_equal(_poses(a), _poses(b))
    assert np.array_equal(a.occupancy, b.occupancy)
    c = make_room(5)
    assert len(c.objects) != len(a.objects) or not np.allclose(_poses(a), _poses(c))
    assert a.target.category == "chair" and make_room(4, target_category="sofa").target.category == "sofa"
    with pytest.raises(ValueError, match="target_category: expected one of"):
        make_room(0, target_category="bottle")


def test_grid_and_world_coordinates_round_trip():
    r = room()
    ij = np.array([[0, 0], [3, 7], [r.shape[0] - 1, r.shape[1] - 1]])
    xy = r.grid_to_world(ij)
    assert np.allclose(xy[1], [(7 + 0.5) * r.cell_size, (3 + 0.5) * r.cell_size])  # row ↔ y, column ↔ x
    assert np.array_equal(r.world_to_grid(xy), ij)
    assert r.shape == (120, 120)


def test_occupancy_matches_object_footprints():
    """A free cell centre has no object above it in the body band; a blocked one has an object
    part right above it (checked with the 3D SDF on a vertical line of samples)."""
    r = room(1)
    rng = np.random.default_rng(0)
    blocked, free = np.argwhere(r.occupancy), np.argwhere(~r.occupancy)
    assert len(blocked) > 50
    cells = np.concatenate([blocked[rng.choice(len(blocked), 300)], free[rng.choice(len(free), 300)]])
    xy = r.grid_to_world(cells)
    z = np.arange(0.0, 2.0, 0.02)
    column = np.concatenate([np.repeat(xy, len(z), 0), np.tile(z, len(xy))[:, None]], axis=1)
    sdf = np.min(np.stack([o.sdf(column) for o in r.objects]), axis=0).reshape(len(xy), len(z))
    is_blocked = r.occupancy[cells[:, 0], cells[:, 1]]
    band = (z >= FOOTPRINT_BAND[0]) & (z <= FOOTPRINT_BAND[1])
    assert np.all(sdf[~is_blocked][:, band] > 0)
    assert np.all(sdf[is_blocked].min(axis=1) <= 0.01)
    assert np.array_equal(r.is_free(xy), ~is_blocked)


def test_objects_do_not_overlap():
    for scene in (room(2), kitchen(2)):
        objs = scene.objects if scene is room(2) else scene.furniture + scene.obstacles
        for k, obj in enumerate(objs):
            pts = obj.surface_points(300, seed=k)
            for other in objs[:k] + objs[k + 1:]:
                assert np.all(other.sdf(pts) > 0), (obj.category, other.category)


def test_inflated_occupancy_grows_with_radius():
    r = room()
    small, large = r.inflated_occupancy(0.1), r.inflated_occupancy(0.4)
    assert np.all(small >= r.occupancy) and np.all(large >= small) and large.sum() > small.sum()
    assert large[0].all() and large[:, -1].all()  # cells next to the walls


@pytest.mark.parametrize("seed", [0, 3])
def test_start_positions_are_free_and_reach_the_target(seed):
    r = room(seed)
    clearance = 0.3
    starts = r.start_positions(8, seed=1, clearance=clearance)
    assert starts.shape == (8, 2)
    assert np.all(r.obstacle_distance(starts) >= clearance)
    # the exact 3D scene SDF (objects and walls) over the body's height agrees
    z = np.linspace(*FOOTPRINT_BAND, 20)
    pts = np.concatenate([np.repeat(starts, len(z), 0), np.tile(z, len(starts))[:, None]], axis=1)
    assert np.all(r.sdf(pts) >= clearance - 1e-9)
    # independent breadth-first search (networkx) on the grid inflated by the clearance
    free = ~r.inflated_occupancy(clearance)
    graph = nx.grid_2d_graph(*free.shape)
    graph.remove_nodes_from([tuple(c) for c in np.argwhere(~free)])
    goal = tuple(r.world_to_grid(r.approach_point(0, clearance)))
    for start in r.world_to_grid(starts):
        assert nx.has_path(graph, tuple(start), goal)
    assert r.reachable_fraction() >= 0.5
    assert np.array_equal(r.start_positions(8, seed=1, clearance=clearance), starts)


def test_approach_point_is_in_front_of_the_seat():
    r = room()
    positions, directions = r.target.sit_goals
    point = r.approach_point(0)
    offset = point - positions[0, :2]
    assert offset @ directions[0, :2] == pytest.approx(np.linalg.norm(offset))
    assert r.obstacle_distance(point) >= r.body_radius


def test_scene_sdf_includes_walls():
    r = room()
    probe = np.array([[0.02, 3.0, 1.0], [3.0, -0.03, 1.0], [-0.5, 3.0, 1.0]])
    d = r.sdf(probe)
    assert d[0] == pytest.approx(0.02, abs=1e-9) and d[1] < 0 and d[2] > 0  # beyond the wall box


def test_kitchen_items_sit_in_or_on_their_holders():
    for seed in range(3):
        k = kitchen(seed)
        assert [f.category for f in k.furniture] == ["shelf", "cabinet", "drawer", "table"]
        assert len(k.items) == 4 and len(k.holders) == 4
        for item, h in zip(k.items, k.holders):
            base = item.translation
            lo, hi = k.furniture[h].bounds
            assert np.all(base >= lo - 1e-9) and np.all(base <= hi + 1e-9)
            # resting on a surface: touching the holder, not inside it
            assert k.furniture[h].sdf(base[None])[0] == pytest.approx(0.0, abs=1e-6)
            pts = item.surface_points(200, seed=0)
            assert np.all(k.furniture[h].sdf(pts) > -1e-6)
            for other in k.items:
                if other is not item:
                    assert np.all(other.sdf(pts) > -1e-6)


def test_kitchen_states_obstacles_and_determinism():
    k = make_kitchen(7, door_angle=1.1, drawer_open=0.2)
    assert k.furniture_of("cabinet").params["door_angle"] == 1.1
    assert k.furniture_of("drawer").params["drawer_open"] == 0.2
    again = make_kitchen(7, door_angle=1.1, drawer_open=0.2)
    assert np.array_equal(_poses(k), _poses(again))
    item = k.items[0]
    near = k.obstacles_near(item.translation + np.array([0.0, 0.0, 0.01]), 0.05, exclude=[item])
    assert any(o is k.holder_of(0) for o, _ in near)
    assert all(o is not item for o, _ in near)
    assert [d for _, d in near] == sorted(d for _, d in near)
    assert 1 <= len(k.obstacles) <= 3
    assert k.occupancy.shape == (100, 100) and k.occupancy.any()
    starts = k.start_positions(4, seed=0, clearance=0.3)
    assert np.all(k.obstacle_distance(starts) >= 0.3)


def test_a_room_comes_back_from_its_layout_as_made(tmp_cache):
    from hoi_tutorial.infra import load_or_build
    from hoi_tutorial.world.scenes import room_from_layout, room_layout

    room = make_room(3, n_clutter=5)

    def layout():
        return room_layout(room)

    stored = load_or_build("room_layout_round_trip", {"seed": 3}, layout)  # built
    back = room_from_layout(load_or_build("room_layout_round_trip", {"seed": 3}, layout))  # loaded
    remade = room_from_layout(stored)
    for other in (back, remade):
        assert other.shape == room.shape and other.target_index == room.target_index
        np.testing.assert_array_equal(other.size, room.size)
        np.testing.assert_array_equal(other.occupancy, room.occupancy)
        np.testing.assert_array_equal(other.clearance, room.clearance)
        points = np.random.default_rng(0).uniform([0, 0, 0], [*room.size, 1.5], (200, 3))
        np.testing.assert_array_equal(other.sdf(points), room.sdf(points))
        np.testing.assert_array_equal(other.obstacle_distance(points[:, :2]), room.obstacle_distance(points[:, :2]))
        assert [(o.category, o.params) for o in other.objects] == [(o.category, o.params) for o in room.objects]
    # the stored grid is the one a room computes from its objects
    np.testing.assert_array_equal(Room(room.size, back.objects, room.target_index)._footprint_grid,
                                  back._footprint_grid)
    with pytest.raises(ValueError, match="room_layout"):
        room_from_layout({"size": room.size})
    with pytest.raises(ValueError, match="footprint_grid"):
        room_from_layout({**stored, "footprint_grid": stored["footprint_grid"][1:]})
    with pytest.raises(TypeError, match="Room"):
        room_layout(stored)
