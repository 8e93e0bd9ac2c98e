"""Rotation conversions: round trips, properties and a cross-check against scipy."""
import math

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from hoi_tutorial.world import rotations as R

# Axis-angle vectors with angle below pi (the representation is two-valued at pi).
_unit = st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda v: 0.1 < np.linalg.norm(v))
axis_angles = st.builds(
    lambda v, a: np.asarray(v) / np.linalg.norm(v) * a, _unit, st.floats(0.0, math.pi - 1e-3)
)
batches = st.lists(axis_angles, min_size=1, max_size=6).map(lambda vs: torch.tensor(np.stack(vs), dtype=torch.float64))


@given(batches)
def test_axis_angle_matrix_round_trip(aa):
    m = R.axis_angle_to_matrix(aa)
    torch.testing.assert_close(R.matrix_to_axis_angle(m), aa, atol=1e-6, rtol=1e-5)


@given(batches)
def test_matrices_are_orthonormal_with_unit_determinant(aa):
    m = R.axis_angle_to_matrix(aa)
    eye = torch.eye(3, dtype=m.dtype).expand_as(m)
    torch.testing.assert_close(m @ m.transpose(-1, -2), eye, atol=1e-10, rtol=1e-12)
    torch.testing.assert_close(torch.linalg.det(m), torch.ones(m.shape[0], dtype=m.dtype), atol=1e-10, rtol=1e-12)


@given(batches)
def test_quaternion_round_trips(aa):
    q = R.axis_angle_to_quaternion(aa)
    torch.testing.assert_close(q.norm(dim=-1), torch.ones(len(aa), dtype=aa.dtype), atol=1e-12, rtol=1e-12)
    torch.testing.assert_close(R.quaternion_to_axis_angle(q), aa, atol=1e-6, rtol=1e-5)
    m = R.quaternion_to_matrix(q)
    torch.testing.assert_close(m, R.axis_angle_to_matrix(aa), atol=1e-10, rtol=1e-12)
    torch.testing.assert_close(R.quaternion_to_matrix(R.matrix_to_quaternion(m)), m, atol=1e-10, rtol=1e-12)
    assert torch.all(R.matrix_to_quaternion(m)[:, 0] >= 0)


@given(batches)
def test_rotation_6d_round_trip(aa):
    m = R.axis_angle_to_matrix(aa)
    six = R.matrix_to_rotation_6d(m)
    assert six.shape == (len(aa), 6)
    torch.testing.assert_close(six[:, :3], m[:, :, 0])
    torch.testing.assert_close(R.rotation_6d_to_matrix(six), m, atol=1e-10, rtol=1e-12)


@given(batches, st.floats(0.2, 5.0))
def test_rotation_6d_gram_schmidt_accepts_unnormalised_input(aa, scale):
    m = R.axis_angle_to_matrix(aa)
    six = R.matrix_to_rotation_6d(m)
    # Scale the first column and add some of it to the second: Gram-Schmidt recovers m.
    skewed = torch.cat([scale * six[:, :3], six[:, 3:] + 0.3 * six[:, :3]], dim=-1)
    torch.testing.assert_close(R.rotation_6d_to_matrix(skewed), m, atol=1e-10, rtol=1e-12)


@given(batches)
def test_against_scipy(aa):
    ref = Rotation.from_rotvec(aa.numpy())
    np.testing.assert_allclose(R.axis_angle_to_matrix(aa).numpy(), ref.as_matrix(), atol=1e-10)
    q_ref = ref.as_quat()  # scalar last (x, y, z, w)
    q_ours = R.axis_angle_to_quaternion(aa).numpy()
    q_ours_xyzw = np.concatenate([q_ours[:, 1:], q_ours[:, :1]], axis=-1)
    # Same rotation up to the quaternion's sign.
    sign = np.sign(np.sum(q_ref * q_ours_xyzw, axis=-1, keepdims=True))
    np.testing.assert_allclose(q_ours_xyzw * sign, q_ref, atol=1e-10)
    m = torch.tensor(ref.as_matrix())
    np.testing.assert_allclose(R.matrix_to_axis_angle(m).numpy(), ref.as_rotvec(), atol=1e-6)
    back = R.quaternion_to_matrix(torch.tensor(q_ours))
    np.testing.assert_allclose(back.numpy(), Rotation.from_quat(q_ref).as_matrix(), atol=1e-10)


def test_matrix_to_quaternion_against_scipy_on_random_rotations():
    ref = Rotation.random(200, random_state=0)
    q = R.matrix_to_quaternion(torch.tensor(ref.as_matrix())).numpy()
    q_ref = ref.as_quat()
    q_ref = np.concatenate([q_ref[:, 3:], q_ref[:, :3]], axis=-1)
    q_ref = np.where(q_ref[:, :1] < 0, -q_ref, q_ref)
    np.testing.assert_allclose(q, q_ref, atol=1e-10)


@given(batches, batches)
def test_quaternion_multiply_matches_matrix_product(aa1, aa2):
    n = min(len(aa1), len(aa2))
    q1, q2 = R.axis_angle_to_quaternion(aa1[:n]), R.axis_angle_to_quaternion(aa2[:n])
    product = R.quaternion_to_matrix(R.quaternion_multiply(q1, q2))
    expected = R.quaternion_to_matrix(q1) @ R.quaternion_to_matrix(q2)
    torch.testing.assert_close(product, expected, atol=1e-10, rtol=1e-12)
    identity = R.quaternion_multiply(q1, R.quaternion_conjugate(q1))
    torch.testing.assert_close(identity, torch.tensor([1.0, 0, 0, 0], dtype=q1.dtype).expand_as(q1), atol=1e-10, rtol=1e-12)


@given(st.lists(st.floats(-math.pi + 1e-6, math.pi - 1e-6), min_size=1, max_size=8))
def test_rotation_about_z_and_yaw_are_inverse(yaws):
    yaw = torch.tensor(yaws, dtype=torch.float64)
    m = R.rotation_about_z(yaw)
    torch.testing.assert_close(R.yaw_of_matrix(m), yaw, atol=1e-9, rtol=1e-12)
    # A positive yaw turns the forward axis +Y towards -X (right-handed about +Z).
    forward = m @ torch.tensor([0.0, 1.0, 0.0], dtype=torch.float64)
    torch.testing.assert_close(forward[..., 0], -torch.sin(yaw))


def test_geodesic_angle_matches_rotation_angle():
    aa = torch.tensor([[0.0, 0.0, 0.7], [0.3, -0.2, 0.1]], dtype=torch.float64)
    angle = R.geodesic_angle(torch.eye(3, dtype=torch.float64).expand(2, 3, 3), R.axis_angle_to_matrix(aa))
    torch.testing.assert_close(angle, aa.norm(dim=-1), atol=1e-7, rtol=1e-5)


def test_gradients_are_finite_at_zero_rotation():
    aa = torch.zeros(2, 3, dtype=torch.float64, requires_grad=True)
    (R.axis_angle_to_matrix(aa).sum() + R.axis_angle_to_quaternion(aa).sum()).backward()
    assert torch.isfinite(aa.grad).all()
    m = torch.eye(3, dtype=torch.float64).repeat(2, 1, 1).requires_grad_(True)
    R.matrix_to_axis_angle(m).sum().backward()
    assert torch.isfinite(m.grad).all()
    six = R.matrix_to_rotation_6d(torch.eye(3, dtype=torch.float64)).requires_grad_(True)
    R.rotation_6d_to_matrix(six).sum().backward()
    assert torch.isfinite(six.grad).all()


@pytest.mark.parametrize(
    "fn, bad",
    [
        (R.axis_angle_to_matrix, torch.zeros(4, 2)),
        (R.matrix_to_axis_angle, torch.zeros(3, 2)),
        (R.quaternion_to_matrix, torch.zeros(3)),
        (R.matrix_to_quaternion, torch.zeros(2, 3)),
        (R.axis_angle_to_quaternion, torch.zeros(4)),
        (R.quaternion_to_axis_angle, torch.zeros(3)),
        (R.matrix_to_rotation_6d, torch.zeros(3, 4)),
        (R.rotation_6d_to_matrix, torch.zeros(5)),
        (R.yaw_of_matrix, torch.zeros(3)),
    ],
)
def test_bad_shapes_raise(fn, bad):
    with pytest.raises(ValueError, match="expected shape"):
        fn(bad)


def test_quaternion_multiply_bad_shape_raises():
    with pytest.raises(ValueError, match="expected shape"):
        R.quaternion_multiply(torch.zeros(4), torch.zeros(3))
