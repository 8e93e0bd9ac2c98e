"""CHOICE's fields (§4.1, Eqs. 1–6) by fast marching: known answers, walls, the time of arrival,
the descent down a time field, invariance and errors."""
import numpy as np
import pytest
import skfmm

from hoi_tutorial.choice.planner import fields as F
from hoi_tutorial.world.objects import make_object, object_from_description
from hoi_tutorial.world.mocap.grasping import reach_grasp


def sphere(centre, radius):
    centre = np.asarray(centre, dtype=np.float64)
    return lambda p: np.linalg.norm(np.asarray(p) - centre, axis=-1) - radius


def box(lo, hi):
    """Exact SDF of an axis-aligned box (world frame)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c, h = (lo + hi) / 2, (hi - lo) / 2

    def sdf(p):
        q = np.abs(np.asarray(p) - c) - h
        return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)

    return sdf


def grid(n=32, spacing=0.025, centre=(0.0, 0.0, 1.0), yaw=0.0):
    return F.FieldGrid(np.asarray(centre, float), yaw, n, spacing)


# ----------------------------------------------------------------------------- grid


def test_grid_points_round_trip_and_interpolation_of_a_linear_field():
    g = grid(n=8, spacing=0.1, centre=(1.0, -2.0, 0.5), yaw=0.7)
    pts = g.points()
    assert pts.shape == (8, 8, 8, 3)
    np.testing.assert_allclose(g.to_world(g.to_local(pts)), pts, atol=1e-12)
    np.testing.assert_allclose(g.to_index(pts[3, 5, 1]), [3, 5, 1], atol=1e-12)
    assert g.contains(pts).all() and not g.contains(np.array([1.0, -2.0, 0.5 + 0.41]))
    a = np.array([0.3, -1.2, 2.0])
    values = pts @ a
    rng = np.random.default_rng(0)
    inside = g.to_world(rng.uniform(-0.34, 0.34, size=(50, 3)))
    np.testing.assert_allclose(g.sample(values, inside), inside @ a, atol=1e-10)


def test_object_grid_is_centred_on_the_object_with_the_presets_spacing():
    bottle = make_object("bottle", 1).placed(1.0, 2.0, 0.3, z=0.8)
    for scale, n in (("toy", 16), ("paper", 32)):
        g = F.object_grid(bottle, F.field_config(scale))
        assert g.n == n and abs(g.n * g.spacing - 0.8) < 1e-9  # CHOICE §8.1: an (80 cm)^3 cube
        lo, hi = bottle.bounds
        np.testing.assert_allclose(g.centre, (lo + hi) / 2)
        assert abs(g.yaw - 0.3) < 1e-9


# ----------------------------------------------------------------------------- distances


def test_target_distance_matches_the_exact_euclidean_distance_in_free_space():
    g = grid()
    target = sphere((0.03, -0.02, 1.01), 0.06)
    sdf = target(g.points())
    d = F.target_distance(g, sdf, np.full(g.shape, np.inf))
    outside = sdf > 0
    err = np.abs(d[outside] - sdf[outside])
    # second-order fast marching: within half a cell everywhere (the front's initialisation next to
    # the surface), a tenth of a cell on average; first order is several times worse
    assert err.max() < 0.5 * g.spacing and err.mean() < 0.15 * g.spacing
    first = F.target_distance(g, sdf, np.full(g.shape, np.inf), order=1)
    assert np.abs(first[outside] - sdf[outside]).mean() > 3 * err.mean()
    assert np.all(d[~outside] == 0.0)


def test_target_distance_of_a_toy_object_matches_its_exact_sdf():
    bottle = make_object("bottle", 2).placed(0.0, 0.0, 0.4, z=0.9)
    g = F.object_grid(bottle, F.field_config("paper"))
    f = F.scene_fields(g, bottle)
    free = f.target_sdf > g.spacing
    assert np.abs(f.d_target[free] - f.target_sdf[free]).max() < 0.5 * g.spacing


def test_a_wall_makes_the_distance_geodesic():
    g = grid()
    target = sphere((0.0, -0.2, 1.0), 0.04)
    wall = box((-0.3, -0.1, 0.7), (0.3, -0.09, 1.3))  # a 1 cm plate, thinner than a cell
    pts = g.points()
    d = F.target_distance(g, target(pts), wall(pts))
    euclid = np.maximum(target(pts), 0.0)
    free = np.isfinite(d)
    assert np.all(d[free] >= euclid[free] - 0.2 * g.spacing)
    # straight behind the plate the path goes around it: far longer than the straight line
    behind = g.sample(d, np.array([0.0, 0.05, 1.0]))
    assert behind > g.sample(euclid, np.array([0.0, 0.05, 1.0])) + 0.2
    # the plate itself is a wall: infinite distance, D_t = 0 there
    assert np.all(np.isinf(d[(wall(pts) < 0.5 * g.spacing) & (target(pts) > 0.5 * g.spacing)]))
    assert np.all(F.inverse_distance(d, 0.025)[np.isinf(d)] == 0.0)


def test_cells_sealed_off_by_an_obstacle_are_unreachable():
    g = grid(n=24)
    target = sphere((0.0, 0.0, 1.0), 0.05)
    outer, inner = box((-0.28, 0.1, 0.75), (0.28, 0.28, 1.25)), box((-0.25, 0.13, 0.78), (0.25, 0.25, 1.22))
    shell = lambda p: np.maximum(outer(p), -inner(p))  # a hollow closed box
    pts = g.points()
    d = F.target_distance(g, target(pts), shell(pts))
    cavity = inner(pts) < -g.spacing
    assert cavity.any() and np.all(np.isinf(d[cavity]))
    d_o = F.obstacle_distance(g, target(pts), shell(pts))
    assert np.all(d_o[cavity] < 0.2)  # the obstacle distance is defined inside the cavity too
    assert np.all(np.isinf(d_o[target(pts) < 0]))  # the target is a wall for D_o


def test_obstacle_distance_without_obstacles_is_infinite_and_D_o_zero():
    bottle = make_object("bottle", 0).placed(0.0, 0.0, 0.0, z=1.0)
    f = F.scene_fields(F.object_grid(bottle), bottle)
    assert np.all(np.isinf(f.d_obstacle)) and np.all(f.D_o == 0.0)
    assert f.D_t.max() == pytest.approx(1 / f.config.epsilon)  # Eq. 3's clipping inside the target


def test_second_order_falls_back_to_first_order(monkeypatch):
    g = grid(n=16, spacing=0.05)
    phi = sphere((0.0, 0.0, 1.0), 0.1)(g.points())
    blocked = np.zeros(g.shape, bool)
    first = F.fast_marching_distance(phi, blocked, g.spacing, order=1)
    real = skfmm.distance

    def failing(phi, dx=1.0, order=2, **kw):
        if order == 2:
            raise ValueError("order 2 not possible here")
        return real(phi, dx=dx, order=order, **kw)

    monkeypatch.setattr(F.skfmm, "distance", failing)
    np.testing.assert_allclose(F.fast_marching_distance(phi, blocked, g.spacing, order=2), first)


# ----------------------------------------------------------------------------- time of arrival


def test_travel_time_along_a_straight_corridor_is_length_over_speed():
    g = grid(n=40, spacing=0.02)
    pts = g.to_local(g.points())
    corridor = (np.abs(pts[..., 1]) < 0.05) & (np.abs(pts[..., 2]) < 0.05)
    source = np.linalg.norm(pts - np.array([-0.35, 0.0, 0.0]), axis=-1) - 0.03
    v = 0.7
    t = F.fast_marching_time(source, np.full(g.shape, v), ~corridor, g.spacing)
    on_axis = corridor & (np.abs(pts[..., 1]) < 0.011) & (np.abs(pts[..., 2]) < 0.011) & (source > 0)
    expected = source[on_axis] / v
    np.testing.assert_allclose(t[on_axis], expected, rtol=0.03, atol=0.2 * g.spacing / v)
    assert np.all(np.isinf(t[~corridor]))


def test_time_of_arrival_along_a_straight_demonstration_is_the_remaining_time():
    g = grid(n=32, spacing=0.025)
    T, v = 31, 0.6  # frames at 30 fps, m/s
    goal = g.points()[26, 17, 17]  # on a row of cell centres: the Gaussian's peak is sampled
    traj = goal + np.outer(np.arange(T)[::-1] / 30.0 * v, [-1.0, 0.0, 0.0])  # towards +x, goal last
    phi = F.time_of_arrival(g, traj, 30.0, np.zeros(g.shape, bool))
    on = traj[g.contains(traj)]
    remaining = np.linalg.norm(on - goal, axis=-1) / v
    np.testing.assert_allclose(g.sample(phi, on), remaining, rtol=0.03, atol=0.01)
    assert g.sample(phi, goal) < 0.02
    # away from the demonstration the front is slow: the same distance costs more time
    side = goal + np.array([0.0, 0.25, 0.0])
    assert g.sample(phi, side) > 3 * (0.25 / v)


def _l_shaped_demo(g):
    goal = g.centre + np.array([0.0, 0.25, 0.0])
    corner = g.centre + np.array([-0.3, 0.25, 0.0])
    start = g.centre + np.array([-0.3, -0.3, 0.0])
    leg1 = start + np.linspace(0, 1, 20)[:, None] * (corner - start)
    leg2 = corner + np.linspace(0, 1, 12)[1:, None] * (goal - corner)
    return np.concatenate([leg1, leg2])


def test_descent_follows_the_demonstration_not_the_straight_line():
    g = grid(n=32, spacing=0.025)
    demo = _l_shaped_demo(g)
    phi = F.time_of_arrival(g, demo, 30.0, np.zeros(g.shape, bool))
    path = F.descend(g, phi, demo[0])
    assert np.linalg.norm(path[-1] - demo[-1]) < g.spacing
    dense = np.concatenate([demo[k] + np.linspace(0, 1, 10)[:, None] * (demo[k + 1] - demo[k]) for k in range(len(demo) - 1)])
    to_demo = lambda pts: np.min(np.linalg.norm(pts[:, None] - dense[None], axis=-1), axis=1)
    straight = demo[0] + np.linspace(0, 1, 50)[:, None] * (demo[-1] - demo[0])
    assert to_demo(path).mean() < g.spacing
    assert to_demo(straight).mean() > 3 * g.spacing  # the baseline a uniform speed would give


def test_descent_reaches_the_goal_in_an_empty_scene_and_never_enters_a_wall():
    g = grid(n=24, spacing=0.025)
    goal = g.centre + np.array([0.15, 0.1, -0.05])
    traj = np.stack([g.centre - np.array([0.2, 0.2, 0.0]), goal])
    phi = F.time_of_arrival(g, traj, 5.0, np.zeros(g.shape, bool))
    for start in g.to_world(np.random.default_rng(1).uniform(-0.28, 0.28, size=(8, 3))):
        assert np.linalg.norm(F.descend(g, phi, start)[-1] - goal) < g.spacing
    wall = box(g.centre + np.array([-0.05, -0.3, -0.3]), g.centre + np.array([0.0, 0.05, 0.3]))(g.points())
    blocked = wall < 0.5 * g.spacing
    phi = F.time_of_arrival(g, traj, 5.0, blocked)
    path = F.descend(g, phi, g.centre + np.array([-0.2, -0.2, 0.0]))
    assert np.linalg.norm(path[-1] - goal) < g.spacing
    assert not np.any(g.sample(blocked.astype(float), path[1:]) > 0.999)


def test_fields_move_with_the_scene_under_a_rigid_ground_motion():
    """Object, support, demonstration and grid turned and shifted together: the same fields."""
    bottle = make_object("bottle", 3)
    motion = reach_grasp(bottle, seed=0, hand="right", pick_up=False)
    target = object_from_description(motion.meta["object"])
    support = object_from_description(motion.meta["support"])
    wrist = np.asarray(motion.joint("right_wrist"))[: motion.meta["anchor_frame"] + 1]
    yaw, shift = 1.1, np.array([0.7, -1.3, 0.0])
    R = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1.0]])
    move = np.eye(4)
    move[:3, :3], move[:3, 3] = R, shift
    target2, support2 = target.with_pose(move @ target.pose), support.with_pose(move @ support.pose)
    # First order: the same numbers. Second order: where scikit-fmm uses its second-order stencil
    # depends on the order in which cells leave its heap, so the last-bit differences of the moved
    # SDFs change it in places (measured: up to 2.4 cm at 5 cm cells, about first order's error).
    for order, atol in ((1, 1e-9), (2, 0.5 * F.field_config("toy").spacing)):
        cfg = F.field_config("toy", order=order)
        a = F.scene_fields(F.object_grid(target, cfg, yaw=0.0), target, [support], wrist, motion.fps, cfg)
        b = F.scene_fields(F.object_grid(target2, cfg, yaw=yaw), target2, [support2], wrist @ R.T + shift,
                           motion.fps, cfg)
        np.testing.assert_allclose(b.grid.points(), a.grid.points() @ R.T + shift, atol=1e-12)
        for name in ("d_target", "d_obstacle", "time"):
            x, y = getattr(a, name), getattr(b, name)
            assert np.array_equal(np.isinf(x), np.isinf(y)), name
            np.testing.assert_allclose(x[np.isfinite(x)], y[np.isfinite(y)], rtol=0, atol=atol, err_msg=name)


def test_a_reach_onto_a_shelf_gives_finite_times_along_the_demonstration():
    bottle = make_object("bottle", 3)
    motion = reach_grasp(bottle, seed=0, hand="right", pick_up=False)
    assert motion.meta["support"]["category"] == "shelf"
    target = object_from_description(motion.meta["object"])
    shelf = object_from_description(motion.meta["support"])
    anchor = motion.meta["anchor_frame"]
    wrist = np.asarray(motion.joint("right_wrist"))[: anchor + 1]
    cfg = F.field_config("paper")
    f = F.scene_fields(F.object_grid(target, cfg, yaw=0.0), target, [shelf], wrist, motion.fps, cfg)
    g = f.grid
    on = g.contains(wrist)
    phi = g.sample(f.time, wrist[on])
    assert np.all(np.isfinite(phi))
    remaining = (anchor - np.flatnonzero(on)) / motion.fps
    # the field's time along the demonstration is the demonstration's own remaining time
    assert abs(phi[0] - remaining[0]) < 0.2 * remaining[0]
    assert np.all(np.diff(phi) < 0.05)  # decreasing towards the goal (up to interpolation)
    assert np.all(f.D_toa[(f.obstacle_sdf < 0) & (f.target_sdf > g.spacing)] == 0.0)  # x_O of §4.2


# ----------------------------------------------------------------------------- errors


def test_clear_errors():
    g = grid(n=16, spacing=0.05)
    empty = np.zeros(g.shape, bool)
    far = g.centre + np.array([2.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="goal: expected a point inside the grid"):
        F.time_of_arrival(g, np.stack([g.centre, far]), 30.0, empty)
    with pytest.raises(ValueError, match="trajectory: expected shape"):
        F.time_of_arrival(g, np.zeros((5, 2)), 30.0, empty)
    with pytest.raises(ValueError, match="trajectory: expected at least 2 frames"):
        F.time_of_arrival(g, g.centre[None], 30.0, empty)
    with pytest.raises(ValueError, match="blocked: expected a bool array"):
        F.time_of_arrival(g, np.stack([g.centre - 0.1, g.centre]), 30.0, np.zeros(g.shape))
    with pytest.raises(ValueError, match="target: expected the target object inside the grid"):
        F.scene_fields(g, sphere(far, 0.05))
    with pytest.raises(ValueError, match="the front"):
        F.fast_marching_distance(np.ones(g.shape), empty, g.spacing)
    with pytest.raises(ValueError, match="phi: expected a 2D or 3D grid"):
        F.fast_marching_distance(np.ones(4), np.zeros(4, bool), 0.1)
    with pytest.raises(ValueError, match="speed: expected finite positive"):
        F.fast_marching_time(sphere(g.centre, 0.1)(g.points()), np.zeros(g.shape), empty, g.spacing)
    phi = F.time_of_arrival(g, np.stack([g.centre - 0.1, g.centre]), 30.0, empty)
    with pytest.raises(ValueError, match="start: expected a point inside the grid"):
        F.descend(g, phi, far)
    walled = phi.copy()
    walled[0, 0, 0] = np.inf
    with pytest.raises(ValueError, match="wall or unreachable"):
        F.descend(g, walled, g.points()[0, 0, 0])
    with pytest.raises(ValueError, match="spacing: expected at most a quarter"):
        F.field_config(spacing=0.5)
    with pytest.raises(ValueError, match="order: expected 1 or 2"):
        F.field_config(order=3)
    with pytest.raises(TypeError, match="obstacles\\[0\\]: expected an object with .sdf"):
        F.scene_fields(g, sphere(g.centre, 0.05), [3.0])
    with pytest.raises(ValueError, match="description: expected a dict"):
        object_from_description({"category": "bottle"})


def test_fast_marching_on_a_2d_slice_matches_the_exact_distance():
    n, dx = 60, 0.01
    u = (np.arange(n) + 0.5) * dx
    x, y = np.meshgrid(u, u, indexing="ij")
    exact = np.hypot(x - 0.31, y - 0.27) - 0.05
    d = F.fast_marching_distance(exact, np.zeros((n, n), bool), dx)
    outside = exact > 0
    assert np.abs(d[outside] - exact[outside]).max() < 0.5 * dx


def test_a_goal_walled_in_by_an_obstacle_is_a_clear_error():
    g = grid(n=16, spacing=0.05)
    blocked = np.linalg.norm(g.points() - g.centre, axis=-1) < 0.2
    with pytest.raises(ValueError, match="goal: expected a free grid cell"):
        F.time_of_arrival(g, np.stack([g.centre + 0.3, g.centre]), 30.0, blocked)
