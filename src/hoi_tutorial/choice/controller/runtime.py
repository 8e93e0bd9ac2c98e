"""The controller at run time (CHOICE §5.1–5.2, Eqs. 14–16, 22, Algorithm 1; Table 4's goal-phase sources): steps 5 and
6 of the algorithm box in ``choice.controller``.

A :class:`ControllerState` is one character's pose, root trajectory, phase and key-joint trajectories;
:class:`KeyJointGoal` the four key joints over the goal's 2 s window and its phase. :func:`controller_step`
runs the network once, poses the whole body by forward kinematics from its predicted local rotations (every bone
keeps its length), moves the phase by Eqs. 15–16 (:func:`phase_update`) and blends ``G T^inv`` with ``T^ego``
(Eq. 14); :func:`rollout` steps a batch of characters with one of Table 4's goal-phase sources, the Kalman filter
of ``kalman`` among them. Every source but ``"none"`` reads the goal phase of a frame from one model,
``kalman.goal_phase_at`` (the keyframe's phase state carried by Eqs. 15–16 to that frame), as training does.
"""
from __future__ import annotations

import time
from typing import NamedTuple, Optional

import numpy as np
import torch

from ..._validate import check_choice, check_finite, check_shape
from ...world.features import root_frame
from ...world.motion import FPS, Motion
from ...world.rotations import rotation_about_z
from ...world.skeleton import NUM_JOINTS, bone_offsets
from . import kalman, phase
from .features import (FUTURE_OFFSETS, KEY_JOINTS, PAST, SAMPLE_STEP, TRANSFORM, VARIANTS, WINDOW, WINDOW_OFFSETS,
                       WRIST_JOINT_INDEX, blend_pose_in_frame, blend_rotations_in_frame, carried_key_trajectories,
                       carried_root_trajectory, decode_transform, encode_transform, goal_phase_features, in_frame,
                       key_joint_transforms, local_rotation_features, next_root_frame, phase_state, pose_features,
                       pose_from_rotations, wrapped_angle)
from .network import ControllerConfig, ControllerNet

__all__ = ["ControllerState", "KeyJointGoal", "initial_state", "clip_goal", "toward_goal", "phase_filter_config",
           "phase_update", "controller_step", "Rollout", "rollout", "step_timing"]

class ControllerState(NamedTuple):
    """The characters' state between two frames (``B`` characters).

    Attributes:
        origin: (B, 3) the root on the ground, world metres. heading: (B,) radians (0 faces +Y).
        pose: (B, 132) joint positions (the body posed by forward kinematics) and velocities in the root frame
            (m, m/s).
        history: (B, 31, 4) the root's world ground position and forward direction over the last
            ``PAST + 1`` frames, the current last.
        future: (B, 7, 4) the root trajectory ``t + 5k`` (k = 0..6) in the root frame: position, forward.
        phase: (B, 3C) the current phase features ``(A sin, A cos, F)``.
        keys: (B, 7, 3, 9) the hip's and wrists' trajectory ``t + 5k`` (k = 0..6) in the root frame: position
            and 6D rotation (the previous step's ego/goal-centric blend).
        offsets: (B, 22, 3) the characters' bone offsets (``world.skeleton.bone_offsets``): forward kinematics
            poses each body with its own bones.
        rotations: (B, 22·6) the whole pose as local joint rotations in 6D (``features.local_rotation_features``:
            the pelvis's in the root frame, every other joint's relative to its parent).
    """

    origin: torch.Tensor
    heading: torch.Tensor
    pose: torch.Tensor
    history: torch.Tensor
    future: torch.Tensor
    phase: torch.Tensor
    keys: torch.Tensor
    offsets: torch.Tensor
    rotations: torch.Tensor


class KeyJointGoal(NamedTuple):
    """A goal keyframe per character.

    Attributes:
        positions: (B, 13, 4, 3) the key joints' world positions over the goal window (metres).
        rotations: (B, 13, 4, 3, 3) their world rotations.
        phase: (B, C, 3) the matched keyframe's phase ``[S, A, F]`` (``X^p_g``; the ``"matched"`` source and
            Kalman's prior carry it to each frame by ``kalman.goal_phase_at``).
        hand: (B,) long, 0 left, 1 right: the working hand.
        due: (B,) the keyframe's frame ``g`` counted from a rollout's start (its first step is frame 0): the goal
            phase at step ``k`` is ``kalman.goal_phase_at(phase, due − k)``. ``None``: unknown, and only the
            ``"none"`` source can run.
    """

    positions: torch.Tensor
    rotations: torch.Tensor
    phase: torch.Tensor
    hand: torch.Tensor
    due: Optional[torch.Tensor] = None


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
        pose = pose_features(clip.joints[frame:frame + 1], clip.joint_velocities()[frame:frame + 1], origin[frame:frame + 1],
                     f[frame:frame + 1])[0]
        past = (torch.arange(-PAST, 1) + frame).clamp(0, len(clip) - 1)
        params = phase.clip_phase(model.phase_model, clip)
        state = params.state()[frame]
        key_p, key_r = key_joint_transforms(clip)
        keys = encode_transform(*in_frame(key_p[frame, 1:], key_r[frame, 1:], origin[frame], f[frame]))  # (3, 9)
        rotations = local_rotation_features(clip, [frame], f[frame:frame + 1])[0]
        rows.append((origin[frame], heading[frame], pose, _ground(origin[past], heading[past]),
                     goal_phase_features(state), keys[None].expand(len(FUTURE_OFFSETS), -1, -1),
                     bone_offsets(clip.betas), rotations))
    origin, heading, pose, history, features, keys, offsets, rotations = (torch.stack(v).float() for v in zip(*rows))
    future = torch.zeros(len(clips), len(FUTURE_OFFSETS), 4)
    future[..., 3] = 1.0
    return ControllerState(origin, heading, pose, history, future, features, keys, offsets, rotations)


@torch.no_grad()
def clip_goal(model: ControllerNet, clips, frame: int = 0) -> KeyJointGoal:
    """The grasp keyframe of each reach-and-grasp clip as a goal, with the clip's PAE phase there as
    the matched goal phase, due ``anchor_frame − frame`` frames after a rollout that starts at the clip's ``frame``
    (:func:`initial_state`'s)."""
    if isinstance(frame, bool) or not isinstance(frame, (int, np.integer)):
        raise ValueError(f"frame: expected an int (the rollout's first frame in the clips), got {frame!r}")
    rows = []
    for clip in clips:
        if "anchor_frame" not in clip.meta or "hand" not in clip.meta:
            raise ValueError("clips: expected reach-and-grasp clips with meta['anchor_frame'] and meta['hand']")
        g = int(clip.meta["anchor_frame"])
        positions, rotations = key_joint_transforms(clip)
        index = (g + WINDOW_OFFSETS).clamp(0, len(clip) - 1)
        params = phase.clip_phase(model.phase_model, clip)
        state = params.state()[g]
        rows.append((positions[index], rotations[index], state, torch.tensor(int(clip.meta["hand"] == "right")),
                     torch.tensor(g - int(frame))))
    positions, rotations, state, hand, due = (torch.stack(v) for v in zip(*rows))
    return KeyJointGoal(positions.float(), rotations.float(), state.float(), hand, due)


def toward_goal(state: ControllerState, goal: KeyJointGoal, speed: float = 1.0) -> ControllerState:
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
                               ("state.offsets", state.offsets, (B, NUM_JOINTS, 3)),
                               ("state.rotations", state.rotations, (B, NUM_JOINTS * 6)),
                               ("goal.positions", goal.positions, (B, WINDOW, len(KEY_JOINTS), 3)),
                               ("goal.rotations", goal.rotations, (B, WINDOW, len(KEY_JOINTS), 3, 3)),
                               ("goal.phase", goal.phase, (B, C, 3)), ("goal.hand", goal.hand, (B,)),
                               ("goal_phase", goal_phase, (B, 3 * C))):
        check_shape(value, shape, name)
    if goal.due is not None:
        check_shape(goal.due, (B,), "goal.due")
        check_finite(goal.due, "goal.due")


@torch.inference_mode()  # no autograd bookkeeping at all: about 15 % of a batch-1 step
def controller_step(model: ControllerNet, state: ControllerState, goal: KeyJointGoal, goal_phase: torch.Tensor,
                    blend_radius: float = ControllerConfig.blend_radius,
                    filter_config: Optional[kalman.PhaseFilterConfig] = None):
    """One frame of the controller for ``B`` characters.

    Args:
        state: the characters' :class:`ControllerState` at ``t``.
        goal: their :class:`KeyJointGoal`.
        goal_phase: (B, 3C) the goal phase features fed to the network (Eq. 13 without noise; zeros for ``"none"``).
        blend_radius: metres; the weight of ``G T^inv`` is ``clip(1 − d / blend_radius, 0, 1)``.
        filter_config: the weights of Eq. 22's deviation (``rotation_weight``, ``body_width``) and the phase
            dynamics of Eqs. 15–16 (``dt``, ``phase_blend`` β, the bounds); None: :func:`phase_filter_config`.
    Returns:
        ``(state at t + 1, outputs)``; ``outputs``: ``joints`` (B, 22, 3) and ``wrist`` (B, 2, 3) world
        positions at ``t + 1`` (the body posed by forward kinematics from the predicted rotations, blended half-way
        from the previous frame's, with the pelvis where the predicted joint positions put it),
        ``ego`` / ``goal_centric`` / ``blended`` (B, 7, 4, 9) key-joint trajectories in the root frame of ``t``
        (``goal_centric`` mapped by Eq. 14), ``blend`` (B,), ``deviation`` (B,) ``c`` of Eq. 22,
        ``network_phase`` (B, 3C) the network's predicted next phase (the state's is :func:`phase_update` of it),
        ``goal`` (B, 13, 4, 9) the goal estimate, ``goal_phase_state`` (B, C, 3) its ``[S, A, F]``.
    """
    _check_step_inputs(model, state, goal, goal_phase)
    filter_config = phase_filter_config(model) if filter_config is None else filter_config
    return _step(model, state, goal, goal_phase, blend_radius, filter_config)


def phase_update(current: torch.Tensor, predicted: torch.Tensor, config: kalman.PhaseFilterConfig) -> torch.Tensor:
    """The next phase by Eqs. 15–16, ``X_{t+Δt} = A X_t + B U``, with ``U`` the update that takes ``A X_t`` to the
    network's predicted phase (Eq. 17: the network's control): the phase advances by its frequency and moves a
    fraction ``β`` (``config.phase_blend``) of the way to the predicted one on the circle; the amplitude and the
    frequency are the predicted ones; all within bounds (``kalman.lds_step``). β = 1 gives the prediction back.

    Args:
        current, predicted: (B, 3C) phase features ``(A sin 2πS, A cos 2πS, F)`` (Eq. 13's, without noise).
    Returns:
        (B, 3C) the next phase features.
    """
    x, x_hat = (phase_state(f).double().numpy() for f in (current, predicted))  # (B, C, 3) [S, A, F]
    advanced = x @ kalman.transition_matrix(config.dt).T  # A X_t
    control = x_hat - advanced  # U with B's unit rows for A and F ...
    control[..., kalman.PHASE] = kalman.phase_difference(x_hat[..., kalman.PHASE], advanced[..., kalman.PHASE])
    return goal_phase_features(kalman.lds_step(x, control, config))  # ... and β on the phase's


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
    goal_p, goal_r = in_frame(goal.positions, goal.rotations, state.origin[:, None, None], frame[:, None, None])
    x = torch.cat([state.pose, trajectory.flatten(1), encode_transform(goal_p, goal_r).flatten(1), state.phase, goal_phase,
                   state.keys.flatten(1)], -1)
    y = model(x)
    layout = model.y_layout
    future_shape = (B, len(FUTURE_OFFSETS), len(KEY_JOINTS), TRANSFORM)
    ego = y[:, layout["ego"]].reshape(future_shape)
    inv_p, inv_r = decode_transform(y[:, layout["inv"]].reshape(future_shape))
    centre_p, centre_r = goal_p[:, WINDOW // 2], goal_r[:, WINDOW // 2]  # G per key joint (B, 4, ...)
    mapped_p = (centre_r[:, None] @ inv_p[..., None])[..., 0] + centre_p[:, None]  # Eq. 14: G T^inv
    mapped_r = centre_r[:, None] @ inv_r
    goal_centric = encode_transform(mapped_p, mapped_r)
    deviation = _deviation(*decode_transform(ego), mapped_p, mapped_r, filter_config).mean(-1)
    # blend toward the goal-centric trajectory as the working wrist nears its goal
    wrist_now = state.pose[:, :NUM_JOINTS * 3].reshape(B, NUM_JOINTS, 3)[rows, WRIST_JOINT_INDEX[goal.hand]]
    distance = (wrist_now - goal_p[rows, WINDOW // 2, 2 + goal.hand]).norm(dim=-1)
    blend = (1.0 - distance / blend_radius).clamp(0.0, 1.0)
    blended = (1 - blend[:, None, None, None]) * ego + blend[:, None, None, None] * goal_centric
    # the root moves; the blended trajectories, carried into the next root frame, are the next future root and
    # key-joint trajectories
    update = y[:, layout["root_update"]]
    shift, turn = next_root_frame(update)
    origin = state.origin + (frame[:, :, :2] @ update[:, :2, None])[..., 0]
    heading = wrapped_angle(state.heading + update[:, 2])
    new_frame = rotation_about_z(heading)
    blended_p, blended_r = decode_transform(blended)
    history = torch.cat([state.history[:, 1:], _ground(origin, heading)[:, None]], dim=1)
    # the body posed by FK from the blended local rotations (every bone keeps its length), the velocities predicted
    predicted = y[:, layout["pose"]]
    rotations = blend_rotations_in_frame(state.rotations, y[:, layout["rotations"]], turn)
    pelvis = blend_pose_in_frame(state.pose, predicted, shift, turn)[:, :3]  # the pelvis blended as before
    joints_next = pose_from_rotations(rotations, pelvis, state.offsets)
    pose_next = torch.cat([joints_next.flatten(1), predicted[:, NUM_JOINTS * 3:]], dim=-1)
    next_state = ControllerState(origin, heading, pose_next,
                                 history, carried_root_trajectory(blended_p[:, :, 0], blended_r[:, :, 0], shift, turn),
                                 phase_update(state.phase, y[:, layout["phase"]], filter_config),
                                 carried_key_trajectories(blended_p[:, :, 1:], blended_r[:, :, 1:], shift, turn),
                                 state.offsets, rotations)
    pose = next_state.pose[:, :NUM_JOINTS * 3].reshape(B, NUM_JOINTS, 3)
    world = pose @ new_frame.transpose(-1, -2) + origin[:, None]
    outputs = {"joints": world, "wrist": world[:, WRIST_JOINT_INDEX], "ego": ego, "goal_centric": goal_centric,
               "blended": blended, "blend": blend, "deviation": torch.as_tensor(deviation, dtype=torch.float32),
               "network_phase": y[:, layout["phase"]],
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


def phase_filter_config(model: ControllerNet, **overrides) -> kalman.PhaseFilterConfig:
    """The goal-phase constants of a rollout: ``A_max`` the largest amplitude of the model's training frames
    (``model.phase_amplitude_max``), the rest ``kalman.PhaseFilterConfig``'s unless overridden."""
    return kalman.PhaseFilterConfig(**{"amplitude_max": float(model.phase_amplitude_max), **overrides})


@torch.inference_mode()
def rollout(model: ControllerNet, state: ControllerState, goal: KeyJointGoal, frames: int, variant: str = "kalman",
            blend_radius: float = ControllerConfig.blend_radius,
            filter_config: Optional[kalman.PhaseFilterConfig] = None) -> Rollout:
    """Drive ``B`` characters toward their goals for ``frames`` frames with one goal-phase source (Table 4).

    The matched goal phase of step ``k`` is ``M_k = kalman.goal_phase_at(goal.phase, goal.due − k)``: the matched
    keyframe's phase carried to that frame by Eqs. 15–16, the goal-phase model training's inputs and targets
    follow (``features.clip_features``) and the filter's prediction ``F G^p`` keeps. ``variant``: ``"none"``
    (zeros), ``"matched"`` (``M_k``), ``"predicted"`` (the network's previous ``P̂_g``, starting from ``M_0``) or
    ``"kalman"`` (Algorithm 1: ``kalman.filter_step`` from step ``k`` to ``k + 1`` on the network's ``P̂_g`` with
    ``R_pred = c Q`` and, where ``matched_measurement_active``, ``M_{k+1}`` with ``R = Q``; starting from ``M_0``
    with ``P = 0``). Every source's goal phase is bounded alike (``kalman.constrain``: the amplitude in
    ``[0, A_max]``, the frequency in ``[0, F_m]``), as the filter bounds its own; ``filter_config`` None:
    :func:`phase_filter_config`. Every source but ``"none"`` needs ``goal.due``.
    """
    check_choice(variant, VARIANTS, "variant")
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise ValueError(f"frames: expected a positive int, got {frames!r}")
    filter_config = phase_filter_config(model) if filter_config is None else filter_config
    B = state.origin.shape[0]
    _check_step_inputs(model, state, goal, torch.zeros(B, 3 * model.channels))
    if goal.due is None and variant != "none":
        raise ValueError(f"goal.due: expected (B,) frames to the keyframe for the {variant!r} goal phase, got None")
    keyframe = kalman.constrain(goal.phase.double().numpy(), filter_config)  # (B, C, 3) X^p_g
    matched = None  # (frames + 1, B, C, 3): M_k of every step k, and of the frame after the last
    if goal.due is not None:
        to_keyframe = goal.due.double().numpy()[None, :, None] - np.arange(frames + 1)[:, None, None]  # g − k
        matched = kalman.goal_phase_at(keyframe, to_keyframe, filter_config)
    estimate = None if matched is None else matched[0]
    covariance = np.zeros(keyframe.shape + (3,))
    variance = model.phase_variance.double().numpy()
    centre = goal.positions[:, WINDOW // 2]
    root_goal, hand_goal = centre[:, 0, :2].double().numpy(), centre[torch.arange(B), 2 + goal.hand].double().numpy()
    records = []
    for k in range(frames):
        if variant == "none":
            fed = torch.zeros(B, 3 * model.channels)
        else:
            fed = goal_phase_features(matched[k] if variant == "matched" else estimate)
        state, out = _step(model, state, goal, fed, blend_radius, filter_config)
        predicted = out["goal_phase_state"].double().numpy()
        if variant == "predicted":
            estimate = kalman.constrain(predicted, filter_config)
        elif variant == "kalman":
            check_finite(predicted, "the network's goal phase")  # a blown-up step stops here, not in the filter
            hand = out["wrist"][torch.arange(B), goal.hand]
            # float64 arrays of the shapes checked before the loop, the deviation ≥ 0 by construction: unchecked
            active = kalman.matched_measurement_active(state.origin[:, :2].double().numpy(), root_goal,
                                                       hand.double().numpy(), hand_goal, filter_config, check=False)
            estimate, covariance = kalman.filter_step(estimate, covariance, variance, predicted,
                                                      out["deviation"].double().numpy()[:, None], filter_config,
                                                      matched_goal=matched[k + 1], use_matched=active[:, None],
                                                      check=False)
        records.append((out["joints"], out["wrist"], state.origin, fed, out["goal_phase_state"], out["deviation"]))
    joints, wrist, origin, fed, predicted, deviation = (torch.stack(v) for v in zip(*records))
    return Rollout(joints, wrist, origin, fed, predicted, deviation, state)


def step_timing(model: ControllerNet, state: ControllerState, goal: KeyJointGoal, steps: int = 300,
                variant: str = "kalman") -> dict:
    """What one run-time step costs against the network alone, on this machine and its current torch threads.

    Three timings of ``steps`` frames each, after a 20-frame warm-up: a :func:`rollout` (the whole step: network,
    forward kinematics, Eq. 14's blend, Eq. 22's deviation, Eqs. 15–16, the filter of ``variant``); the same rollout
    with a timer around each forward (the network inside the step); the network's forward alone, one after another
    on a zero input. A measurement, never a gate (``scripts/bench_choice_controller.py`` prints it).

    Returns:
        ``{"step_ms", "network_ms", "network_in_step_ms", "steps_per_second", "ratio", "ratio_in_step"}``: the
        milliseconds per frame, the whole step's frames a second, and the step over the network alone and over
        the network inside the step.
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"steps: expected a positive int, got {steps!r}")
    rollout(model, state, goal, 20, variant)  # warm-up
    clock = time.perf_counter()
    rollout(model, state, goal, steps, variant)
    step = (time.perf_counter() - clock) / steps
    inside = []

    def timed(x, forward=model.forward):
        t = time.perf_counter()
        y = forward(x)
        inside.append(time.perf_counter() - t)
        return y

    model.forward = timed  # an instance attribute: nn.Module's __call__ finds it first
    try:
        rollout(model, state, goal, steps, variant)
    finally:
        del model.forward
    x = torch.zeros(state.origin.shape[0], model.in_size)
    with torch.inference_mode():
        clock = time.perf_counter()
        for _ in range(steps):
            model(x)
        network = (time.perf_counter() - clock) / steps
    in_step = sum(inside) / steps
    return {"step_ms": 1e3 * step, "network_ms": 1e3 * network, "network_in_step_ms": 1e3 * in_step,
            "steps_per_second": 1.0 / step, "ratio": step / network, "ratio_in_step": step / in_step}
