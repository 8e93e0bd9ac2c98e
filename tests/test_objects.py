"""Procedural objects: exact SDFs against trimesh, voxel codes, affordances, determinism."""
from functools import lru_cache

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from hoi_tutorial.world.objects import (
    CATEGORIES,
    CONTAINERS,
    GRASPABLE,
    LIFTABLE,
    LYING,
    SITTABLE,
    CATEGORY_SIZES,
    make_object,
    size_table,
)
from hoi_tutorial.world.primitives import capsule_between, cylinder, rotation_z, union_sdf, box, sphere

FURNITURE = tuple(c for c in CATEGORIES if c not in GRASPABLE)


@lru_cache(maxsize=None)
def placed_object(category, seed=1):
    """A non-trivially posed instance, so every check also exercises the world transform."""
    return make_object(category, seed).placed(0.7, -1.3, 0.9, z=0.2)


def _box_around(obj, n, seed, pad=0.05):
    lo, hi = obj.bounds
    return np.random.default_rng(seed).uniform(lo - pad, hi + pad, size=(n, 3))


# ----------------------------------------------------------------------------- SDF vs trimesh


@pytest.mark.parametrize("category", CATEGORIES)
def test_sdf_sign_agrees_with_trimesh_containment(category):
    obj = placed_object(category)
    rng = np.random.default_rng(0)
    near = obj.surface_points(200, seed=1) + rng.normal(scale=0.01, size=(200, 3))
    points = np.concatenate([_box_around(obj, 500, 2), near])
    sdf = obj.sdf(points)
    inside = obj.contains(points)
    assert inside.any() and (~inside).any()
    disagree = (sdf < 0) != inside
    # curved parts are polygons in the mesh: allow disagreement only within 1 mm of the surface
    assert np.all(np.abs(sdf[disagree]) < 1e-3), np.abs(sdf[disagree]).max()


@settings(max_examples=60, deadline=None)
@given(
    category=st.sampled_from(CATEGORIES),
    a=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    b=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
)
def test_sdf_is_1_lipschitz(category, a, b):
    obj = placed_object(category)
    lo, hi = obj.bounds
    centre, half = (lo + hi) / 2, (hi - lo) / 2 + 0.1
    p, q = centre + half * np.array(a), centre + half * np.array(b)
    d = obj.sdf(np.stack([p, q]))
    assert abs(d[0] - d[1]) <= np.linalg.norm(p - q) + 1e-9


def test_primitive_sdfs_match_closed_forms():
    pts = np.random.default_rng(0).normal(size=(200, 3))
    r = np.linalg.norm(pts, axis=1)
    assert np.allclose(union_sdf(pts, [sphere((0, 0, 0), 0.5)]), r - 0.5)
    # a capsule of zero-ish length is a sphere; a tall cylinder far from its caps is a disc distance
    assert np.allclose(union_sdf(pts, [capsule_between((0, 0, -1e-9), (0, 0, 1e-9), 0.5)]), r - 0.5)
    side = pts.copy()
    side[:, 2] *= 0.1
    assert np.allclose(union_sdf(side, [cylinder((0, 0, 0), 0.3, 10.0)]), np.linalg.norm(side[:, :2], axis=1) - 0.3)
    # a yawed box equals the axis-aligned box at the un-yawed point
    yaw = 0.6
    turned = pts @ rotation_z(yaw).T
    assert np.allclose(union_sdf(turned, [box((0, 0, 0), (0.3, 0.2, 0.1), yaw=yaw)]), union_sdf(pts, [box((0, 0, 0), (0.3, 0.2, 0.1))]))


# ----------------------------------------------------------------------------- surface, volume, voxels


@pytest.mark.parametrize("category", CATEGORIES)
def test_surface_points_lie_on_the_surface(category):
    obj = placed_object(category)
    pts = obj.surface_points(300, seed=3)
    assert pts.shape == (300, 3)
    assert np.all(np.abs(obj.sdf(pts)) < 1e-3)
    lo, hi = obj.bounds
    assert np.all(pts >= lo - 1e-9) and np.all(pts <= hi + 1e-9)
    # the canonical point cloud is the same sample in the object's frame
    assert np.allclose(obj.point_cloud(300, seed=3), obj.to_canonical(pts))


@pytest.mark.parametrize("category", CATEGORIES)
def test_occupancy_grid_matches_volume(category):
    obj = placed_object(category)
    occ = obj.occupancy_grid()
    assert occ.shape == (8, 8, 8)
    assert occ.min() >= 0.0 and occ.max() <= 1.0
    lo, hi = obj.canonical_bounds
    cell_volume = np.prod((hi - lo) / 8)
    assert occ.sum() * cell_volume == pytest.approx(obj.volume, rel=0.10)


def test_volume_matches_analytic_box_and_ball():
    crate = make_object("box", 4)
    p = crate.params
    exact = p["width"] * p["depth"] * p["height"]
    assert crate.volume == pytest.approx(exact, rel=0.01)
    assert crate.occupancy_grid().sum() * exact / 512 == pytest.approx(exact, rel=1e-9)
    ball = make_object("yoga_ball", 4)
    exact = 4.0 / 3.0 * np.pi * ball.params["radius"] ** 3
    assert ball.volume == pytest.approx(exact, rel=0.02)
    lo, hi = ball.canonical_bounds
    assert ball.occupancy_grid().sum() * np.prod((hi - lo) / 8) == pytest.approx(exact, rel=0.10)


def test_interaction_voxels_centres_and_occupancy():
    obj = make_object("armchair", 2).placed(1.5, 0.5, 0.4)
    shift = np.array([0.3, -0.2, 0.1])
    frame = np.eye(4)
    frame[:3, 3] = shift
    vox = obj.interaction_voxels(frame)
    assert vox.shape == (8, 8, 8, 4)
    assert np.allclose(vox[..., :3], obj.voxel_centres() - shift)
    occ = vox[..., 3]
    assert occ.min() >= 0.0 and occ.max() <= 1.0
    inside = obj.sdf(obj.voxel_centres()) <= 0
    assert inside.any() and np.all(occ[inside] == 1.0)
    assert np.any(occ == 0.0)  # cells more than one cell away from the surface
    # GoalNet frame: relative to the object centre the code does not depend on the placement
    ref = make_object("armchair", 2)
    assert np.allclose(obj.interaction_voxels(obj.centre_frame), ref.interaction_voxels(ref.centre_frame))
    # batched torch frames
    frames = torch.eye(4, dtype=torch.float32).repeat(3, 1, 1)
    frames[:, 0, 3] = torch.tensor([0.0, 1.0, 2.0])
    batched = obj.interaction_voxels(frames)
    assert batched.shape == (3, 8, 8, 8, 4) and batched.dtype == torch.float32
    assert torch.allclose(batched[1, ..., 0] + 1.0, batched[0, ..., 0], atol=1e-5)
    assert batched.reshape(3, -1).shape[1] == 2048


# ----------------------------------------------------------------------------- errors, determinism, frames


def test_unknown_category_and_bad_parameters_raise():
    with pytest.raises(ValueError, match=r"category: expected one of \[.*'chair'.*\], got 'sofaa'"):
        make_object("sofaa")
    with pytest.raises(ValueError, match="overrides: expected parameters of 'chair'"):
        make_object("chair", seat_hieght=0.4)
    with pytest.raises(ValueError, match="door_angle: expected a value in"):
        make_object("cabinet", door_angle=3.5)
    with pytest.raises(TypeError, match="seed"):
        make_object("chair", seed="one")


def test_affordances_missing_for_a_category_raise():
    bottle = make_object("bottle")
    with pytest.raises(ValueError, match="sit_goals: category 'bottle' has no sit affordance; sittable categories are"):
        bottle.sit_goals
    with pytest.raises(ValueError, match="lift_contacts: category 'bottle'"):
        bottle.lift_contacts
    with pytest.raises(ValueError, match="lie_goals: category 'chair'"):
        make_object("chair").lie_goals
    with pytest.raises(ValueError, match="handle_point: category 'shelf'"):
        make_object("shelf").handle_point
    with pytest.raises(ValueError, match="grasp_points: category 'sofa'"):
        make_object("sofa").grasp_points


@pytest.mark.parametrize("category", ["chair", "l_sofa", "cabinet", "teapot"])
def test_same_seed_same_instance(category):
    a, b = make_object(category, 11), make_object(category, 11)
    assert a.params == b.params
    assert np.array_equal(a.surface_points(100, seed=5), b.surface_points(100, seed=5))
    assert a.params != make_object(category, 12).params
    rng_a, rng_b = np.random.default_rng(3), np.random.default_rng(3)
    assert make_object(category, rng_a).params == make_object(category, rng_b).params


def test_sizes_within_ranges_and_scaling():
    for category, spec in CATEGORY_SIZES.items():
        for seed in range(5):
            params = make_object(category, seed).params
            for name, r in spec.items():
                assert r.low <= params[name] <= r.high, (category, name)
    base, wide = make_object("box", 7), make_object("box", 7, size_scale=(1.5, 1.0, 1.0))
    assert wide.params["width"] == pytest.approx(1.5 * base.params["width"])
    assert wide.params["height"] == pytest.approx(base.params["height"])
    assert make_object("chair", 7, seat_height=0.42).params["seat_height"] == 0.42
    assert len(size_table()) == sum(len(s) for s in CATEGORY_SIZES.values())


@pytest.mark.parametrize("category", CATEGORIES)
def test_canonical_frame_on_the_floor(category):
    obj = make_object(category, 5)
    lo, hi = obj.canonical_bounds
    assert lo[2] == pytest.approx(0.0, abs=1e-12)
    if category in GRASPABLE:
        assert obj.canonical_sdf(np.zeros((1, 3)))[0] == pytest.approx(0.0, abs=1e-9)  # base centre on the surface
    elif category not in ("cabinet", "drawer"):
        assert np.allclose((lo[:2] + hi[:2]) / 2, 0.0, atol=1e-9)


def test_placed_sdf_equals_canonical_sdf_of_inverse_point():
    canonical = make_object("l_sofa", 3)
    obj = canonical.placed(2.0, -1.0, 2.2, z=0.3)
    pts = _box_around(obj, 400, 9)
    c, s = np.cos(2.2), np.sin(2.2)
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    local = (pts - np.array([2.0, -1.0, 0.3])) @ R
    assert np.allclose(obj.sdf(pts), canonical.sdf(local), atol=1e-12)
    assert np.allclose(obj.bounds, obj.mesh.bounds, atol=2e-3)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_torch_gradients_are_unit_away_from_the_surface(dtype):
    obj = placed_object("chair")
    pts = torch.as_tensor(_box_around(obj, 300, 4), dtype=dtype).requires_grad_(True)
    d = obj.sdf(pts)
    assert d.dtype == dtype and d.shape == (300,)
    assert np.allclose(d.detach().double().numpy(), obj.sdf(pts.detach().double().numpy()), atol=1e-5)
    (grad,) = torch.autograd.grad(d.sum(), pts)
    assert torch.isfinite(grad).all()
    away = d.detach().abs() > 1e-3
    assert torch.allclose(grad[away].norm(dim=1), torch.ones((), dtype=dtype), atol=1e-4)


# ----------------------------------------------------------------------------- affordances


SIT_COUNTS = {"chair": (1, 1), "armchair": (1, 1), "stool": (1, 4), "sofa": (2, 3), "l_sofa": (3, 5),
              "table": (1, 2), "yoga_ball": (1, 4), "box": (1, 4)}


@pytest.mark.parametrize("category", SITTABLE)
def test_sit_goals_above_the_seat(category):
    counts = set()
    for seed in range(6):
        obj = make_object(category, seed).placed(-0.5, 1.0, 0.3 * seed)
        positions, directions = obj.sit_goals
        counts.add(len(positions))
        sdf = obj.sdf(positions)
        assert np.all(sdf > 0) and np.all(sdf < 0.25)
        assert np.allclose(np.linalg.norm(directions, axis=1), 1.0) and np.allclose(directions[:, 2], 0.0)
        below = positions - np.array([0.0, 0.0, 0.12])  # the seat is right under the pelvis
        assert np.all(obj.sdf(below) < sdf)
    lo, hi = SIT_COUNTS[category]
    assert min(counts) >= lo and max(counts) <= hi


def test_armchair_direction_is_its_front_and_l_sofa_seats_face_two_ways():
    obj = make_object("armchair", 1).placed(0.0, 0.0, 1.0)
    _, directions = obj.sit_goals
    assert np.allclose(directions, [[-np.sin(1.0), np.cos(1.0), 0.0]])
    _, directions = make_object("l_sofa", 1).sit_goals
    assert np.any(np.isclose(directions[:, 1], 1.0)) and np.any(np.isclose(np.abs(directions[:, 0]), 1.0))


@pytest.mark.parametrize("category", LYING)
def test_lie_goals_along_the_cushion(category):
    obj = make_object(category, 2)
    positions, directions = obj.lie_goals
    sdf = obj.sdf(positions)
    assert np.all(sdf > 0) and np.all(sdf < 0.25)
    assert np.allclose(np.linalg.norm(directions, axis=1), 1.0) and np.allclose(directions[:, 2], 0.0)


@pytest.mark.parametrize("category", LIFTABLE)
def test_lift_contacts_on_opposite_sides(category):
    obj = make_object(category, 3).placed(1.0, 1.0, -0.7)
    contacts, facing = obj.lift_contacts, obj.lift_approach
    assert contacts.shape == (2, 3)
    assert np.all(np.abs(obj.sdf(contacts)) < 0.03)
    assert np.linalg.norm(facing) == pytest.approx(1.0) and facing[2] == pytest.approx(0.0)
    right = np.cross(facing, [0.0, 0.0, 1.0])  # forward × up = right (the character convention)
    assert (contacts[1] - contacts[0]) @ right > 0.2  # the right hand is to the right of the left
    assert np.all(contacts[:, 2] > 0.1) and np.all(contacts[:, 2] < 1.2)


@pytest.mark.parametrize("category", GRASPABLE)
def test_grasp_points_on_props(category):
    obj = make_object(category, 6).placed(0.3, 0.2, 2.0, z=0.9)
    points = obj.grasp_points
    assert points.shape[1] == 3 and len(points) >= 1
    assert np.all(np.abs(obj.sdf(points)) < 1e-6)


@pytest.mark.parametrize("category, state, values", [("cabinet", "door_angle", (0.0, 1.2)), ("drawer", "drawer_open", (0.0, 0.3))])
def test_handle_moves_with_door_and_drawer(category, state, values):
    closed = make_object(category, 4, **{state: values[0]}).placed(1.0, 2.0, 0.5)
    opened = closed.with_params(**{state: values[1]})
    assert np.allclose(opened.pose, closed.pose)
    for obj in (closed, opened):
        assert np.all(np.abs(obj.sdf(obj.handle_point[None])) < 1e-6)
        assert np.allclose(obj.grasp_points[0], obj.handle_point)
    moved = np.linalg.norm(opened.handle_point - closed.handle_point)
    assert moved > 0.2
    if category == "drawer":
        assert moved == pytest.approx(values[1])


@pytest.mark.parametrize("category", CONTAINERS + ("table",))
def test_support_surfaces_carry_small_objects(category):
    obj = make_object(category, 8, **({"drawer_open": 0.2} if category == "drawer" else {}))
    for z, x0, x1, y0, y1, free in obj.support_surfaces:
        centre = np.array([[(x0 + x1) / 2, (y0 + y1) / 2, z]])
        assert obj.canonical_sdf(centre)[0] == pytest.approx(0.0, abs=1e-6)  # on top of a board
        above = centre + np.array([0.0, 0.0, min(free, 0.3) / 2])
        assert obj.canonical_sdf(above)[0] > 0
