"""SAMP path planning (§3.3, Appendix E): A* against networkx, waypoints, string pulling, rooms."""
import math
from functools import lru_cache

import networkx as nx
import numpy as np
import pytest

from hoi_tutorial.samp.planning import (
    PlannedPath,
    astar,
    line_of_sight,
    path_cost,
    plan_path,
    shortcut_waypoints,
    turning_points,
)
from hoi_tutorial.samp import planning
from hoi_tutorial.world.scenes import make_room


def grid_graph(blocked, diagonal=True):
    return planning.networkx_grid_graph(blocked, diagonal=diagonal)


def octile(u, v):
    return planning.grid_distance(u, v)


def manhattan(u, v):
    return planning.grid_distance(u, v, diagonal=False)


def assert_valid_path(path, blocked, start, goal, diagonal=True):
    arr = np.asarray(path)
    assert tuple(arr[0]) == tuple(start) and tuple(arr[-1]) == tuple(goal)
    assert not blocked[arr[:, 0], arr[:, 1]].any()
    steps = np.abs(np.diff(arr, axis=0))
    assert np.all(steps.max(axis=1) == 1) if len(arr) > 1 else True
    if not diagonal:
        assert np.all(steps.sum(axis=1) == 1)
    for (i, j), (a, b) in zip(path[:-1], path[1:]):
        if i != a and j != b:  # a diagonal step never cuts a blocked corner
            assert not blocked[a, j] and not blocked[i, b]


@pytest.mark.parametrize("diagonal", [True, False])
def test_astar_cost_matches_networkx_on_random_grids(diagonal):
    rng = np.random.default_rng(0 if diagonal else 1)
    checked, wanted = 0, 60 if diagonal else 25
    for _ in range(400):
        if checked >= wanted:
            break
        H, W = rng.integers(10, 41, size=2)
        blocked = rng.random((H, W)) < rng.uniform(0.0, 0.35)
        free = np.argwhere(~blocked)
        if len(free) < 2:
            continue
        start, goal = (tuple(int(v) for v in free[k]) for k in rng.choice(len(free), 2, replace=False))
        graph = grid_graph(blocked, diagonal)
        if not nx.has_path(graph, start, goal):
            continue
        path = astar(blocked, start, goal, diagonal=diagonal)
        reference = nx.astar_path_length(graph, start, goal, heuristic=octile if diagonal else manhattan,
                                         weight="weight")
        assert path_cost(path) == pytest.approx(reference, abs=1e-9)
        assert_valid_path(path, blocked, start, goal, diagonal)
        checked += 1
    assert checked == wanted


def test_astar_is_deterministic_and_optimal_in_an_empty_grid():
    blocked = np.zeros((12, 20), dtype=bool)
    path = astar(blocked, (1, 2), (9, 17))
    assert path == astar(blocked, (1, 2), (9, 17))
    assert path_cost(path) == pytest.approx(8 * math.sqrt(2.0) + 7)
    assert astar(blocked, (3, 3), (3, 3)) == [(3, 3)]
    assert path_cost(astar(blocked, (0, 0), (5, 7), diagonal=False)) == 12


def test_astar_does_not_cut_corners():
    blocked = np.zeros((3, 3), dtype=bool)
    blocked[0, 1] = True
    path = astar(blocked, (0, 0), (1, 1))
    assert path == [(0, 0), (1, 0), (1, 1)]  # the direct diagonal would graze the blocked cell


def test_astar_errors_are_clear():
    blocked = np.zeros((10, 10), dtype=bool)
    blocked[:, 5] = True  # a wall splitting the grid
    with pytest.raises(ValueError, match="unreachable"):
        astar(blocked, (2, 2), (2, 8))
    with pytest.raises(ValueError, match=r"goal \(4, 5\) lies inside an obstacle"):
        astar(blocked, (2, 2), (4, 5))
    with pytest.raises(ValueError, match="start.*obstacle"):
        astar(blocked, (0, 5), (2, 2))
    with pytest.raises(ValueError, match=r"start: cell \(10, 0\) is outside the grid of shape \(10, 10\)"):
        astar(blocked, (10, 0), (2, 2))
    with pytest.raises(ValueError, match="goal.*outside"):
        astar(blocked, (2, 2), (-1, 3))
    with pytest.raises(ValueError, match=r"blocked: expected an \(H, W\) bool"):
        astar(np.zeros((10, 10, 2), dtype=bool), (0, 0), (1, 1))
    with pytest.raises(ValueError, match="dtype float64"):
        astar(np.zeros((10, 10)), (0, 0), (1, 1))
    with pytest.raises(ValueError, match="two ints"):
        astar(blocked, (0.5, 1), (1, 1))


def test_turning_points_of_an_l_shaped_path():
    path = [(0, 0), (0, 1), (0, 2), (0, 3), (1, 3), (2, 3)]
    assert turning_points(path) == [(0, 0), (0, 3), (2, 3)]
    assert turning_points([(4, 4)]) == [(4, 4)]
    assert turning_points([(0, 0), (1, 1), (2, 2)]) == [(0, 0), (2, 2)]


def test_line_of_sight_supercover():
    blocked = np.zeros((5, 5), dtype=bool)
    assert line_of_sight(blocked, (0, 0), (4, 4))
    blocked[1, 2] = True
    assert not line_of_sight(blocked, (0, 0), (2, 4))  # passes through (1, 2)
    assert not line_of_sight(blocked, (0, 1), (2, 3))  # exactly through the corner beside (1, 2)
    assert line_of_sight(blocked, (0, 0), (4, 0))
    assert not line_of_sight(blocked, (1, 2), (1, 2))


def test_shortcut_waypoints():
    empty = np.zeros((20, 30), dtype=bool)
    path = astar(empty, (2, 1), (15, 27))
    assert shortcut_waypoints(empty, path) == [(2, 1), (15, 27)]

    blocked = np.zeros((20, 30), dtype=bool)
    blocked[3:17, 12:16] = True  # a block between start and goal
    path = astar(blocked, (10, 2), (10, 27))
    way = shortcut_waypoints(blocked, path)
    assert len(way) >= 3 and way[0] == (10, 2) and way[-1] == (10, 27)
    assert all(line_of_sight(blocked, a, b) for a, b in zip(way[:-1], way[1:]))
    assert path_cost(way) <= path_cost(path) + 1e-9
    assert set(way) <= set(path)


@lru_cache(maxsize=None)
def room(seed=3):
    return make_room(seed)


def test_plan_path_in_a_room_keeps_clearance():
    r = room()
    start = r.start_positions(1, seed=0)[0]
    goal = r.approach_point(0)
    plan = plan_path(r, start, goal)
    assert isinstance(plan, PlannedPath)
    blocked = r.inflated_occupancy(r.body_radius)
    assert not blocked[plan.cells[:, 0], plan.cells[:, 1]].any()
    assert np.all(r.clearance[plan.cells[:, 0], plan.cells[:, 1]] >= r.body_radius)
    assert np.allclose(plan.points, r.grid_to_world(plan.cells))
    assert np.allclose(plan.waypoints[0], start) and np.allclose(plan.waypoints[-1], goal)
    # shortcutting never lengthens; the exact end points replace their cells' centres
    ends = np.linalg.norm(start - plan.points[0]) + np.linalg.norm(goal - plan.points[-1])
    assert plan.length <= plan.grid_cost + ends + 1e-9
    assert plan.length == pytest.approx(np.linalg.norm(np.diff(plan.waypoints, axis=0), axis=1).sum())
    corners = plan_path(r, start, goal, shortcut=False)
    assert len(corners.waypoints) >= len(plan.waypoints)
    assert corners.grid_cost == pytest.approx(plan.grid_cost)


@pytest.mark.parametrize("seed", [2, 6])
def test_plan_path_reaches_approach_points_whose_cell_centre_is_too_close(seed):
    # the approach point has clearance >= radius, its cell's centre (up to cell/√2 away) may not
    r = make_room(seed)
    goal = r.approach_point(0)
    assert r.inflated_occupancy(r.body_radius)[tuple(r.world_to_grid(goal))]
    plan = plan_path(r, r.start_positions(1, seed=seed)[0], goal)
    assert np.allclose(plan.waypoints[-1], goal)
    assert not r.inflated_occupancy(r.body_radius)[plan.cells[:, 0], plan.cells[:, 1]].any()
    assert np.linalg.norm(plan.points[-1] - goal) < 1.6 * r.cell_size


def test_plan_path_errors_are_clear():
    r = room()
    goal = r.approach_point(0)
    lx, ly = r.size
    with pytest.raises(ValueError, match=rf"start: expected a floor point inside the room \[0, {lx}\] × \[0, {ly}\] m"):
        plan_path(r, (lx + 1.0, 1.0), goal)
    with pytest.raises(ValueError, match="goal: expected a floor point inside the room"):
        plan_path(r, goal, (-0.5, 1.0))
    seat = r.target.sit_goals[0][0, :2]
    with pytest.raises(ValueError, match="goal .* lies inside an obstacle.*approach_point"):
        plan_path(r, goal, seat)
    with pytest.raises(ValueError, match="start .* lies inside an obstacle"):
        plan_path(r, (0.01, 0.01), goal)  # against two walls


def test_plan_path_unreachable_goal():
    r = room()
    free = ~r.inflated_occupancy(r.body_radius)
    reach = r.free_component(r.approach_point(0), r.body_radius)
    # 4- and 8-connected components can differ only through diagonal gaps; look for an 8-isolated free cell
    others = np.argwhere(free & ~reach)
    start = r.approach_point(0)
    for cell in others:
        try:
            plan_path(r, start, r.grid_to_world(cell))
        except ValueError as exc:
            if "unreachable" in str(exc):
                break
    else:
        pytest.skip("every free cell of this room is reachable")
    with pytest.raises(ValueError, match="unreachable"):
        plan_path(r, start, r.grid_to_world(cell))


@pytest.mark.parametrize("seed", [0, 3, 7])
def test_reaches_agrees_with_plan_path(seed):
    r = room(seed)
    goal = r.approach_point(0)
    # starts that reach the goal and free cells anywhere (some of them cut off from it)
    free_cells = np.argwhere(~r.inflated_occupancy(r.body_radius))[::97]
    starts = np.vstack([r.start_positions(20, seed=seed), r.grid_to_world(free_cells)])
    expected = []
    for xy in starts:
        try:
            plan_path(r, xy, goal)
            expected.append(True)
        except ValueError:
            expected.append(False)
    np.testing.assert_array_equal(planning.reaches(r, starts, goal), expected)
    assert not planning.reaches(r, [[r.size[0] + 1.0, 1.0]], goal).any()  # outside the room


def test_draw_path_draws_cells_and_waypoints():
    import matplotlib.pyplot as plt

    from hoi_tutorial.samp.planning import draw_path

    r = room()
    plan = plan_path(r, r.start_positions(1, seed=1)[0], r.approach_point(0))
    fig, ax = plt.subplots()
    try:
        assert draw_path(r, plan, ax) is ax
        assert len(ax.lines) >= 2
    finally:
        plt.close(fig)


@pytest.mark.parametrize("seed", [0, 3])
def test_approach_point_agrees_with_the_rooms_own(seed):
    room = make_room(seed)
    positions, directions = room.target.sit_goals
    ours = planning.approach_point(room, positions[0], directions[0])
    np.testing.assert_allclose(ours, room.approach_point(0), atol=1e-9)
    assert room.obstacle_distance(ours) >= room.body_radius
    with pytest.raises(ValueError, match="ground-plane"):
        planning.approach_point(room, positions[0], [0.0, 0.0, 1.0])


class _GridRoom:
    """A room given by its inflated grid alone (1 m cells, body radius 0): what the planning functions read."""

    def __init__(self, blocked):
        self.blocked = np.asarray(blocked, dtype=bool)
        self.cell_size, self.body_radius = 1.0, 0.0
        self.size = np.array([self.blocked.shape[1], self.blocked.shape[0]], dtype=float)

    def inflated_occupancy(self, radius):
        return self.blocked

    def obstacle_distance(self, xy):
        i, j = self.world_to_grid(xy)
        return -1.0 if self.blocked[i, j] else 1.0

    def world_to_grid(self, xy):
        return np.floor(np.asarray(xy, dtype=float)[..., ::-1]).astype(np.int64)

    def grid_to_world(self, ij):
        return (np.asarray(ij)[..., ::-1].astype(float) + 0.5)


def test_reaches_keeps_apart_regions_that_touch_only_at_a_corner():
    # Free cells (0, 0)-(1, 1) and (2, 2)-(3, 3) meet at one corner: astar never steps across it.
    blocked = np.ones((4, 4), dtype=bool)
    blocked[:2, :2] = False
    blocked[2:, 2:] = False
    r = _GridRoom(blocked)
    assert not planning.reaches(r, [[0.5, 0.5]], [3.5, 3.5])[0]
    with pytest.raises(ValueError, match="unreachable"):
        plan_path(r, (0.5, 0.5), (3.5, 3.5))
    assert planning.reaches(r, [[0.5, 0.5], [1.5, 0.5]], [1.5, 1.5]).all()


def test_simplify_waypoints_merges_short_legs_and_slight_turns_where_the_walk_is_free():
    r = _GridRoom(np.zeros((10, 10), dtype=bool))
    wiggly = np.array([[0.5, 0.5], [2.5, 0.6], [2.8, 0.7], [5.5, 0.5], [5.5, 5.5]])
    out = planning.simplify_waypoints(r, wiggly, min_leg=0.5, min_turn_deg=20.0)
    np.testing.assert_allclose(out[0], wiggly[0]) and np.testing.assert_allclose(out[-1], wiggly[-1])
    legs = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert legs.min() >= 0.5 and len(out) == 3  # the 0.3 m leg and the 2-4° turns are gone; the 90° turn stays
    np.testing.assert_allclose(out[1], [5.5, 0.5])
    # Rounding a block's corner (x < 6, y > 3) in two short legs: the chord cuts the block, so the two waypoints
    # become the one corner where the lines of the legs before and after them meet.
    blocked = np.zeros((10, 10), dtype=bool)
    blocked[3:, :6] = True
    rounded = np.array([[0.5, 2.5], [6.2, 2.7], [6.4, 3.1], [6.4, 9.5]])
    assert not planning.straight_walk_is_free(_GridRoom(blocked), rounded[0], rounded[2])
    out = planning.simplify_waypoints(_GridRoom(blocked), rounded, min_leg=0.5)
    np.testing.assert_allclose(out, [[0.5, 2.5], [6.4, 2.5 + 0.2 * 5.9 / 5.7], [6.4, 9.5]], atol=1e-9)
    with pytest.raises(ValueError, match="waypoints"):
        planning.simplify_waypoints(r, wiggly[:1])


def test_nearest_walkable_point_moves_a_seat_goal_onto_the_reachable_floor():
    from hoi_tutorial.samp.planning import nearest_walkable_point, plan_path
    room = make_room(3, n_clutter=8)
    goal = np.asarray(room.target.sit_goals[0][0], dtype=np.float64)[:2]
    start = room.start_positions(1, seed=np.random.default_rng(0))[0]
    point = nearest_walkable_point(room, goal, start)
    assert np.linalg.norm(point - goal) <= 1.0
    assert room.obstacle_distance(point) >= room.body_radius - room.cell_size  # a free cell's centre
    plan_path(room, start, point)  # reachable: plans without error
    # No walkable cell within a few centimetres of a seat goal (it lies inside the inflated footprint).
    with pytest.raises(ValueError, match="no walkable point"):
        nearest_walkable_point(room, goal, start, max_distance=0.01)
    with pytest.raises(ValueError, match="max_distance"):
        nearest_walkable_point(room, goal, start, max_distance=-1.0)
