"""Pose-state features: NIFTY Eq. 1, SAMP Eq. 1 (reduced) and the canonical frame.

Facing and the root frame
    A body's *root frame* at a frame is its pelvis projected to the ground (z = 0) with the
    facing direction from the hips: ``across = right_hip − left_hip`` projected to the ground,
    ``forward = up × across`` (so the T-pose and ``standing_pose(heading=0)`` face +Y). The
    heading is the angle of ``forward`` about +Z, with heading 0 facing +Y (as
    ``rotations.yaw_of_matrix``). Hips stay horizontal when lying or sitting, so this works
    where the pelvis's own forward axis points up.

NIFTY Eq. 1 (``nifty_pose_state``), per frame, 336 numbers
    ``X_i = {j^p, j^r, j^v, j^ω, t^p, t^v}``: joint positions (22×3, m), joint rotations as 6D
    (22×6), joint velocities (22×3, m/s, central differences), joint angular velocities
    (22×3, rad/s), the root (pelvis) translation (3, m) and its velocity (3, m/s), all in the
    canonical frame of the first pose (NIFTY §3.1).

    Choices the paper leaves open, made here:

    - ``j^r`` holds each joint's *global* orientation (in the canonical frame), not its rotation
      relative to its parent: an error in one joint's prediction then does not swing the whole
      sub-tree, and the rotations live in the same frame as ``j^p``. Local rotations are
      recovered exactly with ``G_parent^T G_j`` (``kinematics.global_to_local_rotations``).
    - ``j^ω`` is the world-frame angular velocity from consecutive global rotations,
      ``axis_angle(R_{i+1} R_i^T) · fps`` (a forward difference; the last frame repeats the
      one before).
    - ``t^v`` is a *forward* difference, ``(t_{i+1} − t_i) · fps`` (last frame repeated), so the
      decoder's integration of NIFTY Appendix B (integrate ``t^v`` in the ground plane — the
      paper's "XZ plane" is our XY plane, Z being up — and take the height from ``t^p``)
      reproduces the root exactly. ``j^v`` uses central differences like ``Motion.joint_velocities``.

SAMP Eq. 1, reduced (``samp_pose_state``)
    Everything relative to the current root frame. Changes from the paper: ``t = 7`` trajectory
    samples over [−1, 1] s (every 1/3 s; the paper does not state ``t``, the Neural State
    Machine representation it follows samples 13 points over the same window); the joint
    positions relative to the future root (``j̃^p``) are left out; trajectory action labels are
    one-hot (the toy mocap's labels are discrete). Sizes (paper sizes with t samples in
    brackets): ``j^p`` 66, ``j^r`` 132, ``j^v`` 66, ``t^p`` 14 [2t], ``t^d`` 14 [2t], ``t̃^p`` 14 [2t],
    ``t̃^d`` 14 [2t], ``t^a`` 35 [5t], ``g^p`` 21 [3t], ``g^d`` 21 [3t], ``g^a`` 35 [5t], ``c`` 5:
    437 in all (``SAMP_STATE_LAYOUT``).
"""
from __future__ import annotations

from typing import Optional

import numpy as np
import torch

from .._validate import as_tensor, check_choice, check_shape
from .kinematics import global_to_local_rotations
from .motion import ACTIONS, CONTACT_JOINTS, FPS, Motion
from .rotations import (
    matrix_to_axis_angle,
    matrix_to_rotation_6d,
    rotation_6d_to_matrix,
    rotation_about_z,
)
from .skeleton import NUM_JOINTS, joint_index

__all__ = [
    "feature_layout",
    "body_heading",
    "root_frame",
    "to_heading_frame",
    "canonical_transform",
    "canonicalize",
    "NIFTY_STATE_LAYOUT",
    "NIFTY_STATE_SIZE",
    "nifty_pose_state",
    "split_nifty_state",
    "nifty_state_to_pose",
    "motion_from_nifty_state",
    "angular_velocity",
    "SAMP_ACTIONS",
    "SAMP_ACTION_OF",
    "SAMP_SAMPLE_OFFSETS",
    "SAMP_STATE_LAYOUT",
    "SAMP_STATE_SIZE",
    "SAMP_FD_LAYOUT",
    "samp_action_ids",
    "samp_pose_state",
    "samp_fd_features",
]

_LEFT_HIP, _RIGHT_HIP, _PELVIS = joint_index("left_hip"), joint_index("right_hip"), joint_index("pelvis")


# ----------------------------------------------------------------------------- root frame


def body_heading(joints) -> torch.Tensor:
    """Facing angle of a body from its hips.

    Args:
        joints: ``(..., 22, 3)`` joint positions, metres.
    Returns:
        ``(...)`` radians about +Z; 0 faces +Y, ``π/2`` faces −X (as ``rotation_about_z``).
        Ill-defined only when the hip line is vertical (lying on one side).
    """
    joints = as_tensor(joints, "joints")
    check_shape(joints, (..., NUM_JOINTS, 3), "joints")
    across = joints[..., _RIGHT_HIP, :] - joints[..., _LEFT_HIP, :]
    # forward = up × across = (−across_y, across_x, 0); heading = atan2(−forward_x, forward_y).
    return torch.atan2(across[..., 1], across[..., 0])


def root_frame(joints):
    """Ground position and heading of the root frame (pelvis on the ground, facing from the hips).

    Args:
        joints: ``(..., 22, 3)`` metres.
    Returns:
        ``(origin (..., 3) metres with z = 0, heading (...) radians)``.
    """
    heading = body_heading(joints)
    joints = as_tensor(joints, "joints")
    origin = joints[..., _PELVIS, :] * torch.tensor([1.0, 1.0, 0.0], dtype=joints.dtype, device=joints.device)
    return origin, heading


def _joints_of(motion_or_pose):
    if isinstance(motion_or_pose, Motion):
        return motion_or_pose.joints
    if isinstance(motion_or_pose, (tuple, list)) and len(motion_or_pose) == 2:
        joints = as_tensor(motion_or_pose[1], "joints")
        check_shape(joints, (..., NUM_JOINTS, 3), "joints")
        return joints if joints.dim() > 2 else joints[None]
    raise TypeError("motion_or_pose: expected a Motion or a (global_rotations, joints) pair")


def canonical_transform(motion_or_pose, frame: int = 0):
    """The yaw and translation that bring frame ``frame`` to NIFTY's canonical frame.

    NIFTY §3.1: poses are expressed in "the local frame of the pose at the first timestep where
    the human is at the origin and its front-facing vector is aligned with +Y". The origin is
    the pelvis's ground projection (heights are kept: z stays height above the ground) and the
    facing comes from the hips (:func:`body_heading`). Apply with
    ``motion.transformed(yaw, translation)`` (rotate about +Z through the world origin, then
    translate).

    Args:
        motion_or_pose: a ``Motion``, or a pair ``(global_rotations (T, 22, 3, 3) or (22, 3, 3),
            joints (T, 22, 3) or (22, 3))``.
        frame: the frame that becomes canonical.
    Returns:
        ``(yaw, translation)``: a float in radians and a ``(3,)`` tensor in metres (z = 0).
    """
    joints = _joints_of(motion_or_pose)
    if not -joints.shape[0] <= frame < joints.shape[0]:
        raise ValueError(f"frame: expected an index in [0, {joints.shape[0]}), got {frame}")
    origin, heading = root_frame(joints[frame])
    yaw = -float(heading)
    rot = rotation_about_z(torch.tensor(yaw, dtype=joints.dtype))
    translation = -(rot @ origin)
    return yaw, translation.detach()


def canonicalize(motion: Motion, frame: int = 0) -> Motion:
    """The clip moved so frame ``frame`` stands at the origin facing +Y (NIFTY §3.1).

    Args:
        motion: a ``Motion``.
        frame: the frame that becomes canonical.
    Returns:
        a new ``Motion`` (labels kept).
    """
    yaw, translation = canonical_transform(motion, frame)
    return motion.transformed(yaw, translation)


# ----------------------------------------------------------------------------- NIFTY Eq. 1

def feature_layout(parts) -> tuple[dict[str, slice], int]:
    """Consecutive slices for named parts of a flat feature vector.

    Args:
        parts: ``(name, size)`` pairs, where a size is an int or a shape tuple.
    Returns:
        ``(layout, total_size)`` with ``layout[name]`` the part's slice of the last axis.
    """
    layout, start = {}, 0
    for name, size in parts:
        size = int(np.prod(size))
        layout[name] = slice(start, start + size)
        start += size
    return layout, start


_NIFTY_PARTS = (
    ("joint_positions", (NUM_JOINTS, 3)),       # j^p
    ("joint_rotations", (NUM_JOINTS, 6)),       # j^r (6D, global)
    ("joint_velocities", (NUM_JOINTS, 3)),      # j^v
    ("joint_angular_velocities", (NUM_JOINTS, 3)),  # j^ω
    ("root_position", (3,)),                    # t^p
    ("root_velocity", (3,)),                    # t^v
)
NIFTY_STATE_LAYOUT, NIFTY_STATE_SIZE = feature_layout(_NIFTY_PARTS)


def _forward_difference(x: torch.Tensor, fps: float) -> torch.Tensor:
    """``(T, ...)`` -> ``(x_{i+1} − x_i) · fps`` with the last frame repeated (zeros for T = 1)."""
    if x.shape[0] < 2:
        return torch.zeros_like(x)
    v = (x[1:] - x[:-1]) * fps
    return torch.cat([v, v[-1:]], dim=0)


def angular_velocity(global_rotations, fps: float = FPS) -> torch.Tensor:
    """World-frame angular velocity from consecutive rotations (NIFTY Eq. 1's ``j^ω``).

    ``ω_i = axis_angle(R_{i+1} R_i^T) · fps``, the last frame repeating the one before.

    Args:
        global_rotations: ``(T, ..., 3, 3)`` rotations over time (time first).
        fps: frames per second.
    Returns:
        ``(T, ..., 3)`` rad/s.
    """
    rot = as_tensor(global_rotations, "global_rotations")
    check_shape(rot, (..., 3, 3), "global_rotations")
    if rot.dim() < 3:
        raise ValueError(f"global_rotations: expected shape (T, ..., 3, 3), got {tuple(rot.shape)}")
    if rot.shape[0] < 2:
        return torch.zeros(rot.shape[:-2] + (3,), dtype=rot.dtype, device=rot.device)
    omega = matrix_to_axis_angle(rot[1:] @ rot[:-1].transpose(-1, -2)) * fps
    return torch.cat([omega, omega[-1:]], dim=0)


def nifty_pose_state(motion: Motion, canonical: bool = True) -> torch.Tensor:
    """NIFTY Eq. 1 pose states of a clip, ``X_i = {j^p, j^r, j^v, j^ω, t^p, t^v}``.

    Args:
        motion: a ``Motion`` of ``T`` frames.
        canonical: first move the clip to the canonical frame of its first pose
            (:func:`canonicalize`), as NIFTY does; ``False`` keeps the world frame.
    Returns:
        ``(T, 336)`` float tensor laid out as ``NIFTY_STATE_LAYOUT`` (see the module docstring
        for units and the choices made).
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
    m = canonicalize(motion, 0) if canonical else motion
    T = len(m)
    glob = m.global_rotations
    parts = [
        m.joints.reshape(T, -1),
        matrix_to_rotation_6d(glob).reshape(T, -1),
        m.joint_velocities().reshape(T, -1),
        angular_velocity(glob, m.fps).reshape(T, -1),
        m.root_position,
        _forward_difference(m.root_position, m.fps),
    ]
    return torch.cat(parts, dim=-1)


def split_nifty_state(x) -> dict[str, torch.Tensor]:
    """Named parts of NIFTY states ``x: (..., 336)``.

    Returns:
        dict with ``joint_positions (..., 22, 3)``, ``joint_rotations (..., 22, 6)``,
        ``joint_velocities (..., 22, 3)``, ``joint_angular_velocities (..., 22, 3)``,
        ``root_position (..., 3)``, ``root_velocity (..., 3)`` (views of ``x``).
    """
    x = as_tensor(x, "x")
    check_shape(x, (..., NIFTY_STATE_SIZE), "x")
    return {name: x[..., NIFTY_STATE_LAYOUT[name]].reshape(x.shape[:-1] + shape) for name, shape in _NIFTY_PARTS}


def nifty_state_to_pose(x, fps: float = FPS, integrate_root: bool = True):
    """Pose from NIFTY states (NIFTY Appendix B), differentiable and batched.

    Local joint rotations come from the 6D global rotations (Gram-Schmidt, then
    ``G_parent^T G_j``). With ``integrate_root`` the root's ground-plane position (x, y) is the
    first frame's ``t^p`` plus the integral of ``t^v`` (forward Euler, matching the forward
    differences of the encoder), and its height is taken from ``t^p``; otherwise the root is
    ``t^p``.

    Args:
        x: ``(..., T, 336)`` states of clips of ``T`` frames.
        fps: frames per second.
        integrate_root: integrate the root velocity as NIFTY does.
    Returns:
        ``(local_rotations (..., T, 22, 3, 3), root_position (..., T, 3) metres)``.
    """
    x = as_tensor(x, "x")
    check_shape(x, (..., None, NIFTY_STATE_SIZE), "x")
    parts = split_nifty_state(x)
    glob = rotation_6d_to_matrix(parts["joint_rotations"])
    local = global_to_local_rotations(glob)
    root = parts["root_position"]
    if integrate_root:
        step = parts["root_velocity"][..., :-1, :2] / fps
        xy = root[..., :1, :2] + torch.cat([torch.zeros_like(root[..., :1, :2]), torch.cumsum(step, dim=-2)], dim=-2)
        root = torch.cat([xy, root[..., 2:]], dim=-1)
    return local, root


def motion_from_nifty_state(x, betas=None, integrate_root: bool = True, fps: float = FPS) -> Motion:
    """A ``Motion`` from one clip of NIFTY states (NIFTY Appendix B); see :func:`nifty_state_to_pose`.

    Args:
        x: ``(T, 336)`` states.
        betas: ``(10,)`` body shape, or ``None`` for the mean body.
        integrate_root: integrate ``t^v`` in the ground plane (else use ``t^p``).
        fps: frames per second.
    Returns:
        a ``Motion`` without labels.
    """
    x = as_tensor(x, "x")
    check_shape(x, (None, NIFTY_STATE_SIZE), "x")
    local, root = nifty_state_to_pose(x, fps, integrate_root)
    kwargs = {} if betas is None else {"betas": as_tensor(betas, "betas")}
    return Motion(local_rotations=local, root_position=root, fps=fps, **kwargs)


# ----------------------------------------------------------------------------- SAMP Eq. 1 (reduced)

SAMP_ACTIONS: tuple[str, ...] = ("idle", "walk", "run", "sit", "lie")
# Toy-mocap action -> SAMP action.
SAMP_ACTION_OF: dict[str, str] = {
    name: (
        "sit" if name in ("sit_down", "sit", "stand_up")
        else "lie" if name in ("lie_down", "lie")
        else "walk" if name in ("walk", "turn", "side_step")
        else "run" if name == "run"
        else "idle"
    )
    for name in ACTIONS
}
# Trajectory sample times relative to the current frame, seconds (7 samples over [−1, 1] s).
SAMP_SAMPLE_OFFSETS: tuple[float, ...] = tuple(k / 3.0 for k in range(-3, 4))
_NS, _NA = len(SAMP_SAMPLE_OFFSETS), len(SAMP_ACTIONS)

_SAMP_PARTS = (
    ("joint_positions", NUM_JOINTS * 3),         # j^p
    ("joint_rotations", NUM_JOINTS * 6),         # j^r
    ("joint_velocities", NUM_JOINTS * 3),        # j^v
    ("trajectory_positions", 2 * _NS),           # t^p
    ("trajectory_directions", 2 * _NS),          # t^d
    ("goal_trajectory_positions", 2 * _NS),      # t̃^p
    ("goal_trajectory_directions", 2 * _NS),     # t̃^d
    ("trajectory_actions", _NA * _NS),           # t^a
    ("goal_positions", 3 * _NS),                 # g^p
    ("goal_directions", 3 * _NS),                # g^d
    ("goal_actions", _NA * _NS),                 # g^a
    ("contacts", len(CONTACT_JOINTS)),           # c
)
SAMP_STATE_LAYOUT, SAMP_STATE_SIZE = feature_layout(_SAMP_PARTS)
_FD_PARTS = ("joint_positions", "joint_rotations", "joint_velocities",
             "goal_trajectory_positions", "goal_trajectory_directions")
SAMP_FD_LAYOUT, _ = feature_layout([(name, dict(_SAMP_PARTS)[name]) for name in _FD_PARTS])


def samp_action_ids(labels) -> np.ndarray:
    """Map toy-mocap action labels to SAMP's five actions (``SAMP_ACTIONS``).

    Args:
        labels: ``(T,)`` ids into ``motion.ACTIONS`` or names from ``ACTIONS`` (which include
            the five ``SAMP_ACTIONS``), or a single name.
    Returns:
        ``(T,)`` int64 ids into ``SAMP_ACTIONS`` (``(1,)`` for a single name).
    """
    if isinstance(labels, str):
        labels = [labels]
    out = []
    for label in np.asarray(labels, dtype=object).reshape(-1):
        if isinstance(label, str):
            check_choice(label, ACTIONS, "action label")
            out.append(SAMP_ACTIONS.index(SAMP_ACTION_OF[label]))
        else:
            idx = int(label)
            if not 0 <= idx < len(ACTIONS):
                raise ValueError(f"action label: expected an id in [0, {len(ACTIONS)}), got {idx}")
            out.append(SAMP_ACTIONS.index(SAMP_ACTION_OF[ACTIONS[idx]]))
    return np.asarray(out, dtype=np.int64)


def _sample_indices(T: int, fps: float) -> torch.Tensor:
    """``(T, 7)`` frame index of each trajectory sample, clamped to the clip."""
    offsets = torch.tensor([round(o * fps) for o in SAMP_SAMPLE_OFFSETS])
    return (torch.arange(T)[:, None] + offsets[None]).clamp(0, T - 1)


def to_heading_frame(vectors: torch.Tensor, heading: torch.Tensor) -> torch.Tensor:
    """Express world vectors ``(..., 3)`` in frames of heading ``(...)`` (rotate by −heading)."""
    rot = rotation_about_z(heading)
    return (rot.transpose(-1, -2) @ vectors[..., None])[..., 0]


def _goal_arrays(goal_position, goal_direction, T: int, dtype):
    pos = as_tensor(goal_position, "goal_position", dtype=dtype)
    if pos.dim() == 1:
        pos = pos.expand(T, -1)
    check_shape(pos, (T, 3), "goal_position")
    if goal_direction is None:
        raise ValueError("goal_direction: expected a (3,) or (2,) direction when goal_position is given")
    d = as_tensor(goal_direction, "goal_direction", dtype=dtype)
    if d.shape[-1] == 2:
        d = torch.cat([d, torch.zeros_like(d[..., :1])], dim=-1)
    if d.dim() == 1:
        d = d.expand(T, -1)
    check_shape(d, (T, 3), "goal_direction")
    flat = d * torch.tensor([1.0, 1.0, 0.0], dtype=dtype)
    if torch.any(flat.norm(dim=-1) < 1e-8):
        raise ValueError("goal_direction: expected a direction with a non-zero ground-plane part")
    flat = flat / flat.norm(dim=-1, keepdim=True)
    return pos, flat


def _one_hot(ids: np.ndarray, dtype) -> torch.Tensor:
    return torch.nn.functional.one_hot(torch.as_tensor(ids), _NA).to(dtype)


def samp_pose_state(
    motion: Motion,
    goal_position=None,
    goal_direction=None,
    action_labels=None,
    goal_action: Optional[str] = None,
):
    """SAMP Eq. 1 state per frame, reduced (see the module docstring for what changed).

    All parts are expressed in the current frame's root frame (:func:`root_frame`):

    - ``joint_positions`` ``j^p``, ``joint_rotations`` ``j^r`` (6D of ``R_root^T G_j``),
      ``joint_velocities`` ``j^v`` (central differences, m/s);
    - ``trajectory_positions`` / ``trajectory_directions`` ``t^p, t^d``: root ground positions and
      forward directions (x, y) at the 7 samples over [−1, 1] s (``SAMP_SAMPLE_OFFSETS``,
      clamped to the clip's ends);
    - ``goal_trajectory_positions`` / ``goal_trajectory_directions`` ``t̃^p, t̃^d``: the same
      samples expressed in the goal's frame (origin the goal's ground projection, +Y the goal
      direction); zeros without a goal;
    - ``trajectory_actions`` ``t^a``: one-hot SAMP action at each sample;
    - ``goal_positions`` / ``goal_directions`` ``g^p, g^d``: the goal (3D) in each sample's
      root frame; zeros without a goal;
    - ``goal_actions`` ``g^a``: one-hot of ``goal_action`` at each sample; zeros without one;
    - ``contacts`` ``c``: the clip's five contact flags (``CONTACT_JOINTS``), zeros if unlabelled.

    Args:
        motion: a ``Motion`` of ``T`` frames.
        goal_position: ``(3,)`` or ``(T, 3)`` metres, or ``None``.
        goal_direction: ``(3,)``/``(2,)`` or ``(T, 3)``/``(T, 2)`` facing at the goal (only its
            ground-plane part is used), required with ``goal_position``.
        action_labels: per-frame labels for ``t^a`` (``(T,)`` ids or names, or one name);
            default the motion's own ``actions`` (zeros when it has none).
        goal_action: the action to perform at the goal, a name from ``SAMP_ACTIONS`` or
            ``ACTIONS``, ``(T,)`` per-frame labels (a goal that changes along the clip), or ``None``.
    Returns:
        ``(parts, flat)``: a dict of ``(T, n)`` tensors named as ``SAMP_STATE_LAYOUT`` and the
        ``(T, 437)`` concatenation.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
    T, fps = len(motion), motion.fps
    joints, glob = motion.joints, motion.global_rotations
    dtype = joints.dtype
    origin, heading = root_frame(joints)  # (T, 3), (T,)
    rot_t = rotation_about_z(heading).transpose(-1, -2)  # world -> root frame
    parts: dict[str, torch.Tensor] = {}
    parts["joint_positions"] = (rot_t[:, None] @ (joints - origin[:, None])[..., None])[..., 0].reshape(T, -1)
    parts["joint_rotations"] = matrix_to_rotation_6d(rot_t[:, None] @ glob).reshape(T, -1)
    parts["joint_velocities"] = (rot_t[:, None] @ motion.joint_velocities()[..., None])[..., 0].reshape(T, -1)

    idx = _sample_indices(T, fps)  # (T, S)
    sample_origin, sample_heading = origin[idx], heading[idx]  # (T, S, 3), (T, S)
    zero = torch.zeros_like(sample_heading)
    sample_forward = torch.stack([-torch.sin(sample_heading), torch.cos(sample_heading), zero], -1)
    rel = to_heading_frame(sample_origin - origin[:, None], heading[:, None].expand_as(sample_heading))
    parts["trajectory_positions"] = rel[..., :2].reshape(T, -1)
    parts["trajectory_directions"] = to_heading_frame(sample_forward, heading[:, None].expand_as(sample_heading))[..., :2].reshape(T, -1)

    if goal_position is not None:
        goal_pos, goal_dir = _goal_arrays(goal_position, goal_direction, T, dtype)
        goal_heading = torch.atan2(-goal_dir[:, 0], goal_dir[:, 1])[:, None].expand_as(sample_heading)
        goal_ground = goal_pos * torch.tensor([1.0, 1.0, 0.0], dtype=dtype)
        parts["goal_trajectory_positions"] = to_heading_frame(sample_origin - goal_ground[:, None], goal_heading)[..., :2].reshape(T, -1)
        parts["goal_trajectory_directions"] = to_heading_frame(sample_forward, goal_heading)[..., :2].reshape(T, -1)
        parts["goal_positions"] = to_heading_frame(goal_pos[:, None] - sample_origin, sample_heading).reshape(T, -1)
        parts["goal_directions"] = to_heading_frame(goal_dir[:, None].expand_as(sample_origin), sample_heading).reshape(T, -1)
    else:
        for name in ("goal_trajectory_positions", "goal_trajectory_directions", "goal_positions", "goal_directions"):
            parts[name] = torch.zeros(T, dict(_SAMP_PARTS)[name], dtype=dtype)

    labels = action_labels if action_labels is not None else motion.actions
    if labels is None:
        parts["trajectory_actions"] = torch.zeros(T, _NA * _NS, dtype=dtype)
    else:
        ids = samp_action_ids(labels)
        if ids.shape[0] == 1:
            ids = np.repeat(ids, T)
        if ids.shape[0] != T:
            raise ValueError(f"action_labels: expected {T} per-frame labels or one name, got {ids.shape[0]}")
        parts["trajectory_actions"] = _one_hot(ids[idx.numpy()], dtype).reshape(T, -1)
    if goal_action is None:
        parts["goal_actions"] = torch.zeros(T, _NA * _NS, dtype=dtype)
    else:
        gid = samp_action_ids(goal_action)
        if gid.shape[0] == 1:
            gid = np.repeat(gid, T)
        if gid.shape[0] != T:
            raise ValueError(f"goal_action: expected one name or {T} per-frame labels, got {gid.shape[0]}")
        parts["goal_actions"] = _one_hot(np.repeat(gid, _NS), dtype).reshape(T, -1)
    if motion.contacts is None:
        parts["contacts"] = torch.zeros(T, len(CONTACT_JOINTS), dtype=dtype)
    else:
        parts["contacts"] = torch.as_tensor(motion.contacts, dtype=dtype)
    parts = {name: parts[name] for name, _ in _SAMP_PARTS}
    return parts, torch.cat(list(parts.values()), dim=-1)


def samp_fd_features(motion: Motion, goal_position=None, goal_direction=None) -> torch.Tensor:
    """SAMP Eq. 9's feature subset ``X̃ = {j^p, j^r, j^v, t̃^p, t̃^d}`` for the Fréchet distance.

    Args:
        motion: a ``Motion`` of ``T`` frames.
        goal_position: ``(3,)`` metres; default the clip's final root (pelvis ground projection).
        goal_direction: ``(3,)`` or ``(2,)``; default the clip's final facing.
    Returns:
        ``(T, 292)`` laid out as ``SAMP_FD_LAYOUT``.
    """
    if goal_position is None:
        origin, heading = root_frame(motion.joints[-1])
        goal_position = origin
        goal_direction = torch.stack([-torch.sin(heading), torch.cos(heading), torch.zeros_like(heading)])
    parts, _ = samp_pose_state(motion, goal_position, goal_direction)
    return torch.cat([parts[name] for name in _FD_PARTS], dim=-1)
