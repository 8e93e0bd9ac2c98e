"""The toy body surface: capsules around the bones, index-stable vertices and an exact body SDF.

The body is a union of ``NUM_CAPSULES`` capsules (a segment swept by a sphere). Each capsule
rides rigidly in one joint's frame: its two end points are given in that joint's local frame,
derived from the rest skeleton (``skeleton.bone_offsets(betas)``), so bone lengths follow the
body shape ``b``; radii are scaled by ``b[0]`` (overall size), ``b[6]`` (limb girth) and
``b[9]`` (torso girth). In the T-pose every joint frame has the world's axes (Z up, +Y forward,
+X the character's right), so "local" below also reads as "world axes in the T-pose".

Surface vertices stand in for SMPL's mesh vertices (NIFTY's contact sets, D2O, foot skating):
a fixed pattern of rings on each capsule (cylinder rings plus hemispherical caps, about 7 cm
apart on the mean body; ring counts are fixed from the mean body's capsule sizes), stored as
parameters (capsule, position along the axis, polar and azimuth angles), so vertex ``i`` is the
same body spot in every pose and for every body shape. Sample points that lie inside another
capsule in the mean body's T-pose are dropped once, at import, so vertices sit on the visible
surface; the same index set is used for all bodies.

Capsules (``CAPSULE_NAMES``): a hips block across the hip joints, lower/mid/upper torso
(the chest runs across the collar joints), neck, head, upper arms, forearms, hands (past the
wrist), thighs, shins, feet and toes; limb capsules run from a joint to its child joint. Each
foot is two capsules of radius ``FOOT_RADIUS`` along one line, heel to toe tip: the *foot*
from the heel to the ball (riding in the ankle frame) and the *toes* from the ball to the toe
tip (riding in the ``*_foot`` joint's frame, so a toe break — the foot joint bending while the
heel rolls up — keeps the toes flat on the ground). Their end points sit ``FOOT_RADIUS`` above
the ground in the rest pose, so the sole touches z = 0 when standing
(``mocap.poses.standing_pose``). ``RIGHT_TOE_VERTEX`` (the lowest, front-most vertex of the
right toes) is the point NIFTY's foot-skating metric tracks.
"""
from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np
import torch

from .._validate import as_tensor, check_choice, check_shape
from .skeleton import NUM_BETAS, NUM_JOINTS, bone_offsets, joint_index, rest_joint_positions

__all__ = [
    "CAPSULE_NAMES",
    "CAPSULE_JOINTS",
    "CAPSULE_PARTS",
    "NUM_CAPSULES",
    "FOOT_RADIUS",
    "PART_NAMES",
    "NUM_VERTICES",
    "VERTEX_CAPSULE",
    "VERTEX_PART",
    "RIGHT_TOE_VERTEX",
    "LEFT_TOE_VERTEX",
    "RIGHT_HEEL_VERTEX",
    "LEFT_HEEL_VERTEX",
    "HAND_VERTICES",
    "toe_vertices",
    "capsule_local_segments",
    "capsule_segments",
    "body_vertices",
    "body_sdf",
    "capsule_sdf",
    "body_mesh",
    "body_from_motion",
    "toe_positions",
    "object_contact_vertices",
]

FOOT_RADIUS = 0.03

# ----------------------------------------------------------------------------- capsule table

_J = joint_index

PART_NAMES: tuple[str, ...] = (
    "hips", "torso", "head", "left_arm", "right_arm", "left_hand", "right_hand",
    "left_thigh", "right_thigh", "left_shin", "right_shin", "left_foot", "right_foot",
)

# name, joint whose frame it rides in, part, base radius (m), girth group, azimuth reference
# direction (local; vertex rings start there: the sole for feet, the palm for hands).
_CAPSULES = (
    ("hips", "pelvis", "hips", 0.100, "torso", (0.0, 1.0, 0.0)),
    ("lower_torso", "spine1", "torso", 0.115, "torso", (0.0, 1.0, 0.0)),
    ("mid_torso", "spine2", "torso", 0.120, "torso", (0.0, 1.0, 0.0)),
    ("upper_torso", "spine3", "torso", 0.120, "torso", (0.0, 1.0, 0.0)),
    ("neck", "neck", "head", 0.055, "torso", (0.0, 1.0, 0.0)),
    ("head", "head", "head", 0.090, "head", (0.0, 1.0, 0.0)),
    ("left_upper_arm", "left_shoulder", "left_arm", 0.045, "limb", (0.0, 0.0, -1.0)),
    ("right_upper_arm", "right_shoulder", "right_arm", 0.045, "limb", (0.0, 0.0, -1.0)),
    ("left_forearm", "left_elbow", "left_arm", 0.035, "limb", (0.0, 0.0, -1.0)),
    ("right_forearm", "right_elbow", "right_arm", 0.035, "limb", (0.0, 0.0, -1.0)),
    ("left_hand", "left_wrist", "left_hand", 0.030, "limb", (0.0, 0.0, -1.0)),
    ("right_hand", "right_wrist", "right_hand", 0.030, "limb", (0.0, 0.0, -1.0)),
    ("left_thigh", "left_hip", "left_thigh", 0.075, "limb", (0.0, 1.0, 0.0)),
    ("right_thigh", "right_hip", "right_thigh", 0.075, "limb", (0.0, 1.0, 0.0)),
    ("left_shin", "left_knee", "left_shin", 0.050, "limb", (0.0, 1.0, 0.0)),
    ("right_shin", "right_knee", "right_shin", 0.050, "limb", (0.0, 1.0, 0.0)),
    ("left_foot", "left_ankle", "left_foot", FOOT_RADIUS, "foot", (0.0, 0.0, -1.0)),
    ("right_foot", "right_ankle", "right_foot", FOOT_RADIUS, "foot", (0.0, 0.0, -1.0)),
    ("left_toes", "left_foot", "left_foot", FOOT_RADIUS, "foot", (0.0, 0.0, -1.0)),
    ("right_toes", "right_foot", "right_foot", FOOT_RADIUS, "foot", (0.0, 0.0, -1.0)),
)

CAPSULE_NAMES: tuple[str, ...] = tuple(c[0] for c in _CAPSULES)
CAPSULE_JOINTS: tuple[int, ...] = tuple(_J(c[1]) for c in _CAPSULES)
CAPSULE_PARTS: tuple[int, ...] = tuple(PART_NAMES.index(c[2]) for c in _CAPSULES)
NUM_CAPSULES = len(_CAPSULES)
_BASE_RADIUS = torch.tensor([c[3] for c in _CAPSULES], dtype=torch.float64)
_GIRTH_GROUP = tuple(c[4] for c in _CAPSULES)
_AZIMUTH_REFERENCE = torch.tensor([c[5] for c in _CAPSULES], dtype=torch.float64)

# Foot geometry (metres, mean body): the heel end point sits this far behind the ankle and the
# toe end point this far in front of the foot joint (ball of the foot), along the foot's
# horizontal direction; the surface then reaches FOOT_RADIUS further at each end.
_HEEL_BEHIND_ANKLE = 0.025
_TOE_AHEAD_OF_FOOT_JOINT = 0.035


def _as_betas(betas, like: Optional[torch.Tensor] = None) -> torch.Tensor:
    dtype = like.dtype if like is not None and like.is_floating_point() else torch.float32
    if betas is None:
        out = torch.zeros(NUM_BETAS, dtype=dtype)
    else:
        out = as_tensor(betas, "betas", dtype=dtype)
        check_shape(out, (..., NUM_BETAS), "betas")
    return out.to(like.device) if like is not None else out


def capsule_local_segments(betas=None):
    """Capsule end points in their joints' local frames, and radii, for body shape ``betas``.

    Args:
        betas: ``(..., 10)`` toy body shape, or ``None`` for the mean body.
    Returns:
        ``(a (..., C, 3), b (..., C, 3), radius (..., C))`` metres, ``C = NUM_CAPSULES``, in the
        order of ``CAPSULE_NAMES``; capsule ``c`` rides in joint ``CAPSULE_JOINTS[c]``.
    """
    betas = _as_betas(betas) if not isinstance(betas, torch.Tensor) else _as_betas(betas, betas)
    off = bone_offsets(betas)  # (..., 22, 3)
    rest = rest_joint_positions(betas)
    dtype = off.dtype
    batch = betas.shape[:-1]
    size = (1.0 + 0.05 * betas[..., 0])[..., None]  # (..., 1), multiplies constant vectors
    head_size = size * (1.0 + 0.04 * betas[..., 7])[..., None]

    def const(x, y, z, scale=size):
        return torch.tensor([x, y, z], dtype=dtype, device=betas.device) * scale

    zero = torch.zeros(batch + (3,), dtype=dtype, device=betas.device)

    def o(name):
        return off[..., _J(name), :]

    def foot_direction(side):
        to_ball = o(f"{side}_foot")
        horizontal = torch.cat([to_ball[..., :2], torch.zeros_like(to_ball[..., :1])], -1)
        return horizontal, horizontal / horizontal.norm(dim=-1, keepdim=True)

    def lift(height):
        # Local offset that puts a point FOOT_RADIUS above the ground in the rest pose.
        return torch.stack([torch.zeros_like(height), torch.zeros_like(height), FOOT_RADIUS - height], -1)

    def foot(side):
        horizontal, direction = foot_direction(side)
        drop = lift(rest[..., _J(f"{side}_ankle"), 2])
        return -_HEEL_BEHIND_ANKLE * size * direction + drop, horizontal + drop

    def toes(side):
        _, direction = foot_direction(side)
        drop = lift(rest[..., _J(f"{side}_foot"), 2])
        return drop, _TOE_AHEAD_OF_FOOT_JOINT * size * direction + drop

    def hand(side):
        along = o(f"{side}_wrist")
        along = along / along.norm(dim=-1, keepdim=True)
        return 0.045 * size * along, 0.115 * size * along

    ends = {
        # Hips block: across the two hip joints, a little above them.
        "hips": (o("left_hip") + const(0.0, 0.0, 0.03), o("right_hip") + const(0.0, 0.0, 0.03)),
        "lower_torso": (const(0.0, 0.01, -0.02), o("spine2")),
        "mid_torso": (zero, o("spine3")),
        # Chest: across the collar joints, between the sternum and the shoulders.
        "upper_torso": (
            torch.stack([o("left_collar")[..., 0], zero[..., 1], 0.5 * o("left_collar")[..., 2]], -1),
            torch.stack([o("right_collar")[..., 0], zero[..., 1], 0.5 * o("right_collar")[..., 2]], -1),
        ),
        "neck": (const(0.0, 0.0, -0.05), 0.6 * o("head")),
        "head": (const(0.0, 0.015, 0.035, head_size), const(0.0, 0.015, 0.085, head_size)),
        "left_upper_arm": (zero, o("left_elbow")),
        "right_upper_arm": (zero, o("right_elbow")),
        "left_forearm": (zero, o("left_wrist")),
        "right_forearm": (zero, o("right_wrist")),
        "left_hand": hand("left"),
        "right_hand": hand("right"),
        "left_thigh": (zero, o("left_knee")),
        "right_thigh": (zero, o("right_knee")),
        "left_shin": (zero, o("left_ankle")),
        "right_shin": (zero, o("right_ankle")),
        "left_foot": foot("left"),
        "right_foot": foot("right"),
        "left_toes": toes("left"),
        "right_toes": toes("right"),
    }
    a = torch.stack([ends[n][0].expand(batch + (3,)) for n in CAPSULE_NAMES], dim=-2)
    b = torch.stack([ends[n][1].expand(batch + (3,)) for n in CAPSULE_NAMES], dim=-2)
    girth = {
        "torso": size[..., 0] * (1.0 + 0.08 * betas[..., 9]),
        "limb": size[..., 0] * (1.0 + 0.08 * betas[..., 6]),
        "head": head_size[..., 0],
        "foot": torch.ones_like(size[..., 0]),
    }
    scale = torch.stack([girth[g] for g in _GIRTH_GROUP], dim=-1)
    radius = _BASE_RADIUS.to(dtype=dtype, device=betas.device) * scale
    if torch.any(radius <= 0):
        raise ValueError("betas: expected girth entries within about ±5 (a capsule radius became non-positive)")
    return a, b, radius


def _check_pose(global_rotations, joint_positions):
    check_shape(global_rotations, (..., NUM_JOINTS, 3, 3), "global_rotations")
    check_shape(joint_positions, (..., NUM_JOINTS, 3), "joint_positions")
    if global_rotations.shape[:-3] != joint_positions.shape[:-2]:
        raise ValueError(
            f"joint_positions: expected batch shape {tuple(global_rotations.shape[:-3])} to match "
            f"global_rotations, got {tuple(joint_positions.shape[:-2])}"
        )


def _pose_tensors(global_rotations, joint_positions):
    rot = as_tensor(global_rotations, "global_rotations")
    pos = as_tensor(joint_positions, "joint_positions")
    _check_pose(rot, pos)
    dtype = torch.promote_types(rot.dtype, pos.dtype)
    return rot.to(dtype), pos.to(dtype)


def capsule_segments(global_rotations, joint_positions, betas=None):
    """Capsules of a posed body in the world.

    Args:
        global_rotations: ``(..., 22, 3, 3)`` joint orientations (``Motion.global_rotations``).
        joint_positions: ``(..., 22, 3)`` metres (``Motion.joints``).
        betas: ``(10,)`` or ``(..., 10)`` body shape, or ``None`` for the mean body.
    Returns:
        ``(a (..., C, 3), b (..., C, 3), radius (..., C))``: segment end points in metres and
        radii in metres, ``C = NUM_CAPSULES``.
    """
    rot, pos = _pose_tensors(global_rotations, joint_positions)
    local_a, local_b, radius = capsule_local_segments(_as_betas(betas, rot))
    idx = list(CAPSULE_JOINTS)
    frame_rot, frame_pos = rot[..., idx, :, :], pos[..., idx, :]
    a = (frame_rot @ local_a[..., None])[..., 0] + frame_pos
    b = (frame_rot @ local_b[..., None])[..., 0] + frame_pos
    radius = radius.expand(a.shape[:-1])
    return a, b, radius


# ----------------------------------------------------------------------------- vertices

# Sample spacing for the vertex pattern (metres on the mean body).
_SPACING = 0.07


def _sampling_pattern():
    """Per sample: capsule, axial position t, cap sign s (-1, 0, +1), latitude, azimuth."""
    a, b, radius = capsule_local_segments(torch.zeros(NUM_BETAS, dtype=torch.float64))
    rows = []
    for c in range(NUM_CAPSULES):
        r = float(radius[c])
        length = float((b[c] - a[c]).norm())
        per_ring = max(6, 2 * round(math.pi * r / _SPACING))  # even: the reference side and its opposite
        n_rings = max(2, round(length / _SPACING) + 1)
        n_lat = max(1, round(0.5 * math.pi * r / _SPACING))
        for t in np.linspace(0.0, 1.0, n_rings):
            for k in range(per_ring):
                rows.append((c, t, 0.0, 0.0, 2 * math.pi * k / per_ring))
        for sign, t in ((-1.0, 0.0), (1.0, 1.0)):
            for i in range(1, n_lat + 1):
                lat = 0.5 * math.pi * i / (n_lat + 1)
                count = max(3, round(per_ring * math.cos(lat)))
                for k in range(count):
                    rows.append((c, t, sign, lat, 2 * math.pi * (k + 0.5 * i) / count))
            rows.append((c, t, sign, 0.5 * math.pi, 0.0))  # the pole
    return np.array(rows, dtype=np.float64)


def _vertices_local(pattern: np.ndarray, betas: torch.Tensor):
    """Vertex positions in their capsules' joint frames, ``(..., N, 3)`` metres."""
    local_a, local_b, radius = capsule_local_segments(betas)
    dtype, device = local_a.dtype, local_a.device
    cap = torch.as_tensor(pattern[:, 0].astype(np.int64), device=device)
    t, sign, lat, azim = (torch.as_tensor(pattern[:, i], dtype=dtype, device=device) for i in range(1, 5))
    a, b, r = local_a[..., cap, :], local_b[..., cap, :], radius[..., cap]
    axis = b - a
    u = axis / axis.norm(dim=-1, keepdim=True)
    ref = _AZIMUTH_REFERENCE.to(dtype=dtype, device=device)[cap]
    e1 = ref - (ref * u).sum(-1, keepdim=True) * u
    e1 = e1 / e1.norm(dim=-1, keepdim=True)
    e2 = torch.cross(u, e1.expand_as(u), dim=-1)
    radial = torch.cos(azim)[:, None] * e1 + torch.sin(azim)[:, None] * e2
    normal = torch.cos(lat)[:, None] * radial + (torch.sin(lat) * sign)[:, None] * u
    return a + t[:, None] * axis + r[..., None] * normal, normal


def _segment_distance(points: torch.Tensor, a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Distance from ``points (..., P, 1, 3)`` to segments ``a, b (..., 1, C, 3)`` -> ``(..., P, C)``."""
    ab = b - a
    ap = points - a
    denom = (ab * ab).sum(-1).clamp_min(1e-12)
    t = ((ap * ab).sum(-1) / denom).clamp(0.0, 1.0)
    diff = ap - t[..., None] * ab
    # Clamped square root: finite gradients for points exactly on a segment.
    return (diff * diff).sum(-1).clamp_min(1e-12).sqrt()


def _build_vertex_set():
    pattern = _sampling_pattern()
    zeros = torch.zeros(NUM_BETAS, dtype=torch.float64)
    local, normal = _vertices_local(pattern, zeros)
    # T-pose: every joint frame has world axes, so a local point is offset by its joint's rest position.
    rest = rest_joint_positions(zeros)
    cap = pattern[:, 0].astype(np.int64)
    joint = torch.as_tensor(np.asarray(CAPSULE_JOINTS)[cap])
    world = local + rest[joint]
    seg_a, seg_b, radius = capsule_local_segments(zeros)
    seg_a = seg_a + rest[list(CAPSULE_JOINTS)]
    seg_b = seg_b + rest[list(CAPSULE_JOINTS)]
    sdf = _segment_distance(world[:, None, :], seg_a[None], seg_b[None]) - radius
    sdf[torch.arange(len(cap)), torch.as_tensor(cap)] = float("inf")  # ignore the vertex's own capsule
    visible = (sdf.min(dim=-1).values >= 0.0).numpy()
    return pattern[visible], world[visible].numpy(), normal[visible].numpy()


_PATTERN, _REST_VERTICES, _REST_NORMALS = _build_vertex_set()
NUM_VERTICES = int(_PATTERN.shape[0])
VERTEX_CAPSULE = _PATTERN[:, 0].astype(np.int64)
VERTEX_PART = np.asarray(CAPSULE_PARTS, dtype=np.int64)[VERTEX_CAPSULE]
_VERTEX_JOINT = np.asarray(CAPSULE_JOINTS, dtype=np.int64)[VERTEX_CAPSULE]


def _foot_vertex(side: str, end: str) -> int:
    """Lowest vertex at the front of the toes or the back of the heel in the rest pose."""
    ids = np.flatnonzero(VERTEX_CAPSULE == CAPSULE_NAMES.index(f"{side}_toes" if end == "toe" else f"{side}_foot"))
    z = _REST_VERTICES[ids, 2]
    low = ids[z <= z.min() + 1e-6]
    y = _REST_VERTICES[low, 1]
    return int(low[np.argmax(y)] if end == "toe" else low[np.argmin(y)])


RIGHT_TOE_VERTEX = _foot_vertex("right", "toe")
LEFT_TOE_VERTEX = _foot_vertex("left", "toe")
RIGHT_HEEL_VERTEX = _foot_vertex("right", "heel")
LEFT_HEEL_VERTEX = _foot_vertex("left", "heel")

# Palm side: in the T-pose the palms face down, so hand vertices whose outward normal points down.
HAND_VERTICES: dict[str, np.ndarray] = {
    side: np.flatnonzero((VERTEX_CAPSULE == CAPSULE_NAMES.index(f"{side}_hand")) & (_REST_NORMALS[:, 2] < -0.4))
    for side in ("left", "right")
}


def _vertices(global_rotations, joint_positions, betas, index=None) -> torch.Tensor:
    rot, pos = _pose_tensors(global_rotations, joint_positions)
    pattern = _PATTERN if index is None else _PATTERN[index]
    joint = _VERTEX_JOINT if index is None else _VERTEX_JOINT[index]
    local, _ = _vertices_local(pattern, _as_betas(betas, rot))
    joint = torch.as_tensor(joint, device=rot.device)
    return (rot[..., joint, :, :] @ local[..., None])[..., 0] + pos[..., joint, :]


def body_vertices(global_rotations, joint_positions, betas=None) -> torch.Tensor:
    """Index-stable body surface vertices of a posed body.

    Args:
        global_rotations: ``(..., 22, 3, 3)`` joint orientations.
        joint_positions: ``(..., 22, 3)`` metres.
        betas: ``(10,)`` or ``(..., 10)`` body shape, or ``None`` for the mean body.
    Returns:
        ``(..., NUM_VERTICES, 3)`` metres; vertex ``i`` lies on capsule ``VERTEX_CAPSULE[i]``.
    """
    return _vertices(global_rotations, joint_positions, betas)


def body_sdf(points, global_rotations, joint_positions, betas=None) -> torch.Tensor:
    """Exact signed distance to the body (the union of its capsules), negative inside.

    ``sdf(p) = min_c (|p − closest point of segment c| − r_c)``. Differentiable in the points
    and the pose. The batch dimensions of the points and of the pose broadcast against each
    other, e.g. object points ``(P, 3)`` against a clip ``(T, 22, ...)`` give ``(T, P)``.
    Memory grows as ``batch × P × C``; P up to a few thousand per pose needs no chunking.

    Args:
        points: ``(..., P, 3)`` query points, metres.
        global_rotations: ``(..., 22, 3, 3)`` joint orientations.
        joint_positions: ``(..., 22, 3)`` metres.
        betas: ``(10,)`` or ``(..., 10)`` body shape, or ``None``.
    Returns:
        ``(..., P)`` signed distance in metres.
    """
    points = as_tensor(points, "points")
    check_shape(points, (..., None, 3), "points")
    a, b, radius = capsule_segments(global_rotations, joint_positions, betas)
    return capsule_sdf(points, a, b, radius)


def capsule_sdf(points, a, b, radius) -> torch.Tensor:
    """Signed distance to a union of capsules (segments ``a``–``b`` of radius ``radius``), negative inside.

    Args:
        points: ``(..., P, 3)`` query points, metres.
        a, b: ``(..., C, 3)`` segment ends, metres (e.g. from :func:`capsule_segments`).
        radius: ``(..., C)`` metres.
    Returns:
        ``(..., P)`` metres, in the promoted dtype of the points and the capsules.
    """
    dtype = torch.promote_types(points.dtype, a.dtype)
    points = points.to(dtype)
    dist = _segment_distance(points[..., :, None, :], a[..., None, :, :].to(dtype), b[..., None, :, :].to(dtype))
    return (dist - radius[..., None, :].to(dtype)).min(dim=-1).values


def body_mesh(global_rotations, joint_positions, betas=None, sections: int = 24):
    """A triangle mesh of one posed body for rendering: the capsule meshes concatenated.

    The parts overlap (no boolean union), so for inside tests use ``mesh.split()`` and test
    each part, or use :func:`body_sdf`.

    Args:
        global_rotations: ``(22, 3, 3)`` joint orientations of one pose.
        joint_positions: ``(22, 3)`` metres.
        betas: ``(10,)`` body shape or ``None``.
        sections: mesh resolution around each capsule.
    Returns:
        ``trimesh.Trimesh`` in metres.
    """
    import trimesh

    check_shape(global_rotations, (NUM_JOINTS, 3, 3), "global_rotations")
    check_shape(joint_positions, (NUM_JOINTS, 3), "joint_positions")
    a, b, radius = capsule_segments(global_rotations, joint_positions, betas)
    a, b, radius = (x.detach().cpu().double().numpy() for x in (a, b, radius))
    parts = []
    for c in range(NUM_CAPSULES):
        axis = b[c] - a[c]
        length = float(np.linalg.norm(axis))
        mesh = trimesh.creation.capsule(height=length, radius=float(radius[c]), count=[sections, sections])
        mesh.apply_translation(-mesh.bounds.mean(axis=0))  # centre it, whatever the trimesh version
        z = axis / length
        helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = np.cross(helper, z)
        x /= np.linalg.norm(x)
        transform = np.eye(4)
        transform[:3, :3] = np.stack([x, np.cross(z, x), z], axis=1)
        transform[:3, 3] = 0.5 * (a[c] + b[c])
        mesh.apply_transform(transform)
        parts.append(mesh)
    return trimesh.util.concatenate(parts)


def body_from_motion(motion, frames=None) -> torch.Tensor:
    """Surface vertices of a ``Motion``.

    Args:
        motion: a ``world.motion.Motion`` of ``T`` frames.
        frames: frame indices (a slice, a list or an int array), or ``None`` for all.
    Returns:
        ``(T', NUM_VERTICES, 3)`` metres.
    """
    rot, pos = motion.global_rotations, motion.joints
    if frames is not None:
        rot, pos = rot[frames], pos[frames]
    return body_vertices(rot, pos, motion.betas)


def toe_vertices(global_rotations, joint_positions, betas=None) -> torch.Tensor:
    """Both toe vertices of posed bodies (right, then left), without computing the other vertices.

    Args:
        global_rotations: ``(..., 22, 3, 3)`` world rotations of the joints.
        joint_positions: ``(..., 22, 3)`` metres.
        betas: ``(..., 10)`` or ``(10,)`` body shapes (default: the mean body).
    Returns:
        ``(..., 2, 3)`` metres: ``RIGHT_TOE_VERTEX`` and ``LEFT_TOE_VERTEX``.
    """
    return _vertices(global_rotations, joint_positions, betas, index=[RIGHT_TOE_VERTEX, LEFT_TOE_VERTEX])


def toe_positions(motion, side: str = "right") -> torch.Tensor:
    """Trajectory of a toe vertex (the bottom of the toe tip), for NIFTY's foot-skating metric.

    Args:
        motion: a ``Motion`` of ``T`` frames.
        side: ``"right"`` (NIFTY's choice) or ``"left"``.
    Returns:
        ``(T, 3)`` metres.
    """
    check_choice(side, ("right", "left"), "side")
    return toe_vertices(motion.global_rotations, motion.joints, motion.betas)[..., 0 if side == "right" else 1, :]


def object_contact_vertices(motion_frame_vertices, object_sdf: Callable, threshold: float = 0.0) -> np.ndarray:
    """Body vertices touching or inside an object (NIFTY's per-vertex contact set).

    Args:
        motion_frame_vertices: ``(..., V, 3)`` body vertices in metres (one frame or many).
        object_sdf: callable mapping points ``(N, 3)`` metres to signed distances ``(N,)``
            (negative inside the object), numpy or torch.
        threshold: metres; a vertex is in contact when the object's SDF is ≤ ``threshold``.
    Returns:
        ``(..., V)`` bool.
    """
    check_shape(motion_frame_vertices, (..., None, 3), "motion_frame_vertices")
    if isinstance(motion_frame_vertices, torch.Tensor):
        flat = motion_frame_vertices.detach().reshape(-1, 3)
    else:
        flat = np.asarray(motion_frame_vertices, dtype=np.float64).reshape(-1, 3)
    sdf = object_sdf(flat)
    sdf = sdf.detach().cpu().numpy() if isinstance(sdf, torch.Tensor) else np.asarray(sdf)
    if sdf.size != flat.shape[0]:
        raise ValueError(f"object_sdf: expected one value per point ({flat.shape[0]}), got {sdf.size}")
    return (sdf.reshape(motion_frame_vertices.shape[:-1]) <= threshold)
