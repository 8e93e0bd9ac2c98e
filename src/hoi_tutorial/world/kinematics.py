"""Batched forward kinematics and analytic two-bone inverse kinematics on the SMPL-22 tree.

A pose is a set of *local* joint rotations ``(..., 22, 3, 3)`` (each relative to its parent's
frame; the pelvis's is its world orientation) and a root translation ``(..., 3)`` (the pelvis
position in metres). Rest offsets come from ``skeleton.bone_offsets(betas)``; the identity pose
is SMPL's T-pose facing +Y.
"""
from __future__ import annotations

import torch

from .._validate import check_shape
from .rotations import axis_angle_to_matrix
from .skeleton import NUM_JOINTS, PARENTS, bone_offsets

__all__ = [
    "forward_kinematics",
    "global_to_local_rotations",
    "two_bone_ik",
    "solve_limb_ik",
    "LIMBS",
]

# (upper joint, middle joint, end joint) of each two-bone limb.
LIMBS = {
    "left_leg": (1, 4, 7),
    "right_leg": (2, 5, 8),
    "left_arm": (16, 18, 20),
    "right_arm": (17, 19, 21),
}


def forward_kinematics(local_rotations: torch.Tensor, root_position: torch.Tensor, offsets=None):
    """Global joint rotations and positions from local rotations.

    ``G_j = G_parent(j) @ R_j`` and ``p_j = p_parent(j) + G_parent(j) @ o_j``.

    Args:
        local_rotations: ``(..., 22, 3, 3)`` local rotation matrices.
        root_position: ``(..., 3)`` pelvis position, metres.
        offsets: ``(22, 3)`` or ``(..., 22, 3)`` rest offsets (default: the mean body).
    Returns:
        ``(global_rotations (..., 22, 3, 3), positions (..., 22, 3))``.
    """
    check_shape(local_rotations, (..., NUM_JOINTS, 3, 3), "local_rotations")
    check_shape(root_position, (..., 3), "root_position")
    if root_position.shape[:-1] != local_rotations.shape[:-3]:
        raise ValueError(
            f"root_position: expected batch shape {tuple(local_rotations.shape[:-3])} to match "
            f"local_rotations, got {tuple(root_position.shape[:-1])}"
        )
    if offsets is None:
        offsets = bone_offsets(None)
    check_shape(offsets, (..., NUM_JOINTS, 3), "offsets")
    offsets = offsets.to(dtype=local_rotations.dtype, device=local_rotations.device)
    offsets = offsets.expand(local_rotations.shape[:-3] + (NUM_JOINTS, 3))
    # one unbind per input and positions kept as columns (..., 3, 1) until the end: the same products and sums
    # in fewer calls (a batch-1 call is mostly per-call overhead: about twice as fast)
    local = local_rotations.unbind(-3)
    columns = offsets[..., None].unbind(-3)
    rots = [local[0]]
    pos = [root_position[..., None]]
    for j in range(1, NUM_JOINTS):
        p = PARENTS[j]
        rots.append(rots[p] @ local[j])
        pos.append(pos[p] + rots[p] @ columns[j])
    return torch.stack(rots, dim=-3), torch.cat(pos, dim=-1).transpose(-1, -2)


def global_to_local_rotations(global_rotations: torch.Tensor) -> torch.Tensor:
    """Inverse of the rotation part of FK: ``R_j = G_parent(j)^T @ G_j``; ``(..., 22, 3, 3)``."""
    check_shape(global_rotations, (..., NUM_JOINTS, 3, 3), "global_rotations")
    parents = torch.tensor([0] + list(PARENTS[1:]), device=global_rotations.device)
    parent_rot = global_rotations[..., parents, :, :]
    local = parent_rot.transpose(-1, -2) @ global_rotations
    return torch.cat([global_rotations[..., :1, :, :], local[..., 1:, :, :]], dim=-3)


def _normalize(v: torch.Tensor) -> torch.Tensor:
    return v / v.norm(dim=-1, keepdim=True).clamp_min(1e-9)


def _rotation_between(p: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
    """Smallest rotation ``(..., 3, 3)`` turning direction ``p`` onto direction ``q`` (both ``(..., 3)``)."""
    p, q = _normalize(p), _normalize(q)
    axis = torch.cross(p, q, dim=-1)
    angle = torch.atan2(axis.norm(dim=-1), (p * q).sum(-1))
    # Anti-parallel vectors: any axis perpendicular to p works.
    helper = torch.where(p[..., :1].abs() < 0.9, torch.tensor([1.0, 0.0, 0.0]).to(p), torch.tensor([0.0, 1.0, 0.0]).to(p))
    perp = torch.cross(p, helper, dim=-1)
    axis = torch.where(axis.norm(dim=-1, keepdim=True) < 1e-9, perp, axis)
    return axis_angle_to_matrix(_normalize(axis) * angle[..., None])


def two_bone_ik(
    upper_global: torch.Tensor,
    middle_global: torch.Tensor,
    upper_pos: torch.Tensor,
    middle_pos: torch.Tensor,
    end_pos: torch.Tensor,
    target: torch.Tensor,
    pole: torch.Tensor,
):
    """Analytic two-bone IK (law of cosines), returning new *global* rotations of the two joints.

    The chain upper -> middle -> end (hip-knee-ankle or shoulder-elbow-wrist) is bent so the end
    reaches ``target`` when it is within reach (otherwise the limb points straight at it), with
    the middle joint bending in the plane that contains ``pole``, a direction (not a point) the
    middle joint should move towards (forward for knees, backward for elbows). The new middle
    joint position follows from the law of cosines; each bone is then carried onto its new
    direction by the smallest rotation, so bone lengths are kept exactly.

    Args:
        upper_global, middle_global: ``(..., 3, 3)`` current global rotations of the two joints.
        upper_pos, middle_pos, end_pos: ``(..., 3)`` current joint positions, metres.
        target: ``(..., 3)`` desired end position, metres.
        pole: ``(..., 3)`` bend direction for the middle joint.
    Returns:
        ``(new_upper_global, new_middle_global)``, each ``(..., 3, 3)``.
    """
    for name, t in (("upper_pos", upper_pos), ("middle_pos", middle_pos), ("end_pos", end_pos),
                    ("target", target), ("pole", pole)):
        check_shape(t, (..., 3), name)
    check_shape(upper_global, (..., 3, 3), "upper_global")
    check_shape(middle_global, (..., 3, 3), "middle_global")
    a, b, c = upper_pos, middle_pos, end_pos
    l_ab = (b - a).norm(dim=-1)
    l_bc = (c - b).norm(dim=-1)
    eps = 1e-4
    to_target = target - a
    l_at = to_target.norm(dim=-1).clamp(min=(l_ab - l_bc).abs() + eps, max=l_ab + l_bc - eps)
    u = _normalize(to_target)
    # Bend plane: spanned by the reach direction u and the pole; w points to the pole side.
    n = torch.cross(u, pole, dim=-1)
    degenerate = n.norm(dim=-1, keepdim=True) < 1e-6
    n = _normalize(torch.where(degenerate, torch.cross(u, b - a, dim=-1), n))
    w = torch.cross(n, u, dim=-1)
    # Law of cosines: the angle at the upper joint between the reach line and the first bone.
    cos_a = ((l_ab**2 + l_at**2 - l_bc**2) / (2 * l_ab * l_at)).clamp(-1.0, 1.0)
    sin_a = (1 - cos_a**2).clamp_min(0).sqrt()
    b_new = a + l_ab[..., None] * (cos_a[..., None] * u + sin_a[..., None] * w)
    c_new = a + l_at[..., None] * u
    # Minimal (swing) rotations carry each bone onto its new direction.
    r_upper = _rotation_between(b - a, b_new - a)
    shin = (r_upper @ (c - b)[..., None])[..., 0]
    r_middle = _rotation_between(shin, c_new - b_new)
    new_upper = r_upper @ upper_global
    new_middle = r_middle @ r_upper @ middle_global
    return new_upper, new_middle


def solve_limb_ik(
    local_rotations: torch.Tensor,
    root_position: torch.Tensor,
    limb: str,
    target: torch.Tensor,
    pole: torch.Tensor,
    offsets=None,
) -> torch.Tensor:
    """Pose a limb so its end joint reaches ``target``; returns updated local rotations.

    Args:
        local_rotations: ``(..., 22, 3, 3)``.
        root_position: ``(..., 3)`` metres.
        limb: one of ``"left_leg"``, ``"right_leg"``, ``"left_arm"``, ``"right_arm"``.
        target: ``(..., 3)`` world position for the ankle or wrist, metres.
        pole: ``(..., 3)`` world direction the knee/elbow should bend towards.
        offsets: rest offsets as in :func:`forward_kinematics`.
    Returns:
        ``(..., 22, 3, 3)`` local rotations with the limb's two joints changed.
    """
    if limb not in LIMBS:
        raise ValueError(f"limb: expected one of {list(LIMBS)}, got {limb!r}")
    upper, middle, end = LIMBS[limb]
    glob, pos = forward_kinematics(local_rotations, root_position, offsets)
    target = target.to(pos)
    pole = pole.to(pos).expand_as(target)
    new_upper, new_middle = two_bone_ik(
        glob[..., upper, :, :], glob[..., middle, :, :],
        pos[..., upper, :], pos[..., middle, :], pos[..., end, :], target, pole,
    )
    parent_upper = glob[..., PARENTS[upper], :, :]
    out = local_rotations.clone()
    out[..., upper, :, :] = parent_upper.transpose(-1, -2) @ new_upper
    out[..., middle, :, :] = new_upper.transpose(-1, -2) @ new_middle
    return out
