"""Pose-state features: canonical frame, NIFTY Eq. 1 round trip, SAMP Eq. 1 (reduced)."""
import math

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from hoi_tutorial.world import features as F
from hoi_tutorial.world.mocap.poses import standing_pose
from hoi_tutorial.world.motion import ACTIONS, CONTACT_JOINTS, Motion, action_id
from hoi_tutorial.world.rotations import axis_angle_to_matrix, rotation_about_z, yaw_of_matrix
from hoi_tutorial.world.skeleton import NUM_BETAS, NUM_JOINTS


def _toy_motion(seed: int, T: int = 30, heading: float = 0.8, betas=None) -> Motion:
    """A standing pose with jittering joints drifting over the ground."""
    gen = torch.Generator().manual_seed(seed)
    local, root = standing_pose(betas, position=(1.0, -2.0), heading=heading)
    jitter = axis_angle_to_matrix(0.25 * torch.randn(T, NUM_JOINTS, 3, generator=gen))
    local = jitter @ local.expand(T, -1, -1, -1)
    steps = 0.02 * torch.randn(T, 3, generator=gen) + torch.tensor([0.03, 0.01, 0.0])
    kwargs = {} if betas is None else {"betas": betas}
    return Motion(local, root + torch.cumsum(steps, dim=0), **kwargs)


def test_nifty_layout_sizes_sum_to_336():
    sizes = {name: s.stop - s.start for name, s in F.NIFTY_STATE_LAYOUT.items()}
    assert sizes == {"joint_positions": 66, "joint_rotations": 132, "joint_velocities": 66,
                     "joint_angular_velocities": 66, "root_position": 3, "root_velocity": 3}
    assert sum(sizes.values()) == F.NIFTY_STATE_SIZE == 336
    stops = [s.stop for s in F.NIFTY_STATE_LAYOUT.values()]
    starts = [s.start for s in F.NIFTY_STATE_LAYOUT.values()]
    assert starts == [0] + stops[:-1]


@given(st.floats(-3.0, 3.0), st.floats(-5.0, 5.0), st.floats(-5.0, 5.0))
def test_canonicalize_faces_plus_y_at_the_origin(heading, x, y):
    local, root = standing_pose(position=(x, y), heading=heading)
    motion = Motion(local[None].repeat(3, 1, 1, 1), root[None].repeat(3, 1))
    assert abs(float(F.body_heading(motion.joints[0])) - heading) < 2e-3 or abs(abs(heading) - math.pi) < 2e-3
    canon = F.canonicalize(motion)
    assert abs(float(F.body_heading(canon.joints[0]))) < 1e-5
    torch.testing.assert_close(canon.root_position[0, :2], torch.zeros(2), atol=1e-5, rtol=1e-5)
    assert float(canon.root_position[0, 2]) == pytest.approx(float(root[2]), abs=1e-6)
    # The pelvis's own heading follows (the hips' facing is within a milliradian of it).
    assert abs(float(yaw_of_matrix(canon.global_rotations[0, 0]))) < 2e-3


def test_canonical_transform_accepts_a_pose_pair_and_a_later_frame():
    motion = _toy_motion(0, heading=-2.0)
    yaw, translation = F.canonical_transform((motion.global_rotations, motion.joints), frame=10)
    assert translation.shape == (3,) and float(translation[2]) == 0.0
    moved = F.canonicalize(motion, frame=10)
    assert abs(float(F.body_heading(moved.joints[10]))) < 1e-5
    torch.testing.assert_close(moved.joints[10, 0, :2], torch.zeros(2), atol=1e-5, rtol=1e-5)
    yaw_motion, translation_motion = F.canonical_transform(motion, 10)
    assert yaw == pytest.approx(yaw_motion) and torch.equal(translation, translation_motion)
    yaw_numpy, _ = F.canonical_transform((motion.global_rotations.numpy(), motion.joints.numpy()), frame=10)
    assert yaw_numpy == pytest.approx(yaw)
    assert float(F.body_heading(motion.joints.numpy()[0])) == pytest.approx(float(F.body_heading(motion.joints[0])))
    with pytest.raises(ValueError, match="frame"):
        F.canonical_transform(motion, frame=99)
    with pytest.raises(TypeError, match="Motion"):
        F.canonical_transform(motion.joints)


@pytest.mark.parametrize("seed", [0, 1])
def test_nifty_state_round_trip(seed):
    betas = None if seed == 0 else torch.linspace(-1, 1, NUM_BETAS)
    motion = _toy_motion(seed, T=40, betas=betas)
    state = F.nifty_pose_state(motion)
    assert state.shape == (40, 336)
    back = F.motion_from_nifty_state(state, betas=motion.betas)
    canon = F.canonicalize(motion)
    assert float((back.joints - canon.joints).abs().max()) < 1e-4
    torch.testing.assert_close(back.local_rotations, canon.local_rotations, atol=1e-5, rtol=1e-5)
    # Without integration the root comes straight from t^p.
    direct = F.motion_from_nifty_state(state, betas=motion.betas, integrate_root=False)
    assert float((direct.root_position - canon.root_position).abs().max()) < 1e-6
    # The state starts in the canonical frame: pelvis on the z axis.
    parts = F.split_nifty_state(state)
    torch.testing.assert_close(parts["root_position"][0, :2], torch.zeros(2), atol=1e-5, rtol=1e-5)


def test_root_integration_uses_the_velocity():
    state = F.nifty_pose_state(_toy_motion(2, T=20))
    edited = state.clone()
    edited[:, F.NIFTY_STATE_LAYOUT["root_velocity"]] += torch.tensor([0.3, -0.6, 0.0])
    back = F.motion_from_nifty_state(edited)
    original = F.motion_from_nifty_state(state)
    shift = back.root_position - original.root_position
    expected = torch.arange(20)[:, None] / 30.0 * torch.tensor([0.3, -0.6, 0.0])
    torch.testing.assert_close(shift, expected, atol=1e-5, rtol=1e-5)


def test_split_and_decode_are_batched_and_differentiable():
    state = torch.stack([F.nifty_pose_state(_toy_motion(s, T=10)) for s in range(3)]).requires_grad_(True)
    parts = F.split_nifty_state(state)
    assert parts["joint_positions"].shape == (3, 10, 22, 3)
    assert parts["joint_rotations"].shape == (3, 10, 22, 6)
    assert parts["root_velocity"].shape == (3, 10, 3)
    local, root = F.nifty_state_to_pose(state)
    assert local.shape == (3, 10, 22, 3, 3) and root.shape == (3, 10, 3)
    (local.sum() + root[:, -1].sum()).backward()
    assert torch.isfinite(state.grad).all() and float(state.grad.abs().sum()) > 0
    with pytest.raises(ValueError, match="expected shape"):
        F.split_nifty_state(torch.zeros(4, 335))


def test_velocities_of_a_constant_drift():
    local, root = standing_pose()
    T = 12
    velocity = torch.tensor([0.6, -0.3, 0.0])
    motion = Motion(local.expand(T, -1, -1, -1), root + torch.arange(T)[:, None] / 30.0 * velocity)
    parts = F.split_nifty_state(F.nifty_pose_state(motion, canonical=False))
    torch.testing.assert_close(parts["root_velocity"], velocity.expand(T, 3), atol=1e-4, rtol=1e-5)
    torch.testing.assert_close(parts["joint_velocities"], velocity.expand(T, 22, 3), atol=1e-4, rtol=1e-5)
    torch.testing.assert_close(parts["joint_angular_velocities"], torch.zeros(T, 22, 3), atol=1e-5, rtol=1e-5)


@given(st.floats(-4.0, 4.0), st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: np.linalg.norm(v) > 0.2))
def test_angular_velocity_of_a_constant_spin(rate, axis):
    axis = torch.tensor(axis) / torch.tensor(axis).norm()
    T, fps = 15, 30.0
    spin = axis_angle_to_matrix(torch.arange(T)[:, None] / fps * rate * axis)
    local, root = standing_pose()
    local = local.expand(T, -1, -1, -1).clone()
    local[:, 0] = spin @ local[:, 0]
    motion = Motion(local, root.expand(T, 3))
    omega = F.split_nifty_state(F.nifty_pose_state(motion, canonical=False))["joint_angular_velocities"]
    # A rigid spin of the whole body: every joint turns at the same rate about the same axis.
    torch.testing.assert_close(omega, (rate * axis).expand(T, 22, 3), atol=2e-4, rtol=1e-5)
    torch.testing.assert_close(F.angular_velocity(spin, fps), (rate * axis).expand(T, 3), atol=2e-4, rtol=1e-5)


def test_samp_layout_and_action_mapping():
    sizes = {name: s.stop - s.start for name, s in F.SAMP_STATE_LAYOUT.items()}
    assert sum(sizes.values()) == F.SAMP_STATE_SIZE == 437
    assert sizes["trajectory_positions"] == 2 * len(F.SAMP_SAMPLE_OFFSETS) == 14
    assert sizes["trajectory_actions"] == 5 * 7 and sizes["contacts"] == len(CONTACT_JOINTS)
    assert F.SAMP_SAMPLE_OFFSETS[0] == -1.0 and F.SAMP_SAMPLE_OFFSETS[-1] == 1.0
    expected = {"sit_down": "sit", "stand_up": "sit", "lie": "lie", "lie_down": "lie", "turn": "walk",
                "side_step": "walk", "run": "run", "lift": "idle", "open_door": "idle"}
    for name, samp in expected.items():
        assert F.SAMP_ACTIONS[int(F.samp_action_ids(name)[0])] == samp
        assert F.samp_action_ids([action_id(name)])[0] == F.SAMP_ACTIONS.index(samp)
    assert set(F.SAMP_ACTION_OF) == set(ACTIONS)
    with pytest.raises(ValueError, match="action label"):
        F.samp_action_ids("dance")


def test_samp_state_shapes_and_frames():
    T = 45
    motion = _toy_motion(3, T=T, heading=2.0)
    motion.actions = np.array([action_id("walk")] * 30 + [action_id("sit_down")] * 15)
    motion.contacts = np.zeros((T, 5), dtype=bool)
    motion.contacts[:, 1] = True
    parts, flat = F.samp_pose_state(motion, goal_position=[2.0, 0.0, 0.45], goal_direction=[0.0, -1.0], goal_action="sit")
    assert flat.shape == (T, 437)
    for name, s in F.SAMP_STATE_LAYOUT.items():
        assert parts[name].shape == (T, s.stop - s.start)
        torch.testing.assert_close(flat[:, s], parts[name])
    traj = parts["trajectory_positions"].reshape(T, 7, 2)
    dirs = parts["trajectory_directions"].reshape(T, 7, 2)
    # The middle sample is the current root: the origin of its own frame, facing +Y.
    torch.testing.assert_close(traj[:, 3], torch.zeros(T, 2), atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(dirs[:, 3], torch.tensor([0.0, 1.0]).expand(T, 2), atol=1e-5, rtol=1e-5)
    # Pelvis at the root frame's origin (height kept).
    jp = parts["joint_positions"].reshape(T, 22, 3)
    torch.testing.assert_close(jp[:, 0, :2], torch.zeros(T, 2), atol=1e-5, rtol=1e-5)
    actions = parts["trajectory_actions"].reshape(T, 7, 5)
    assert torch.all(actions.sum(-1) == 1)
    assert actions[0, 3].argmax() == F.SAMP_ACTIONS.index("walk") and actions[-1, 3].argmax() == F.SAMP_ACTIONS.index("sit")
    goal_actions = parts["goal_actions"].reshape(T, 7, 5)
    assert torch.all(goal_actions[..., F.SAMP_ACTIONS.index("sit")] == 1)
    torch.testing.assert_close(parts["contacts"][:, 1], torch.ones(T))
    # The goal seen from each sample's frame has its true distance.
    goal = parts["goal_positions"].reshape(T, 7, 3)
    truth = torch.tensor([2.0, 0.0, 0.45]) - F.root_frame(motion.joints)[0]
    torch.testing.assert_close(goal[:, 3].norm(dim=-1), truth.norm(dim=-1), atol=1e-5, rtol=1e-5)


def test_samp_state_takes_a_goal_action_per_frame():
    T = 12
    motion = _toy_motion(6, T=T)
    labels = ["walk"] * 5 + ["sit"] * 7
    parts, _ = F.samp_pose_state(motion, [1.0, 0.0, 0.4], [0.0, 1.0], goal_action=labels)
    ids = parts["goal_actions"].reshape(T, 7, 5).argmax(-1)
    expected = torch.as_tensor(F.samp_action_ids(labels))
    assert torch.equal(ids, expected[:, None].expand(T, 7))  # every sample of a frame carries its frame's goal
    single, _ = F.samp_pose_state(motion, [1.0, 0.0, 0.4], [0.0, 1.0], goal_action="sit")
    torch.testing.assert_close(parts["goal_actions"][5:], single["goal_actions"][5:])
    with pytest.raises(ValueError, match="goal_action"):
        F.samp_pose_state(motion, [1.0, 0.0, 0.4], [0.0, 1.0], goal_action=["walk"] * 3)


def test_samp_state_is_invariant_to_moving_the_clip():
    motion = _toy_motion(4, T=20)
    moved = motion.transformed(yaw=1.3, translation=(0.5, -0.7, 0.0))
    goal, direction = torch.tensor([1.0, 2.0, 0.4]), torch.tensor([1.0, 0.0, 0.0])
    rot = rotation_about_z(torch.tensor(1.3))
    _, flat = F.samp_pose_state(motion, goal, direction, action_labels="walk")
    _, flat_moved = F.samp_pose_state(moved, rot @ goal + torch.tensor([0.5, -0.7, 0.0]), rot @ direction, action_labels="walk")
    torch.testing.assert_close(flat_moved, flat, atol=1e-4, rtol=1e-5)


def test_samp_state_without_goal_or_labels_has_zero_goal_parts():
    parts, flat = F.samp_pose_state(_toy_motion(5, T=12))
    assert flat.shape == (12, 437)
    for name in ("goal_trajectory_positions", "goal_positions", "goal_actions", "trajectory_actions", "contacts"):
        assert torch.all(parts[name] == 0)
    with pytest.raises(ValueError, match="goal_direction"):
        F.samp_pose_state(_toy_motion(5, T=12), goal_position=[0.0, 0.0, 0.0])


def test_samp_fd_features():
    motion = _toy_motion(6, T=25)
    features = F.samp_fd_features(motion)
    sizes = {name: s.stop - s.start for name, s in F.SAMP_FD_LAYOUT.items()}
    assert features.shape == (25, sum(sizes.values())) == (25, 292)
    # Default goal: the clip's final root, so the last frame sits at the goal facing +Y.
    goal_traj = features[:, F.SAMP_FD_LAYOUT["goal_trajectory_positions"]].reshape(25, 7, 2)
    goal_dirs = features[:, F.SAMP_FD_LAYOUT["goal_trajectory_directions"]].reshape(25, 7, 2)
    torch.testing.assert_close(goal_traj[-1, 3], torch.zeros(2), atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(goal_dirs[-1, 3], torch.tensor([0.0, 1.0]), atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("name", ["local_rotations", "root_position", "betas"])
def test_a_motion_refuses_non_finite_values_by_name(name):
    # A NaN root or rotation would reach every metric and figure unnoticed: refused where the Motion is made.
    values = {"local_rotations": torch.eye(3).expand(4, NUM_JOINTS, 3, 3).clone(),
              "root_position": torch.zeros(4, 3), "betas": torch.zeros(NUM_BETAS)}
    Motion(**values)
    values[name].view(-1)[0] = float("nan")
    with pytest.raises(ValueError, match=f"{name}: expected finite values"):
        Motion(**values)
