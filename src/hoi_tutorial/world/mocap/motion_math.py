"""Small math shared by the toy-mocap generators: seeded generators, angle wrapping, easing
curves (smoothstep, minimum jerk, bump), rotations about the axes or any axis, heading vectors,
blending and rotation interpolation. Everything is numpy float64 (torch only inside
:func:`slerp_rot` and :func:`minimal_rotation`); heading 0 faces +Y and +X is the character's
right.
"""
from __future__ import annotations

import math

import numpy as np
import torch

from ..rotations import axis_angle_to_matrix, matrix_to_axis_angle

__all__ = [
    "seeded_rng",
    "wrap_angle",
    "smoothstep",
    "min_jerk",
    "bump",
    "rot_x",
    "rot_y",
    "rot_z",
    "rot_axis",
    "forward_xy",
    "right_xy",
    "forward_xyz",
    "right_xyz",
    "heading_of",
    "normalize",
    "lerp",
    "slerp_rot",
    "minimal_rotation",
]


def seeded_rng(seed) -> np.random.Generator:
    """``seed`` itself when it is a ``numpy.random.Generator``, else a new one seeded with the int."""
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed: expected an int or numpy.random.Generator, got {type(seed).__name__}")
    return np.random.default_rng(int(seed))


def wrap_angle(angle):
    """Angle(s) wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def smoothstep(x):
    """``3x^2 - 2x^3`` on ``x`` clipped to [0, 1]: zero velocity at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def min_jerk(x):
    """Minimum-jerk blend 10x^3 - 15x^4 + 6x^5: zero velocity and acceleration at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10.0 + x * (-15.0 + 6.0 * x))


def bump(x):
    """``sin^2(pi x)`` on [0, 1]: 0 at both ends, 1 in the middle, flat ends."""
    return np.sin(np.pi * np.clip(x, 0.0, 1.0)) ** 2


def rot_z(yaw):
    """``(...)`` radians -> ``(..., 3, 3)`` numpy rotations about +Z."""
    yaw = np.asarray(yaw, dtype=np.float64)
    c, s = np.cos(yaw), np.sin(yaw)
    o, z = np.ones_like(yaw), np.zeros_like(yaw)
    return np.stack([c, -s, z, s, c, z, z, z, o], -1).reshape(yaw.shape + (3, 3))


def rot_x(angle):
    """``(...)`` radians -> ``(..., 3, 3)`` numpy rotations about +X."""
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(angle), np.zeros_like(angle)
    return np.stack([o, z, z, z, c, -s, z, s, c], -1).reshape(angle.shape + (3, 3))


def rot_y(angle):
    """``(...)`` radians -> ``(..., 3, 3)`` numpy rotations about +Y."""
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(angle), np.zeros_like(angle)
    return np.stack([c, z, s, z, o, z, -s, z, c], -1).reshape(angle.shape + (3, 3))


def rot_axis(axis, angle):
    """Rotations ``(..., 3, 3)`` about unit ``axis (3,)`` by ``angle (...)`` radians (Rodrigues)."""
    axis = np.asarray(axis, dtype=np.float64)
    angle = np.asarray(angle, dtype=np.float64)[..., None, None]
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def forward_xy(yaw):
    """Ground direction ``(..., 2)`` a heading faces (heading 0 faces +Y)."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([-np.sin(yaw), np.cos(yaw)], -1)


def right_xy(yaw):
    """The character's right ``(..., 2)`` on the ground for a heading."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([np.cos(yaw), np.sin(yaw)], -1)


def forward_xyz(heading):
    """Ground direction ``(..., 3)`` that a heading faces (heading 0 faces +Y)."""
    heading = np.asarray(heading, dtype=np.float64)
    return np.stack([-np.sin(heading), np.cos(heading), np.zeros_like(heading)], -1)


def right_xyz(heading):
    """The character's right ``(..., 3)`` on the ground for a heading."""
    heading = np.asarray(heading, dtype=np.float64)
    return np.stack([np.cos(heading), np.sin(heading), np.zeros_like(heading)], -1)


def heading_of(direction) -> float:
    """Heading (radians) that faces the ground direction ``direction`` (its x and y)."""
    return float(math.atan2(-direction[0], direction[1]))


def normalize(v):
    """``v (..., n)`` scaled to unit length along the last axis (zero vectors stay near zero)."""
    v = np.asarray(v, dtype=np.float64)
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def _expand(w, like):
    """Weights ``(T,)`` broadcast over the trailing dimensions of ``like (T, ...)``."""
    w = np.asarray(w, dtype=np.float64)
    return w.reshape(w.shape + (1,) * (np.ndim(like) - np.ndim(w)))


def lerp(a, b, w):
    """``a + w (b - a)`` with per-frame weights ``w (T,)``."""
    return a + _expand(w, b) * (b - a)


def slerp_rot(r0, r1, w):
    """Rotations ``(T, ..., 3, 3)`` from ``r0 (..., 3, 3)`` to ``r1 (..., 3, 3)`` (geodesic) at weights ``w (T,)``."""
    r0 = np.asarray(r0)
    rel = torch.as_tensor(np.swapaxes(r0, -1, -2) @ np.asarray(r1))
    axis_angle = matrix_to_axis_angle(rel[None]).numpy()[0]
    w = np.asarray(w)
    steps = axis_angle_to_matrix(torch.as_tensor(w.reshape(w.shape + (1,) * axis_angle.ndim) * axis_angle[None]))
    return r0[None] @ steps.numpy()


def minimal_rotation(p, q):
    """Smallest rotations ``(..., 3, 3)`` turning unit directions ``p`` onto ``q`` (both ``(..., 3)``)."""
    p, q = normalize(p), normalize(q)
    axis = np.cross(p, q)
    s = np.linalg.norm(axis, axis=-1)
    c = np.sum(p * q, axis=-1)
    angle = np.arctan2(s, c)
    axis = axis / np.maximum(s, 1e-12)[..., None]
    aa = axis * angle[..., None]
    return axis_angle_to_matrix(torch.as_tensor(aa)).numpy()
