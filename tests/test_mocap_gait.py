"""Procedural locomotion (``world.mocap.gait``) and the toy-mocap front door (``world.mocap``)."""
import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from hoi_tutorial.metrics import foot_skating
from hoi_tutorial.world import mocap
from hoi_tutorial.world.body import toe_positions
from hoi_tutorial.world.mocap import gait
from hoi_tutorial.world.motion import ACTIONS, Motion
from hoi_tutorial.world.rotations import yaw_of_matrix
from hoi_tutorial.world.skeleton import FOOT_JOINT_HEIGHT, PARENTS, bone_lengths, joint_index

LOCOMOTION = ("idle", "walk", "run", "turn", "side_step")
FOOT = {"left": joint_index("left_foot"), "right": joint_index("right_foot")}
CONTACT_COLUMN = {"left": 1, "right": 2}


@pytest.fixture(scope="module")
def clips():
    """One clip of each locomotion kind, generated once for the module."""
    return {
        "walk": gait.walk_path([[0.0, 0.0], [0.0, 3.0], [2.0, 4.5]], seed=3),
        "straight_walk": gait.walk_path([[0.0, 0.0], [0.0, 6.0]], seed=4),
        "run": gait.walk_path([[0.0, 0.0], [0.0, 9.0]], seed=5, gait="run"),
        "turn": gait.turn_in_place(2.4, seed=6, position=(1.0, -1.0), heading=0.3),
        "side_step": gait.side_step(0.8, seed=7, heading=-0.5),
        "idle": gait.idle(3.0, seed=8, position=(0.5, 0.5), heading=1.0),
    }


def _heading(motion, frame):
    return float(yaw_of_matrix(motion.global_rotations[frame, 0]))


def _angle_diff(a, b):
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


# ----------------------------------------------------------------------------- determinism

@pytest.mark.parametrize("kind", LOCOMOTION)
def test_same_seed_same_clip_and_different_seed_different_clip(kind):
    a = mocap.generate_clip(kind, seed=11)
    b = mocap.generate_clip(kind, seed=11)
    c = mocap.generate_clip(kind, seed=12)
    assert torch.equal(a.local_rotations, b.local_rotations)
    assert torch.equal(a.root_position, b.root_position)
    assert np.array_equal(a.actions, b.actions) and np.array_equal(a.contacts, b.contacts)
    assert a.local_rotations.shape != c.local_rotations.shape or not torch.equal(a.local_rotations, c.local_rotations)


def test_generator_seed_is_accepted_and_reproducible():
    a = gait.walk_path([[0, 0], [1.5, 1.5]], seed=np.random.default_rng(4))
    b = gait.walk_path([[0, 0], [1.5, 1.5]], seed=np.random.default_rng(4))
    assert torch.equal(a.local_rotations, b.local_rotations)


# ----------------------------------------------------------------------------- feet

@pytest.mark.parametrize("name", ["walk", "straight_walk", "run", "turn", "side_step"])
def test_foot_skating_of_generated_locomotion_is_small(clips, name):
    motion = clips[name]
    for side in ("right", "left"):
        toe = toe_positions(motion, side)
        assert float(foot_skating(toe)) < 0.05, (name, side)


@pytest.mark.parametrize("name", ["walk", "straight_walk", "run", "turn", "side_step", "idle"])
def test_feet_in_contact_are_planted_on_the_ground(clips, name):
    motion = clips[name]
    joints = motion.joints.numpy()
    for side, column in CONTACT_COLUMN.items():
        contact = motion.contacts[:, column]
        assert contact.any()
        foot = joints[:, FOOT[side]]
        both = contact[1:] & contact[:-1]
        step = np.linalg.norm(np.diff(foot[:, :2], axis=0), axis=1)
        assert step[both].max(initial=0.0) < 0.002, (name, side)
        assert np.abs(foot[contact, 2] - FOOT_JOINT_HEIGHT).max() < 0.005, (name, side)


def test_swinging_feet_lift_off_the_ground(clips):
    motion = clips["straight_walk"]
    for side, column in CONTACT_COLUMN.items():
        swing = ~motion.contacts[:, column]
        height = motion.joints[:, FOOT[side], 2].numpy()
        assert swing.any() and height[swing].max() > FOOT_JOINT_HEIGHT + 0.04


def test_walk_has_double_support_and_run_has_flight(clips):
    walk, run = clips["straight_walk"], clips["run"]
    walking = walk.actions == ACTIONS.index("walk")
    feet = walk.contacts[:, 1:3]
    assert (feet.all(1) & walking).any()
    assert feet[walking].any(1).all()  # a walker always has a foot on the ground
    running = run.actions == ACTIONS.index("run")
    flight = ~run.contacts[:, 1:3].any(1) & running
    assert flight.sum() >= 6


# ----------------------------------------------------------------------------- skeleton

def test_bone_lengths_are_preserved_and_values_finite():
    betas = mocap.sample_betas(3)
    motion = gait.walk_path([[0, 0], [0.5, 3.0]], betas=betas, seed=2)
    joints = motion.joints
    assert torch.isfinite(joints).all() and torch.isfinite(motion.local_rotations).all()
    lengths = (joints[:, 1:] - joints[:, list(PARENTS[1:])]).norm(dim=-1)
    expected = bone_lengths(betas)[1:]
    assert torch.allclose(lengths, expected.expand_as(lengths), atol=1e-4)


@pytest.mark.parametrize("name", ["walk", "run", "turn", "side_step", "idle"])
def test_knees_stay_bent_forward_and_never_over_extend(clips, name):
    motion = clips[name]
    joints = motion.joints.numpy()
    rot = motion.global_rotations.numpy()
    for side in ("left", "right"):
        hip, knee, ankle = (joints[:, joint_index(f"{side}_{j}")] for j in ("hip", "knee", "ankle"))
        thigh, shin = np.linalg.norm(knee - hip, axis=1), np.linalg.norm(ankle - knee, axis=1)
        reach = np.linalg.norm(ankle - hip, axis=1) / (thigh + shin)
        assert reach.max() < 0.9985, (name, side)
        # The knee sits in front of the hip-ankle line, along the foot's forward direction.
        line = ankle - hip
        t = np.einsum("ij,ij->i", knee - hip, line) / np.einsum("ij,ij->i", line, line)
        off_line = knee - (hip + t[:, None] * line)
        foot_forward = rot[:, joint_index(f"{side}_ankle"), :, 1]
        assert (np.einsum("ij,ij->i", off_line, foot_forward) > 0).all(), (name, side)


def test_arms_swing_opposite_to_the_legs(clips):
    motion = clips["straight_walk"]
    joints = motion.joints.numpy()
    walking = (motion.actions == ACTIONS.index("walk"))
    forward = lambda j: joints[walking, joint_index(j), 1] - joints[walking, 0, 1]  # noqa: E731  walking along +Y
    legs = forward("left_ankle") - forward("right_ankle")
    arms = forward("left_wrist") - forward("right_wrist")
    assert np.corrcoef(legs, arms)[0, 1] < -0.5


# ----------------------------------------------------------------------------- paths, speed, heading

def test_walk_reaches_the_last_waypoint_and_ends_still(clips):
    motion = clips["walk"]
    end = motion.root_position[-1, :2].numpy()
    assert np.linalg.norm(end - np.array([2.0, 4.5])) < 0.15
    tail = motion.joints[-6:].numpy()
    assert np.abs(np.diff(tail, axis=0)).max() < 1e-4
    assert motion.action_names()[-1] == "idle"
    assert motion.contacts[-1, 1:3].all()


def _cruise_speed(motion, label):
    speed = motion.root_velocity()[:, :2].norm(dim=-1).numpy()
    moving = (motion.actions == ACTIONS.index(label)) & (speed > 0.8 * speed.max())
    return float(np.mean(speed[moving]))


def test_sampled_speed_lies_in_the_gait_range(clips):
    assert 0.85 <= _cruise_speed(clips["straight_walk"], "walk") <= 1.55
    assert 2.3 <= _cruise_speed(clips["run"], "run") <= 3.5


@pytest.mark.parametrize("speed", [1.0, 1.4])
def test_requested_walking_speed_is_kept(speed):
    motion = gait.walk_path([[0, 0], [0, 7.0]], seed=1, speed=speed)
    assert abs(_cruise_speed(motion, "walk") - speed) < 0.08


def test_heading_follows_the_path(clips):
    motion = clips["walk"]
    velocity = motion.root_velocity()[:, :2].numpy()
    speed = np.linalg.norm(velocity, axis=1)
    yaw = yaw_of_matrix(motion.global_rotations[:, 0]).numpy()
    for f in np.flatnonzero(speed > 0.6):
        direction = math.atan2(-velocity[f, 0], velocity[f, 1])
        assert _angle_diff(direction, yaw[f]) < math.radians(25), f


@pytest.mark.parametrize("end_heading", [math.pi, -1.0, 0.5])
def test_end_heading_is_honoured(end_heading):
    motion = gait.walk_path([[0, 0], [0.0, 2.5]], seed=4, end_heading=end_heading)
    assert _angle_diff(_heading(motion, -1), end_heading) < math.radians(10)
    assert np.linalg.norm(motion.root_position[-1, :2].numpy() - [0.0, 2.5]) < 0.15
    names = motion.action_names()
    if _angle_diff(end_heading, 0.0) > math.radians(20):
        assert "turn" in names and names.index("turn") > names.index("walk")


@pytest.mark.parametrize("end_heading", [math.pi, -1.6, 1.0])
def test_end_heading_is_reached_with_turning_steps(end_heading):
    motion = gait.walk_path([[0, 0], [0.0, 2.5]], seed=4, end_heading=end_heading, end_turn="steps")
    assert _angle_diff(_heading(motion, -1), end_heading) < math.radians(10)
    assert np.linalg.norm(motion.root_position[-1, :2].numpy() - [0.0, 2.5]) < 0.15
    # The body turns while it steps in: no turn on the spot, and shorter than walking, then turning.
    assert "turn" not in motion.action_names()
    spot = gait.walk_path([[0, 0], [0.0, 2.5]], seed=4, end_heading=end_heading)
    assert len(motion) < len(spot) - 15
    joints = motion.joints.numpy()
    for side, column in CONTACT_COLUMN.items():
        contact = motion.contacts[:, column]
        both = contact[1:] & contact[:-1]
        assert np.linalg.norm(np.diff(joints[:, FOOT[side], :2], axis=0), axis=1)[both].max(initial=0.0) < 0.002
    # Turning steps never cross the legs: where both feet are down, the right one is to the right.
    yaw = yaw_of_matrix(motion.global_rotations[:, 0]).numpy()
    right = np.stack([np.cos(yaw), np.sin(yaw)], -1)
    gap = np.einsum("ti,ti->t", joints[:, FOOT["right"], :2] - joints[:, FOOT["left"], :2], right)
    planted = motion.contacts[:, 1] & motion.contacts[:, 2]
    assert gap[planted].min() > 0.08


def test_turn_in_place_turns_on_the_spot(clips):
    motion = clips["turn"]
    assert _angle_diff(_heading(motion, -1), 0.3 + 2.4) < math.radians(10)
    drift = np.linalg.norm(motion.root_position[:, :2].numpy() - [1.0, -1.0], axis=1)
    assert drift.max() < 0.15
    assert "turn" in motion.action_names()


def test_side_step_moves_sideways_without_crossing_feet(clips):
    motion = clips["side_step"]
    heading = -0.5
    right = np.array([math.cos(heading), math.sin(heading)])
    shift = motion.root_position[-1, :2].numpy() - motion.root_position[0, :2].numpy()
    assert abs(float(shift @ right) - 0.8) < 0.1 and abs(float(shift @ np.array([-right[1], right[0]]))) < 0.1
    assert _angle_diff(_heading(motion, -1), heading) < math.radians(5)
    joints = motion.joints.numpy()
    gap = (joints[:, FOOT["right"], :2] - joints[:, FOOT["left"], :2]) @ right
    assert gap.min() > 0.1


def test_idle_keeps_both_feet_planted_but_is_alive(clips):
    motion = clips["idle"]
    assert motion.contacts[:, 1:3].all()
    assert set(motion.action_names()) == {"idle"}
    pelvis = motion.root_position.numpy()
    assert np.ptp(pelvis[:, :2], axis=0).max() > 0.003
    wrist = motion.joint("right_wrist").numpy()
    assert np.ptp(wrist, axis=0).max() > 0.005


def test_start_pose_is_continued_exactly(clips):
    previous = clips["turn"]
    start = (previous.local_rotations[-1], previous.root_position[-1])
    heading = _heading(previous, -1)
    ahead = previous.root_position[-1, :2].numpy() + 2.0 * np.array([-math.sin(heading), math.cos(heading)])
    motion = gait.walk_path([[0.0, 0.0], ahead], seed=9, start=start)
    assert torch.allclose(motion.joints[0], previous.joints[-1], atol=1e-3)
    joined = Motion.concatenate([previous, motion.slice(1, len(motion))])
    seam = len(previous)
    jump = (joined.joints[seam] - joined.joints[seam - 1]).norm(dim=-1).max()
    assert float(jump) < 0.03  # under 0.9 m/s across the seam: the body eases out of the start pose


@settings(max_examples=6)
@given(st.lists(st.tuples(st.floats(-2.5, 2.5), st.floats(-2.5, 2.5)), min_size=2, max_size=4),
       st.integers(0, 2**16))
def test_random_paths_end_at_the_goal_with_planted_feet(points, seed):
    waypoints = np.array(points)
    if np.linalg.norm(np.diff(waypoints, axis=0), axis=1).min() < 0.3:
        waypoints = mocap.random_path(seed, len(points))
    motion = gait.walk_path(waypoints, seed=seed)
    assert np.linalg.norm(motion.root_position[-1, :2].numpy() - waypoints[-1]) < 0.15
    for side, column in CONTACT_COLUMN.items():
        contact = motion.contacts[:, column]
        foot = motion.joints[:, FOOT[side]].numpy()
        both = contact[1:] & contact[:-1]
        assert np.linalg.norm(np.diff(foot[:, :2], axis=0), axis=1)[both].max(initial=0.0) < 0.002


def test_footstep_plan_alternates_feet_beside_the_root():
    def root_at(t):  # 1.2 m/s along +Y for 3 s
        return np.array([0.0, 1.2 * min(t, 3.0)]), 0.0

    initial = {"left": (np.array([-0.12, 0.08]), 0.0), "right": (np.array([0.12, 0.08]), 0.0)}
    steps = gait.footstep_plan(root_at, 3.0, initial=initial, first_side="right", step_period=0.55,
                               duty=0.62, half_width=0.075, over_foot=0.47)
    moving = sorted((s for s in steps if math.isfinite(s.start)), key=lambda s: s.start)
    assert len(moving) >= 6
    assert all(a.side != b.side for a, b in zip(moving[:-2], moving[1:-1]))  # alternating while walking
    for side in ("left", "right"):
        own = sorted((s for s in steps if s.side == side), key=lambda s: s.start)
        assert all(a.end < b.start for a, b in zip(own[:-1], own[1:]))  # a foot swings between stances
        sign = -1.0 if side == "left" else 1.0
        assert all(sign * s.ball[0] > 0.03 for s in own)  # each foot stays on its own side
    final = {s.side: s for s in steps if math.isinf(s.end)}
    assert abs(final["left"].ball[1] - final["right"].ball[1]) < 0.02  # feet side by side at the end
    assert abs(final["left"].ball[1] - (3.6 + 0.08)) < 0.05


def test_interaction_kinds_are_registered_when_their_module_exists():
    present = [kind for kind in mocap.INTERACTION_KINDS if kind in mocap.ACTION_GENERATORS]
    if not present:
        pytest.skip("world.mocap.interactions is not part of this build")
    assert present == list(mocap.INTERACTION_KINDS)
    clips = mocap.generate_dataset(1, seed=2, kinds=["sit"])
    again = mocap.generate_dataset(1, seed=2, kinds=["sit"])
    assert torch.equal(clips[0].local_rotations, again[0].local_rotations)
    assert clips[0].meta["kind"] == "sit" and "sit" in clips[0].action_names()


# ----------------------------------------------------------------------------- errors

def test_bad_inputs_raise_clear_errors():
    with pytest.raises(ValueError, match="waypoints"):
        gait.walk_path(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="waypoints"):
        gait.walk_path([[0.0, 0.0]])
    with pytest.raises(ValueError, match="gait"):
        gait.walk_path([[0, 0], [1, 1]], gait="jog")
    with pytest.raises(ValueError, match="end_turn"):
        gait.walk_path([[0, 0], [1, 1]], end_heading=1.0, end_turn="hop")
    with pytest.raises(ValueError, match="duration"):
        gait.idle(-1.0)
    with pytest.raises(ValueError, match="start"):
        gait.idle(1.0, start=(torch.eye(3), torch.zeros(3)))
    with pytest.raises(ValueError, match="distance"):
        gait.side_step(0.0)
    with pytest.raises(ValueError, match="kind"):
        mocap.generate_clip("moonwalk", seed=0)


def test_unknown_kind_lists_the_registered_kinds():
    with pytest.raises(ValueError) as info:
        mocap.generate_clip("moonwalk", seed=0)
    for kind in LOCOMOTION:
        assert kind in str(info.value)


def test_a_bare_string_of_kinds_is_refused_by_name():
    # list("sit") would be its letters, and the error would name "s"
    with pytest.raises(ValueError, match=r"a sequence of kind names such as \('sit',\), got the string 'sit'"):
        mocap.generate_dataset(1, seed=0, kinds="sit")


# ----------------------------------------------------------------------------- front door

def test_registry_has_locomotion_kinds_and_labels_clips():
    for kind in LOCOMOTION:
        assert kind in mocap.ACTION_GENERATORS
    motion = mocap.generate_clip("run", seed=2)
    assert motion.meta["kind"] == "run" and "run" in motion.action_names()


def test_sample_betas_is_deterministic_and_clipped():
    a, b = mocap.sample_betas(5), mocap.sample_betas(5)
    assert a.shape == (10,) and torch.equal(a, b)
    assert not torch.equal(a, mocap.sample_betas(6))
    big = mocap.sample_betas(0, scale=4.0)
    assert big.abs().max() <= 2.5
    assert torch.equal(mocap.sample_betas(1, scale=0.0), torch.zeros(10))


def test_generate_dataset_is_deterministic_and_seeds_each_clip_independently():
    a = mocap.generate_dataset(2, seed=3, kinds=["turn", "idle"], subjects=2)
    b = mocap.generate_dataset(2, seed=3, kinds=["turn", "idle"], subjects=2)
    assert len(a) == 4
    for x, y in zip(a, b):
        assert torch.equal(x.local_rotations, y.local_rotations) and torch.equal(x.betas, y.betas)
    assert [m.meta["kind"] for m in a] == ["turn", "turn", "idle", "idle"]
    assert [m.meta["subject"] for m in a] == [0, 1, 0, 1]
    assert not torch.equal(a[0].betas, a[1].betas)
    # Adding kinds or clips leaves the others unchanged.
    c = mocap.generate_dataset(1, seed=3, kinds=["idle"], subjects=2)
    assert torch.equal(c[0].local_rotations, a[2].local_rotations)
    with pytest.raises(ValueError, match="kinds"):
        mocap.generate_dataset(1, seed=0, kinds=["moonwalk"])


def test_a_motion_comes_back_from_the_cache_field_by_field(tmp_cache, assert_same_motion):
    from hoi_tutorial.infra import load_or_build
    from hoi_tutorial.world.motion import motion_from_payload, motion_payload

    clip = mocap.generate_clip("walk", seed=3)  # float32, action and contact labels, a nested meta
    for k, motion in enumerate((clip, clip.transformed(0.4, (1.0, 2.0, 0.0)).slice(3, 9),
                                Motion(clip.local_rotations.double(), clip.root_position.double(), clip.betas.double()))):
        def payload():
            return motion_payload(motion)

        load_or_build("motion_round_trip", {"k": k}, payload)  # built and stored
        back = motion_from_payload(load_or_build("motion_round_trip", {"k": k}, payload))  # loaded
        assert_same_motion(motion, back)
    with pytest.raises(TypeError, match="Motion"):
        motion_payload(clip.joints)
    with pytest.raises(ValueError, match="motion_payload"):
        motion_from_payload({"local_rotations": clip.local_rotations})


def test_a_cached_dataset_is_the_dataset_made_directly(tmp_cache, capsys, assert_same_motion):
    kinds = ("walk", "reach_grasp", "open_door")
    made = mocap.generate_dataset(2, seed=4, kinds=kinds, subjects=2)
    built = mocap.generate_dataset(2, seed=4, kinds=kinds, subjects=2, cache=True)
    capsys.readouterr()
    loaded = mocap.generate_dataset(2, seed=4, kinds=kinds, subjects=2, cache=True)
    assert "[cache] loaded mocap_dataset" in capsys.readouterr().out
    assert len(made) == len(built) == len(loaded) == 6
    for x, y, z in zip(made, built, loaded):
        assert_same_motion(x, y)
        assert_same_motion(x, z)
    other = mocap.generate_dataset(2, seed=4, kinds=kinds, cache=True)  # the mean body: other clips, not these
    assert not torch.equal(other[1].betas, made[1].betas) and not torch.equal(other[1].joints, made[1].joints)
    with pytest.raises(ValueError, match="cache"):
        mocap.generate_dataset(1, seed=0, kinds=("walk",), cache="yes")
