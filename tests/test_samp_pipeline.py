"""SAMP's pipeline in a room: sub-task goals along the A* path, penetration frames, a run end to end."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from hoi_tutorial.samp import goalnet as gn, motion_data as md, motionnet as mn, pipeline as pl
from hoi_tutorial.world.features import SAMP_STATE_SIZE
from hoi_tutorial.world.scenes import make_room

pytestmark = pytest.mark.usefixtures("one_cpu_thread", "module_cache")  # rollouts are cached


@pytest.fixture(scope="module")
def tasks():
    return pl.room_tasks([make_room(k, n_clutter=8) for k in range(2)], seed=0)


def test_room_tasks_start_away_from_the_goal_facing_it(tasks):
    for task in tasks:
        to_goal = task.goal_position[:2] - task.start_root[:2]
        assert np.linalg.norm(to_goal) >= 2.0
        assert task.room.is_free(task.start_root[None, :2])[0]
        # the root frame's forward (−sin θ, cos θ) points within 30° of the goal
        forward = np.array([-np.sin(task.start_root[2]), np.cos(task.start_root[2])])
        assert forward @ to_goal / np.linalg.norm(to_goal) >= np.cos(np.radians(30.0)) - 1e-9


def test_goals_follow_the_path_and_end_with_the_action(tasks):
    goals, waypoints = pl.goals_along_path(tasks[0], switch="waypoints")
    assert len(goals) == len(waypoints)  # the waypoints after the start, then the sitting goal
    for (position, direction, action, radius), point in zip(goals[:-1], waypoints[1:]):
        np.testing.assert_allclose(position[:2], point)
        assert action == "walk" and radius > 0 and abs(np.linalg.norm(direction) - 1) < 1e-9
    assert goals[-1][2] == "sit" and goals[-1][3] == 0.0
    np.testing.assert_allclose(goals[-1][0], tasks[0].goal_position)
    # the last walk goal is the standing spot in front of the seat
    spot = tasks[0].room.standing_point(tasks[0].goal_position, tasks[0].goal_direction)
    np.testing.assert_allclose(waypoints[-1], spot)
    direct, none = pl.goals_along_path(tasks[0], planning=False)
    assert none is None and len(direct) == 1 and direct[0][2] == "sit"
    with pytest.raises(ValueError, match="action"):
        pl.goals_along_path(tasks[0], action="lie")


def test_a_start_outside_the_room_is_a_clear_error(tasks):
    task = tasks[0]
    outside = dataclasses.replace(task, start_root=np.array([task.room.size[0] + 1.0, 1.0, 0.0]))
    for planning in (True, False):
        with pytest.raises(ValueError, match=r"start: expected a floor point inside the room"):
            pl.goals_along_path(outside, planning=planning)


def test_goalnet_tasks_take_a_proposed_goal_with_a_standing_spot():
    torch.manual_seed(0)
    model = gn.build_goalnet(gn.goalnet_config(interaction_hidden=(16,), interaction_out=4, hidden=(16,), latent=2)).eval()
    rooms = [make_room(k, n_clutter=8) for k in range(2)]
    tasks = pl.room_tasks(rooms, seed=0, goalnet=model)
    for task, room in zip(tasks, rooms):
        room.standing_point(task.goal_position, task.goal_direction)  # raises when there is none
        assert np.linalg.norm(task.start_root[:2] - task.goal_position[:2]) >= 2.0
    # the goal is one GoalNet proposed: the same draw as sample_goals with the task's generator
    again = pl.room_tasks(rooms, seed=0, goalnet=model)
    np.testing.assert_array_equal(again[0].goal_position, tasks[0].goal_position)
    labelled = pl.room_tasks(rooms, seed=0)
    assert not np.allclose(labelled[0].goal_position, tasks[0].goal_position)


def test_penetrating_frames_counts_clutter_not_the_target(tasks):
    room = tasks[0].room
    deepest = []
    for i, obj in enumerate(room.objects):  # the deepest of 2000 points in each clutter object's box
        if i != room.target_index:
            lo, hi = obj.canonical_bounds
            candidates = obj.to_world(np.random.default_rng(i).uniform(lo, hi, size=(2000, 3)))
            deepest.append(candidates[np.argmin(obj.sdf(candidates))])
    inside_clutter = min(deepest, key=lambda p: room.sdf(p[None])[0])
    assert room.sdf(inside_clutter[None])[0] < -0.02
    inside_target = tasks[0].goal_position - np.array([0.0, 0.0, 0.1])  # just under the seated pelvis: in the seat
    free = np.r_[tasks[0].start_root[:2], 1.0]
    joints = np.repeat(free[None, None], 3, axis=0).repeat(22, axis=1)
    joints[1, 5] = inside_clutter
    joints[2, 5] = inside_target
    assert room.sdf(inside_target[None])[0] < 0  # it is inside the scene, but only the target
    np.testing.assert_array_equal(pl.penetrating_frames(room, joints), [False, True, False])



def test_penetrating_frames_measure_every_joint_against_every_other_object_and_the_walls(tasks):
    """Against the measure taken directly: the distance of every joint to every non-target object and the walls (the
    function measures only the joints inside an object's bounding box)."""
    from hoi_tutorial.world.primitives import union_sdf

    room = tasks[0].room
    rng = np.random.default_rng(3)
    joints = np.concatenate([rng.uniform([-0.1, -0.1, 0.0], [*(room.size + 0.1), 1.8], size=(400, 22, 3)),
                             rng.uniform([0.0, 0.0, 0.0], [*room.size, 0.6], size=(400, 22, 3))])
    others = [obj.sdf(joints) for i, obj in enumerate(room.objects) if i != room.target_index]
    deepest = np.min(np.stack(others + [union_sdf(joints, room._walls)], axis=-1), axis=-1)
    direct = (deepest < -0.02).any(axis=-1)
    assert 0.05 < direct.mean() < 0.95  # both kinds of frame are there
    np.testing.assert_array_equal(pl.penetrating_frames(room, joints), direct)

def test_room_run_end_to_end_with_and_without_planning(tasks):
    torch.manual_seed(0)
    model = mn.build_motion_model(mn.motionnet_config(
        state_hidden=(16, 8, 8), interaction_hidden=(8, 8), interaction_out=4, gating_hidden=(8, 4),
        prediction_hidden=16, n_experts=2, latent=2, model="moe")).eval()
    for planning in (True, False):
        result = pl.run_room_tasks(model, tasks, seconds=0.4, planning=planning)
        assert result.rollout.states.shape == (2, 13, SAMP_STATE_SIZE)
        assert result.penetration.shape == (2,) and 0.0 <= result.penetration_percent <= 100.0
        for share in (result.penetration, result.target_penetration, result.walking_penetration,
                      result.joint_penetration):
            assert share.shape == (2,) and ((0.0 <= share) & (share <= 1.0)).all()
        assert (result.waypoints[0] is None) == (not planning)
        for b, frame in enumerate(result.handover_frames()):
            if not planning:
                assert frame == 0  # the seat is the only goal from the start
                continue
            under = (result.rollout.goal_index[b] == result.action_goal[b]).numpy()
            assert (frame is None) == (not under.any())
            if frame is not None:
                assert under[frame] and not under[:frame].any()
    with pytest.raises(ValueError, match="tasks"):
        pl.run_room_tasks(model, [])


def test_a_cached_room_run_is_the_run_itself_and_a_moved_object_is_another_room(tasks, tmp_cache, monkeypatch):
    import dataclasses

    from hoi_tutorial.infra import cache_only

    torch.manual_seed(0)
    model = mn.build_motion_model(mn.motionnet_config(
        state_hidden=(16, 8, 8), interaction_hidden=(8, 8), interaction_out=4, gating_hidden=(8, 4),
        prediction_hidden=16, n_experts=2, latent=2)).eval()
    arguments = dict(seconds=0.4, seed=0, planning=True, latent_scale=1.0, settle=1.5, reach_radius=0.3,
                     switch="demo", action_radius=1.5, waypoint_radius=pl.WAYPOINT_RADIUS,
                     lookahead=pl.DEMO_LOOKAHEAD)

    def assert_same(a, b):
        for name in ("execution_time", "position_error", "rotation_error", "reached", "penetration",
                     "target_penetration", "walking_penetration", "joint_penetration"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        for name in ("states", "roots", "goal_index", "actions"):
            assert torch.equal(getattr(a.rollout, name), getattr(b.rollout, name)), name
        assert len(a.waypoints) == len(b.waypoints)
        for wa, wb in zip(a.waypoints, b.waypoints):
            np.testing.assert_array_equal(wa, wb)

    direct = pl._run_room_tasks(model, tasks, **arguments)
    assert_same(pl.run_room_tasks(model, tasks, seconds=0.4), direct)
    assert [p.name.split("-")[0] for p in tmp_cache.iterdir()] == ["samp_room_runs"]  # the run's motion inside it
    with monkeypatch.context() as patch, cache_only():
        patch.setattr(pl, "_run_room_tasks", lambda *a, **k: pytest.fail("a cached room run was run again"))
        assert_same(pl.run_room_tasks(model, tasks, seconds=0.4), direct)
    # a clutter object moved by 10 cm makes another room: run for it, never the cached run
    room = tasks[0].room
    clutter = next(i for i in range(len(room.objects)) if i != room.target_index)
    objects = list(room.objects)
    objects[clutter] = objects[clutter].with_pose(objects[clutter].pose @ np.diag([1.0, 1.0, 1.0, 1.0])
                                                   + np.pad(np.array([[0.1], [0.0], [0.0]]), ((0, 1), (3, 0))))
    moved = [dataclasses.replace(tasks[0], room=dataclasses.replace(room, objects=objects)), tasks[1]]
    assert_same(pl.run_room_tasks(model, moved, seconds=0.4), pl._run_room_tasks(model, moved, **arguments))
    assert len(list(tmp_cache.iterdir())) == 2


def test_rooms_and_room_tasks_come_back_from_the_cache_as_made(tmp_cache, monkeypatch):
    from hoi_tutorial.infra import cache_only

    rooms = pl.cluttered_rooms(2, seed=3)
    made = [make_room(3000 + k, n_clutter=8, target_category=pl.ROOM_TARGETS[k]) for k in range(2)]
    assert [pl._room_digest(r) for r in rooms] == [pl._room_digest(r) for r in made]  # every object, bit for bit
    for room, original in zip(rooms, made):
        np.testing.assert_array_equal(room.clearance, original.clearance)
    direct = [pl._task_digest(t) for t in pl.room_tasks(made, seed=0, cache=False)]
    assert [pl._task_digest(t) for t in pl.room_tasks(rooms, seed=0)] == direct
    with monkeypatch.context() as patch, cache_only():
        patch.setattr(pl, "make_room", lambda *a, **k: pytest.fail("a cached room was made again"))
        patch.setattr(pl, "_room_tasks", lambda *a, **k: pytest.fail("cached tasks were drawn again"))
        again = pl.room_tasks(pl.cluttered_rooms(2, seed=3), seed=0)
    assert [pl._task_digest(t) for t in again] == direct and [t.room_index for t in again] == [0, 1]
    # another seed draws other starts, not the cached ones
    assert [pl._task_digest(t) for t in pl.room_tasks(rooms, seed=1)] != direct
    with pytest.raises(ValueError, match="n_rooms"):
        pl.cluttered_rooms(0)


def test_room_voxel_cells_give_the_target_or_every_object(tasks):
    centres, occupancy = pl.room_voxel_cells(tasks)
    assert centres.shape == (2, 512, 3) and occupancy.shape == (2, 512)
    target = md.object_voxel_cells(tasks[0].room.target)
    np.testing.assert_allclose(centres[0].numpy(), target[0])
    every_c, every_o = pl.room_voxel_cells(tasks, every_object=True)
    most = max(len(t.room.objects) for t in tasks)
    assert every_c.shape == (2, 512 * most, 3)
    for b, t in enumerate(tasks):  # a room with fewer objects is padded with cells that sense nothing
        n = len(t.room.objects)
        assert float(every_o[b, 512 * n:].abs().sum()) == 0.0 and float(every_o[b, :512 * n].sum()) > 0.0


def test_an_nsm_like_model_runs_in_a_room_sensing_every_object(tasks):
    torch.manual_seed(0)
    model = mn.build_motion_model(mn.motionnet_config(
        state_hidden=(16, 8, 8), interaction_hidden=(8, 8), interaction_out=4, gating_hidden=(8, 4),
        prediction_hidden=16, n_experts=2, model="nsm")).eval()
    result = pl.run_room_tasks(model, tasks, seconds=0.4, planning=False)
    assert result.rollout.states.shape == (2, 13, SAMP_STATE_SIZE)


def test_the_path_switch_hands_over_to_the_action_once_the_rest_of_the_path_is_short(tasks):
    task = tasks[0]
    goals, waypoints = pl.goals_along_path(task, switch="path")
    assert all(g[3] == pl.WAYPOINT_RADIUS for g in goals[:-1])  # every walk goal passed within the waypoint radius
    path_goals = pl.PathGoals.from_paths([goals], [waypoints], [task.room], action_radius=1.5)
    legs = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    expected = np.r_[np.cumsum(legs[::-1])[::-1][1:], 0.0]  # goal k is waypoint k + 1; the spot has 0 left
    np.testing.assert_allclose(path_goals.remaining[0, :len(goals) - 1].numpy(), expected, rtol=1e-5, atol=1e-5)
    action, spot = len(goals) - 1, waypoints[-1]
    start = torch.zeros(1, dtype=torch.int64)
    # On the free segment just before the spot, with waypoints pending: the action takes over.
    before = spot - 0.3 * (spot - waypoints[-2]) / np.linalg.norm(spot - waypoints[-2])
    near = torch.tensor([[*before, 0.0]], dtype=torch.float32)
    assert int(path_goals.advance(start, near)[0]) == action
    # At the start (the whole path still ahead, longer than the radius): the walk goes on.
    far = torch.tensor([[*waypoints[0], 0.0]], dtype=torch.float32)
    assert legs.sum() > 1.5 and int(path_goals.advance(start, far)[0]) < action
    # The waypoint rule needs the last waypoint first.
    old_goals, old_points = pl.goals_along_path(task, switch="waypoints")
    assert old_goals[-2][3] == 1.5 and all(g[3] == pl.WAYPOINT_RADIUS for g in old_goals[:-2])
    tight, _ = pl.goals_along_path(task, switch="waypoints", waypoint_radius=0.5)
    assert all(g[3] == 0.5 for g in tight[:-2]) and tight[-2][3] == 1.5
    with pytest.raises(ValueError, match="switch"):
        pl.goals_along_path(task, switch="seat")


def test_the_demo_path_runs_to_the_goal_itself_without_corners_near_it(tasks):
    for task in tasks:
        points = pl.demo_waypoints(task)
        np.testing.assert_allclose(points[0], task.start_root[:2])
        np.testing.assert_allclose(points[-1], task.goal_position[:2])  # the seat itself, not a spot in front
        corners = points[1:-1]
        assert all(np.linalg.norm(c - task.goal_position[:2]) > pl.DEMO_CORNER_PRUNE for c in corners)
        assert task.room.is_free(corners).all() if len(corners) else True
        goals, waypoints = pl.goals_along_path(task)  # the demo is the default
        assert len(goals) == 2 and goals[-1][2] == "sit" and waypoints is not None
        assert goals[0][2] == ("walk" if len(corners) else "sit")


def _straight_corridor_goals(lookahead=1.0):
    # a path (0, 0) -> (4, 0) -> (4, 3): one corner at (4, 0); the sitting goal at (4, 3)
    points = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]])
    walk = (np.r_[lookahead, 0.0, 0.0], np.r_[1.0, 0.0, 0.0], "walk", 0.0)
    sit = (np.r_[4.0, 3.0, 0.0], np.r_[0.0, -1.0, 0.0], "sit", 0.0)
    return pl.SteeredGoals.from_paths([[walk, sit]], [points], lookahead=lookahead), points


def test_steered_goals_move_ahead_along_the_path_and_hand_over_at_the_last_corner():
    goals, _ = _straight_corridor_goals(lookahead=1.0)
    index = torch.zeros(1, dtype=torch.int64)
    # Beside the first leg at x = 1 (0.2 m off it): the walk goal is 1 m further along the path, facing along it.
    index = goals.advance(index, torch.tensor([[1.0, 0.2, 0.0]]))
    assert int(index[0]) == 0
    np.testing.assert_allclose(goals.positions[0, 0, :2].numpy(), [2.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(goals.directions[0, 0, :2].numpy(), [1.0, 0.0], atol=1e-6)
    local = goals.seen_from(index, torch.tensor([[1.0, 0.2, 0.0]]))  # the bookkeeping sees the moved goal
    assert local is not None
    # At x = 3.3, the goal wraps round the corner: 0.7 m short of it plus 1 m, i.e. 0.3 m up the second leg.
    goals.advance(index, torch.tensor([[2.2, 0.0, 0.0]]))
    index = goals.advance(index, torch.tensor([[3.3, 0.0, 0.0]]))
    assert int(index[0]) == 0
    np.testing.assert_allclose(goals.positions[0, 0, :2].numpy(), [4.0, 0.3], atol=1e-6)
    np.testing.assert_allclose(goals.directions[0, 0, :2].numpy(), [0.0, 1.0], atol=1e-6)
    # Within 0.5 m of the last corner: the sitting goal from now on.
    index = goals.advance(index, torch.tensor([[3.6, 0.0, 0.0]]))
    assert int(index[0]) == 1
    assert int(goals.advance(index, torch.tensor([[0.0, 0.0, 0.0]]))[0]) == 1  # and never back


def test_steered_goals_never_move_back_nor_jump_to_a_leg_that_passes_near():
    goals, _ = _straight_corridor_goals(lookahead=1.0)
    index = torch.zeros(1, dtype=torch.int64)
    goals.advance(index, torch.tensor([[1.2, 0.0, 0.0]]))
    goals.advance(index, torch.tensor([[2.0, 0.0, 0.0]]))
    goals.advance(index, torch.tensor([[1.0, 0.0, 0.0]]))  # walked back: the progress stays
    np.testing.assert_allclose(goals.positions[0, 0, :2].numpy(), [3.0, 0.0], atol=1e-6)
    # Beside the second leg's far end, 3 m ahead along the path: too far to be this frame's progress.
    goals.advance(index, torch.tensor([[4.4, 2.9, 0.0]]))
    np.testing.assert_allclose(goals.positions[0, 0, :2].numpy(), [3.0, 0.0], atol=1e-6)
    # A path with no corner: the sitting goal at once.
    sit = (np.r_[2.0, 0.0, 0.0], np.r_[1.0, 0.0, 0.0], "sit", 0.0)
    direct = pl.SteeredGoals.from_paths([[sit, sit]], [np.array([[0.0, 0.0], [2.0, 0.0]])])
    assert int(direct.advance(torch.zeros(1, dtype=torch.int64), torch.tensor([[0.0, 0.0, 0.0]]))[0]) == 1
    with pytest.raises(ValueError, match="lookahead"):
        pl.SteeredGoals.from_paths([[sit, sit]], [np.array([[0.0, 0.0], [2.0, 0.0]])], lookahead=0.0)
    with pytest.raises(ValueError, match="waypoints"):
        pl.SteeredGoals.from_paths([[sit, sit]], [])
