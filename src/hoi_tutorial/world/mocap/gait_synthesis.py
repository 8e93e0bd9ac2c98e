"""Gait synthesis: a root plan and a footstep plan turned into a labelled ``Motion`` — pelvis
bob, sway, lean and twist, the pelvis lowered where a leg could not reach, swinging legs folded
towards the hip, counter-rotating spine, swinging arms, a steady head, and exact two-bone IK on
the ankle targets (see the ``gait`` module docstring).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d, maximum_filter1d

from ..._validate import check_finite
from ..kinematics import forward_kinematics, solve_limb_ik
from ..motion import CONTACT_JOINTS, FPS, Motion
from ..rotations import axis_angle_to_matrix, matrix_to_axis_angle
from ..skeleton import NUM_JOINTS, joint_index
from .footsteps import Footstep, foot_track
from .gait_body import SIDES, SIDE_JOINTS, SIDE_SIGN, GaitBody
from .gait_params import GaitParams, GaitStyle
from .motion_math import forward_xy, right_xy, rot_x, rot_y, rot_z, smoothstep
from .poses import ARM_DOWN_ANGLE

__all__ = ["RootPlan", "synthesize"]

_CONTACT_COLUMN = {side: CONTACT_JOINTS.index(f"{side}_foot") for side in SIDES}
_SPINE = [joint_index(n) for n in ("spine1", "spine2", "spine3")]
_NECK, _HEAD = joint_index("neck"), joint_index("head")

# Fraction of the full hip-to-ankle length a leg may reach: knees always keep a slight bend.
_REACH = 0.995
_SWING_REACH = 0.985
# Standing, the pelvis sits this much below its straight-legged rest height (knees unlocked).
_STAND_DROP = 0.004


@dataclass
class RootPlan:
    """Root (pelvis ground point) trajectory sampled at the clip's frames."""

    times: np.ndarray       # (T,) seconds
    xy: np.ndarray          # (T, 2) metres
    yaw: np.ndarray         # (T,) radians
    envelope: np.ndarray    # (T,) 0..1, how much of the gait's style is expressed


# --------------------------------------------------------------------------- the synthesiser

def _step_phase(times: np.ndarray, touch_downs: list[float]):
    """Phase in [0, 1) since the last touch-down, and a validity mask (between two touch-downs)."""
    td = np.sort(np.asarray(touch_downs, dtype=np.float64))
    phase = np.zeros_like(times)
    valid = np.zeros(times.shape, dtype=bool)
    if len(td) < 2:
        return phase, valid
    idx = np.searchsorted(td, times, side="right") - 1
    inside = (idx >= 0) & (idx < len(td) - 1)
    i = idx[inside]
    phase[inside] = (times[inside] - td[i]) / (td[i + 1] - td[i])
    valid[inside] = True
    return phase, valid


def _highest_pelvis(ankle: np.ndarray, pelvis_xy: np.ndarray, hip_offset: np.ndarray, reach: float) -> np.ndarray:
    """Highest pelvis ``(T,)`` from which a hip (``hip_offset (T, 3)`` from the pelvis) reaches ``ankle (T, 3)``."""
    d_h = np.linalg.norm(ankle[:, :2] - pelvis_xy - hip_offset[:, :2], axis=1)
    vertical = np.sqrt(np.clip(reach**2 - d_h**2, (0.3 * reach) ** 2, None))
    return ankle[:, 2] + vertical - hip_offset[:, 2]


def _fold_swing(ankle: np.ndarray, fold: np.ndarray, hip: np.ndarray, leg: float) -> np.ndarray:
    """Swing ankle targets ``(T, 3)`` drawn towards the hip where they are nearly out of reach.

    The hip-ankle distance saturates smoothly between 0.93 and ``_SWING_REACH`` leg lengths; the
    ``fold (T,)`` weight eases this in and out over the swing, so lift-off and touch-down are
    continuous. Drawing the ankle towards the (higher) hip bends the knee and lifts the foot.
    """
    dist = np.linalg.norm(ankle - hip, axis=1)
    soft, hard = 0.93 * leg, _SWING_REACH * leg
    sat = np.where(dist > soft, soft + (hard - soft) * np.tanh((dist - soft) / (hard - soft)), dist)
    scale = (dist + fold * (sat - dist)) / np.maximum(dist, 1e-9)
    return hip + (ankle - hip) * scale[:, None]


def _highest_swing_pelvis(ankle, fold, pelvis_xy, hip_offset, leg: float, z_high: np.ndarray) -> np.ndarray:
    """Highest pelvis ``(T,)`` (at most ``z_high``) at which the folded swing ankle is within reach.

    ``inf`` where ``z_high`` is fine; found by bisection over 40 cm below ``z_high``.
    """
    def reachable(z):
        hip = np.concatenate([pelvis_xy, z[:, None]], -1) + hip_offset
        return np.linalg.norm(_fold_swing(ankle, fold, hip, leg) - hip, axis=1) <= _REACH * leg

    high = z_high.copy()
    low = z_high - 0.4
    fine = reachable(high)
    for _ in range(14):
        mid = 0.5 * (low + high)
        ok = reachable(mid)
        low = np.where(ok, mid, low)
        high = np.where(ok, high, mid)
    return np.where(fine, np.inf, low)


def _lower_smoothly(z_desired: np.ndarray, z_max: np.ndarray) -> np.ndarray:
    """``min(z_desired, z_max)`` with the lowering spread smoothly over a few frames (never less)."""
    penalty = np.clip(z_desired - z_max, 0.0, None)
    smooth = gaussian_filter1d(maximum_filter1d(penalty, size=5, mode="nearest"), 1.5, mode="nearest")
    return z_desired - np.maximum(penalty, smooth)


def synthesize(body: GaitBody, root: RootPlan, steps: list[Footstep], params: GaitParams, style: GaitStyle,
               step_period: float, stride: float, actions: np.ndarray, start=None, meta=None,
               extra_sway: Optional[np.ndarray] = None) -> Motion:
    """Turn a root plan and a footstep plan into a labelled ``Motion`` (see the module docstring)."""
    times = root.times
    T = len(times)
    env = root.envelope
    tracks = {side: foot_track(body, side, steps, times, style.swing_height, params.heel_off_fraction,
                               style.toe_up * float(np.max(env, initial=0.0)), 2.0 * step_period * params.duty)
              for side in SIDES}
    sigma = 0.07 * FPS

    # Per-frame feet in the root frame: forward and lateral offsets of the ankles.
    fwd, right = forward_xy(root.yaw), right_xy(root.yaw)
    rel = {side: tracks[side][0][:, :2] - root.xy for side in SIDES}
    ahead = {side: np.einsum("ti,ti->t", rel[side], fwd) for side in SIDES}
    lateral = {side: np.einsum("ti,ti->t", rel[side], right) for side in SIDES}

    # Leg-phase signal: +1 when the left foot is a full step ahead of the right.
    leg_signal = (ahead["left"] - ahead["right"]) / max(stride, 0.3)
    leg_signal = gaussian_filter1d(np.clip(leg_signal, -1.3, 1.3), 2.0, mode="nearest")
    arm_signal = np.concatenate([leg_signal[:1], leg_signal[:-1]])  # arms trail the legs a little

    # Lateral sway towards the supporting foot (or feet).
    support = np.full(T, np.nan)
    for f in range(T):
        lat = [lateral[s][f] for s in SIDES if tracks[s][2][f]]
        if lat:
            support[f] = np.mean(lat)
    if np.all(np.isnan(support)):
        support[:] = 0.0
    good = ~np.isnan(support)
    support = np.interp(np.arange(T), np.flatnonzero(good), support[good])
    rest_mid = 0.5 * (body.stand_ankle["left"][0] + body.stand_ankle["right"][0])
    sway = style.sway * gaussian_filter1d(support - rest_mid, sigma, mode="nearest")
    if extra_sway is not None:
        sway = sway + extra_sway
    pelvis_xy = root.xy + sway[:, None] * right

    # Pelvis orientation: heading, a twist that brings the forward leg's hip forward, a lean.
    pelvis_yaw = root.yaw - style.pelvis_twist * leg_signal
    pelvis_pitch = 0.6 * style.lean * env
    spine_pitch = 0.4 * style.lean * env
    g_pelvis = rot_z(pelvis_yaw) @ rot_x(-pelvis_pitch)

    # Pelvis height: nominal drop and bob, then lowered wherever a leg cannot reach its ankle.
    phase, valid = _step_phase(times, [s.start for s in steps if math.isfinite(s.start)])
    # Phase (in step periods after touch-down) at which the pelvis passes over the stance ankle.
    if params.duty < 1:
        travel = 2.0 * params.duty * max(stride, 1e-3)
        mid_stance = 2.0 * params.duty * (params.over_foot + body.stand_ankle_forward / travel)
    else:
        mid_stance = 0.5
    wave = np.where(valid, np.cos(2 * np.pi * (phase - mid_stance)), 0.0)
    bob = style.bob * env * (-wave if params.spring else wave)
    z_des = body.stand_height - _STAND_DROP - style.drop * env + gaussian_filter1d(bob, 1.0, mode="nearest")
    # Feet on the ground hold the pelvis down (the pelvis is lowered where a stance leg would
    # over-extend); a swinging leg folds towards the hip instead, and only where it cannot fold
    # (just after lift-off, just before touch-down) does it lower the pelvis too.
    hip_off = {side: g_pelvis @ body.hip[side] for side in SIDES}  # (T, 3) each
    z_max = np.full(T, np.inf)
    for side in SIDES:
        ankle, _, contact, fold = tracks[side]
        leg = body.leg_length[side]
        stance_limit = _highest_pelvis(ankle, pelvis_xy, hip_off[side], _REACH * leg)
        swing_limit = _highest_swing_pelvis(ankle, fold, pelvis_xy, hip_off[side], leg, z_des)
        z_max = np.minimum(z_max, np.where(contact, stance_limit, swing_limit))
    pelvis_z = _lower_smoothly(z_des, z_max)
    root_pos = np.concatenate([pelvis_xy, pelvis_z[:, None]], -1)
    for side in SIDES:
        ankle, rot, contact, fold = tracks[side]
        folded = _fold_swing(ankle, fold, root_pos + hip_off[side], body.leg_length[side])
        tracks[side] = (folded, rot, contact, fold)

    # Local rotations.
    local = np.tile(np.eye(3), (T, NUM_JOINTS, 1, 1))
    local[:, 0] = g_pelvis
    spine_yaw = (style.pelvis_twist + style.shoulder_twist) * leg_signal / 3.0
    breath = style.noise.get("breath", np.zeros(T))
    for k, j in enumerate(_SPINE):
        local[:, j] = rot_z(spine_yaw) @ rot_x(-(spine_pitch / 3.0 + (breath if k == 2 else 0.0)))
    g_neck = g_pelvis
    for j in _SPINE + [_NECK]:
        g_neck = g_neck @ local[:, j]
    head_yaw = root.yaw + style.noise.get("head_yaw", np.zeros(T))
    head_goal = rot_z(head_yaw) @ rot_x(-np.full(T, style.head_pitch))
    correction = torch.from_numpy(np.swapaxes(g_neck, -1, -2) @ head_goal)
    half = axis_angle_to_matrix(0.5 * matrix_to_axis_angle(correction)).numpy()
    local[:, _NECK] = half
    local[:, _HEAD] = half

    arm = style.arm_swing * arm_signal
    drift = style.noise.get("arms", np.zeros((T, 2)))
    for side in SIDES:
        swing = (-arm if side == "left" else arm) + drift[:, 0 if side == "left" else 1]
        down = rot_y(np.full(T, SIDE_SIGN[side] * ARM_DOWN_ANGLE))
        local[:, SIDE_JOINTS[side]["shoulder"]] = rot_x(swing) @ down
        # The elbow flexes a little more as the arm swings forward (not for an idle arm's drift).
        extra = min(0.5 * style.elbow, math.radians(15.0)) if style.arm_swing > 0 else 0.0
        bend = style.elbow + extra * np.clip(swing / max(style.arm_swing, 1e-6), 0.0, 1.0)
        local[:, SIDE_JOINTS[side]["elbow"]] = rot_z(SIDE_SIGN[side] * bend)

    local_t = torch.from_numpy(local)
    root_t = torch.from_numpy(root_pos)
    if start is not None:
        local_t, root_t = _blend_from(start, local_t, root_t)

    # Legs: exact IK on the ankle targets, knees bending towards the foot's forward direction.
    # Solved after the start blend, so planted feet stay exact while the body eases in.
    offsets = body.offsets_torch.double()
    for side in SIDES:
        target = torch.from_numpy(tracks[side][0])
        foot_fwd = tracks[side][1][:, :, 1].copy()
        foot_fwd[:, 2] = 0.0
        pole = torch.from_numpy(foot_fwd / np.linalg.norm(foot_fwd, axis=1, keepdims=True).clip(1e-9))
        local_t = solve_limb_ik(local_t, root_t, f"{side}_leg", target, pole, offsets)
    glob, _ = forward_kinematics(local_t, root_t, offsets)
    for side in SIDES:
        knee = glob[:, SIDE_JOINTS[side]["knee"]]
        local_t[:, SIDE_JOINTS[side]["ankle"]] = knee.transpose(-1, -2) @ torch.from_numpy(tracks[side][1])

    contacts = np.zeros((T, len(CONTACT_JOINTS)), dtype=bool)
    for side in SIDES:
        contacts[:, _CONTACT_COLUMN[side]] = tracks[side][2]
    motion = Motion(local_rotations=local_t.float(), root_position=root_t.float(), betas=body.betas,
                    fps=FPS, actions=actions, contacts=contacts, meta=dict(meta or {}))
    check_finite(motion.local_rotations, "local_rotations")
    return motion


def _blend_from(start, local_t: torch.Tensor, root_t: torch.Tensor, seconds: float = 0.3):
    """Ease the first frames from the ``start`` pose into the generated ones (frame 0 == start)."""
    start_local, start_root = start
    n = min(len(local_t), max(2, int(round(seconds * FPS))))
    w = torch.from_numpy(1.0 - smoothstep(np.arange(n) / (n - 1)))
    gen = local_t[:n]
    rel = matrix_to_axis_angle(gen.transpose(-1, -2) @ start_local.double()[None].expand_as(gen))
    local_t = local_t.clone()
    local_t[:n] = gen @ axis_angle_to_matrix(rel * w[:, None, None])
    root_t = root_t.clone()
    root_t[:n] = root_t[:n] + (start_root.double()[None] - root_t[:n]) * w[:, None]
    return local_t, root_t
