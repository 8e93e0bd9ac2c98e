"""The goal-driven deep-phase controller (CHOICE §5.1, Eqs. 13–14, 22, Algorithm 1, Fig. 4; Table 4's variants).

The algorithm box, as this module runs it (``B`` characters, ``C`` PAE channels, ``K = 4`` key joints
root / hip / left wrist / right wrist, ``w = 13`` samples over 2 s):

1. **Data** (:func:`controller_data`): toy reach-and-grasp clips (approach walk, reach, grasp); door and drawer
   clips (walk, reach the handle, pull) too when ``ControllerConfig.kinds`` names them. Keyframes
   are the grasp (``meta["anchor_frame"]``) and the clip's last frame; ``g(t)`` is the next keyframe at
   or after ``t``. The PAE (``phase``) gives every frame's ``(S, F, A)``.
2. **Inputs** ``X_t`` (all in the root frame of ``t``): the pose (root-relative joint positions and
   velocities), the 2D root trajectory (13 samples over ``[t − 1 s, t + 1 s]``: position and forward
   direction), the goals ``G_t^keyJ`` (the four key joints' positions and 6D rotations at 13 samples
   centred on ``g``), the current phase ``A·(sin 2πS, cos 2πS), F`` and the goal phase features of
   Eq. 13, ``P̃_g = (A_g·sin 2πS_g + ε, A_g·cos 2πS_g + ε, F_g + ε)``, ``ε ~ N(0, 0.1)`` in training, and
   the hip's and wrists' 6D trajectories over the next second (7 samples ``t + 5k``; §5.1: "in addition to
   the 2D root trajectories on the ground, the 6D transformations of the hip and left/right wrists are also
   given"): the recorded ones in training, noised by ``key_noise``; at run time the previous step's blend.
3. **Network** (Fig. 4): a gating network on the phase features (current and goal ``A·sin, A·cos``)
   blends the experts of an MoE main network (``nn.moe.MoEMLP``).
4. **Outputs** ``Y_{t+1}``: the next pose (in the next root frame) with the root's update, the next
   phase, the egocentric key-joint trajectory ``T^ego_{t+1}`` (1 s ahead, in the root frame of ``t``),
   the goal-centric one ``T^inv_{t+1}`` (each key joint in its own goal frame ``G``), and the goal
   estimate ``Ĝ`` (13-sample window at ``g``) with its phase ``P̂_g``.
5. **Run time** (:func:`controller_step`): ``G T^inv`` (Eq. 14) is blended with ``T^ego`` with a weight
   that grows as the working wrist nears its goal; the blended trajectories are the next step's inputs (the
   root's as its future root trajectory, the hip's and wrists' as theirs: Fig. 4, "our bi-directional control
   blends the key-joint transformation prediction", fed back as NSM feeds back its control signals).
   ``c = Dev(G T^inv, T^ego)`` (Eq. 22) is returned for the Kalman filter.
6. **Goal phase sources** (:func:`rollout`, Table 4): ``"none"`` (zeros), ``"matched"`` (the matched
   clip's phase at its keyframe, held), ``"predicted"`` (the network's own ``P̂_g`` fed back), ``"kalman"``
   (``kalman.filter_step`` on the network's ``P̂_g`` with ``R_pred = c Q`` and the matched phase with
   ``R = Q`` where ``matched_measurement_active``; Algorithm 1).

Choices the paper does not state, ours:

- One network serves all four variants: in training the goal phase features are zeroed with
  probability ``phase_dropout``, so that ``"none"`` (zeros) is a state the network has seen.
- Key-joint transforms: the root is the pelvis projected to the ground with the hips' heading
  (``world.features.root_frame``); the hip is the pelvis joint; rotations are global, as 6D.
- The goal window is the 13 frames ``g + 5k`` (k = −6..6, clamped to the clip), one ``g`` for the whole
  window (the paper's per-sample ``g(t')`` differs only across a keyframe).
- The future windows (ego, goal-centric, blended root) are the 7 samples ``t + 1 + 5k`` (k = 0..6).
- The blend weight is ``λ = clip(1 − d / blend_radius, 0, 1)``, ``d`` the working wrist's distance to
  its goal; positions and 6D rotations are blended linearly and the rotations re-orthonormalised.
- ``c`` of Eq. 22 is the mean over the 7 future samples of the sum over the 4 key joints.
- ``σ̄`` of Eq. 19 is the variance of ``[S, A, F]`` per channel over the training frames (``S`` as the
  wrapped number in [0, 1), not a circular variance).
- The filter starts from the matched goal phase with ``P = 0`` (Algorithm 1 initialises the goal
  on the click; the paper's ``G^p = 0`` would feed a zero goal phase at first). ``"predicted"`` starts
  from the matched phase too.
- Training is teacher-forced, then, for its last ``unroll_steps``, unrolled over ``unroll`` frames on the
  network's own pose, phase and future root trajectory (:func:`train_controller`); inputs and outputs are
  standardised with the training data's mean and std; the loss is the mean squared error in those units.
- At run time each joint moves half-way from its previous position carried by the predicted velocity to the
  predicted position (``POSE_BLEND``, :func:`blended_pose`), as Starke et al.'s released controllers do.
- A rollout starts with the future root trajectory on the straight line to the goal's root at 1 m/s
  (:func:`toward_goal`; a standing start is a fixed point the toy controller may not leave).

Measured at toy (one CPU thread): 48 clips, about 8 400 frames, 2400 steps (the last 400 unrolled over 6 frames)
in 51 / 54 / 52 s with seeds 0 / 1 / 2. On 12 unseen reaches the working wrist comes within a median 0.13 / 0.22 /
0.31 m of its grasp with the Kalman goal phase, 0.08 / 0.17 / 0.20 m without a goal phase (Table 4's runs,
``evaluation.table4_runs``); 3000 steps (600 unrolled) took about 70 s for Kalman medians of 0.13 / 0.31 / 0.38 m.
Before the hip's and wrists' trajectories were inputs, those medians were 0.37 / 0.40 / 0.14 m, and with seed 2 some
characters blew up (unsmoothness 3 346 cm/s², against 156 now). Trained on 16 clips of each of ``CLIP_KINDS``
instead (about as many frames, 2400 steps), the door wrist of ``pick_and_place.controller_at_cabinet`` came within
0.31 / 0.22 / 0.28 m of the demo's handle from its standing start, against 0.63 / 0.43 / 0.43 m: nearer, still 20–30
cm short, while Table 4's Kalman row slid 246 / 389 / 193 cm/s² against 158 / 98 / 194 and, with seed 1, moved less
smoothly than the recorded clips (381 against 299 cm/s²). So the toy preset keeps reach-and-grasp clips only.

Scaling (paper → toy): 8 PAE channels → 4 (``phase``); gating 3 × 128 → 2 × 64 hidden + output, main
network 3 × 512 → 3 × 128; experts (not stated in CHOICE; DeepPhase 8) → 4; 70 % of 150 sequences for
150 epochs (8 h) → ``clips`` toy clips for ``steps`` batches; 60 fps → 30 fps; the full 22-joint pose
(no joint rotations, ours) stands for the paper's pose.
"""
from __future__ import annotations

import copy
import dataclasses
import math
import sys
from dataclasses import dataclass
from typing import NamedTuple, Optional

import numpy as np
import torch
from torch import nn

from .._validate import check_choice, check_finite, check_positive_ints, check_shape
from ..infra import TrainedModel, load_or_build, scaled_config, single_threaded, state_dict_to_cpu, train, trainer_config
from ..nn import moe
from ..nn.moe import MoEMLP
from ..world import mocap
from ..world.features import feature_layout, root_frame
from ..world.motion import FPS, Motion
from ..world.rotations import matrix_to_rotation_6d, rotation_6d_to_matrix, rotation_about_z
from ..world.skeleton import NUM_JOINTS, joint_index
from . import kalman, phase
from .phase import PhaseAutoencoder, PhaseParameters

__all__ = [
    "KEY_JOINTS", "CLIP_KINDS", "VARIANTS", "WINDOW", "SAMPLE_STEP", "WINDOW_OFFSETS", "FUTURE_OFFSETS",
    "ControllerConfig", "CONTROLLER_SCALES", "controller_config",
    "key_joint_transforms", "goal_phase_features", "phase_state",
    "ControllerData", "clip_features", "controller_data", "ControllerNet", "build_controller", "train_controller",
    "trained_controller", "ControllerState", "Goal", "initial_state", "clip_goal", "toward_goal", "POSE_BLEND",
    "blended_pose", "next_key_trajectories", "controller_step",
    "Rollout", "rollout",
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
_PELVIS, _WRISTS = joint_index("pelvis"), (joint_index("left_wrist"), joint_index("right_wrist"))
_WRIST_INDEX = torch.tensor(_WRISTS)  # the working wrist's joint, indexed by the hand (0 left, 1 right)


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class ControllerConfig:
    """The controller, its data and its training (defaults: the ``toy`` preset).

    Attributes:
        clips: toy clips trained on, per kind.
        kinds: the ``world.mocap`` kinds of the clips, each with one hand keyframe (``meta["anchor_frame"]``):
            any of :data:`CLIP_KINDS`.
        hidden: the main network's width (CHOICE §8.1: 512).
        gating_hidden: the gating network's width (CHOICE §8.1: 128).
        n_experts: experts of the MoE (not stated by CHOICE; DeepPhase: 8).
        steps, batch_size, lr, lr_schedule, grad_clip, optimizer: training (CHOICE: 150 epochs, 8 h).
        phase_noise: standard deviation of Eq. 13's noise (CHOICE: 0.1).
        phase_dropout: probability that a training sample's goal phase is zeroed (ours; the ``"none"`` variant).
        key_noise: standard deviation of the noise on the key-joint trajectory input in training, metres and 6D
            units (ours, as Eq. 13 noises the goal phase: without it the network leans on the recorded future and
            its own fed-back trajectories drive it off).
        unroll, unroll_steps: the last ``unroll_steps`` of the ``steps`` run the network ``unroll`` frames on its
            own predicted pose, phase and trajectories (ours; see :func:`train_controller`).
        blend_radius: metres; the ego/goal-centric blend weight reaches 1 at the goal (ours).
        phase_scale, phase_steps: the PAE's preset and, when not ``None``, its training steps.
        seed: seeds the clips, the PAE, the weights, the batches and the noise.
    """

    clips: int = 48
    kinds: tuple = ("reach_grasp",)
    hidden: int = 128
    gating_hidden: int = 64
    n_experts: int = 4
    steps: int = 2400
    batch_size: int = 32
    lr: float = 1e-3
    lr_schedule: str = "cosine"
    grad_clip: Optional[float] = 1.0
    optimizer: str = "adam"
    phase_noise: float = 0.1
    phase_dropout: float = 0.2
    key_noise: float = 0.1
    unroll: int = 6
    unroll_steps: int = 400
    blend_radius: float = 1.0
    phase_scale: str = "toy"
    phase_steps: Optional[int] = None
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("clips", "hidden", "gating_hidden", "n_experts", "steps", "batch_size", "unroll"))
        if isinstance(self.unroll_steps, bool) or not isinstance(self.unroll_steps, int) \
                or not 0 <= self.unroll_steps <= self.steps:
            raise ValueError(f"unroll_steps: expected an int in [0, steps={self.steps}], got {self.unroll_steps!r}")
        for name in ("lr", "blend_radius"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: expected a positive number, got {getattr(self, name)!r}")
        for name in ("phase_noise", "key_noise"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name}: expected a standard deviation >= 0, got {getattr(self, name)!r}")
        if not 0 <= self.phase_dropout < 1:
            raise ValueError(f"phase_dropout: expected a probability in [0, 1), got {self.phase_dropout!r}")
        if self.phase_steps is not None:
            check_positive_ints(self, ("phase_steps",))
        kinds = self.kinds
        if isinstance(kinds, str) or not isinstance(kinds, tuple) or not kinds or len(set(kinds)) < len(kinds) \
                or not all(k in CLIP_KINDS for k in kinds):
            raise ValueError(f"kinds: expected a tuple of distinct names from {CLIP_KINDS}, got {kinds!r}")


# CHOICE §8.1: gating 3 x 128, main network 3 x 512, 150 epochs over 70 % of ~150 x 3 min at 60 fps.
CONTROLLER_SCALES = {
    "small": {"clips": 64, "hidden": 256, "gating_hidden": 128, "n_experts": 8, "steps": 8000,
              "phase_scale": "small"},
    "paper": {"clips": 400, "hidden": 512, "gating_hidden": 128, "n_experts": 8, "steps": 200000, "batch_size": 64,
              "lr": 1e-4, "phase_scale": "paper"},
}


def controller_config(scale: str = "toy", **overrides) -> ControllerConfig:
    """The preset for ``scale``, fields overridable (``controller_config("toy", steps=100)``)."""
    return scaled_config(ControllerConfig, scale, CONTROLLER_SCALES, overrides, factory="controller_config")


# ----------------------------------------------------------------------------- features


def key_joint_transforms(motion: Motion) -> tuple[torch.Tensor, torch.Tensor]:
    """The four key joints' world transforms per frame: positions (T, 4, 3) metres and rotations
    (T, 4, 3, 3) — the root on the ground with the hips' heading, the pelvis, the two wrists."""
    joints, rotations = motion.joints, motion.global_rotations
    origin, heading = root_frame(joints)
    positions = torch.stack([origin, joints[:, _PELVIS], joints[:, _WRISTS[0]], joints[:, _WRISTS[1]]], dim=1)
    rots = torch.stack([rotation_about_z(heading), rotations[:, _PELVIS], rotations[:, _WRISTS[0]],
                        rotations[:, _WRISTS[1]]], dim=1)
    return positions, rots


def _in_frame(positions, rotations, origin, frame):
    """Positions (..., 3) and rotations (..., 3, 3) seen from frames ``(origin (..., 3), frame (..., 3, 3))``
    whose batch shape broadcasts against theirs: ``Rᵀ (p − o)`` and ``Rᵀ r``."""
    local = ((positions - origin)[..., None, :] @ frame)[..., 0, :]  # (pᵀ R)ᵀ = Rᵀ p: matmul, cheaper than einsum
    return local, frame.transpose(-1, -2) @ rotations


def _encode(positions, rotations) -> torch.Tensor:
    """(..., 9): position and 6D rotation."""
    return torch.cat([positions, matrix_to_rotation_6d(rotations)], dim=-1)


def _decode(encoded) -> tuple[torch.Tensor, torch.Tensor]:
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


def _parts(channels: int):
    """The input and output layouts (``world.features.feature_layout``)."""
    future = (len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)
    x_parts = (("pose", 2 * NUM_JOINTS * 3), ("trajectory", (WINDOW, 4)),
               ("goal", (WINDOW, len(KEY_JOINTS), TRANSFORM)), ("phase", 3 * channels), ("goal_phase", 3 * channels),
               ("keys", (len(FUTURE_OFFSETS), len(KEY_JOINTS) - 1, TRANSFORM)))
    y_parts = (("pose", 2 * NUM_JOINTS * 3), ("root_update", 3), ("phase", 3 * channels), ("ego", future),
               ("inv", future), ("goal", (WINDOW, len(KEY_JOINTS), TRANSFORM)), ("goal_phase", 3 * channels))
    return feature_layout(x_parts), feature_layout(y_parts)


# ----------------------------------------------------------------------------- data


class ControllerData(NamedTuple):
    """Every frame ``t`` of the training clips that has a next frame.

    Attributes:
        x: (N, in) the inputs (goal phase without noise). y: (N, out) the targets.
        phase_variance: (C, 3) ``σ̄``, the variance of ``[S, A, F]`` over the frames.
        clip: (N,) long, the clip of each frame (frames of a clip are consecutive); None: one clip.
    """

    x: torch.Tensor
    y: torch.Tensor
    phase_variance: torch.Tensor
    clip: Optional[torch.Tensor] = None


def _pose(joints, velocities, origin, frame):
    """(T, 132) joint positions and velocities in root frames (origin (T, 3), frame (T, 3, 3))."""
    local = torch.einsum("tji,tkj->tki", frame, joints - origin[:, None])
    velocity = torch.einsum("tji,tkj->tki", frame, velocities)
    return torch.cat([local.flatten(1), velocity.flatten(1)], dim=-1)


@torch.no_grad()
def clip_features(clip: Motion, pae: PhaseAutoencoder) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(x (T−1, in), y (T−1, out), phase states (T, C, 3))`` of one reach-and-grasp clip."""
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

    def at(index):  # frame indices clamped to the clip
        return index.clamp(0, T - 1)

    def window(index, o, f):  # key joints at frames index (N, S) seen from (o, f) of each row
        p, r = _in_frame(positions[index], rotations[index], o[:, None, None], f[:, None, None])
        return _encode(p, r)

    o, f = origin[t], frame[t]
    traj_index = at(t[:, None] + WINDOW_OFFSETS)
    traj_p, traj_r = _in_frame(origin[traj_index], frame[traj_index], o[:, None], f[:, None])
    trajectory = torch.cat([traj_p[..., :2], traj_r[..., :2, 1]], dim=-1)  # position, forward (+Y)
    x = torch.cat([_pose(joints[t], clip.joint_velocities()[t], o, f), trajectory.flatten(1),
                   window(at(goal_frame[:, None] + WINDOW_OFFSETS), o, f).flatten(1), features[t],
                   features[goal_frame], window(at(t[:, None] + FUTURE_OFFSETS), o, f)[:, :, 1:].flatten(1)], dim=-1)

    n = t + 1
    update_p, _ = _in_frame(origin[n], frame[n], o, f)
    root_update = torch.cat([update_p[:, :2], _wrapped(heading[n] - heading[t])[:, None]], dim=-1)  # dx, dy, dyaw
    future = at(n[:, None] + FUTURE_OFFSETS)
    g_p, g_r = positions[goal_frame], rotations[goal_frame]  # (N, 4, 3), (N, 4, 3, 3): G per key joint
    inv_p, inv_r = _in_frame(positions[future], rotations[future], g_p[:, None], g_r[:, None])
    y = torch.cat([_pose(joints[n], clip.joint_velocities()[n], origin[n], frame[n]), root_update, features[n],
                   window(future, o, f).flatten(1), _encode(inv_p, inv_r).flatten(1),
                   window(at(goal_next[:, None] + WINDOW_OFFSETS), o, f).flatten(1), features[goal_next]], dim=-1)
    return x.float(), y.float(), states


def _next_root_frame(update: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
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
    return _blended_pose(previous, predicted, *_next_root_frame(update))


def _blended_pose(previous, predicted, shift, turn):
    """:func:`blended_pose` with the next root frame ``(shift, turn)`` of :func:`_next_root_frame` given."""
    n = NUM_JOINTS * 3
    moved = (previous[:, :n].reshape(-1, NUM_JOINTS, 3) - shift[:, None]) @ turn  # Rᵀ p per joint
    carried = moved.flatten(1) + predicted[:, n:] / FPS
    return torch.cat([(1 - POSE_BLEND) * carried + POSE_BLEND * predicted[:, :n], predicted[:, n:]], dim=-1)


def _next_future(ego: torch.Tensor, update: torch.Tensor) -> torch.Tensor:
    """(B, 7, 4) the root trajectory input of ``t + 1`` (position, forward; root frame of ``t + 1``) from the
    predicted egocentric root samples ``ego`` (B, 7·4·9, root frame of ``t``) and root update ``(dx, dy, dyaw)``."""
    B = ego.shape[0]
    root_p, root_r = _decode(ego.reshape(B, len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)[:, :, 0])
    return _carried_future(root_p, root_r, *_next_root_frame(update))


def _carried_future(root_p, root_r, shift, turn):
    """:func:`_next_future` from the decoded root samples, positions (B, 7, 3) and rotations (B, 7, 3, 3), and the
    next root frame ``(shift, turn)`` of :func:`_next_root_frame`."""
    turn = turn[:, :2, :2]  # (B, 2, 2)
    position = (root_p[..., :2] - shift[:, None, :2]) @ turn  # Rᵀ p as pᵀ R
    forward = root_r[..., :2, 1] @ turn
    return torch.cat([position, forward], dim=-1)


def next_key_trajectories(ego: torch.Tensor, update: torch.Tensor) -> torch.Tensor:
    """(B, 7, 3, 9) the hip's and wrists' trajectory input of ``t + 1`` (root frame of ``t + 1``: position and 6D
    rotation at ``t + 1 + 5k``) from the predicted or blended key-joint samples ``ego`` (B, 7·4·9 or (B, 7, 4, 9),
    root frame of ``t``) and the root update ``(dx, dy, dyaw)`` (B, 3)."""
    B = ego.shape[0]
    p, r = _decode(ego.reshape(B, len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)[:, :, 1:])
    return _carried_keys(p, r, *_next_root_frame(update))


def _carried_keys(p, r, shift, turn):
    """:func:`next_key_trajectories` from the decoded hip and wrist samples, positions (B, 7, 3, 3) and rotations
    (B, 7, 3, 3, 3), and the next root frame ``(shift, turn)`` of :func:`_next_root_frame`."""
    return _encode(*_in_frame(p, r, shift[:, None, None], turn[:, None, None]))


def _wrapped(angle: torch.Tensor) -> torch.Tensor:
    """Angles wrapped into [−π, π)."""
    return torch.remainder(angle + math.pi, 2 * math.pi) - math.pi


def controller_data(config: ControllerConfig, pae: PhaseAutoencoder) -> ControllerData:
    """The training frames of ``config.clips`` toy clips of each of ``config.kinds`` (seeded by ``config.seed``)."""
    clips = mocap.generate_dataset(config.clips, seed=config.seed, kinds=config.kinds)
    parts = [clip_features(clip, pae) for clip in clips]
    states = torch.cat([s for _, _, s in parts])
    clip = torch.cat([torch.full((len(x),), i, dtype=torch.long) for i, (x, _, _) in enumerate(parts)])
    return ControllerData(torch.cat([x for x, _, _ in parts]), torch.cat([y for _, y, _ in parts]), states.var(0), clip)


# ----------------------------------------------------------------------------- the network


class ControllerNet(nn.Module):
    """The MoE controller of Fig. 4: ``X_t (B, in) -> Y_{t+1} (B, out)``.

    The gating network sees the current and goal phase-manifold features ``A·(sin, cos)`` (standardised);
    the main network ``nn.moe.MoEMLP`` sees the whole standardised input. Inputs and outputs are
    standardised with buffers set from the training data. The trained PAE rides along, frozen, as
    ``phase_model`` (a rollout's first phase comes from it).
    """

    def __init__(self, pae: PhaseAutoencoder, hidden: int, gating_hidden: int, n_experts: int):
        super().__init__()
        self.channels = pae.channels
        (self.x_layout, self.in_size), (self.y_layout, self.out_size) = _parts(self.channels)
        C = self.channels
        gate = torch.zeros(self.in_size, dtype=torch.bool)
        for name in ("phase", "goal_phase"):
            gate[self.x_layout[name].start:self.x_layout[name].start + 2 * C] = True
        self.register_buffer("gating_mask", gate, persistent=False)
        self.net = MoEMLP(self.in_size, hidden, self.out_size, n_experts, gating_in=int(gate.sum()),
                          gating_hidden=gating_hidden)
        for name, size, fill in (("x_mean", self.in_size, 0.0), ("x_std", self.in_size, 1.0),
                                 ("y_mean", self.out_size, 0.0), ("y_std", self.out_size, 1.0)):
            self.register_buffer(name, torch.full((size,), fill))
        self.register_buffer("phase_variance", torch.ones(C, 3))
        self.phase_model = pae
        for p in pae.parameters():
            p.requires_grad_(False)

    def set_statistics(self, data: ControllerData) -> None:
        """Standardise with the data's mean and std (a constant coordinate keeps a unit scale); keep ``σ̄``."""
        for name, values in (("x", data.x), ("y", data.y)):
            getattr(self, f"{name}_mean").copy_(values.mean(0))
            getattr(self, f"{name}_std").copy_(values.std(0).clamp_min(1e-3))
        self.phase_variance.copy_(data.phase_variance.clamp_min(1e-6))

    def forward_standardised(self, xn: torch.Tensor) -> torch.Tensor:
        """``ŷ (B, out)`` standardised from ``xn (B, in)`` standardised."""
        return self.net(xn, xn[:, self.gating_mask])

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``Y (B, out)`` in the data's units from ``X (B, in)``."""
        check_shape(x, (None, self.in_size), "x")
        return self.forward_standardised((x - self.x_mean) / self.x_std) * self.y_std + self.y_mean


def build_controller(config: ControllerConfig, pae: PhaseAutoencoder) -> ControllerNet:
    """A fresh controller for ``config`` on the PAE ``pae``, its weights seeded by ``config.seed``."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return ControllerNet(pae, config.hidden, config.gating_hidden, config.n_experts)


def _noised_inputs(x, layout, config: ControllerConfig, generator) -> torch.Tensor:
    """Eq. 13: ``N(0, phase_noise)`` on every goal phase feature, and the whole goal phase zeroed with
    probability ``phase_dropout`` (ours); ``N(0, key_noise)`` on the key-joint trajectories (ours). Returns a
    new ``x``."""
    x = x.clone()
    part = layout["goal_phase"]
    noise = torch.randn(x.shape[0], part.stop - part.start, generator=generator) * config.phase_noise
    keep = (torch.rand(x.shape[0], 1, generator=generator) >= config.phase_dropout).float()
    x[:, part] = (x[:, part] + noise) * keep
    keys = layout["keys"]
    x[:, keys] = x[:, keys] + config.key_noise * torch.randn(x.shape[0], keys.stop - keys.start, generator=generator)
    return x


@single_threaded
def train_controller(data: ControllerData, config: ControllerConfig, pae: PhaseAutoencoder, device="cpu",
                     progress: bool = False):
    """Fit the controller to ``data`` (mean squared error in standardised units).

    The first ``steps − unroll_steps`` batches are teacher-forced (single frames). The last ``unroll_steps``
    draw ``unroll`` consecutive frames of one clip and run the network on its own output: frame ``k + 1``'s
    pose, phase, future root trajectory and key-joint trajectories are the network's frame-``k`` predictions
    (:func:`next_key_trajectories`; the past root trajectory,
    goals and goal phase stay the data's), the loss averaged over the frames and back-propagated through them
    (ours: CHOICE trains for 150 epochs and does not say how; a teacher-forced toy controller wanders off on
    unseen clips, the autoregressive drift that scheduled sampling addresses, e.g. MVAE, Ling et al. 2020).
    At run time :func:`controller_step` also blends the pose (:func:`blended_pose`); training feeds the raw
    prediction back (measured at toy: blending in training too gave runaway rollouts with seed 1).

    Returns:
        ``(ControllerNet in eval mode, TrainResult)``.
    """
    if not isinstance(data, ControllerData) or len(data.x) == 0:
        raise ValueError("data: expected ControllerData with at least one frame")
    model = build_controller(config, pae)
    check_shape(data.x, (None, model.in_size), "data.x")
    check_shape(data.y, (len(data.x), model.out_size), "data.y")
    model.set_statistics(data)
    clip = data.clip if data.clip is not None else torch.zeros(len(data.x), dtype=torch.long)
    U = config.unroll
    starts = torch.nonzero(clip[:len(clip) - U + 1] == clip[U - 1:]).flatten() if len(clip) >= U else clip[:0]
    if config.unroll_steps and U > 1 and len(starts) == 0:
        raise ValueError(f"data: no clip has the {U} consecutive frames that unroll={U} needs")
    fed = [(model.x_layout[name], model.y_layout[name]) for name in ("pose", "phase")]
    trajectory, ego, update = model.x_layout["trajectory"], model.y_layout["ego"], model.y_layout["root_update"]
    keys = model.x_layout["keys"]
    assert keys.stop == model.in_size  # the key-joint trajectories come last
    past = 4 * PAST // SAMPLE_STEP  # the past samples' numbers in the trajectory
    assert fed[0][0].start == 0 and fed[0][0].stop <= trajectory.start and trajectory.stop <= fed[1][0].start

    def sample_batch(step, generator):
        if step < config.steps - config.unroll_steps or U == 1:
            index = torch.randint(0, len(data.x), (config.batch_size, 1), generator=generator)
        else:
            index = starts[torch.randint(0, len(starts), (config.batch_size,), generator=generator)][:, None] \
                + torch.arange(U)
        x = _noised_inputs(data.x[index.flatten()], model.x_layout, config, generator)
        return {"x": x.reshape(*index.shape, -1), "y": data.y[index]}

    def loss_fn(net, batch):
        yn = (batch["y"] - net.y_mean) / net.y_std  # (B, U, out)
        loss, x = 0.0, batch["x"][:, 0]  # the input fed at frame k, in the data's units
        for k in range(yn.shape[1]):
            out = net.forward_standardised((x - net.x_mean) / net.x_std)
            loss = loss + (out - yn[:, k]).square().mean()
            if k + 1 < yn.shape[1]:  # the next frame sees the pose, phase and future root trajectory it made
                y = out * net.y_std + net.y_mean
                data = batch["x"][:, k + 1]
                x = torch.cat([y[:, fed[0][1]],
                               data[:, fed[0][0].stop:trajectory.start + past],
                               _next_future(y[:, ego], y[:, update]).flatten(1), data[:, trajectory.stop:fed[1][0].start],
                               y[:, fed[1][1]], data[:, fed[1][0].stop:keys.start],
                               next_key_trajectories(y[:, ego], y[:, update]).flatten(1)], dim=-1)
        return loss / yn.shape[1]

    result = train(model, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return model.eval(), result


def _phase_model(config: ControllerConfig, device, progress) -> TrainedModel:
    overrides = {} if config.phase_steps is None else {"steps": config.phase_steps}
    return phase.trained_phase_autoencoder(config.phase_scale, config.seed, device=device, progress=progress,
                                           **overrides)


def trained_controller(config: ControllerConfig, device="cpu", progress: bool = False) -> TrainedModel:
    """The controller trained on :func:`controller_data` once, then loaded from the cache (the PAE is
    ``phase.trained_phase_autoencoder``'s, cached on its own). ``details``: ``n_frames``, ``final_loss``."""
    pae = _phase_model(config, device, progress).model

    def build():
        data = controller_data(config, pae)
        # a copy: training moves the model, and with it its PAE, to ``device``; the shared PAE stays on the CPU
        model, result = train_controller(data, config, copy.deepcopy(pae), device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_frames": len(data.x), "final_loss": result.final_loss}

    key = {"model": dataclasses.asdict(config), "fps": FPS}
    artifact = load_or_build("choice_controller", key, build, code=(mocap, moe, phase, sys.modules[__name__]))
    model = build_controller(config, pae)
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"],
                        {"n_frames": artifact["n_frames"], "final_loss": artifact["final_loss"]})


# ----------------------------------------------------------------------------- run time


class ControllerState(NamedTuple):
    """The characters' state between two frames (``B`` characters).

    Attributes:
        origin: (B, 3) the root on the ground, world metres. heading: (B,) radians (0 faces +Y).
        pose: (B, 132) joint positions and velocities in the root frame (m, m/s).
        history: (B, 31, 4) the root's world ground position and forward direction over the last
            ``PAST + 1`` frames, the current last.
        future: (B, 7, 4) the root trajectory ``t + 5k`` (k = 0..6) in the root frame: position, forward.
        phase: (B, 3C) the current phase features ``(A sin, A cos, F)``.
        keys: (B, 7, 3, 9) the hip's and wrists' trajectory ``t + 5k`` (k = 0..6) in the root frame: position
            and 6D rotation (the previous step's ego/goal-centric blend).
    """

    origin: torch.Tensor
    heading: torch.Tensor
    pose: torch.Tensor
    history: torch.Tensor
    future: torch.Tensor
    phase: torch.Tensor
    keys: torch.Tensor


class Goal(NamedTuple):
    """A goal keyframe per character.

    Attributes:
        positions: (B, 13, 4, 3) the key joints' world positions over the goal window (metres).
        rotations: (B, 13, 4, 3, 3) their world rotations.
        phase: (B, C, 3) the matched goal phase ``[S, A, F]`` (the ``"matched"`` source, Kalman's prior).
        hand: (B,) long, 0 left, 1 right: the working hand.
    """

    positions: torch.Tensor
    rotations: torch.Tensor
    phase: torch.Tensor
    hand: torch.Tensor


def _ground(origin, heading):
    """(B, 4): ground position and forward direction (+Y rotated by ``heading``)."""
    return torch.stack([origin[:, 0], origin[:, 1], -torch.sin(heading), torch.cos(heading)], dim=-1)


@torch.no_grad()
def initial_state(model: ControllerNet, clips, frame: int = 0) -> ControllerState:
    """The state of each clip at ``frame`` (its pose, root history and PAE phase); the future root
    trajectory and the key joints' trajectories stand still (ours: the data's future is not known at run time)."""
    clips = list(clips)
    if not clips or not all(isinstance(c, Motion) for c in clips):
        raise ValueError("clips: expected a non-empty sequence of world.motion.Motion")
    rows = []
    for clip in clips:
        if not 0 <= frame < len(clip):
            raise ValueError(f"frame: expected an index in [0, {len(clip)}), got {frame}")
        origin, heading = root_frame(clip.joints)
        f = rotation_about_z(heading)
        pose = _pose(clip.joints[frame:frame + 1], clip.joint_velocities()[frame:frame + 1], origin[frame:frame + 1],
                     f[frame:frame + 1])[0]
        past = (torch.arange(-PAST, 1) + frame).clamp(0, len(clip) - 1)
        params = phase.clip_phase(model.phase_model, clip)
        state = params.state()[frame]
        key_p, key_r = key_joint_transforms(clip)
        keys = _encode(*_in_frame(key_p[frame, 1:], key_r[frame, 1:], origin[frame], f[frame]))  # (3, 9)
        rows.append((origin[frame], heading[frame], pose, _ground(origin[past], heading[past]),
                     goal_phase_features(state), keys[None].expand(len(FUTURE_OFFSETS), -1, -1)))
    origin, heading, pose, history, features, keys = (torch.stack(v).float() for v in zip(*rows))
    future = torch.zeros(len(clips), len(FUTURE_OFFSETS), 4)
    future[..., 3] = 1.0
    return ControllerState(origin, heading, pose, history, future, features, keys)


@torch.no_grad()
def clip_goal(model: ControllerNet, clips) -> Goal:
    """The grasp keyframe of each reach-and-grasp clip as a goal, with the clip's PAE phase there as
    the matched goal phase."""
    rows = []
    for clip in clips:
        if "anchor_frame" not in clip.meta or "hand" not in clip.meta:
            raise ValueError("clips: expected reach-and-grasp clips with meta['anchor_frame'] and meta['hand']")
        g = int(clip.meta["anchor_frame"])
        positions, rotations = key_joint_transforms(clip)
        index = (g + WINDOW_OFFSETS).clamp(0, len(clip) - 1)
        params = phase.clip_phase(model.phase_model, clip)
        state = params.state()[g]
        rows.append((positions[index], rotations[index], state, torch.tensor(int(clip.meta["hand"] == "right"))))
    positions, rotations, state, hand = (torch.stack(v) for v in zip(*rows))
    return Goal(positions.float(), rotations.float(), state.float(), hand)


def toward_goal(state: ControllerState, goal: Goal, speed: float = 1.0) -> ControllerState:
    """``state`` with its future root trajectory on the straight line to the goal's root (the goal window's
    centre), walked at ``speed`` m/s and stopping there, facing along the line (facing the goal root's heading
    once on it). Ours: the start of a rollout, where no trajectory has been predicted yet; CHOICE's
    navigation (§6.2) brings the character near its goal, and a standing start is a fixed point the toy
    controller may not leave."""
    if not speed > 0:
        raise ValueError(f"speed: expected a positive number of m/s, got {speed!r}")
    B = state.origin.shape[0]
    frame = rotation_about_z(state.heading)
    target = goal.positions[:, WINDOW // 2, 0]  # (B, 3) the root's goal, world
    local = torch.einsum("bji,bj->bi", frame, target - state.origin)[:, :2]
    distance = local.norm(dim=-1, keepdim=True)
    direction = local / distance.clamp_min(1e-6)
    travelled = torch.minimum(speed * FUTURE_OFFSETS.float()[None] / FPS, distance)  # (B, 7)
    position = direction[:, None] * travelled[..., None]
    goal_forward = torch.einsum("bji,bj->bi", frame, goal.rotations[:, WINDOW // 2, 0, :, 1])[:, :2]
    arrived = (travelled >= distance - 1e-6)[..., None]
    forward = torch.where(arrived, goal_forward[:, None].expand(B, len(FUTURE_OFFSETS), 2),
                          direction[:, None].expand(B, len(FUTURE_OFFSETS), 2))
    return state._replace(future=torch.cat([position, forward], dim=-1))


def _deviation(ego_p, ego_r, goal_p, goal_r, config: kalman.PhaseFilterConfig) -> np.ndarray:
    """``c`` of Eq. 22 (``kalman.bidirectional_deviation``) per sample, (B, 7): the egocentric and goal-centric
    key joints' positions (B, 7, 4, 3) and rotations (B, 7, 4, 3, 3) in one root frame. The rotations come from
    Gram–Schmidt or are products of rotations, orthonormal to float32 rounding: the check is skipped."""
    ego_p, ego_r, goal_p, goal_r = (x.double().numpy() for x in (ego_p, ego_r, goal_p, goal_r))
    return kalman.bidirectional_deviation(ego_r, ego_p, goal_r, goal_p, config, check=False)


def _check_step_inputs(model, state, goal, goal_phase):
    B = state.origin.shape[0]
    C = model.channels
    for name, value, shape in (("state.origin", state.origin, (B, 3)), ("state.heading", state.heading, (B,)),
                               ("state.pose", state.pose, (B, 2 * NUM_JOINTS * 3)),
                               ("state.history", state.history, (B, PAST + 1, 4)),
                               ("state.future", state.future, (B, len(FUTURE_OFFSETS), 4)),
                               ("state.phase", state.phase, (B, 3 * C)),
                               ("state.keys", state.keys, (B, len(FUTURE_OFFSETS), len(KEY_JOINTS) - 1, TRANSFORM)),
                               ("goal.positions", goal.positions, (B, WINDOW, len(KEY_JOINTS), 3)),
                               ("goal.rotations", goal.rotations, (B, WINDOW, len(KEY_JOINTS), 3, 3)),
                               ("goal.phase", goal.phase, (B, C, 3)), ("goal.hand", goal.hand, (B,)),
                               ("goal_phase", goal_phase, (B, 3 * C))):
        check_shape(value, shape, name)


@torch.inference_mode()  # no autograd bookkeeping at all: about 15 % of a batch-1 step
def controller_step(model: ControllerNet, state: ControllerState, goal: Goal, goal_phase: torch.Tensor,
                    blend_radius: float = ControllerConfig.blend_radius,
                    filter_config: kalman.PhaseFilterConfig = kalman.PhaseFilterConfig()):
    """One frame of the controller for ``B`` characters.

    Args:
        state: the characters' :class:`ControllerState` at ``t``.
        goal: their :class:`Goal`.
        goal_phase: (B, 3C) the goal phase features fed to the network (Eq. 13 without noise; zeros for ``"none"``).
        blend_radius: metres; the weight of ``G T^inv`` is ``clip(1 − d / blend_radius, 0, 1)``.
        filter_config: the weights of Eq. 22's deviation (``rotation_weight``, ``position_weight``).
    Returns:
        ``(state at t + 1, outputs)``; ``outputs``: ``joints`` (B, 22, 3) and ``wrist`` (B, 2, 3) world
        positions at ``t + 1``,
        ``ego`` / ``goal_centric`` / ``blended`` (B, 7, 4, 9) key-joint trajectories in the root frame of ``t``
        (``goal_centric`` mapped by Eq. 14), ``blend`` (B,), ``deviation`` (B,) ``c`` of Eq. 22,
        ``goal`` (B, 13, 4, 9) the goal estimate, ``goal_phase_state`` (B, C, 3) its ``[S, A, F]``.
    """
    _check_step_inputs(model, state, goal, goal_phase)
    return _step(model, state, goal, goal_phase, blend_radius, filter_config)


def _step(model, state, goal, goal_phase, blend_radius, filter_config):
    """:func:`controller_step` on checked inputs (a rollout checks them once: a step keeps their shapes)."""
    B = state.origin.shape[0]
    rows = torch.arange(B)
    frame = rotation_about_z(state.heading)
    # inputs in the root frame of t
    past = state.history[:, :PAST:SAMPLE_STEP]  # frames t − 30, ..., t − 5
    past_p = (past[..., :2] - state.origin[:, None, :2]) @ frame[:, :2, :2]
    past_dir = past[..., 2:] @ frame[:, :2, :2]
    trajectory = torch.cat([torch.cat([past_p, past_dir], -1), state.future], dim=1)
    goal_p, goal_r = _in_frame(goal.positions, goal.rotations, state.origin[:, None, None], frame[:, None, None])
    x = torch.cat([state.pose, trajectory.flatten(1), _encode(goal_p, goal_r).flatten(1), state.phase, goal_phase,
                   state.keys.flatten(1)], -1)
    y = model(x)
    layout = model.y_layout
    future_shape = (B, len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)
    ego = y[:, layout["ego"]].reshape(future_shape)
    inv_p, inv_r = _decode(y[:, layout["inv"]].reshape(future_shape))
    centre_p, centre_r = goal_p[:, WINDOW // 2], goal_r[:, WINDOW // 2]  # G per key joint (B, 4, ...)
    mapped_p = (centre_r[:, None] @ inv_p[..., None])[..., 0] + centre_p[:, None]  # Eq. 14: G T^inv
    mapped_r = centre_r[:, None] @ inv_r
    goal_centric = _encode(mapped_p, mapped_r)
    deviation = _deviation(*_decode(ego), mapped_p, mapped_r, filter_config).mean(-1)
    # blend toward the goal-centric trajectory as the working wrist nears its goal
    wrist_now = state.pose[:, :NUM_JOINTS * 3].reshape(B, NUM_JOINTS, 3)[rows, _WRIST_INDEX[goal.hand]]
    distance = (wrist_now - goal_p[rows, WINDOW // 2, 2 + goal.hand]).norm(dim=-1)
    blend = (1.0 - distance / blend_radius).clamp(0.0, 1.0)
    blended = (1 - blend[:, None, None, None]) * ego + blend[:, None, None, None] * goal_centric
    # the root moves; the blended trajectories, carried into the next root frame, are the next future root and
    # key-joint trajectories
    update = y[:, layout["root_update"]]
    shift, turn = _next_root_frame(update)
    origin = state.origin + (frame[:, :, :2] @ update[:, :2, None])[..., 0]
    heading = _wrapped(state.heading + update[:, 2])
    new_frame = rotation_about_z(heading)
    blended_p, blended_r = _decode(blended)
    history = torch.cat([state.history[:, 1:], _ground(origin, heading)[:, None]], dim=1)
    next_state = ControllerState(origin, heading, _blended_pose(state.pose, y[:, layout["pose"]], shift, turn),
                                 history, _carried_future(blended_p[:, :, 0], blended_r[:, :, 0], shift, turn),
                                 y[:, layout["phase"]],
                                 _carried_keys(blended_p[:, :, 1:], blended_r[:, :, 1:], shift, turn))
    pose = next_state.pose[:, :NUM_JOINTS * 3].reshape(B, NUM_JOINTS, 3)
    world = pose @ new_frame.transpose(-1, -2) + origin[:, None]
    outputs = {"joints": world, "wrist": world[:, _WRIST_INDEX], "ego": ego, "goal_centric": goal_centric,
               "blended": blended, "blend": blend, "deviation": torch.as_tensor(deviation, dtype=torch.float32),
               "goal": y[:, layout["goal"]].reshape(B, WINDOW, len(KEY_JOINTS), TRANSFORM),
               "goal_phase_state": phase_state(y[:, layout["goal_phase"]])}
    return next_state, outputs


class Rollout(NamedTuple):
    """What :func:`rollout` records, frame by frame (``N`` frames).

    Attributes:
        joints: (N, B, 22, 3) world joint positions after each step (metres).
        wrist: (N, B, 2, 3) world wrist positions after each step.
        origin: (N, B, 3) the root.
        goal_phase: (N, B, 3C) the goal phase features fed to the network at each step.
        predicted_goal_phase: (N, B, C, 3) the network's ``[S, A, F]`` at the goal.
        deviation: (N, B) ``c`` of Eq. 22.
        state: the final :class:`ControllerState`.
    """

    joints: torch.Tensor
    wrist: torch.Tensor
    origin: torch.Tensor
    goal_phase: torch.Tensor
    predicted_goal_phase: torch.Tensor
    deviation: torch.Tensor
    state: ControllerState


@torch.inference_mode()
def rollout(model: ControllerNet, state: ControllerState, goal: Goal, frames: int, variant: str = "kalman",
            blend_radius: float = ControllerConfig.blend_radius,
            filter_config: kalman.PhaseFilterConfig = kalman.PhaseFilterConfig()) -> Rollout:
    """Drive ``B`` characters toward their goals for ``frames`` frames with one goal-phase source (Table 4).

    ``variant``: ``"none"`` (zeros), ``"matched"`` (``goal.phase`` held), ``"predicted"`` (the network's
    previous ``P̂_g``, starting from ``goal.phase``) or ``"kalman"`` (Algorithm 1: ``kalman.filter_step`` on
    the network's ``P̂_g`` with ``R_pred = c Q`` and, where ``matched_measurement_active``, ``goal.phase``
    with ``R = Q``; starting from ``goal.phase`` with ``P = 0``).
    """
    check_choice(variant, VARIANTS, "variant")
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise ValueError(f"frames: expected a positive int, got {frames!r}")
    B = state.origin.shape[0]
    _check_step_inputs(model, state, goal, torch.zeros(B, 3 * model.channels))
    estimate = goal.phase.double().numpy()
    matched = estimate.copy()
    covariance = np.zeros(estimate.shape + (3,))
    variance = model.phase_variance.double().numpy()
    centre = goal.positions[:, WINDOW // 2]
    root_goal, hand_goal = centre[:, 0, :2].double().numpy(), centre[torch.arange(B), 2 + goal.hand].double().numpy()
    records = []
    for _ in range(frames):
        fed = torch.zeros(B, 3 * model.channels) if variant == "none" else goal_phase_features(
            goal.phase if variant == "matched" else estimate)
        state, out = _step(model, state, goal, fed, blend_radius, filter_config)
        predicted = out["goal_phase_state"].double().numpy()
        if variant == "predicted":
            estimate = predicted
        elif variant == "kalman":
            check_finite(predicted, "the network's goal phase")  # a blown-up step stops here, not in the filter
            hand = out["wrist"][torch.arange(B), goal.hand]
            # float64 arrays of the shapes checked before the loop, the deviation ≥ 0 by construction: unchecked
            active = kalman.matched_measurement_active(state.origin[:, :2].double().numpy(), root_goal,
                                                       hand.double().numpy(), hand_goal, filter_config, check=False)
            estimate, covariance = kalman.filter_step(estimate, covariance, variance, predicted,
                                                      out["deviation"].double().numpy()[:, None], filter_config,
                                                      matched_goal=matched, use_matched=active[:, None], check=False)
        records.append((out["joints"], out["wrist"], state.origin, fed, out["goal_phase_state"], out["deviation"]))
    joints, wrist, origin, fed, predicted, deviation = (torch.stack(v) for v in zip(*records))
    return Rollout(joints, wrist, origin, fed, predicted, deviation, state)
