"""CHOICE's navigation and navigation matching (§6.2, Eq. 23; ``pick_and_place.navigation``,
``pick_and_place.locomotion``): the cost term by term, the fast-marching path around walls, the 3 m split, the
features N and their KD-tree against brute force, collision rejection, following a path with stitched toy-mocap
motions, and errors."""
import numpy as np
import pytest
import torch
from hypothesis import given, strategies as st

from hoi_tutorial.choice.pick_and_place import locomotion as LOC, navigation as NAV
from hoi_tutorial.world.mocap import standing_pose
from hoi_tutorial.world.motion import Motion
from hoi_tutorial.world.scenes import make_room
from hoi_tutorial.world.skeleton import joint_index

CELL = 0.05


def box_room(size, boxes=(), config=NAV.NavigationConfig()):
    """A floor ``size`` (2,) metres with axis-aligned boxes ``(lo (2,), hi (2,))`` and walls round it; Eq. 23's
    obstacles within ``body_radius`` of them, collisions within ``collision_radius`` (as the toy scenes')."""
    H, W = int(round(size[1] / CELL)), int(round(size[0] / CELL))
    i, j = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    c = (np.stack([j, i], -1) + 0.5) * CELL
    clearance = np.minimum.reduce([c[..., 0], size[0] - c[..., 0], c[..., 1], size[1] - c[..., 1]])
    for lo, hi in boxes:
        gap = np.maximum(np.maximum(np.asarray(lo) - c, c - np.asarray(hi)), 0.0)
        clearance = np.minimum(clearance, np.linalg.norm(gap, axis=-1))
    return NAV.NavigationGrid(clearance < config.body_radius, CELL, clearance < config.collision_radius)


EMPTY = box_room((6.0, 5.0))
WALL = box_room((6.0, 5.0), [((2.9, 0.0), (3.1, 3.0))])  # a wall from the bottom up to y = 3 m


@pytest.fixture(scope="module")
def database(module_cache, one_cpu_thread):
    return LOC.motion_database(NAV.navigation_config("toy"))


def dense(path, step=CELL / 8):
    """Points every ``step`` metres along a polyline (K, 2)."""
    out = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        out.append(a + (np.arange(1, n + 1) / n)[:, None] * (b - a))
    return np.concatenate(out)


def distance_to_line(points, a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    u = (b - a) / np.linalg.norm(b - a)
    rel = points - a
    return np.abs(rel[:, 0] * u[1] - rel[:, 1] * u[0])


# ----------------------------------------------------------------------------- Eq. 23


def test_eq23_each_term_alone():
    goal, d = np.array([2.0, 1.0]), np.array([0.0, 3.0])  # d_g any length: +y
    cost = lambda p, blocked=False: float(NAV.navigation_cost(np.asarray(p, float), goal, d, np.asarray(blocked)))
    # obstacles: infinite, wherever they are
    assert cost([2.0, 1.1], True) == np.inf and cost([5.0, 5.0], True) == np.inf
    # near the goal (L1 < 0.4): angle(p − p_g, d_g)/π + 0.5
    assert cost([2.0, 1.2]) == pytest.approx(0.5)          # on the side d_g points to
    assert cost([2.0, 0.8]) == pytest.approx(1.5)          # opposite
    assert cost([2.2, 1.0]) == pytest.approx(1.0)          # perpendicular
    assert cost([2.1, 1.1]) == pytest.approx(0.75)         # 45°
    assert cost([1.9, 0.9]) == pytest.approx(1.25)         # 135°
    assert cost(goal) == pytest.approx(0.5)                # the goal itself (angle 0, ours)
    # otherwise 1: far away, and inside the L2 disc of radius l but outside the L1 diamond
    assert cost([4.0, 4.0]) == 1.0 and cost([2.0, 1.5]) == 1.0
    assert np.hypot(0.25, 0.25) < 0.4 and cost([2.25, 0.75]) == 1.0
    # l is a parameter, and its L1 boundary is outside (strict <; 0.5 m is exact in binary)
    far = lambda p: float(NAV.navigation_cost(np.asarray(p, float), goal, d, np.array(False), near_goal=0.5))
    assert far([2.0, 0.55]) == pytest.approx(1.5) and far([2.0, 0.5]) == 1.0 and far([2.25, 1.25]) == 1.0


def test_cost_map_is_eq23_at_the_cell_centres():
    goal, d = np.array([3.0, 2.0]), np.array([1.0, 1.0])
    c = NAV.cost_map(WALL, goal, d)
    assert c.shape == WALL.shape and np.all(np.isinf(c[WALL.blocked])) and np.all(np.isfinite(c[~WALL.blocked]))
    centres = WALL.centres()
    near = np.abs(centres - goal).sum(-1) < 0.4
    assert np.all(c[~near & ~WALL.blocked] == 1.0)
    assert c[near & ~WALL.blocked].min() >= 0.5 and c[near & ~WALL.blocked].max() <= 1.5


# ----------------------------------------------------------------------------- the 2D path


def test_travel_time_in_an_empty_room_is_the_distance_to_the_goal():
    goal = np.array([4.02, 3.03])
    config = NAV.navigation_config(near_goal=1e-6)  # c = 1 everywhere: T is a distance
    T = NAV.travel_time(EMPTY, goal, (1.0, 0.0), config)
    centre = (np.asarray(EMPTY.point_cell(goal))[::-1] + 0.5) * CELL
    gap = np.maximum(np.abs(EMPTY.centres() - centre) - CELL / 2, 0.0)  # the front starts on the goal cell's border
    exact = np.linalg.norm(gap, axis=-1)
    free = ~EMPTY.blocked
    assert T[EMPTY.point_cell(goal)] == 0.0 and np.sum(T == 0.0) == 1
    assert np.all(np.isinf(T[EMPTY.blocked]))
    assert np.abs(T[free] - exact[free]).max() < CELL


def test_path_in_an_empty_room_is_the_straight_line_when_it_is_cheapest():
    start, goal = np.array([1.0, 1.0]), np.array([5.0, 3.5])
    plan = NAV.plan_path(EMPTY, start, goal, start - goal)  # d_g points back to the start: arriving costs 0.5
    straight = np.linalg.norm(goal - start)
    np.testing.assert_allclose(plan.path[[0, -1]], [start, goal])
    assert distance_to_line(dense(plan.path), start, goal).max() < CELL
    assert plan.length == pytest.approx(straight, rel=1e-3)
    # its cost is ∫ c ds: 1 per metre, 0.5 over the last 0.4 m of L1 distance (the diamond along the line)
    u = (goal - start) / straight
    inside = 0.4 / np.abs(u).sum()
    assert plan.path_cost == pytest.approx(straight - inside + 0.5 * inside, abs=CELL)
    # and fast marching agrees, to the grid
    assert plan.time[EMPTY.point_cell(start)] == pytest.approx(plan.path_cost, abs=2 * CELL)


def test_arriving_is_cheap_from_the_side_the_goal_direction_points_to():
    goal, d = np.array([4.0, 2.5]), np.array([0.0, 1.0])
    T = NAV.travel_time(EMPTY, goal, d)
    at = lambda p: T[EMPTY.point_cell(p)]
    cheap, side, costly = at(goal + 0.3 * d), at(goal + (0.3, 0.0)), at(goal - 0.3 * d)
    # 0.3 m in at cost 0.5 (the front starts on the goal cell's border, half a cell out); from the side
    # straight in costs 1 a metre, and bending through the cheaper half costs less
    assert cheap == pytest.approx(0.5 * 0.3, abs=CELL) and side <= 0.3
    assert cheap < side < costly and costly > 2 * cheap
    # the plan from behind is no costlier than walking straight in
    start = goal - (0.0, 2.0)
    plan = NAV.plan_path(EMPTY, start, goal, d)
    assert plan.path_cost <= NAV.path_cost(np.stack([start, goal]), EMPTY, goal, d) + 1e-9


def test_path_goes_round_a_wall_never_through_an_obstacle_cell():
    start, goal = np.array([1.5, 1.0]), np.array([4.5, 1.0])
    plan = NAV.plan_path(WALL, start, goal, (0.0, -1.0))
    points = dense(plan.path)
    assert np.all(WALL.free(points))
    assert points[:, 1].max() > 3.0 + 0.25  # over the top of the wall, at the body radius
    # optimal: the path's cost is the fast-marching time from the start, to a couple of cells
    assert plan.path_cost == pytest.approx(plan.time[WALL.point_cell(start)], abs=3 * CELL)
    # the cell path before pulling it taut never enters a blocked cell either
    cells = NAV._descend(WALL, plan.time, WALL.point_cell(start))
    assert not WALL.blocked[cells[:, 0], cells[:, 1]].any()
    assert np.all(np.abs(np.diff(cells, axis=0)) <= 1) and tuple(cells[-1]) == WALL.point_cell(goal)


def test_segment_check_counts_a_touched_corner():
    blocked = np.zeros((4, 4), bool)
    blocked[1, 1] = True
    grid = NAV.NavigationGrid(blocked, 1.0)
    assert not NAV._segment_is_free(grid, np.array([0.5, 2.5]), np.array([2.5, 0.5]))  # through cell (1, 1)'s corners
    assert NAV._segment_is_free(grid, np.array([0.5, 0.5]), np.array([0.5, 3.5]))
    assert not NAV._segment_is_free(grid, np.array([0.5, 0.5]), np.array([2.5, 2.5]))  # corner to corner of (1, 1)


# ----------------------------------------------------------------------------- the split


@given(st.lists(st.tuples(st.floats(0, 10), st.floats(0, 10)), min_size=2, max_size=8), st.floats(0.5, 4.0))
def test_split_gives_subgoals_at_most_every_metres_apart_along_the_path(points, every):
    path = np.asarray(points)
    subgoals = NAV.split_path(path, every)
    np.testing.assert_allclose(subgoals[-1], path[-1])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    # where each sub-goal lies along the path (points of a polyline; the arc length at the marks)
    marks = np.arange(every, arc[-1], every)
    assert len(subgoals) == len(marks) + 1
    along = np.concatenate([[0.0], marks, [arc[-1]]])
    steps = np.diff(along)
    assert np.all(steps <= every + 1e-9) and np.allclose(steps[:-1], every)
    ends = np.concatenate([path[:1], subgoals])
    assert np.all(np.linalg.norm(np.diff(ends, axis=0), axis=1) <= every + 1e-9)


def test_split_of_a_plan_every_3_m():
    plan = NAV.plan_path(WALL, (1.5, 1.0), (4.5, 1.0), (0.0, -1.0))
    subgoals = NAV.split_path(plan.path)  # the paper's 3 m
    assert len(subgoals) == int(np.ceil(plan.length / 3.0))
    for point in subgoals[:-1]:  # on the path, 3 m apart along it
        assert min(distance_to_line(point[None], a, b)[0] for a, b in zip(plan.path[:-1], plan.path[1:])) < 1e-9
    assert np.all(np.linalg.norm(np.diff(np.concatenate([plan.path[:1], subgoals]), axis=0), axis=1) <= 3.0 + 1e-9)


# ----------------------------------------------------------------------------- the features N


def test_feature_layout_is_the_papers_N():
    sizes = {name: s.stop - s.start for name, s in LOC.FEATURE_LAYOUT.items()}
    assert list(sizes) == ["goal_direction", "goal_position", "left_rotation", "left_position", "right_rotation",
                           "right_position", "hip_rotation", "hip_position", "root_velocity"]
    assert list(sizes.values()) == [2, 2, 6, 3, 6, 3, 6, 3, 2] and LOC.FEATURE_SIZE == 33


def test_frame_features_of_a_standing_pose_and_their_invariance_to_where_it_stands():
    local, root = standing_pose(position=(1.0, 2.0), heading=0.7)
    origin, heading, pose = LOC.frame_features(local[None], root[None])
    np.testing.assert_allclose(origin[0], [1.0, 2.0], atol=1e-6)
    assert heading[0] == pytest.approx(0.7, abs=2e-3)  # facing from the hips (the toy pelvis is not quite symmetric)
    hip = LOC.FEATURE_LAYOUT["hip_position"]
    np.testing.assert_allclose(pose[0, hip.start - 4:hip.stop - 4], [0.0, 0.0, float(root[2])], atol=1e-6)
    np.testing.assert_allclose(pose[0, -2:], 0.0)  # standing: no velocity
    local2, root2 = standing_pose(position=(-3.0, 0.5), heading=-2.0)
    np.testing.assert_allclose(LOC.frame_features(local2[None], root2[None])[2], pose, atol=1e-5)


def test_database_features_are_where_the_placed_motion_ends(database):
    rng = np.random.default_rng(0)
    for window in rng.choice(len(database), size=20, replace=False):
        _, s, e = database.windows[window]
        origin, heading = np.array([1.5, -0.5]), float(rng.uniform(-np.pi, np.pi))
        roots = LOC._placed_roots(database, window, origin, heading)
        c, si = np.cos(heading), np.sin(heading)
        local_end = np.array([[c, si], [-si, c]]) @ (roots[-1] - origin)  # world → the start's root frame
        np.testing.assert_allclose(database.features[window, 2:4], local_end, atol=1e-9)
        turn = database.heading[e] - database.heading[s]
        np.testing.assert_allclose(database.features[window, :2], [-np.sin(turn), np.cos(turn)], atol=1e-9)
        np.testing.assert_allclose(database.features[window, 4:], database.pose[s])
        # placed at its own start it is the clip itself
        np.testing.assert_allclose(LOC._placed_roots(database, window, database.origin[s], database.heading[s]),
                                   database.origin[s:e + 1], atol=1e-9)


def test_query_features_put_the_subgoal_in_the_root_frame():
    pose = np.arange(29.0)
    q = LOC.query_features(pose, origin=(1.0, 1.0), heading=np.pi / 2, subgoal=(0.0, 1.0), subgoal_direction=(0.0, -2.0))
    # heading π/2 faces −x: the sub-goal 1 m along −x is 1 m ahead (+y local), −y is on its left (−x local)
    np.testing.assert_allclose(q[2:4], [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(q[:2], [-1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(q[4:], pose)


# ----------------------------------------------------------------------------- matching


def test_kd_tree_matching_equals_brute_force(database):
    rng = np.random.default_rng(1)
    queries = database.features[rng.choice(len(database), 12)] + rng.normal(0.0, 0.05, size=(12, LOC.FEATURE_SIZE))
    distances, indices = LOC.match(database, queries, k=5)
    assert distances.shape == indices.shape == (12, 5)
    brute = np.linalg.norm(database.scaled(database.features)[None] - database.scaled(queries)[:, None], axis=-1)
    order = np.argsort(brute, axis=1)[:, :5]
    np.testing.assert_array_equal(indices, order)
    np.testing.assert_allclose(distances, np.take_along_axis(brute, order, axis=1), rtol=1e-10, atol=1e-12)
    d1, i1 = LOC.match(database, queries[0], k=1)
    assert d1.shape == (1,) and i1[0] == order[0, 0]


def test_the_distance_weighs_each_group_by_its_spread(database):
    std = database.features.std(axis=0)
    weights = NAV.NavigationConfig().weights
    for (name, part), w in zip(LOC.FEATURE_LAYOUT.items(), weights):
        spread = std[part].mean()
        np.testing.assert_allclose(database.scales[part], np.sqrt(w) / (spread if spread > 1e-9 else 1.0))


def test_a_matched_motion_that_collides_is_rejected_for_the_next_nearest(database):
    origin, heading = np.array([3.0, 2.5]), 0.3
    walking = np.flatnonzero(np.linalg.norm(database.features[:, 2:4], axis=1) > 1.0)
    nearest = int(walking[0])
    query = database.features[nearest]
    window, _, distance, rejected = LOC.select_window(database, EMPTY, query, origin, heading)
    assert window == nearest and distance == 0.0 and rejected == ()
    # a box on the nearest motion's last steps, in the collision map only (the motions of the same clip
    # from the same keyframe that end sooner stay clear of it)
    roots = LOC._placed_roots(database, nearest, origin, heading)
    collision = EMPTY.collision.copy()
    i, j = EMPTY.cell_of(roots[-2])
    collision[i - 1:i + 2, j - 1:j + 2] = True
    grid = NAV.NavigationGrid(EMPTY.blocked, CELL, collision)
    assert LOC.window_collides(database, grid, nearest, origin, heading)
    window, last, distance, rejected = LOC.select_window(database, grid, query, origin, heading, candidates=16)
    _, order = LOC.match(database, query, 16)
    collides = [LOC.window_collides(database, grid, int(w), origin, heading) for w in order]
    first_free = int(order[collides.index(False)])
    assert window == first_free != nearest and rejected[0] == nearest
    assert list(rejected) == [int(w) for w in order[:collides.index(False)]]
    assert last == database.windows[window, 2] and distance > 0.0


def test_placed_limbs_are_the_stitched_motions_and_a_caller_can_reject_them(database):
    origin, heading = np.array([3.0, 2.5]), 0.3
    walking = np.flatnonzero(np.linalg.norm(database.features[:, 2:4], axis=1) > 1.0)
    nearest = int(walking[0])
    _, s, e = database.windows[nearest]
    # the placed limb points are the joints of the motion moved so that its first root frame is (origin, heading)
    yaw = heading - float(database.heading[s])
    c, si = np.cos(yaw), np.sin(yaw)
    shift = origin - np.array([c * database.origin[s, 0] - si * database.origin[s, 1],
                               si * database.origin[s, 0] + c * database.origin[s, 1]])
    piece = Motion(torch.as_tensor(database.local_rotations[s:e + 1]), torch.as_tensor(database.root_position[s:e + 1]))
    moved = piece.transformed(yaw, np.r_[shift, 0.0]).joints[:, [joint_index(n) for n in LOC.LIMB_JOINTS]]
    placed = LOC.placed_limb_points(database, nearest, origin, heading)
    np.testing.assert_allclose(placed, moved.double().numpy(), atol=1e-4)
    # a clear() that refuses the nearest motion's wrists (a box around its last right-wrist point) passes it over
    box = placed[-1, LOC.LIMB_JOINTS.index("right_wrist")]

    def clear(points):
        return not np.any(np.all(np.abs(points - box) < 0.05, axis=-1))

    query = database.features[nearest]
    window, _, _, rejected = LOC.select_window(database, EMPTY, query, origin, heading, clear=clear)
    assert window != nearest and rejected[0] == nearest
    assert clear(LOC.placed_limb_points(database, window, origin, heading))


def test_a_motion_is_cut_at_its_frame_nearest_the_subgoal(database):
    origin, heading = np.array([3.0, 2.5]), 0.0
    window = int(np.flatnonzero(np.linalg.norm(database.features[:, 2:4], axis=1) > 2.0)[0])
    roots = LOC._placed_roots(database, window, origin, heading)
    target = roots[len(roots) // 2]
    _, last, _, _ = LOC.select_window(database, EMPTY, database.features[window], origin, heading, candidates=1,
                                      cut_at=target)
    assert last == database.windows[window, 1] + len(roots) // 2


# ----------------------------------------------------------------------------- following the path


def check_walk(nav, grid, start, config=NAV.NavigationConfig()):
    assert nav.reached and nav.stopped == "reached" and nav.goal_error <= config.goal_tolerance
    assert not grid.collides(nav.root[:, :2]).any()
    np.testing.assert_allclose(nav.root[0, :2], start, atol=1e-5)
    assert len(nav.motion) == len(nav.root) == len(nav.heading)
    assert nav.segments[0].frames.start == 0 and nav.segments[-1].frames.stop == len(nav.root)
    for a, b in zip(nav.segments[:-1], nav.segments[1:]):
        assert a.frames.stop == b.frames.start
    # the root moves like a walk: no jump at the seams
    assert np.linalg.norm(np.diff(nav.root[:, :2], axis=0), axis=1).max() * 30.0 < 2.5


def test_follow_path_in_an_empty_room_reaches_the_goal(database):
    start = np.array([1.0, 1.0])
    nav = LOC.follow_path(EMPTY, database, start, (5.0, 3.5), (-1.0, -0.6))
    check_walk(nav, EMPTY, start)
    again = LOC.follow_path(EMPTY, database, start, (5.0, 3.5), (-1.0, -0.6))
    np.testing.assert_array_equal(again.root, nav.root)  # deterministic


def test_follow_path_round_a_wall_reaches_the_goal_without_a_collision(database):
    start = np.array([1.5, 1.0])
    nav = LOC.follow_path(WALL, database, start, (4.5, 1.0), (0.0, -1.0))
    check_walk(nav, WALL, start)
    assert nav.root[:, 1].max() > 3.0  # it went round the wall


def test_follow_path_in_a_toy_room_to_the_chair(database):
    config = NAV.NavigationConfig()
    room = make_room(8)
    grid = NAV.navigation_grid(room, config)
    np.testing.assert_array_equal(grid.blocked, room.inflated_occupancy(config.body_radius))
    np.testing.assert_array_equal(grid.collision, room.inflated_occupancy(config.collision_radius))
    start, goal = room.start_positions(1, seed=8)[0], room.approach_point(0)
    nav = LOC.follow_path(grid, database, start, goal, room.target.sit_goals[1][0, :2], config=config)
    check_walk(nav, grid, start, config)
    assert nav.plan.length > 2 * config.segment_length and len(nav.segments) >= 3  # split and matched 3 m at a time


def test_the_database_is_cached(database):
    again = LOC.motion_database(NAV.navigation_config("toy"))
    np.testing.assert_array_equal(again.features, database.features)
    np.testing.assert_array_equal(again.windows, database.windows)


# ----------------------------------------------------------------------------- errors


def test_errors_name_what_was_expected(database):
    with pytest.raises(ValueError, match=r"goal: expected a floor point inside the scene \[0, 6\] × \[0, 5\] m"):
        NAV.plan_path(EMPTY, (1.0, 1.0), (7.0, 1.0), (1.0, 0.0))
    with pytest.raises(ValueError, match=r"goal \[3, 1\] m lies inside an obstacle"):
        NAV.plan_path(WALL, (1.0, 1.0), (3.0, 1.0), (1.0, 0.0))
    with pytest.raises(ValueError, match=r"start \[3, 2\] m lies inside an obstacle"):
        LOC.follow_path(WALL, database, (3.0, 2.0), (1.0, 1.0), (1.0, 0.0))
    with pytest.raises(ValueError, match="start: expected a floor point"):
        NAV.plan_path(EMPTY, (1.0, 1.0, 0.0), (2.0, 1.0), (1.0, 0.0))
    with pytest.raises(ValueError, match="goal_direction: expected a non-zero 2D direction"):
        NAV.plan_path(EMPTY, (1.0, 1.0), (2.0, 1.0), (0.0, 0.0))
    walled_in = box_room((6.0, 5.0), [((2.9, 0.0), (3.1, 5.0))])
    with pytest.raises(ValueError, match="cannot reach the goal"):
        NAV.plan_path(walled_in, (1.0, 1.0), (5.0, 1.0), (1.0, 0.0))
    with pytest.raises(ValueError, match=r"query: expected navigation features N of shape \(\.\.\., 33\)"):
        LOC.match(database, np.zeros(32))
    with pytest.raises(ValueError, match=r"query: expected navigation features N"):
        LOC.match(database, np.zeros((4, 34)))
    with pytest.raises(ValueError, match=r"pose: expected shape \(29\)"):
        LOC.query_features(np.zeros(33), (0.0, 0.0), 0.0, (1.0, 0.0), (1.0, 0.0))
    with pytest.raises(ValueError, match="blocked: expected a bool array of shape"):
        NAV.navigation_cost(np.zeros((3, 2)), (0.0, 0.0), (1.0, 0.0), np.zeros(4, bool))
    with pytest.raises(ValueError, match=r"blocked: expected a non-empty \(H, W\) bool numpy array"):
        NAV.NavigationGrid(np.zeros((4, 4)), 0.05)
    with pytest.raises(ValueError, match="collision: expected the shape of blocked"):
        NAV.NavigationGrid(np.zeros((4, 4), bool), 0.05, np.zeros((4, 5), bool))
    with pytest.raises(ValueError, match="weights: expected 9 non-negative numbers"):
        NAV.navigation_config(weights=(1.0, 1.0))
    with pytest.raises(ValueError, match="collision_radius: expected at most body_radius"):
        NAV.navigation_config(collision_radius=0.3)


def test_a_standing_spot_on_a_blocked_cell_is_snapped_to_its_free_neighbour():
    blocked = np.zeros((10, 10), bool)
    blocked[:, :5] = True
    grid = NAV.NavigationGrid(blocked, 0.1)
    assert grid.point_cell((0.49, 0.55)) == (5, 5)  # in cell (5, 4), 0.06 m from the free cell's centre
    with pytest.raises(ValueError, match="inside an obstacle"):
        grid.point_cell((0.25, 0.55))
