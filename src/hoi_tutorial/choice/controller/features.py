"""The controller's features (CHOICE §5.1, Eq. 13, Fig. 4): the key joints, the goal phase, and the input and
output layouts, per frame of a clip and carried from one root frame to the next.

Steps 1–2 of the algorithm box in ``choice.controller``: :func:`clip_features` turns a toy clip into its inputs
``X_t`` and targets ``Y_{t+1}``; :func:`io_layouts` names their parts. The helpers that carry a prediction into
the next root frame (:func:`blended_pose`, :func:`next_root_trajectory`, :func:`next_key_trajectories`) are shared
by training's unroll (``network``) and the run-time loop (``runtime``).
"""
from __future__ import annotations

import math

import numpy as np
import torch

from ..._validate import check_shape
from ...world.features import feature_layout, root_frame
from ...world.kinematics import forward_kinematics
from ...world.motion import FPS, Motion
from ...world.rotations import matrix_to_rotation_6d, rotation_6d_to_matrix, rotation_about_z
from ...world.skeleton import NUM_JOINTS, joint_index
from . import kalman, phase
from .phase import PhaseAutoencoder, PhaseParameters

__all__ = [
    "KEY_JOINTS", "CLIP_KINDS", "VARIANTS", "WINDOW", "SAMPLE_STEP", "WINDOW_OFFSETS", "FUTURE_OFFSETS", "PAST",
    "TRANSFORM", "POSE_BLEND", "PELVIS_JOINT", "WRIST_JOINTS", "WRIST_JOINT_INDEX",
    "key_joint_transforms", "in_frame", "encode_transform", "decode_transform", "goal_phase_features", "phase_state",
    "io_layouts", "pose_features", "local_rotation_features", "pose_from_rotations", "clip_features",
    "next_root_frame", "blended_pose", "blend_pose_in_frame", "blend_rotations_in_frame",
    "next_root_trajectory", "carried_root_trajectory", "next_key_trajectories", "carried_key_trajectories",
    "wrapped_angle",
]

KEY_JOINTS = ("root", "hip", "left_wrist", "right_wrist")  # Eq. 14's four key joints
CLIP_KINDS = ("reach_grasp", "open_door", "open_drawer")  # toy clips with one hand keyframe (walk, reach, hold)
VARIANTS = ("none", "matched", "predicted", "kalman")  # Table 4's goal-phase sources
WINDOW = 13  # w of §5.1: samples of a 2 s window
WINDOW_SECONDS = 2.0
SAMPLE_STEP = int(round(WINDOW_SECONDS * FPS / (WINDOW - 1)))  # frames between two samples
WINDOW_OFFSETS = SAMPLE_STEP * (torch.arange(WINDOW) - WINDOW // 2)  # (13,) frames about the pivot
FUTURE_OFFSETS = SAMPLE_STEP * torch.arange(WINDOW // 2 + 1)  # (7,) a 1 s future window from t + 1
PAST = int(-WINDOW_OFFSETS[0])  # frames of root history the input needs
TRANSFORM = 9  # a key joint's position (3) and 6D rotation (6)
# Each joint's next position at run time: the prediction blended half-half with the previous position moved by
# the predicted velocity, as Starke et al.'s released controllers (MANN, NSM, DeepPhase) do; CHOICE is silent.
POSE_BLEND = 0.5
PELVIS_JOINT, WRIST_JOINTS = joint_index("pelvis"), (joint_index("left_wrist"), joint_index("right_wrist"))
WRIST_JOINT_INDEX = torch.tensor(WRIST_JOINTS)  # the working wrist's joint, indexed by the hand (0 left, 1 right)



# ----------------------------------------------------------------------------- features


def key_joint_transforms(motion: Motion) -> tuple[torch.Tensor, torch.Tensor]:
    """The four key joints' world transforms per frame: positions (T, 4, 3) metres and rotations
    (T, 4, 3, 3) — the root on the ground with the hips' heading, the pelvis, the two wrists."""
    joints, rotations = motion.joints, motion.global_rotations
    origin, heading = root_frame(joints)
    positions = torch.stack([origin, joints[:, PELVIS_JOINT], joints[:, WRIST_JOINTS[0]], joints[:, WRIST_JOINTS[1]]], dim=1)
    rots = torch.stack([rotation_about_z(heading), rotations[:, PELVIS_JOINT], rotations[:, WRIST_JOINTS[0]],
                        rotations[:, WRIST_JOINTS[1]]], dim=1)
    return positions, rots


def in_frame(positions, rotations, origin, frame):
    """Positions (..., 3) and rotations (..., 3, 3) seen from frames ``(origin (..., 3), frame (..., 3, 3))``
    whose batch shape broadcasts against theirs: ``Rᵀ (p − o)`` and ``Rᵀ r``."""
    local = ((positions - origin)[..., None, :] @ frame)[..., 0, :]  # (pᵀ R)ᵀ = Rᵀ p: matmul, cheaper than einsum
    return local, frame.transpose(-1, -2) @ rotations


def encode_transform(positions, rotations) -> torch.Tensor:
    """(..., 9): position and 6D rotation."""
    return torch.cat([positions, matrix_to_rotation_6d(rotations)], dim=-1)


def decode_transform(encoded) -> tuple[torch.Tensor, torch.Tensor]:
    return encoded[..., :3], rotation_6d_to_matrix(encoded[..., 3:])


def goal_phase_features(state) -> torch.Tensor:
    """Eq. 13's features without noise, ``(A·sin 2πS, A·cos 2πS, F)`` per channel: (..., 3C) from a
    phase state ``[S, A, F]`` (..., C, 3) (``kalman``'s order; ``phase.manifold_features``'s sin/cos order)."""
    state = torch.as_tensor(np.asarray(state) if not torch.is_tensor(state) else state, dtype=torch.float32)
    check_shape(state, (..., None, 3), "state")
    params = PhaseParameters(state[..., 0], state[..., 2], state[..., 1], torch.zeros_like(state[..., 0]))
    return torch.cat([phase.manifold_features(params).flatten(-2), state[..., 2]], dim=-1)


def phase_state(features: torch.Tensor) -> torch.Tensor:
    """The inverse of :func:`goal_phase_features`: ``[S, A, F]`` (..., C, 3) from (..., 3C) features
    (``A = ‖p‖``, ``S = atan2(sin, cos) / 2π`` in [0, 1))."""
    check_shape(features, (..., None), "features")
    if features.shape[-1] % 3:
        raise ValueError(f"features: expected 3C numbers (A sin, A cos per channel, then F), got {features.shape[-1]}")
    C = features.shape[-1] // 3
    manifold = features[..., :2 * C].reshape(*features.shape[:-1], C, 2)
    S = torch.remainder(torch.atan2(manifold[..., 0], manifold[..., 1]) / (2 * math.pi), 1.0)
    return torch.stack([S, manifold.norm(dim=-1), features[..., 2 * C:]], dim=-1)


def io_layouts(channels: int):
    """The input and output layouts (``world.features.feature_layout``)."""
    future = (len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)
    x_parts = (("pose", 2 * NUM_JOINTS * 3), ("trajectory", (WINDOW, 4)),
               ("goal", (WINDOW, len(KEY_JOINTS), TRANSFORM)), ("phase", 3 * channels), ("goal_phase", 3 * channels),
               ("keys", (len(FUTURE_OFFSETS), len(KEY_JOINTS) - 1, TRANSFORM)))
    y_parts = (("pose", 2 * NUM_JOINTS * 3), ("root_update", 3), ("phase", 3 * channels), ("ego", future),
               ("inv", future), ("goal", (WINDOW, len(KEY_JOINTS), TRANSFORM)), ("goal_phase", 3 * channels),
               ("rotations", NUM_JOINTS * 6))
    return feature_layout(x_parts), feature_layout(y_parts)




def pose_features(joints, velocities, origin, frame):
    """(T, 132) joint positions and velocities in root frames (origin (T, 3), frame (T, 3, 3))."""
    local = torch.einsum("tji,tkj->tki", frame, joints - origin[:, None])
    velocity = torch.einsum("tji,tkj->tki", frame, velocities)
    return torch.cat([local.flatten(1), velocity.flatten(1)], dim=-1)


def local_rotation_features(clip: Motion, frames, frame: torch.Tensor) -> torch.Tensor:
    """(N, 22·6) the pose at ``frames`` (N,) as local joint rotations in 6D — the pelvis's relative to the root frame
    ``frame`` (N, 3, 3) of each frame, every other joint's relative to its parent (``Motion.local_rotations``) — the
    whole-body pose §5.1's controller outputs, as Starke et al.'s controllers write it.
    :func:`pose_from_rotations` poses a body from it."""
    frames = torch.as_tensor(frames)
    check_shape(frame, (len(frames), 3, 3), "frame")
    local = clip.local_rotations[frames].clone()
    local[:, 0] = frame.to(local.dtype).transpose(-1, -2) @ local[:, 0]  # the pelvis seen from the root frame
    return matrix_to_rotation_6d(local).flatten(1)


def pose_from_rotations(rotations: torch.Tensor, pelvis: torch.Tensor, offsets: torch.Tensor) -> torch.Tensor:
    """(B, 22, 3) joint positions, root frame: the body posed by forward kinematics (``world.kinematics``) from 6D
    local rotations ``rotations`` (B, 22·6, :func:`local_rotation_features`' layout; any 6 numbers, Gram–Schmidt
    makes rotations of them), the pelvis position ``pelvis`` (B, 3) in the root frame and the body's bone offsets
    ``offsets`` (22, 3) or (B, 22, 3) (``world.skeleton.bone_offsets``). Every bone keeps its length."""
    check_shape(rotations, (None, NUM_JOINTS * 6), "rotations")
    check_shape(pelvis, (rotations.shape[0], 3), "pelvis")
    local = rotation_6d_to_matrix(rotations.reshape(-1, NUM_JOINTS, 6))
    return forward_kinematics(local, pelvis.to(local.dtype), offsets)[1]


@torch.no_grad()
def clip_features(clip: Motion, pae: PhaseAutoencoder) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(x (T−1, in), y (T−1, out), phase states (T, C, 3))`` of one reach-and-grasp clip.

    The goal phase of frame ``t`` (the input ``P_g`` of Eq. 13 at ``t``, the target ``P̂_g`` at ``t + 1``) is the
    next keyframe's PAE phase state carried to that frame by ``kalman.goal_phase_at`` (Eqs. 15–16), the one
    goal-phase model the run time's matched measurement and Kalman filter use too.
    """
    T = len(clip)
    joints = clip.joints
    origin, heading = root_frame(joints)
    frame = rotation_about_z(heading)
    positions, rotations = key_joint_transforms(clip)
    params = phase.clip_phase(pae, clip)
    states = params.state()  # (T, C, 3)
    features = goal_phase_features(states)  # (T, 3C)
    anchor = int(clip.meta["anchor_frame"])
    t = torch.arange(T - 1)
    goal_frame = torch.where(t <= anchor, anchor, T - 1)  # g(t): the next keyframe
    goal_next = torch.where(t + 1 <= anchor, anchor, T - 1)
    goal_phase, goal_phase_next = (  # (T − 1, 3C): the goal phase of frames t and t + 1
        goal_phase_features(kalman.goal_phase_at(states[g].double().numpy(), (g - f).double().numpy()[:, None],
                                                 kalman.PhaseFilterConfig(dt=1.0 / clip.fps)))
        for g, f in ((goal_frame, t), (goal_next, t + 1)))

    def at(index):  # frame indices clamped to the clip
        return index.clamp(0, T - 1)

    def window(index, o, f):  # key joints at frames index (N, S) seen from (o, f) of each row
        p, r = in_frame(positions[index], rotations[index], o[:, None, None], f[:, None, None])
        return encode_transform(p, r)

    o, f = origin[t], frame[t]
    traj_index = at(t[:, None] + WINDOW_OFFSETS)
    traj_p, traj_r = in_frame(origin[traj_index], frame[traj_index], o[:, None], f[:, None])
    trajectory = torch.cat([traj_p[..., :2], traj_r[..., :2, 1]], dim=-1)  # position, forward (+Y)
    x = torch.cat([pose_features(joints[t], clip.joint_velocities()[t], o, f), trajectory.flatten(1),
                   window(at(goal_frame[:, None] + WINDOW_OFFSETS), o, f).flatten(1), features[t],
                   goal_phase, window(at(t[:, None] + FUTURE_OFFSETS), o, f)[:, :, 1:].flatten(1)], dim=-1)

    n = t + 1
    update_p, _ = in_frame(origin[n], frame[n], o, f)
    root_update = torch.cat([update_p[:, :2], wrapped_angle(heading[n] - heading[t])[:, None]], dim=-1)  # dx, dy, dyaw
    future = at(n[:, None] + FUTURE_OFFSETS)
    g_p, g_r = positions[goal_frame], rotations[goal_frame]  # (N, 4, 3), (N, 4, 3, 3): G per key joint
    inv_p, inv_r = in_frame(positions[future], rotations[future], g_p[:, None], g_r[:, None])
    y = torch.cat([pose_features(joints[n], clip.joint_velocities()[n], origin[n], frame[n]), root_update, features[n],
                   window(future, o, f).flatten(1), encode_transform(inv_p, inv_r).flatten(1),
                   window(at(goal_next[:, None] + WINDOW_OFFSETS), o, f).flatten(1), goal_phase_next,
                   local_rotation_features(clip, n, frame[n])], dim=-1)
    return x.float(), y.float(), states


def next_root_frame(update: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The root frame of ``t + 1`` seen from ``t``: its origin (B, 3) and rotation (B, 3, 3), from the root's update
    ``(dx, dy, dyaw)`` (B, 3); a point ``p`` of frame ``t`` is ``Rᵀ (p − o)`` in frame ``t + 1``."""
    return torch.cat([update[:, :2], torch.zeros_like(update[:, :1])], dim=-1), rotation_about_z(update[:, 2])


def blended_pose(previous: torch.Tensor, predicted: torch.Tensor, update: torch.Tensor) -> torch.Tensor:
    """The pose of ``t + 1`` a step keeps (B, 132), root frame of ``t + 1``: each joint ``POSE_BLEND`` of the way
    from its previous position moved by the predicted velocity to the predicted position; the predicted velocities.

    Args:
        previous: (B, 132) the pose of ``t`` (root frame of ``t``). predicted: (B, 132) the network's pose of
            ``t + 1`` (root frame of ``t + 1``). update: (B, 3) the root's ``(dx, dy, dyaw)`` (root frame of ``t``).
    """
    return blend_pose_in_frame(previous, predicted, *next_root_frame(update))


def blend_pose_in_frame(previous, predicted, shift, turn):
    """:func:`blended_pose` with the next root frame ``(shift, turn)`` of :func:`next_root_frame` given."""
    n = NUM_JOINTS * 3
    moved = (previous[:, :n].reshape(-1, NUM_JOINTS, 3) - shift[:, None]) @ turn  # Rᵀ p per joint
    carried = moved.flatten(1) + predicted[:, n:] / FPS
    return torch.cat([(1 - POSE_BLEND) * carried + POSE_BLEND * predicted[:, :n], predicted[:, n:]], dim=-1)


def blend_rotations_in_frame(previous, predicted, turn):
    """The local rotations of ``t + 1`` a step keeps (B, 22·6, :func:`local_rotation_features`' layout): each
    ``POSE_BLEND`` of the way from the previous one (root frame of ``t``; the pelvis's carried into the next root
    frame ``turn`` of :func:`next_root_frame`) to the predicted one (root frame of ``t + 1``), as
    :func:`blend_pose_in_frame` blends the positions. The blend of two 6D vectors is not a rotation until
    Gram–Schmidt (:func:`pose_from_rotations`) makes one of it."""
    previous = previous.reshape(-1, NUM_JOINTS, 2, 3).clone()  # two columns per joint
    previous[:, 0] = previous[:, 0] @ turn  # the pelvis's columns seen from the next root frame: (Rᵀ c)ᵀ
    return (1 - POSE_BLEND) * previous.flatten(1) + POSE_BLEND * predicted


def next_root_trajectory(ego: torch.Tensor, update: torch.Tensor) -> torch.Tensor:
    """(B, 7, 4) the root trajectory input of ``t + 1`` (position, forward; root frame of ``t + 1``) from the
    predicted egocentric root samples ``ego`` (B, 7·4·9, root frame of ``t``) and root update ``(dx, dy, dyaw)``."""
    B = ego.shape[0]
    root_p, root_r = decode_transform(ego.reshape(B, len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)[:, :, 0])
    return carried_root_trajectory(root_p, root_r, *next_root_frame(update))


def carried_root_trajectory(root_p, root_r, shift, turn):
    """:func:`next_root_trajectory` from the decoded root samples, positions (B, 7, 3) and rotations (B, 7, 3, 3), and the
    next root frame ``(shift, turn)`` of :func:`next_root_frame`."""
    turn = turn[:, :2, :2]  # (B, 2, 2)
    position = (root_p[..., :2] - shift[:, None, :2]) @ turn  # Rᵀ p as pᵀ R
    forward = root_r[..., :2, 1] @ turn
    return torch.cat([position, forward], dim=-1)


def next_key_trajectories(ego: torch.Tensor, update: torch.Tensor) -> torch.Tensor:
    """(B, 7, 3, 9) the hip's and wrists' trajectory input of ``t + 1`` (root frame of ``t + 1``: position and 6D
    rotation at ``t + 1 + 5k``) from the predicted or blended key-joint samples ``ego`` (B, 7·4·9 or (B, 7, 4, 9),
    root frame of ``t``) and the root update ``(dx, dy, dyaw)`` (B, 3)."""
    B = ego.shape[0]
    p, r = decode_transform(ego.reshape(B, len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)[:, :, 1:])
    return carried_key_trajectories(p, r, *next_root_frame(update))


def carried_key_trajectories(p, r, shift, turn):
    """:func:`next_key_trajectories` from the decoded hip and wrist samples, positions (B, 7, 3, 3) and rotations
    (B, 7, 3, 3, 3), and the next root frame ``(shift, turn)`` of :func:`next_root_frame`."""
    return encode_transform(*in_frame(p, r, shift[:, None, None], turn[:, None, None]))


def wrapped_angle(angle: torch.Tensor) -> torch.Tensor:
    """Angles wrapped into [−π, π)."""
    return torch.remainder(angle + math.pi, 2 * math.pi) - math.pi
