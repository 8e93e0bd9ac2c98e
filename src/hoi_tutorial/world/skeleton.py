"""The SMPL-22 skeleton of the toy world and the toy body-shape vector ``b``.

Joint names, order and parents are SMPL's body joints (no hands). Rest offsets are taken from
SMPL's neutral body in its T-pose, converted from SMPL's frame (Y up, +Z forward, +X the body's
left) to the toy world's frame (Z up, +Y forward, +X the body's right):
``ours = (-x_smpl, z_smpl, y_smpl)``, a proper rotation.

The toy body shape ``b`` has 10 numbers like SMPL's betas; ``b = 0`` is the mean body and each
entry is about one standard deviation per unit. It scales bone lengths (and, in ``world.body``,
limb thickness):

====  ==========================================  ==========================
 b    effect                                      per unit
====  ==========================================  ==========================
 0    overall size (every bone)                    +5 %
 1    leg length (hip-knee, knee-ankle)            +4 %
 2    arm length (shoulder-elbow, elbow-wrist)     +4 %
 3    shoulder width (collar-shoulder)             +6 %
 4    hip width (pelvis-hip)                       +6 %
 5    torso length (spine chain, neck)             +4 %
 6    limb girth (capsule radii, ``world.body``)   +8 %
 7    head and neck size                           +4 %
 8    foot length (ankle-foot)                     +5 %
 9    torso girth (``world.body``)                 +8 %
====  ==========================================  ==========================
"""
from __future__ import annotations

import numpy as np
import torch

from .._validate import as_tensor, check_shape

__all__ = [
    "JOINT_NAMES",
    "PARENTS",
    "NUM_JOINTS",
    "NUM_BETAS",
    "joint_index",
    "REST_JOINTS_SMPL",
    "rest_joint_positions",
    "bone_offsets",
    "bone_lengths",
    "rest_pelvis_height",
    "FOOT_JOINT_HEIGHT",
    "LEFT_JOINTS",
    "RIGHT_JOINTS",
    "MIRROR_INDEX",
    "children_of",
]

JOINT_NAMES: tuple[str, ...] = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2",
    "left_ankle", "right_ankle", "spine3", "left_foot", "right_foot", "neck",
    "left_collar", "right_collar", "head", "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist",
)
PARENTS: tuple[int, ...] = (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19)
NUM_JOINTS = 22
NUM_BETAS = 10

# SMPL neutral T-pose joint locations in SMPL's own frame (Y up, +Z forward, +X body's left), metres.
REST_JOINTS_SMPL = np.array(
    [
        [-0.0022, -0.2408, 0.0286], [0.0586, -0.3266, 0.0219], [-0.0606, -0.3314, 0.0218],
        [0.0044, -0.1142, -0.0017], [0.1043, -0.7188, 0.0085], [-0.1043, -0.7219, 0.0076],
        [0.0015, 0.0220, 0.0260], [0.0884, -1.1257, -0.0263], [-0.0919, -1.1333, -0.0281],
        [0.0019, 0.0760, 0.0256], [0.1192, -1.1832, 0.1077], [-0.1197, -1.1836, 0.1113],
        [-0.0011, 0.2980, -0.0143], [0.0788, 0.2003, -0.0044], [-0.0806, 0.1987, -0.0080],
        [0.0050, 0.3624, 0.0391], [0.1720, 0.2331, -0.0157], [-0.1714, 0.2307, -0.0189],
        [0.4318, 0.2298, -0.0390], [-0.4324, 0.2270, -0.0368], [0.6859, 0.2433, -0.0337],
        [-0.6878, 0.2447, -0.0332],
    ]
)

# Height of the foot joint (ball of the foot) above the ground when the sole is flat, metres.
FOOT_JOINT_HEIGHT = 0.035

LEFT_JOINTS = tuple(i for i, n in enumerate(JOINT_NAMES) if n.startswith("left_"))
RIGHT_JOINTS = tuple(i for i, n in enumerate(JOINT_NAMES) if n.startswith("right_"))
MIRROR_INDEX = tuple(
    JOINT_NAMES.index(n.replace("left_", "right_")) if n.startswith("left_")
    else JOINT_NAMES.index(n.replace("right_", "left_")) if n.startswith("right_")
    else i
    for i, n in enumerate(JOINT_NAMES)
)


def joint_index(name: str) -> int:
    """Index of an SMPL joint by name (e.g. ``"right_wrist"`` -> 21)."""
    if name not in JOINT_NAMES:
        raise ValueError(f"joint name: expected one of {list(JOINT_NAMES)}, got {name!r}")
    return JOINT_NAMES.index(name)


def children_of(joint: int) -> tuple[int, ...]:
    """Direct children of a joint index in the kinematic tree."""
    return tuple(j for j, p in enumerate(PARENTS) if p == joint)


def _smpl_to_world(points: np.ndarray) -> np.ndarray:
    """SMPL frame (Y up, +Z forward, +X left) -> toy world (Z up, +Y forward, +X right)."""
    return np.stack([-points[..., 0], points[..., 2], points[..., 1]], axis=-1)


_REST_OFFSETS = np.zeros((NUM_JOINTS, 3))
_REST_OFFSETS[1:] = _smpl_to_world(REST_JOINTS_SMPL[1:] - REST_JOINTS_SMPL[list(PARENTS[1:])])

# Which bones each shape entry lengthens: entry -> (child joints whose offset scales, per-unit gain, axes).
_IDX = {n: i for i, n in enumerate(JOINT_NAMES)}
_LEG = [_IDX[n] for n in ("left_knee", "right_knee", "left_ankle", "right_ankle")]
_ARM = [_IDX[n] for n in ("left_elbow", "right_elbow", "left_wrist", "right_wrist")]
_SHOULDER = [_IDX[n] for n in ("left_shoulder", "right_shoulder")]
_HIP = [_IDX[n] for n in ("left_hip", "right_hip")]
_TORSO = [_IDX[n] for n in ("spine1", "spine2", "spine3", "neck", "left_collar", "right_collar")]
_HEAD = [_IDX["head"]]
_FOOT = [_IDX[n] for n in ("left_foot", "right_foot")]


def _as_betas(betas) -> torch.Tensor:
    if betas is None:
        return torch.zeros(NUM_BETAS)
    # A floating tensor keeps its dtype (float64 callers get float64 offsets); anything else -> float32.
    if not (isinstance(betas, torch.Tensor) and betas.is_floating_point()):
        betas = as_tensor(betas, "betas")
    check_shape(betas, (..., NUM_BETAS), "betas")
    return betas


def bone_offsets(betas=None) -> torch.Tensor:
    """Rest offsets of each joint from its parent for body shape ``betas``.

    Args:
        betas: ``(..., 10)`` toy body shape, or ``None`` for the mean body.
    Returns:
        ``(..., 22, 3)`` metres in the parent's rest frame (T-pose, world axes); row 0 is zero.
    """
    betas = _as_betas(betas)
    base = torch.as_tensor(_REST_OFFSETS, dtype=betas.dtype, device=betas.device)
    scale = torch.ones(betas.shape[:-1] + (NUM_JOINTS, 3), dtype=betas.dtype, device=betas.device)
    scale = scale * (1.0 + 0.05 * betas[..., 0])[..., None, None]
    scale[..., _LEG, :] *= (1.0 + 0.04 * betas[..., 1])[..., None, None]
    scale[..., _ARM, :] *= (1.0 + 0.04 * betas[..., 2])[..., None, None]
    # Widths scale only the lateral (x) component of the offset.
    scale[..., _SHOULDER, 0] *= (1.0 + 0.06 * betas[..., 3])[..., None]
    scale[..., _HIP, 0] *= (1.0 + 0.06 * betas[..., 4])[..., None]
    scale[..., _TORSO, :] *= (1.0 + 0.04 * betas[..., 5])[..., None, None]
    scale[..., _HEAD, :] *= (1.0 + 0.04 * betas[..., 7])[..., None, None]
    scale[..., _FOOT, :] *= (1.0 + 0.05 * betas[..., 8])[..., None, None]
    if torch.any(scale <= 0):
        raise ValueError("betas: expected values within about ±5 (a bone length became non-positive)")
    return base * scale


def bone_lengths(betas=None) -> torch.Tensor:
    """Length of the bone ending at each joint, ``(..., 22)`` metres (0 for the pelvis)."""
    return bone_offsets(betas).norm(dim=-1)


def rest_joint_positions(betas=None) -> torch.Tensor:
    """T-pose joint positions ``(..., 22, 3)`` standing on the ground, facing +Y, pelvis above the origin."""
    offsets = bone_offsets(betas)
    pos = [offsets[..., 0, :]]
    for j in range(1, NUM_JOINTS):
        pos.append(pos[PARENTS[j]] + offsets[..., j, :])
    joints = torch.stack(pos, dim=-2)
    height = rest_pelvis_height(betas)
    return joints + torch.stack([torch.zeros_like(height), torch.zeros_like(height), height], -1)[..., None, :]


def rest_pelvis_height(betas=None) -> torch.Tensor:
    """Pelvis height ``(...)`` metres when standing straight with flat feet on the ground."""
    offsets = bone_offsets(betas)
    # Vertical drop pelvis -> hip -> knee -> ankle -> foot (all T-pose offsets point down the leg).
    chain = [_IDX["right_hip"], _IDX["right_knee"], _IDX["right_ankle"], _IDX["right_foot"]]
    drop = -offsets[..., chain, 2].sum(-1)
    return drop + FOOT_JOINT_HEIGHT
