"""Batched rotation conversions in torch.

Representations and their shapes (any number of leading batch dimensions ``...``):

- rotation matrix ``(..., 3, 3)``, acting on column vectors (``v_world = R @ v_local``);
- axis-angle ``(..., 3)``: unit axis times the angle in radians;
- quaternion ``(..., 4)`` in ``(w, x, y, z)`` order, unit norm;
- 6D ``(..., 6)``: the first two columns of the matrix, concatenated (Zhou et al. 2019), the
  continuous representation used for NIFTY Eq. 1's ``j^r`` and SAMP Eq. 1's ``j^r``.

Every function is differentiable and keeps the input's device and dtype.
"""
from __future__ import annotations

import torch

from .._validate import check_shape

__all__ = [
    "axis_angle_to_matrix",
    "matrix_to_axis_angle",
    "quaternion_to_matrix",
    "matrix_to_quaternion",
    "axis_angle_to_quaternion",
    "quaternion_to_axis_angle",
    "quaternion_multiply",
    "quaternion_conjugate",
    "matrix_to_rotation_6d",
    "rotation_6d_to_matrix",
    "rotation_about_z",
    "yaw_of_matrix",
    "geodesic_angle",
]

_EPS = 1e-8


def _skew(v: torch.Tensor) -> torch.Tensor:
    """Cross-product matrix ``[v]_x``: ``(..., 3) -> (..., 3, 3)``."""
    zero = torch.zeros_like(v[..., 0])
    x, y, z = v.unbind(-1)
    return torch.stack(
        [zero, -z, y, z, zero, -x, -y, x, zero], dim=-1
    ).reshape(v.shape[:-1] + (3, 3))


def axis_angle_to_matrix(axis_angle: torch.Tensor) -> torch.Tensor:
    """Rodrigues' formula. ``axis_angle: (..., 3)`` radians -> ``(..., 3, 3)``."""
    check_shape(axis_angle, (..., 3), "axis_angle")
    angle = axis_angle.norm(dim=-1, keepdim=True)
    # sin(a)/a and (1-cos a)/a^2 with Taylor expansions near zero keep gradients finite.
    small = angle < 1e-4
    a2 = angle * angle
    safe = torch.where(small, torch.ones_like(angle), angle)
    sinc = torch.where(small, 1.0 - a2 / 6.0, torch.sin(safe) / safe)
    cosc = torch.where(small, 0.5 - a2 / 24.0, (1.0 - torch.cos(safe)) / (safe * safe))
    K = _skew(axis_angle)
    eye = torch.eye(3, dtype=axis_angle.dtype, device=axis_angle.device).expand(K.shape)
    return eye + sinc[..., None] * K + cosc[..., None] * (K @ K)


def quaternion_to_matrix(quaternion: torch.Tensor) -> torch.Tensor:
    """``quaternion: (..., 4)`` as (w, x, y, z), normalised inside -> ``(..., 3, 3)``."""
    check_shape(quaternion, (..., 4), "quaternion")
    q = quaternion / quaternion.norm(dim=-1, keepdim=True).clamp_min(_EPS)
    w, x, y, z = q.unbind(-1)
    m = torch.stack(
        [
            1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
        ],
        dim=-1,
    )
    return m.reshape(q.shape[:-1] + (3, 3))


def matrix_to_quaternion(matrix: torch.Tensor) -> torch.Tensor:
    """``matrix: (..., 3, 3)`` -> unit quaternion ``(..., 4)`` (w, x, y, z) with ``w >= 0``.

    Uses the numerically stable branch (largest diagonal term) per element.
    """
    check_shape(matrix, (..., 3, 3), "matrix")
    m = matrix
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    # Four candidate (un-normalised) quaternions, each well conditioned in its own regime.
    t0 = 1 + m00 + m11 + m22
    t1 = 1 + m00 - m11 - m22
    t2 = 1 - m00 + m11 - m22
    t3 = 1 - m00 - m11 + m22
    cand = torch.stack(
        [
            torch.stack([t0, m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], -1),
            torch.stack([m[..., 2, 1] - m[..., 1, 2], t1, m[..., 1, 0] + m[..., 0, 1], m[..., 0, 2] + m[..., 2, 0]], -1),
            torch.stack([m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] + m[..., 0, 1], t2, m[..., 2, 1] + m[..., 1, 2]], -1),
            torch.stack([m[..., 1, 0] - m[..., 0, 1], m[..., 0, 2] + m[..., 2, 0], m[..., 2, 1] + m[..., 1, 2], t3], -1),
        ],
        dim=-2,
    )
    best = torch.stack([t0, t1, t2, t3], dim=-1).argmax(dim=-1)
    q = torch.gather(cand, -2, best[..., None, None].expand(best.shape + (1, 4))).squeeze(-2)
    q = q / q.norm(dim=-1, keepdim=True).clamp_min(_EPS)
    return torch.where(q[..., :1] < 0, -q, q)


def axis_angle_to_quaternion(axis_angle: torch.Tensor) -> torch.Tensor:
    """``(..., 3)`` radians -> ``(..., 4)`` (w, x, y, z)."""
    check_shape(axis_angle, (..., 3), "axis_angle")
    angle = axis_angle.norm(dim=-1, keepdim=True)
    half = 0.5 * angle
    small = angle < 1e-4
    safe = torch.where(small, torch.ones_like(angle), angle)
    # sin(a/2)/a -> 1/2 - a^2/48 near zero.
    s = torch.where(small, 0.5 - angle * angle / 48.0, torch.sin(half) / safe)
    return torch.cat([torch.cos(half), axis_angle * s], dim=-1)


def quaternion_to_axis_angle(quaternion: torch.Tensor) -> torch.Tensor:
    """``(..., 4)`` (w, x, y, z) -> axis-angle ``(..., 3)`` with angle in ``[0, pi]``."""
    check_shape(quaternion, (..., 4), "quaternion")
    q = quaternion / quaternion.norm(dim=-1, keepdim=True).clamp_min(_EPS)
    q = torch.where(q[..., :1] < 0, -q, q)
    xyz = q[..., 1:]
    sin_half = xyz.norm(dim=-1, keepdim=True)
    angle = 2.0 * torch.atan2(sin_half, q[..., :1])
    small = sin_half < 1e-6
    safe = torch.where(small, torch.ones_like(sin_half), sin_half)
    scale = torch.where(small, 2.0 / q[..., :1].clamp_min(_EPS), angle / safe)
    return xyz * scale


def matrix_to_axis_angle(matrix: torch.Tensor) -> torch.Tensor:
    """``(..., 3, 3)`` -> axis-angle ``(..., 3)`` (through the quaternion, stable near pi)."""
    return quaternion_to_axis_angle(matrix_to_quaternion(matrix))


def quaternion_multiply(q1: torch.Tensor, q2: torch.Tensor) -> torch.Tensor:
    """Hamilton product ``q1 * q2`` (apply ``q2`` first), both ``(..., 4)`` (w, x, y, z)."""
    check_shape(q1, (..., 4), "q1")
    check_shape(q2, (..., 4), "q2")
    w1, x1, y1, z1 = q1.unbind(-1)
    w2, x2, y2, z2 = q2.unbind(-1)
    return torch.stack(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ],
        dim=-1,
    )


def quaternion_conjugate(q: torch.Tensor) -> torch.Tensor:
    """Inverse of a unit quaternion ``(..., 4)``."""
    check_shape(q, (..., 4), "q")
    return q * torch.tensor([1.0, -1.0, -1.0, -1.0], dtype=q.dtype, device=q.device)


def matrix_to_rotation_6d(matrix: torch.Tensor) -> torch.Tensor:
    """6D representation: the first two columns of ``(..., 3, 3)`` -> ``(..., 6)``.

    Layout ``[R00, R10, R20, R01, R11, R21]`` (column 0 then column 1).
    """
    check_shape(matrix, (..., 3, 3), "matrix")
    return torch.cat([matrix[..., :, 0], matrix[..., :, 1]], dim=-1)


def rotation_6d_to_matrix(rot6d: torch.Tensor) -> torch.Tensor:
    """Gram-Schmidt from the 6D representation ``(..., 6)`` to a rotation ``(..., 3, 3)``.

    Any 6 numbers whose two 3-vectors are not parallel map to a valid rotation, which is what
    makes the representation continuous for networks (Zhou et al. 2019).
    """
    check_shape(rot6d, (..., 6), "rot6d")
    a1, a2 = rot6d[..., :3], rot6d[..., 3:]
    # linalg's norm and cross: the same numbers as Tensor.norm and torch.cross, fewer dispatches per call
    b1 = a1 / torch.linalg.vector_norm(a1, dim=-1, keepdim=True).clamp_min(_EPS)
    a2 = a2 - (b1 * a2).sum(-1, keepdim=True) * b1
    b2 = a2 / torch.linalg.vector_norm(a2, dim=-1, keepdim=True).clamp_min(_EPS)
    b3 = torch.linalg.cross(b1, b2)
    return torch.stack([b1, b2, b3], dim=-1)


def rotation_about_z(yaw: torch.Tensor) -> torch.Tensor:
    """Rotation by ``yaw: (...)`` radians about the up axis (+Z) -> ``(..., 3, 3)``."""
    yaw = torch.as_tensor(yaw, dtype=torch.get_default_dtype()) if not torch.is_tensor(yaw) else yaw
    c, s = torch.cos(yaw), torch.sin(yaw)
    o, z = torch.ones_like(yaw), torch.zeros_like(yaw)
    return torch.stack([c, -s, z, s, c, z, z, z, o], dim=-1).reshape(yaw.shape + (3, 3))


def yaw_of_matrix(matrix: torch.Tensor) -> torch.Tensor:
    """Heading angle of a rotation ``(..., 3, 3)`` -> ``(...)`` radians.

    The heading is the angle about +Z of the rotated local forward axis (+Y) projected on the
    ground, measured so that ``yaw_of_matrix(rotation_about_z(a)) == a``.
    """
    check_shape(matrix, (..., 3, 3), "matrix")
    forward = matrix[..., :, 1]
    return torch.atan2(-forward[..., 0], forward[..., 1])


def geodesic_angle(r1: torch.Tensor, r2: torch.Tensor) -> torch.Tensor:
    """Angle (radians) of the relative rotation between ``r1`` and ``r2``, both ``(..., 3, 3)``."""
    check_shape(r1, (..., 3, 3), "r1")
    check_shape(r2, (..., 3, 3), "r2")
    rel = r1.transpose(-1, -2) @ r2
    cos = ((rel.diagonal(dim1=-2, dim2=-1).sum(-1) - 1.0) * 0.5).clamp(-1.0, 1.0)
    return torch.acos(cos)
