"""Forward kinematics, global/local rotations, two-bone IK and the body-shape vector."""
import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from hoi_tutorial.world import skeleton as S
from hoi_tutorial.world.kinematics import LIMBS, forward_kinematics, global_to_local_rotations, solve_limb_ik
from hoi_tutorial.world.rotations import axis_angle_to_matrix

seeds = st.integers(0, 2**31 - 1)


def _random_pose(seed, batch=3, scale=0.8):
    gen = torch.Generator().manual_seed(seed)
    local = axis_angle_to_matrix(scale * torch.randn(batch, S.NUM_JOINTS, 3, generator=gen, dtype=torch.float64))
    root = torch.randn(batch, 3, generator=gen, dtype=torch.float64)
    betas = 1.5 * torch.randn(batch, S.NUM_BETAS, generator=gen, dtype=torch.float64)
    return local, root, betas


@given(seeds)
def test_fk_preserves_bone_lengths(seed):
    local, root, betas = _random_pose(seed)
    offsets = S.bone_offsets(betas)
    _, pos = forward_kinematics(local, root, offsets)
    parents = list(S.PARENTS[1:])
    lengths = (pos[:, 1:] - pos[:, parents]).norm(dim=-1)
    torch.testing.assert_close(lengths, offsets[:, 1:].norm(dim=-1), atol=1e-10, rtol=1e-12)
    torch.testing.assert_close(pos[:, 0], root)


@given(st.lists(st.floats(-2.0, 2.0), min_size=10, max_size=10))
def test_identity_pose_is_the_rest_pose(betas):
    betas = torch.tensor(betas, dtype=torch.float64)
    rest = S.rest_joint_positions(betas)
    height = S.rest_pelvis_height(betas)
    identity = torch.eye(3, dtype=torch.float64).repeat(S.NUM_JOINTS, 1, 1)
    glob, pos = forward_kinematics(identity, torch.stack([height * 0, height * 0, height]), S.bone_offsets(betas))
    torch.testing.assert_close(pos, rest, atol=1e-12, rtol=1e-12)
    torch.testing.assert_close(glob, identity)
    # Standing straight with flat feet: the foot joints sit FOOT_JOINT_HEIGHT above the ground.
    assert abs(float(rest[S.joint_index("right_foot"), 2]) - S.FOOT_JOINT_HEIGHT) < 1e-9
    assert float(rest[S.joint_index("head"), 2]) > float(rest[S.joint_index("neck"), 2]) > float(rest[0, 2])


@given(seeds)
def test_global_to_local_inverts_fk(seed):
    local, root, betas = _random_pose(seed)
    glob, _ = forward_kinematics(local, root, S.bone_offsets(betas))
    torch.testing.assert_close(global_to_local_rotations(glob), local, atol=1e-10, rtol=1e-12)


def _limb_setup(seed, limb):
    gen = torch.Generator().manual_seed(seed)
    local, root, betas = _random_pose(seed, batch=4, scale=0.5)
    offsets = S.bone_offsets(betas)
    upper, middle, end = LIMBS[limb]
    _, pos = forward_kinematics(local, root, offsets)
    l1 = offsets[:, middle].norm(dim=-1)
    l2 = offsets[:, end].norm(dim=-1)
    return gen, local, root, offsets, pos, (upper, middle, end), l1, l2


@given(seeds, st.sampled_from(sorted(LIMBS)))
def test_two_bone_ik_reaches_reachable_targets(seed, limb):
    gen, local, root, offsets, pos, (upper, middle, end), l1, l2 = _limb_setup(seed, limb)
    direction = torch.nn.functional.normalize(torch.randn(4, 3, generator=gen, dtype=torch.float64), dim=-1)
    frac = torch.rand(4, generator=gen, dtype=torch.float64)
    low, high = (l1 - l2).abs() + 0.02, l1 + l2 - 0.02
    target = pos[:, upper] + direction * (low + frac * (high - low))[:, None]
    pole = torch.tensor([0.0, 1.0, 0.0], dtype=torch.float64).expand(4, 3)
    new_local = solve_limb_ik(local, root, limb, target, pole, offsets)
    _, new_pos = forward_kinematics(new_local, root, offsets)
    assert float((new_pos[:, end] - target).norm(dim=-1).max()) < 1e-4
    # Bone lengths kept, and only the limb's two joints changed.
    torch.testing.assert_close((new_pos[:, middle] - new_pos[:, upper]).norm(dim=-1), l1, atol=1e-9, rtol=1e-12)
    torch.testing.assert_close((new_pos[:, end] - new_pos[:, middle]).norm(dim=-1), l2, atol=1e-9, rtol=1e-12)
    others = [j for j in range(S.NUM_JOINTS) if j not in (upper, middle)]
    torch.testing.assert_close(new_local[:, others], local[:, others])


@given(seeds, st.sampled_from(sorted(LIMBS)))
def test_two_bone_ik_points_at_unreachable_targets(seed, limb):
    gen, local, root, offsets, pos, (upper, middle, end), l1, l2 = _limb_setup(seed, limb)
    direction = torch.nn.functional.normalize(torch.randn(4, 3, generator=gen, dtype=torch.float64), dim=-1)
    target = pos[:, upper] + 3.0 * direction
    pole = torch.tensor([0.0, 1.0, 0.0], dtype=torch.float64).expand(4, 3)
    new_local = solve_limb_ik(local, root, limb, target, pole, offsets)
    _, new_pos = forward_kinematics(new_local, root, offsets)
    reach = new_pos[:, end] - new_pos[:, upper]
    cos = (torch.nn.functional.normalize(reach, dim=-1) * direction).sum(-1)
    assert float(cos.min()) > 1 - 1e-6
    # Fully stretched (up to the solver's small margin).
    torch.testing.assert_close(reach.norm(dim=-1), l1 + l2, atol=1e-3, rtol=1e-5)


@pytest.mark.parametrize("limb, pole", [("right_leg", (0.0, 1.0, 0.0)), ("left_leg", (0.0, 1.0, 0.0)),
                                        ("right_arm", (0.0, -1.0, 0.0)), ("left_arm", (0.0, 0.0, 1.0))])
def test_middle_joint_bends_towards_the_pole(limb, pole):
    identity = torch.eye(3, dtype=torch.float64).repeat(S.NUM_JOINTS, 1, 1)
    root = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
    upper, middle, end = LIMBS[limb]
    _, pos = forward_kinematics(identity, root)
    pos = pos.double()
    # Pull the end joint 70 % of the way towards the upper joint: the limb must bend.
    target = pos[upper] + 0.7 * (pos[end] - pos[upper])
    pole = torch.tensor(pole, dtype=torch.float64)
    new_local = solve_limb_ik(identity, root, limb, target, pole)
    _, new_pos = forward_kinematics(new_local, root)
    axis = torch.nn.functional.normalize(new_pos[end] - new_pos[upper], dim=0)
    rel = new_pos[middle] - new_pos[upper]
    bend = rel - (rel @ axis) * axis
    assert float(bend.norm()) > 0.05
    assert float(torch.nn.functional.normalize(bend, dim=0) @ pole) > 0.9


def test_bad_limb_name_raises():
    identity = torch.eye(3).repeat(S.NUM_JOINTS, 1, 1)
    with pytest.raises(ValueError, match="limb"):
        solve_limb_ik(identity, torch.zeros(3), "tail", torch.zeros(3), torch.tensor([0.0, 1.0, 0.0]))


def test_fk_bad_shapes_raise():
    with pytest.raises(ValueError, match="expected shape"):
        forward_kinematics(torch.eye(3).repeat(21, 1, 1), torch.zeros(3))
    with pytest.raises(ValueError, match="batch shape"):
        forward_kinematics(torch.eye(3).repeat(2, S.NUM_JOINTS, 1, 1), torch.zeros(3, 3))


_HEIGHT = lambda b: float(S.rest_joint_positions(b)[S.joint_index("head"), 2])  # noqa: E731
_LEG = lambda b: float(S.bone_lengths(b)[[S.joint_index("right_knee"), S.joint_index("right_ankle")]].sum())  # noqa: E731
_ARM = lambda b: float(S.bone_lengths(b)[[S.joint_index("right_elbow"), S.joint_index("right_wrist")]].sum())  # noqa: E731


def _width(b, a, c):
    joints = S.rest_joint_positions(b)
    return float(joints[S.joint_index(c), 0] - joints[S.joint_index(a), 0])


@pytest.mark.parametrize(
    "entry, measure",
    [
        (0, _HEIGHT),
        (1, _LEG),
        (1, _HEIGHT),
        (2, _ARM),
        (3, lambda b: _width(b, "left_shoulder", "right_shoulder")),
        (4, lambda b: _width(b, "left_hip", "right_hip")),
        (5, lambda b: float(S.rest_joint_positions(b)[S.joint_index("neck"), 2] - S.rest_joint_positions(b)[0, 2])),
        (7, lambda b: float(S.bone_lengths(b)[S.joint_index("head")])),
        (8, lambda b: float(S.bone_lengths(b)[S.joint_index("right_foot")])),
    ],
)
def test_betas_change_bone_lengths_in_the_documented_direction(entry, measure):
    plus, minus = torch.zeros(S.NUM_BETAS), torch.zeros(S.NUM_BETAS)
    plus[entry], minus[entry] = 1.0, -1.0
    assert measure(plus) > measure(torch.zeros(S.NUM_BETAS)) > measure(minus)


def test_overall_size_scales_every_bone():
    b = torch.zeros(S.NUM_BETAS)
    b[0] = 1.0
    ratio = S.bone_lengths(b)[1:] / S.bone_lengths(None)[1:]
    torch.testing.assert_close(ratio, torch.full_like(ratio, 1.05))
    assert float(S.rest_pelvis_height(b)) > float(S.rest_pelvis_height(None))


def test_mirror_index_is_an_involution():
    mirror = np.asarray(S.MIRROR_INDEX)
    np.testing.assert_array_equal(mirror[mirror], np.arange(S.NUM_JOINTS))
