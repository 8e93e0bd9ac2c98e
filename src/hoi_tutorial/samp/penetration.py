"""How far the body goes into the room's furniture (SAMP §5.2, "the percentage of frames where a penetration
happens"), measured with the toy body's surface, not its joint centres.

The toy body is a union of capsules (``world.body``: a segment swept by a sphere of radius ``r``). A capsule
reaches ``r − d`` metres into an object when its segment comes within ``d`` of the object's surface from outside,
or lies ``−d`` inside it: with the object's exact signed distance ``φ`` (negative inside),

    depth(capsule, object) = r − min over the segment of φ(p).

The segment is read at ``CAPSULE_SAMPLES`` points; a frame's depth is the largest over the capsules and the
objects. A frame *penetrates* when that depth exceeds a tolerance (2 cm, as the joint-centre count of
``pipeline.penetrating_frames``). The target, where the character is asked to sit, is measured apart: contact with it
is the task, and going into it is the paper's Limitations' failure, not a collision on the way.

A joint centre lies a capsule radius (5-12 cm) inside the skin, so a body can brush a table with its thigh, or pass
its hand through a shelf, with no joint centre inside: the joint-centre count misses such frames (the test of this
module walks a body through a table).
"""
from __future__ import annotations

from typing import Optional

import numpy as np
import torch

from .._validate import check_shape
from ..world.body import capsule_segments
from ..world.features import SAMP_STATE_LAYOUT
from ..world.primitives import union_sdf
from ..world.rotations import rotation_6d_to_matrix, rotation_about_z
from ..world.skeleton import NUM_JOINTS

__all__ = ["CAPSULE_SAMPLES", "TOLERANCE", "rollout_pose", "body_depths", "penetration_shares"]

# Points read along each capsule's segment (ours): the longest toy capsule, the thigh, about 0.45 m, is read every
# 6-7 cm, less than the thinnest capsule's diameter.
CAPSULE_SAMPLES = 8
# How far into an object a frame must reach to count (as the joint-centre count of ``pipeline.penetrating_frames``).
TOLERANCE = 0.02


def rollout_pose(states: torch.Tensor, roots: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The world pose of SAMP states (Eq. 1), as ``world.body`` takes it.

    Args:
        states: ``(..., 437)`` SAMP states (``runtime.Rollout.states``); their ``j^p`` and ``j^r`` are in the root frame.
        roots: ``(..., 3)`` the world roots ``(x, y, heading)``; the root frame's +Y is ``(−sin h, cos h)``.
    Returns:
        ``(global_rotations (..., 22, 3, 3), joint_positions (..., 22, 3))`` in the world, float64.
    """
    states, roots = torch.as_tensor(states), torch.as_tensor(roots)
    check_shape(roots, (..., 3), "roots")
    lead = states.shape[:-1]
    local_p = states[..., SAMP_STATE_LAYOUT["joint_positions"]].reshape(*lead, NUM_JOINTS, 3).double()
    local_r = rotation_6d_to_matrix(states[..., SAMP_STATE_LAYOUT["joint_rotations"]].reshape(*lead, NUM_JOINTS, 6)
                                    .double())
    yaw = rotation_about_z(roots[..., 2].double())                                           # R_z(h)
    positions = (yaw[..., None, :, :] @ local_p[..., None])[..., 0]
    positions = positions + torch.cat([roots[..., :2].double(), torch.zeros_like(roots[..., :1]).double()],
                                      -1)[..., None, :]
    return yaw[..., None, :, :] @ local_r, positions


def body_depths(room, global_rotations, joint_positions, betas=None) -> dict:
    """Per frame, how far the body's capsules reach into the room's walls and non-target objects, and into the target.

    Args:
        room: a ``world.scenes.Room``.
        global_rotations: ``(T, 22, 3, 3)``; joint_positions: ``(T, 22, 3)`` metres, world (:func:`rollout_pose`).
        betas: the body shape (``None``: the mean body, as SAMP's toy characters).
    Returns:
        ``{"clutter": (T,), "target": (T,)}`` metres, the largest ``r − min φ`` over the capsules, exact where
        positive (the body reaches in). Segment points farther than the largest radius outside an object's bounding
        box are not read, so where the body stays clear the value is negative but may be lower than the exact one.
    """
    a, b, radius = capsule_segments(global_rotations, joint_positions, betas)         # (T, C, 3), (T, C)
    t = torch.linspace(0.0, 1.0, CAPSULE_SAMPLES, dtype=a.dtype)
    points = (a[..., None, :] + t[:, None] * (b - a)[..., None, :]).numpy()           # (T, C, K, 3)
    radius = radius.numpy()
    flat = points.reshape(-1, 3)
    reach = float(radius.max())

    def deepest(sdf_of, lo, hi) -> np.ndarray:
        phi = np.full(len(flat), np.inf)
        near = np.flatnonzero(np.all((flat >= lo - reach) & (flat <= hi + reach), axis=1))  # the rest is clear
        if len(near):
            phi[near] = sdf_of(flat[near])
        return (radius - phi.reshape(points.shape[:-1]).min(axis=-1)).max(axis=-1)

    big = np.full(3, np.inf)
    clutter = deepest(lambda p: union_sdf(p, room._walls), -big, big)
    for i, obj in enumerate(room.objects):
        if i != room.target_index:
            clutter = np.maximum(clutter, deepest(obj.sdf, *obj.bounds))
    target = deepest(room.target.sdf, *room.target.bounds)
    return {"clutter": clutter, "target": target}


def penetration_shares(room, global_rotations, joint_positions, betas=None, tolerance: float = TOLERANCE) -> dict:
    """The share of frames whose body reaches more than ``tolerance`` metres into the clutter (walls and non-target
    objects) and, apart, into the target: ``{"clutter": float, "target": float}`` in [0, 1]."""
    if not (np.isfinite(tolerance) and tolerance >= 0.0):
        raise ValueError(f"tolerance: expected a non-negative number of metres, got {tolerance!r}")
    depths = body_depths(room, global_rotations, joint_positions, betas)
    return {name: float(np.mean(d > tolerance)) for name, d in depths.items()}
