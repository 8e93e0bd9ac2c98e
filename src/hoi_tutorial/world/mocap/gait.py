"""Procedural locomotion for the toy mocap: idle, walk, run, turn in place and side steps.

Every clip is built the same way, the way a procedural animation system builds it:

1. a *root plan*: where the pelvis is on the ground and which way it faces at every time: a
   smooth path through waypoints walked at a cruise speed (slower in tight bends, with smooth
   starts and stops; optionally turning towards a final heading over the last steps), a turn on
   the spot, a lateral shift, or standing;
2. a *footstep plan*: feet alternate at a fixed cadence; each step lands beside where the root
   will be a set fraction of the way through the step's stance, half a step width to the side,
   turned with the root's heading. A foot in stance is exactly fixed on the ground: its ball
   (the ``*_foot`` joint, at height ``skeleton.FOOT_JOINT_HEIGHT``) and its yaw do not change from
   touch-down to lift-off; late in stance the heel rolls up about that fixed ball, so
   ground-truth foot skating stays ≈ 0;
3. a *swing*: between two stances the ankle rises, travels on a minimum-jerk curve and sets down;
4. the *body*: the pelvis follows the root with a vertical bob (highest over the stance foot when
   walking, lowest there when running), a sway towards the supporting foot and a forward lean;
   the spine counter-rotates, the arms swing opposite to the legs, the head looks along the
   heading. The legs are posed by exact two-bone IK on the ankle targets with the knees bending
   forward. The pelvis is lowered wherever a stance leg would otherwise over-extend, and a
   swinging leg folds (its ankle is drawn towards the hip) instead of straightening.

Styles are stochastic through ``seed`` (speed, step length, arm swing, bob, lean, sway, swing
height, heel roll); the body shape ``betas`` is the caller's (default: the mean body). All clips
run at 30 fps and carry action labels ("idle", "walk", "run", "turn", "side_step") and foot
contact labels (``Motion.contacts[:, 1]`` left foot, ``[:, 2]`` right foot).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import torch
from scipy.ndimage import gaussian_filter1d, maximum_filter1d

from ...infra.device import single_threaded
from ..._validate import as_tensor, check_choice, check_finite, check_shape
from ..kinematics import forward_kinematics, solve_limb_ik
from ..motion import CONTACT_JOINTS, FPS, Motion, action_id
from ..rotations import axis_angle_to_matrix, matrix_to_axis_angle, yaw_of_matrix
from ..skeleton import FOOT_JOINT_HEIGHT, NUM_BETAS, NUM_JOINTS, bone_offsets, joint_index, rest_pelvis_height
from .poses import ARM_DOWN_ANGLE, standing_pose

__all__ = [
    "GAITS",
    "walk_path",
    "idle",
    "turn_in_place",
    "side_step",
    "footstep_plan",
    "Footstep",
    "path_from_waypoints",
]

SIDES = ("left", "right")
_J = {side: {part: joint_index(f"{side}_{part}") for part in ("hip", "knee", "ankle", "foot", "shoulder", "elbow")}
      for side in SIDES}
_SIGN = {"left": -1.0, "right": 1.0}  # +X is the character's right
_CONTACT_COLUMN = {side: CONTACT_JOINTS.index(f"{side}_foot") for side in SIDES}
_SPINE = [joint_index(n) for n in ("spine1", "spine2", "spine3")]
_NECK, _HEAD = joint_index("neck"), joint_index("head")

# Fraction of the full hip-to-ankle length a leg may reach: knees always keep a slight bend.
_REACH = 0.995
_SWING_REACH = 0.985
# Standing, the pelvis sits this much below its straight-legged rest height (knees unlocked).
_STAND_DROP = 0.004


@dataclass(frozen=True)
class GaitParams:
    """Ranges of one gait's style parameters; each clip draws its style from them.

    Lengths in metres, angles in radians, speeds in m/s. ``step_ratio`` gives the step length
    as a fraction of the hip height ``l``: ``L = l * (a + b * speed)``.
    """

    speed: tuple[float, float]
    step_ratio: tuple[float, float]
    duty: float                      # fraction of a stride each foot spends on the ground
    over_foot: float                 # fraction of stance at which the root passes over its standing spot
    half_width: float                # lateral ankle offset from the root while moving
    swing_height: tuple[float, float]
    heel_off: tuple[float, float]    # heel pitch at lift-off
    heel_off_fraction: float         # last fraction of stance spent rolling the heel up
    arm_swing: tuple[float, float]
    elbow: tuple[float, float]
    bob: tuple[float, float]
    drop: tuple[float, float]        # mean pelvis lowering at cruise speed
    lean: tuple[float, float]
    sway: tuple[float, float]        # share of the stance foot's lateral offset the pelvis takes
    pelvis_twist: tuple[float, float]
    accel_time: float                # seconds to reach 1 m/s (ramps scale with speed)
    spring: bool                     # True: pelvis lowest at mid-stance (running)
    lateral_accel: float = 1.5       # m/s² allowed in bends (sets the cornering speed)
    min_turn_speed: float = 0.3      # m/s, the slowest a bend makes the walker


GAITS: dict[str, GaitParams] = {
    "walk": GaitParams(
        speed=(0.9, 1.5), step_ratio=(0.27, 0.38), duty=0.62, over_foot=0.47, half_width=0.075,
        swing_height=(0.05, 0.09), heel_off=(math.radians(26), math.radians(32)), heel_off_fraction=0.4,
        arm_swing=(math.radians(12), math.radians(22)), elbow=(math.radians(12), math.radians(25)),
        bob=(0.012, 0.022), drop=(0.01, 0.02), lean=(math.radians(1), math.radians(4)),
        sway=(0.25, 0.4), pelvis_twist=(math.radians(3), math.radians(6)), accel_time=0.55, spring=False,
    ),
    "run": GaitParams(
        speed=(2.4, 3.4), step_ratio=(0.23, 0.32), duty=0.36, over_foot=0.5, half_width=0.05,
        swing_height=(0.16, 0.24), heel_off=(math.radians(25), math.radians(32)), heel_off_fraction=0.5,
        arm_swing=(math.radians(30), math.radians(45)), elbow=(math.radians(75), math.radians(95)),
        bob=(0.02, 0.035), drop=(0.03, 0.05), lean=(math.radians(6), math.radians(11)),
        sway=(0.15, 0.25), pelvis_twist=(math.radians(5), math.radians(9)), accel_time=0.45, spring=True,
        lateral_accel=4.0, min_turn_speed=1.0,
    ),
}

# Slow stepping gaits (no root speed range: the root plan sets the motion).
_TURN = GaitParams(
    speed=(0.0, 0.0), step_ratio=(0.0, 0.0), duty=0.7, over_foot=0.5, half_width=0.09,
    swing_height=(0.04, 0.07), heel_off=(0.0, 0.0), heel_off_fraction=0.0,
    arm_swing=(math.radians(3), math.radians(6)), elbow=(math.radians(10), math.radians(18)),
    bob=(0.0, 0.0), drop=(0.005, 0.015), lean=(0.0, math.radians(2)),
    sway=(0.25, 0.4), pelvis_twist=(0.0, 0.0), accel_time=0.0, spring=False,
)
_SIDE = GaitParams(
    speed=(0.25, 0.35), step_ratio=(0.0, 0.0), duty=0.7, over_foot=0.5, half_width=0.14,
    swing_height=(0.04, 0.07), heel_off=(0.0, 0.0), heel_off_fraction=0.0,
    arm_swing=(math.radians(2), math.radians(5)), elbow=(math.radians(10), math.radians(18)),
    bob=(0.0, 0.0), drop=(0.01, 0.02), lean=(0.0, math.radians(2)),
    sway=(0.3, 0.45), pelvis_twist=(0.0, 0.0), accel_time=1.2, spring=False,
)
_IDLE = GaitParams(
    speed=(0.0, 0.0), step_ratio=(0.0, 0.0), duty=1.0, over_foot=0.5, half_width=0.09,
    swing_height=(0.0, 0.0), heel_off=(0.0, 0.0), heel_off_fraction=0.0,
    arm_swing=(0.0, 0.0), elbow=(math.radians(8), math.radians(18)),
    bob=(0.0, 0.0), drop=(0.0, 0.0), lean=(0.0, math.radians(1.5)),
    sway=(0.0, 0.0), pelvis_twist=(0.0, 0.0), accel_time=0.0, spring=False,
)


# --------------------------------------------------------------------------- small helpers

def _rng(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed: expected an int or numpy.random.Generator, got {type(seed).__name__}")
    return np.random.default_rng(int(seed))


def _wrap(angle):
    """Angle(s) wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _min_jerk(x):
    """Minimum-jerk blend 10x^3 - 15x^4 + 6x^5: zero velocity and acceleration at both ends."""
    x = np.clip(x, 0.0, 1.0)
    return x**3 * (10.0 + x * (-15.0 + 6.0 * x))


def _rot_z(yaw):
    """``(...)`` radians -> ``(..., 3, 3)`` numpy rotations about +Z."""
    yaw = np.asarray(yaw, dtype=np.float64)
    c, s = np.cos(yaw), np.sin(yaw)
    o, z = np.ones_like(yaw), np.zeros_like(yaw)
    return np.stack([c, -s, z, s, c, z, z, z, o], -1).reshape(yaw.shape + (3, 3))


def _rot_x(angle):
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(angle), np.zeros_like(angle)
    return np.stack([o, z, z, z, c, -s, z, s, c], -1).reshape(angle.shape + (3, 3))


def _rot_y(angle):
    angle = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    o, z = np.ones_like(angle), np.zeros_like(angle)
    return np.stack([c, z, s, z, o, z, -s, z, c], -1).reshape(angle.shape + (3, 3))


def _forward(yaw):
    """Ground direction ``(..., 2)`` a heading faces (heading 0 faces +Y)."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([-np.sin(yaw), np.cos(yaw)], -1)


def _right(yaw):
    """The character's right ``(..., 2)`` on the ground for a heading."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([np.cos(yaw), np.sin(yaw)], -1)


def _smooth_noise(rng: np.random.Generator, times: np.ndarray, amplitude: float, periods=(2.0, 6.0), terms: int = 4):
    """Sum of a few sinusoids of random period and phase: slow, smooth drift ``(T,)`` of RMS ``amplitude``."""
    out = np.zeros_like(times)
    for _ in range(terms):
        period = rng.uniform(*periods)
        out += np.sin(2 * np.pi * times / period + rng.uniform(0, 2 * np.pi))
    return amplitude * out * math.sqrt(2.0 / terms)


# --------------------------------------------------------------------------- body geometry

class _Body:
    """Rest geometry of one body shape, in numpy float64."""

    def __init__(self, betas):
        self.betas = torch.zeros(NUM_BETAS) if betas is None else as_tensor(betas, "betas").clone()
        check_shape(self.betas, (NUM_BETAS,), "betas")
        check_finite(self.betas, "betas")
        self.offsets_torch = bone_offsets(self.betas)
        off = self.offsets_torch.double().numpy()
        self.offsets = off
        self.stand_height = float(rest_pelvis_height(self.betas))
        self.hip, self.leg_length, self.foot, self.stand_ankle, self.flat_ankle_height = {}, {}, {}, {}, {}
        for side in SIDES:
            j = _J[side]
            self.hip[side] = off[j["hip"]]
            self.leg_length[side] = float(np.linalg.norm(off[j["knee"]]) + np.linalg.norm(off[j["ankle"]]))
            self.foot[side] = off[j["foot"]]  # ankle -> ball with a flat foot facing +Y
            chain = off[j["hip"]] + off[j["knee"]] + off[j["ankle"]]
            self.stand_ankle[side] = chain[:2]
            self.flat_ankle_height[side] = FOOT_JOINT_HEIGHT - off[j["foot"], 2]
        self.stand_ankle_forward = 0.5 * float(self.stand_ankle["left"][1] + self.stand_ankle["right"][1])
        self.hip_height = self.stand_height + 0.5 * (self.hip["left"][2] + self.hip["right"][2])

    def ankle_from_ball(self, side, ball, yaw, pitch):
        """Ankle position ``(..., 3)`` and orientation ``(..., 3, 3)`` for a foot whose ball is at ``ball``."""
        rot = _rot_z(yaw) @ _rot_x(-np.asarray(pitch))  # positive pitch lifts the heel
        return ball - rot @ self.foot[side], rot

    def ball_from_ankle_xy(self, side, ankle_xy, yaw):
        """Ball ground position ``(2,)`` of a flat foot whose ankle is above ``ankle_xy``."""
        return ankle_xy + (_rot_z(yaw) @ self.foot[side])[:2]


# --------------------------------------------------------------------------- paths

@dataclass
class _Path:
    """A smooth ground path sampled by arc length (every ~1 cm)."""

    arc: np.ndarray       # (N,) metres
    points: np.ndarray    # (N, 2) metres
    heading: np.ndarray   # (N,) radians, unwrapped

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    def at(self, s):
        """Position ``(..., 2)`` and heading ``(...)`` at arc length(s) ``s``."""
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        xy = np.stack([np.interp(s, self.arc, self.points[:, 0]), np.interp(s, self.arc, self.points[:, 1])], -1)
        return xy, np.interp(s, self.arc, self.heading)


def path_from_waypoints(waypoints, spacing: float = 0.01) -> _Path:
    """Centripetal Catmull-Rom curve through ``waypoints (K, 2)`` metres, resampled by arc length.

    Returns an object with ``arc (N,)``, ``points (N, 2)``, ``heading (N,)`` (radians, heading 0
    faces +Y) and ``at(s)`` giving position and heading at arc length ``s``.
    """
    pts = np.asarray(waypoints, dtype=np.float64)
    check_shape(pts, (None, 2), "waypoints")
    check_finite(pts, "waypoints")
    if len(pts) < 2:
        raise ValueError(f"waypoints: expected at least 2 points, got {len(pts)}")
    keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-6])
    pts = pts[keep]
    if len(pts) < 2:
        raise ValueError("waypoints: expected at least two distinct points")
    ext = np.concatenate([2 * pts[:1] - pts[1:2], pts, 2 * pts[-1:] - pts[-2:-1]])
    dense = [pts[:1]]
    for i in range(1, len(ext) - 2):
        p0, p1, p2, p3 = ext[i - 1], ext[i], ext[i + 1], ext[i + 2]
        # Centripetal knots (alpha = 1/2) avoid cusps and self-intersections inside a segment.
        t0 = 0.0
        t1 = t0 + max(np.linalg.norm(p1 - p0), 1e-6) ** 0.5
        t2 = t1 + max(np.linalg.norm(p2 - p1), 1e-6) ** 0.5
        t3 = t2 + max(np.linalg.norm(p3 - p2), 1e-6) ** 0.5
        n = max(8, int(np.linalg.norm(p2 - p1) / 0.004))
        t = np.linspace(t1, t2, n + 1)[1:, None]
        a1 = (t1 - t) / (t1 - t0) * p0 + (t - t0) / (t1 - t0) * p1
        a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2
        a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3
        b1 = (t2 - t) / (t2 - t0) * a1 + (t - t0) / (t2 - t0) * a2
        b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3
        dense.append((t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2)
    dense = np.concatenate(dense)
    seg = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    arc_dense = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(2, int(math.ceil(arc_dense[-1] / spacing)) + 1)
    arc = np.linspace(0.0, arc_dense[-1], n)
    points = np.stack([np.interp(arc, arc_dense, dense[:, 0]), np.interp(arc, arc_dense, dense[:, 1])], -1)
    tangent = np.gradient(points, axis=0)
    heading = np.unwrap(np.arctan2(-tangent[:, 0], tangent[:, 1]))
    return _Path(arc=arc, points=points, heading=heading)


# --------------------------------------------------------------------------- footstep plans

@dataclass
class Footstep:
    """One stance of one foot: the ball of the foot is fixed at ``ball`` with yaw ``yaw``.

    Attributes:
        side: ``"left"`` or ``"right"``.
        start, end: touch-down and lift-off times, seconds (``-inf`` / ``inf`` when the stance
            starts before or lasts beyond the clip).
        ball: ``(2,)`` ground position of the ``*_foot`` joint, metres (its height is
            ``skeleton.FOOT_JOINT_HEIGHT``).
        yaw: foot heading, radians.
        heel_off: heel pitch reached at lift-off, radians (the heel rolls up about the ball).
    """

    side: str
    start: float
    end: float
    ball: np.ndarray
    yaw: float
    heel_off: float = 0.0


@dataclass
class _RootPlan:
    """Root (pelvis ground point) trajectory sampled at the clip's frames."""

    times: np.ndarray       # (T,) seconds
    xy: np.ndarray          # (T, 2) metres
    yaw: np.ndarray         # (T,) radians
    envelope: np.ndarray    # (T,) 0..1, how much of the gait's style is expressed


def footstep_plan(root_at, stop_time: float, *, initial: dict, first_side: str, step_period: float,
                  duty: float, half_width: float, over_foot: float = 0.5, forward_offset: float = 0.0,
                  betas=None, first_lift_off: float = 0.2, min_step: float = 0.03,
                  max_steps: int = 400) -> list[Footstep]:
    """Alternating footsteps that follow a root trajectory.

    Step ``i`` touches down at ``t_i = t_0 + i * step_period`` and stays for
    ``2 * step_period * duty`` seconds. Its ankle lands beside the root's position at
    ``t_i + over_foot * stance`` (``half_width`` to the side, ``forward_offset`` ahead, turned with
    the root's heading), so the root passes over the foot ``over_foot`` of the way through the
    stance. Steps placed after ``stop_time`` land in the standing stance around the final root;
    steps that would move a foot less than ``min_step`` (and turn it less than 6°) are not taken.
    Planning ends once both feet stand in their final places.

    Args:
        root_at: callable ``t -> (xy (2,), yaw)`` giving the root's ground position (metres) and
            heading (radians) at time ``t`` seconds.
        stop_time: seconds after which the root stands still.
        initial: ``{"left": (ball (2,), yaw), "right": (ball (2,), yaw)}`` feet at the start.
        first_side: the foot that steps first.
        step_period: seconds between touch-downs (inverse cadence).
        duty: stance fraction of a stride, in (0, 1).
        half_width: lateral ankle offset from the root while moving, metres.
        over_foot: fraction of the stance at which the root passes over the foot's spot
            (walking ≈ 0.47: the foot lands closer in front than it leaves behind, as the heel
            rolls up late in stance).
        forward_offset: fore-aft ankle offset from the root, metres (the standing pose's,
            ``-5.7 cm`` for the mean body, keeps stepping feet where standing feet are).
        betas: ``(10,)`` body shape or None.
        first_lift_off: time the first foot leaves the ground, seconds.
        min_step: smallest step taken, metres.
        max_steps: planning stops after this many steps.
    Returns:
        ``Footstep`` list, per foot in time order, the initial stance of each foot first.
    """
    return _plan_footsteps(root_at, stop_time, initial=initial, first_side=first_side, step_period=step_period,
                           duty=duty, half_width=half_width, over_foot=over_foot, forward_offset=forward_offset,
                           body=_Body(betas), first_lift_off=first_lift_off, min_step=min_step,
                           max_steps=max_steps)


def _plan_footsteps(root_at, stop_time: float, *, initial: dict, first_side: str, step_period: float,
                    duty: float, half_width: float, over_foot: float, forward_offset: float, body: _Body,
                    first_lift_off: float = 0.2, min_step: float = 0.03, max_steps: int = 400,
                    min_gap: Optional[float] = None, settle_step: Optional[float] = None) -> list[Footstep]:
    """:func:`footstep_plan` for a body whose rest geometry is already computed.

    ``min_gap``: when given, a foot lands at least this far (metres) to its own side of the
    other, planted foot, measured across the root's heading (turning steps that move the body
    sideways would otherwise cross the legs). ``settle_step``: when given, a final step (one
    that brings a foot to the standing stance) is taken only when it moves the foot at least
    this far (metres) or turns it by 12° or more.
    """
    check_choice(first_side, SIDES, "first_side")
    if not 0.0 < duty < 1.0:
        raise ValueError(f"duty: expected a value in (0, 1), got {duty}")
    if step_period <= 0:
        raise ValueError(f"step_period: expected a positive number of seconds, got {step_period}")
    stances = {side: [Footstep(side, -math.inf, math.inf, np.asarray(initial[side][0], dtype=np.float64),
                               float(initial[side][1]))] for side in SIDES}
    swing = 2.0 * step_period * (1.0 - duty)
    t0 = first_lift_off + swing
    done = {side: False for side in SIDES}
    order = (first_side, "right" if first_side == "left" else "left")
    for i in range(max_steps):
        side = order[i % 2]
        touch_down = t0 + i * step_period
        mid = touch_down + 2.0 * step_period * duty * over_foot
        final = mid >= stop_time
        xy, yaw = root_at(min(mid, stop_time))
        if final:
            ankle_xy = xy + (_rot_z(yaw)[:2, :2] @ body.stand_ankle[side])
        else:
            ankle_xy = xy + _SIGN[side] * half_width * _right(yaw) + forward_offset * _forward(yaw)
        ball = body.ball_from_ankle_xy(side, ankle_xy, yaw)
        if min_gap is not None:
            # Both the ball and the ankle keep to their side: a foot turned across the other
            # (a pivot step) must not land on it.
            other_side = "right" if side == "left" else "left"
            other = stances[other_side][-1]
            other_ankle = other.ball - (_rot_z(other.yaw) @ body.foot[other_side])[:2]
            across = min(_SIGN[side] * float(np.dot(ball - other.ball, _right(yaw))),
                         _SIGN[side] * float(np.dot(ankle_xy - other_ankle, _right(yaw))))
            if across < min_gap:
                ball = ball + min(min_gap - across, _TURNING_PUSH) * _SIGN[side] * _right(yaw)
        prev = stances[side][-1]
        turn = abs(float(_wrap(yaw - prev.yaw)))
        step_min, turn_min = min_step, math.radians(6.0)
        if final and settle_step is not None:
            step_min, turn_min = settle_step, math.radians(12.0)
        if np.linalg.norm(ball - prev.ball) >= step_min or turn >= turn_min:
            prev.end = touch_down - swing
            stances[side].append(Footstep(side, touch_down, math.inf, ball, float(prev.yaw + _wrap(yaw - prev.yaw))))
        if final:
            done[side] = True
            if all(done.values()):
                break
    return stances["left"] + stances["right"]


def _assign_heel_off(steps: list[Footstep], heel_off: float, stride: float) -> None:
    """Heel roll at lift-off, scaled by how far forward the foot's next step goes."""
    for side in SIDES:
        seq = [s for s in steps if s.side == side]
        for a, b in zip(seq[:-1], seq[1:]):
            ahead = float(np.dot(b.ball - a.ball, _forward(a.yaw)))
            a.heel_off = heel_off * float(np.clip(ahead / max(stride, 1e-6), 0.0, 1.0))


# --------------------------------------------------------------------------- per-frame foot tracks

def _foot_track(body: _Body, side: str, steps: list[Footstep], times: np.ndarray, swing_height: float,
                heel_off_fraction: float, toe_up: float, stance_duration: float):
    """One foot's ankle target ``(T, 3)``, ankle rotation ``(T, 3, 3)``, ground contact ``(T,)`` and
    ``fold (T,)``: how freely the swing may be pulled towards the hip (0 on the ground, 1 mid-swing)."""
    seq = sorted([s for s in steps if s.side == side], key=lambda s: s.start)
    T = len(times)
    ankle = np.zeros((T, 3))
    rot = np.zeros((T, 3, 3))
    contact = np.zeros(T, dtype=bool)
    fold = np.zeros(T)

    def stance_pose(step, t):
        pitch = 0.0
        if step.heel_off > 0 and math.isfinite(step.end):
            # A stance that began before the clip rolls over the gait's usual stance duration.
            duration = step.end - step.start if math.isfinite(step.start) else stance_duration
            roll_start = max(step.end - heel_off_fraction * duration, 0.0)
            u = np.clip((t - roll_start) / max(step.end - roll_start, 1e-6), 0.0, 1.0)
            pitch = step.heel_off * u**1.5
        ball = np.array([step.ball[0], step.ball[1], FOOT_JOINT_HEIGHT])
        a, r = body.ankle_from_ball(side, ball, step.yaw, pitch)
        return a, r, pitch

    for f, t in enumerate(times):
        k = 0
        while k + 1 < len(seq) and seq[k + 1].start <= t:
            k += 1
        cur = seq[k]
        if t <= cur.end or k + 1 >= len(seq):
            ankle[f], rot[f], _ = stance_pose(cur, t)
            contact[f] = True
            continue
        nxt = seq[k + 1]
        u = (t - cur.end) / max(nxt.start - cur.end, 1e-6)
        a0, _, pitch0 = stance_pose(cur, cur.end)
        a1, _, _ = stance_pose(nxt, nxt.start)
        # The foot rises before it travels and arrives before it sets down (little sliding near the floor).
        m = _min_jerk((u - 0.06) / 0.88)
        pos = a0 + (a1 - a0) * m
        # Asymmetric lift: the foot rises quickly after toe-off and lands softly.
        lift_u = u**0.75
        pos[2] = a0[2] + (a1[2] - a0[2]) * _smoothstep(u) + swing_height * 4.0 * lift_u * (1.0 - lift_u)
        yaw = cur.yaw + (nxt.yaw - cur.yaw) * m
        pitch = pitch0 * (1.0 - _smoothstep(u / 0.5)) - toe_up * math.sin(math.pi * np.clip((u - 0.35) / 0.6, 0, 1))
        ankle[f] = pos
        rot[f] = _rot_z(yaw) @ _rot_x(-pitch)
        fold[f] = _smoothstep(u / 0.08) * _smoothstep((1.0 - u) / 0.1)
    return ankle, rot, contact, fold


# --------------------------------------------------------------------------- style

@dataclass
class _Style:
    swing_height: float
    heel_off: float
    arm_swing: float
    elbow: float
    bob: float
    drop: float
    lean: float
    sway: float
    pelvis_twist: float
    shoulder_twist: float
    head_pitch: float
    toe_up: float
    noise: dict = field(default_factory=dict)


def _sample_style(rng: np.random.Generator, params: GaitParams) -> _Style:
    u = lambda r: float(rng.uniform(*r))  # noqa: E731
    twist = u(params.pelvis_twist)
    return _Style(
        swing_height=u(params.swing_height), heel_off=u(params.heel_off), arm_swing=u(params.arm_swing),
        elbow=u(params.elbow), bob=u(params.bob), drop=u(params.drop), lean=u(params.lean), sway=u(params.sway),
        pelvis_twist=twist, shoulder_twist=twist * rng.uniform(0.8, 1.3),
        head_pitch=float(rng.uniform(math.radians(2), math.radians(8))),
        toe_up=math.radians(6.0) if params.swing_height[1] > 0 else 0.0,
    )


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


def _synthesize(body: _Body, root: _RootPlan, steps: list[Footstep], params: GaitParams, style: _Style,
                step_period: float, stride: float, actions: np.ndarray, start=None, meta=None,
                extra_sway: Optional[np.ndarray] = None) -> Motion:
    """Turn a root plan and a footstep plan into a labelled ``Motion`` (see the module docstring)."""
    times = root.times
    T = len(times)
    env = root.envelope
    tracks = {side: _foot_track(body, side, steps, times, style.swing_height, params.heel_off_fraction,
                                style.toe_up * float(np.max(env, initial=0.0)), 2.0 * step_period * params.duty)
              for side in SIDES}
    sigma = 0.07 * FPS

    # Per-frame feet in the root frame: forward and lateral offsets of the ankles.
    fwd, right = _forward(root.yaw), _right(root.yaw)
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
    g_pelvis = _rot_z(pelvis_yaw) @ _rot_x(-pelvis_pitch)

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
        local[:, j] = _rot_z(spine_yaw) @ _rot_x(-(spine_pitch / 3.0 + (breath if k == 2 else 0.0)))
    g_neck = g_pelvis
    for j in _SPINE + [_NECK]:
        g_neck = g_neck @ local[:, j]
    head_yaw = root.yaw + style.noise.get("head_yaw", np.zeros(T))
    head_goal = _rot_z(head_yaw) @ _rot_x(-np.full(T, style.head_pitch))
    correction = torch.from_numpy(np.swapaxes(g_neck, -1, -2) @ head_goal)
    half = axis_angle_to_matrix(0.5 * matrix_to_axis_angle(correction)).numpy()
    local[:, _NECK] = half
    local[:, _HEAD] = half

    arm = style.arm_swing * arm_signal
    drift = style.noise.get("arms", np.zeros((T, 2)))
    for side in SIDES:
        swing = (-arm if side == "left" else arm) + drift[:, 0 if side == "left" else 1]
        down = _rot_y(np.full(T, _SIGN[side] * ARM_DOWN_ANGLE))
        local[:, _J[side]["shoulder"]] = _rot_x(swing) @ down
        # The elbow flexes a little more as the arm swings forward (not for an idle arm's drift).
        extra = min(0.5 * style.elbow, math.radians(15.0)) if style.arm_swing > 0 else 0.0
        bend = style.elbow + extra * np.clip(swing / max(style.arm_swing, 1e-6), 0.0, 1.0)
        local[:, _J[side]["elbow"]] = _rot_z(_SIGN[side] * bend)

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
        knee = glob[:, _J[side]["knee"]]
        local_t[:, _J[side]["ankle"]] = knee.transpose(-1, -2) @ torch.from_numpy(tracks[side][1])

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
    w = torch.from_numpy(1.0 - _smoothstep(np.arange(n) / (n - 1)))
    gen = local_t[:n]
    rel = matrix_to_axis_angle(gen.transpose(-1, -2) @ start_local.double()[None].expand_as(gen))
    local_t = local_t.clone()
    local_t[:n] = gen @ axis_angle_to_matrix(rel * w[:, None, None])
    root_t = root_t.clone()
    root_t[:n] = root_t[:n] + (start_root.double()[None] - root_t[:n]) * w[:, None]
    return local_t, root_t


# --------------------------------------------------------------------------- start states

def _check_start(start):
    """``start`` as float64 ``(local_rotations (22, 3, 3), root_position (3,))``, or None."""
    if start is None:
        return None
    if not isinstance(start, (tuple, list)) or len(start) != 2:
        raise ValueError("start: expected a pair (local_rotations (22, 3, 3), root_position (3,))")
    local, root = as_tensor(start[0], "start local_rotations"), as_tensor(start[1], "start root_position")
    check_shape(local, (NUM_JOINTS, 3, 3), "start local_rotations")
    check_shape(root, (3,), "start root_position")
    check_finite(local, "start local_rotations")
    check_finite(root, "start root_position")
    return local.double(), root.double()


def _state_of(body: _Body, start):
    """Feet (ball xy, yaw) and root (xy, heading) of a start pose."""
    local, root = start
    glob, pos = forward_kinematics(local, root, body.offsets_torch.double())
    feet = {}
    for side in SIDES:
        ball = pos[_J[side]["foot"], :2].numpy().copy()
        yaw = float(yaw_of_matrix(glob[_J[side]["ankle"]]))
        feet[side] = (ball, yaw)
    heading = float(yaw_of_matrix(glob[0]))
    return feet, root[:2].numpy().copy(), heading


def _default_start(body: _Body, position, heading):
    local, root = standing_pose(body.betas, position=position, heading=heading)
    return local.double(), root.double()


def _positions(value, name):
    arr = np.asarray(value, dtype=np.float64)
    check_shape(arr, (2,), name)
    check_finite(arr, name)
    return arr


# --------------------------------------------------------------------------- clip builders

def _speed_profile(length: float, cruise: float, ramp_per_speed: float):
    """Arc length ``s(t)`` with smooth acceleration and deceleration; returns (s_of_t, stop_time, cruise)."""
    ramp_per_speed = max(ramp_per_speed, 1e-3)
    # Distance of both ramps is cruise * ramp / 2 each (smoothstep has mean 1/2).
    if cruise * cruise * ramp_per_speed > length:
        cruise = math.sqrt(length / ramp_per_speed)
    ramp = cruise * ramp_per_speed
    cruise_time = (length - cruise * ramp) / cruise
    stop = 2 * ramp + cruise_time

    def s_of_t(t):
        t = np.asarray(t, dtype=np.float64)
        x = np.clip(t / ramp, 0, 1)
        accel = cruise * ramp * (x**3 - 0.5 * x**4)
        y = np.clip((stop - t) / ramp, 0, 1)
        decel = length - cruise * ramp * (y**3 - 0.5 * y**4)
        mid = cruise * ramp * 0.5 + cruise * (t - ramp)
        return np.where(t < ramp, accel, np.where(t > stop - ramp, decel, mid)).clip(0, length)

    return s_of_t, stop, cruise


def _path_speed_profile(path: _Path, cruise: float, accel: float, lateral_accel: float, min_speed: float):
    """Arc length ``s(t)`` along a curved path: slower in tight bends, smooth starts and stops.

    The speed limit at arc length ``s`` is ``min(cruise, sqrt(lateral_accel / curvature))`` (never
    below ``min_speed``); a forward and a backward pass cap the acceleration at ``accel`` m/s², and
    a Gaussian blur of the speed over time removes the remaining kinks (the distance is rescaled
    so the walk still ends exactly at the path's end).

    Returns ``(s_of_t, stop_time, speed_of_t)``.
    """
    ds = float(np.mean(np.diff(path.arc))) if len(path.arc) > 1 else path.length
    curvature = np.abs(np.gradient(path.heading, path.arc)) if len(path.arc) > 2 else np.zeros_like(path.arc)
    curvature = gaussian_filter1d(curvature, max(1.0, 0.15 / max(ds, 1e-6)), mode="nearest")
    limit = np.clip(np.sqrt(lateral_accel / np.maximum(curvature, 1e-9)), min_speed, cruise)
    v = limit.copy()
    v[0] = v[-1] = 0.0
    steps = np.diff(path.arc)
    for i in range(1, len(v)):
        v[i] = min(v[i], math.sqrt(v[i - 1] ** 2 + 2 * accel * steps[i - 1]))
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2 * accel * steps[i]))
    dt = 2.0 * steps / np.maximum(v[1:] + v[:-1], 1e-9)
    t_of_s = np.concatenate([[0.0], np.cumsum(dt)])
    fine = 1.0 / (10 * FPS)
    sigma = 0.12
    pad = 4 * sigma
    t_grid = np.arange(-pad, t_of_s[-1] + pad + fine, fine)
    s_grid = np.interp(t_grid, t_of_s, path.arc)
    speed = gaussian_filter1d(np.gradient(s_grid, fine), sigma / fine, mode="constant")
    s_smooth = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * fine)])
    start = int(np.searchsorted(s_smooth, 1e-5 * path.length))
    end = int(np.searchsorted(s_smooth, s_smooth[-1] * (1 - 1e-5)))
    scale = path.length / max(s_smooth[end] - s_smooth[start], 1e-12)
    t_grid = t_grid[start:end + 1] - t_grid[start]
    s_smooth = (s_smooth[start:end + 1] - s_smooth[start]) * scale
    speed = speed[start:end + 1] * scale
    stop = float(t_grid[-1])

    def s_of_t(t):
        return np.interp(np.asarray(t, dtype=np.float64), t_grid, s_smooth)

    def speed_of_t(t):
        return np.interp(np.asarray(t, dtype=np.float64), t_grid, speed, left=0.0, right=0.0)

    return s_of_t, stop, speed_of_t


def _times(duration: float) -> np.ndarray:
    return np.arange(int(math.ceil(duration * FPS)) + 1) / FPS


# Least distance across the heading between the balls (and the ankles) of the feet in turning
# steps, metres, and the most a foot is pushed out to keep it.
_TURNING_GAP = 0.12
_TURNING_PUSH = 0.2
# After turning steps, a foot already near its standing place stays (no shuffle to close up), m.
_TURNING_SETTLE_STEP = 0.07
# Turning steps: the fastest the body may move sideways while turned from its path, m/s; the
# longest it may keep turning on the spot after the root has stopped (a short pivot), seconds.
_TURNING_SIDE_SPEED = 0.45
_TURNING_PIVOT = 0.5


def _turning_time(angle: float) -> float:
    """Seconds turning steps take to turn the body by ``angle`` radians (1.1 s for a quarter turn,
    1.8 s for a half turn; a turn on the spot takes about as long)."""
    return 0.5 + 0.4 * abs(angle)


def _allowed_deviation(speed):
    """Largest angle (radians, ``(...)``) between the heading and the direction of travel at ``speed``
    (m/s): sideways at most ``_TURNING_SIDE_SPEED``, backwards only when slower still."""
    speed = np.asarray(speed, dtype=np.float64)
    side = np.arcsin(np.clip(_TURNING_SIDE_SPEED / np.maximum(speed, 1e-9), 0.0, 1.0))
    slow = 0.5 * np.pi * (2.0 - np.clip(speed / _TURNING_SIDE_SPEED, 0.0, 1.0))
    return np.where(speed > _TURNING_SIDE_SPEED, side, slow)


def _turning_schedule(path: _Path, s_of_t, speed_of_t, stop: float, end_yaw: float):
    """How far ``w(t)`` (0 → 1) the heading has blended from the path's direction into ``end_yaw``.

    The blend is a smoothstep in time lasting ``_turning_time`` of the turn left when it starts
    (a bend of the path included), ending at most ``_TURNING_PIVOT`` seconds after the root stops:
    just late enough that the body never moves sideways faster than ``_TURNING_SIDE_SPEED`` while
    turned from its path. Returns ``(w, end_time)`` with ``w`` a callable of time (seconds).
    """
    grid = np.arange(0.0, stop + _TURNING_PIVOT + 1e-9, 1.0 / (4 * FPS))
    _, path_yaw = path.at(s_of_t(grid))
    left = np.abs(end_yaw - path_yaw)
    allowed = _allowed_deviation(speed_of_t(grid))
    earliest = min(0.6, 0.5 * stop)
    for pivot in np.arange(0.0, _TURNING_PIVOT + 1e-9, 0.05):
        end = stop + pivot
        duration = _turning_time(end_yaw - float(np.interp(end - _turning_time(np.pi), grid, path_yaw)))
        for _ in range(3):
            begin = max(end - duration, earliest)
            duration = _turning_time(end_yaw - float(np.interp(begin, grid, path_yaw)))
        begin = max(end - duration, earliest)
        w = _smoothstep((grid - begin) / max(end - begin, 1e-6))
        if np.all(w * left <= allowed + 1e-6):
            break

    def weight(t):
        return _smoothstep((np.asarray(t, dtype=np.float64) - begin) / max(end - begin, 1e-6))

    return weight, float(end)


def _locomotion_segment(body: _Body, start, rng: np.random.Generator, *, gait: str, path: _Path,
                        speed: Optional[float], settle_hold: float, meta: dict,
                        end_heading: Optional[float] = None) -> Motion:
    """Walk or run along ``path`` from ``start`` and stop with both feet planted.

    With ``end_heading`` the body turns to it over the last steps while the root finishes the
    path (turning steps: the root's heading leaves the path's tangent as the walker slows down).
    """
    params = GAITS[gait]
    style = _sample_style(rng, params)
    cruise = float(rng.uniform(*params.speed)) if speed is None else float(speed)
    feet, _, start_heading = _state_of(body, start)
    # Peak acceleration of the smooth ramps: 1.5 * speed / ramp time, ramp time = accel_time * speed.
    s_of_t, stop, speed_of_t = _path_speed_profile(path, cruise, 1.0 / params.accel_time, params.lateral_accel,
                                                   params.min_turn_speed)
    step_length = body.hip_height * (params.step_ratio[0] + params.step_ratio[1] * cruise) * rng.uniform(0.94, 1.06)
    step_period = step_length / cruise
    heading0 = path.heading[0]
    start_offset = float(_wrap(start_heading - heading0))
    end_offset = 0.0 if end_heading is None else float(_wrap(float(end_heading) - path.heading[-1]))
    end_yaw = float(path.heading[-1]) + end_offset
    turning, still = None, stop
    if end_offset != 0.0:
        # Turning steps: the heading leaves the path's direction for ``end_heading`` as the
        # walker slows down, finishing with a short pivot where the turn is large.
        turning, still = _turning_schedule(path, s_of_t, speed_of_t, stop, end_yaw)

    def root_at(t):
        xy, yaw = path.at(s_of_t(t))
        t = np.asarray(t)
        yaw = yaw + start_offset * (1.0 - _smoothstep(t / 0.5))
        if turning is not None:
            yaw = yaw + (end_yaw - yaw) * turning(t)
        return xy, yaw

    first = "left" if rng.random() < 0.5 else "right"
    steps = _plan_footsteps(root_at, still, initial=feet, first_side=first, step_period=step_period,
                            duty=params.duty, half_width=params.half_width, over_foot=params.over_foot,
                            forward_offset=body.stand_ankle_forward, body=body,
                            min_gap=None if turning is None else _TURNING_GAP,
                            settle_step=None if turning is None else _TURNING_SETTLE_STEP)
    _assign_heel_off(steps, style.heel_off, step_length)
    last_touch = max([s.start for s in steps if math.isfinite(s.start)], default=0.0)
    moving_end = max(still, last_touch) + 0.25
    times = _times(moving_end + settle_hold)
    xy, yaw = root_at(times)
    envelope = np.clip(speed_of_t(times) / cruise, 0.0, 1.0)
    root = _RootPlan(times=times, xy=xy, yaw=yaw, envelope=envelope)
    actions = np.where(times <= moving_end, action_id(gait), action_id("idle"))
    meta = {**meta, "gait": gait, "speed": cruise, "step_length": step_length,
            "cadence": 1.0 / step_period, "path_length": path.length}
    if turning is not None:
        meta.update(turning_steps=end_offset, pivot=still - stop)
    return _synthesize(body, root, steps, params, style, step_period, step_length, actions, start=start, meta=meta)


def _turn_segment(body: _Body, start, rng: np.random.Generator, angle: float, settle_hold: float, meta: dict) -> Motion:
    """Turn on the spot by ``angle`` radians with small stepping turns."""
    params = _TURN
    style = _sample_style(rng, params)
    feet, root_xy, heading0 = _state_of(body, start)
    n_steps = max(2, int(math.ceil(abs(angle) / math.radians(rng.uniform(40, 55)))))
    step_period = float(rng.uniform(0.42, 0.55))
    swing = 2 * step_period * (1 - params.duty)
    lift = 0.1
    duration = lift + swing + (n_steps - 1) * step_period + step_period * params.duty
    stop = duration - 0.5 * step_period

    def root_at(t):
        u = _min_jerk((np.asarray(t) - 0.05) / max(stop - 0.05, 1e-3))
        return np.broadcast_to(root_xy, np.shape(t) + (2,)).copy(), heading0 + angle * u

    first = "left" if angle > 0 else "right"
    steps = _plan_footsteps(root_at, stop, initial=feet, first_side=first, step_period=step_period,
                            duty=params.duty, half_width=params.half_width, over_foot=params.over_foot,
                            forward_offset=body.stand_ankle_forward, body=body, first_lift_off=lift)
    last_touch = max([s.start for s in steps if math.isfinite(s.start)], default=0.0)
    moving_end = max(stop, last_touch) + 0.2
    times = _times(moving_end + settle_hold)
    xy, yaw = root_at(times)
    envelope = np.full(len(times), 0.3)
    root = _RootPlan(times=times, xy=xy, yaw=yaw, envelope=envelope)
    actions = np.where(times <= moving_end, action_id("turn"), action_id("idle"))
    meta = {**meta, "angle": float(angle), "steps": n_steps}
    return _synthesize(body, root, steps, params, style, step_period, 0.5, actions, start=start, meta=meta)


def _side_segment(body: _Body, start, rng: np.random.Generator, distance: float, settle_hold: float,
                  meta: dict) -> Motion:
    """Shift ``distance`` metres to the character's right (negative: left) with side steps."""
    params = _SIDE
    style = _sample_style(rng, params)
    feet, root_xy, heading = _state_of(body, start)
    step_period = float(rng.uniform(0.38, 0.46))
    # Feet never cross: the root moves less than the free width between the feet per step.
    cruise = min(float(rng.uniform(*params.speed)), (2 * params.half_width - 0.14) / step_period)
    s_of_t, stop, cruise_used = _speed_profile(abs(distance), cruise, params.accel_time)
    direction = math.copysign(1.0, distance) * _right(heading)

    def root_at(t):
        return root_xy + s_of_t(t)[..., None] * direction, np.full(np.shape(t), heading)

    first = "right" if distance > 0 else "left"
    steps = _plan_footsteps(root_at, stop, initial=feet, first_side=first, step_period=step_period,
                            duty=params.duty, half_width=params.half_width, over_foot=params.over_foot,
                            forward_offset=body.stand_ankle_forward, body=body)
    last_touch = max([s.start for s in steps if math.isfinite(s.start)], default=0.0)
    moving_end = max(stop, last_touch) + 0.2
    times = _times(moving_end + settle_hold)
    xy, yaw = root_at(times)
    envelope = np.clip(np.gradient(s_of_t(times), times) / cruise_used, 0.0, 1.0)
    root = _RootPlan(times=times, xy=xy, yaw=yaw, envelope=envelope)
    actions = np.where(times <= moving_end, action_id("side_step"), action_id("idle"))
    meta = {**meta, "distance": float(distance), "speed": cruise_used}
    return _synthesize(body, root, steps, params, style, step_period, 0.5, actions, start=start, meta=meta)


def _idle_segment(body: _Body, start, rng: np.random.Generator, duration: float, still: bool, meta: dict) -> Motion:
    """Stand on both feet: subtle sway, breathing and arm drift (none when ``still``)."""
    params = _IDLE
    style = _sample_style(rng, params)
    feet, root_xy, heading = _state_of(body, start)
    times = _times(duration)
    T = len(times)
    # Root centred between the feet: the body stands over its support.
    ankle_mid = np.zeros(2)
    for side in SIDES:
        ball, yaw = feet[side]
        ankle_mid += 0.5 * (ball - (_rot_z(yaw) @ body.foot[side])[:2])
    stand_mid = 0.5 * (body.stand_ankle["left"] + body.stand_ankle["right"])
    centre = ankle_mid - _rot_z(heading)[:2, :2] @ stand_mid
    if still:
        sway = np.zeros(T)
        style.noise = {}
    else:
        amp = float(rng.uniform(0.006, 0.012))
        sway = _smooth_noise(rng, times, amp, periods=(2.5, 7.0))
        breath_period = float(rng.uniform(3.2, 4.8))
        style.noise = {
            "breath": math.radians(rng.uniform(0.6, 1.2)) * np.sin(2 * np.pi * times / breath_period + rng.uniform(0, 6.3)),
            "head_yaw": _smooth_noise(rng, times, math.radians(rng.uniform(2, 6)), periods=(3.0, 7.0)),
            "arms": np.stack([_smooth_noise(rng, times, math.radians(rng.uniform(1.0, 2.5)), periods=(2.5, 6.0))
                              for _ in SIDES], -1),
        }
        # Ease the drift in from the start pose.
        ease = _smoothstep(times / 0.6)
        sway = sway * ease
        for key in style.noise:
            style.noise[key] = style.noise[key] * (ease if style.noise[key].ndim == 1 else ease[:, None])
    steps = [Footstep(side, -math.inf, math.inf, feet[side][0], feet[side][1]) for side in SIDES]
    root = _RootPlan(times=times, xy=np.broadcast_to(centre, (T, 2)).copy(), yaw=np.full(T, heading),
                     envelope=np.zeros(T))
    actions = np.full(T, action_id("idle"))
    return _synthesize(body, root, steps, params, style, 1.0, 0.5, actions, start=start, meta=meta,
                       extra_sway=sway)


def _join(parts: list[Motion], meta: dict) -> Motion:
    """Concatenate segments that each start on the previous one's last frame (dropping the repeat)."""
    trimmed = [parts[0]] + [p.slice(1, len(p)) for p in parts[1:] if len(p) > 1]
    out = Motion.concatenate(trimmed)
    out.meta = {**meta, "parts": [p.meta for p in parts]}
    return out


def _last_pose(motion: Motion):
    return motion.local_rotations[-1].double(), motion.root_position[-1].double()


# --------------------------------------------------------------------------- public API

@single_threaded
def walk_path(waypoints, *, betas=None, seed=0, speed: Optional[float] = None, gait: str = "walk",
              end_heading: Optional[float] = None, start=None, settle: bool = True,
              end_turn: str = "spot") -> Motion:
    """Walk (or run) along a smooth path through ground waypoints and stop standing.

    The root follows a centripetal Catmull-Rom curve through the waypoints at a cruise speed
    (sampled from the gait's range when ``speed`` is None: walk 0.9–1.5 m/s, run 2.4–3.4 m/s),
    accelerating from and decelerating to a standstill and slowing down in tight bends (sideways
    acceleration at most 1.5 m/s² walking, 4 m/s² running). Step length grows with speed and the
    hip height; cadence is speed / step length. The clip ends with both feet planted, facing the
    path's final direction, or ``end_heading``: after stepping round on the spot
    (``end_turn="spot"``), or turning while arriving (``end_turn="steps"``: over the last second
    or two of the walk, longer for larger turns, the heading leaves the path's direction for
    ``end_heading`` as the walker slows down, never moving sideways faster than 0.45 m/s, so the
    last steps are turning steps, ending with at most half a second of pivoting once the root
    has stopped; the feet never cross). A path shorter than 15 cm is not walked (the character
    stands, turning to ``end_heading`` on the spot if given).

    Args:
        waypoints: ``(K, 2)`` metres on the ground, ``K >= 2``; the first is the start (replaced
            by the start pose's root position when ``start`` is given).
        betas: ``(10,)`` toy body shape, ``None`` for the mean body.
        seed: int or ``numpy.random.Generator``: style (speed, step length, arm swing, bob, lean,
            sway, swing height) and which foot steps first.
        speed: cruise speed, m/s (lowered automatically on paths too short to reach it).
        gait: ``"walk"`` or ``"run"``.
        end_heading: final heading, radians (0 faces +Y), or None.
        start: optional ``(local_rotations (22, 3, 3), root_position (3,))`` to begin from; frame
            0 reproduces it exactly (default: ``standing_pose`` at ``waypoints[0]`` facing the path).
            A start facing more than 25° away from the path first turns on the spot.
        settle: append half a second of standing still ("idle") at the end; without it the clip
            ends a quarter of a second after the last foot lands (or when the end turn is done).
        end_turn: ``"spot"`` or ``"steps"``: how the walk turns to ``end_heading`` (see above).
    Returns:
        ``Motion`` at 30 fps labelled "walk"/"run" while moving, "turn" while turning on the
        spot, "idle" once settled; foot contacts in ``contacts[:, 1:3]``.
    """
    check_choice(gait, tuple(GAITS), "gait")
    check_choice(end_turn, ("spot", "steps"), "end_turn")
    rng = _rng(seed)
    body = _Body(betas)
    start = _check_start(start)
    pts = np.asarray(waypoints, dtype=np.float64)
    check_shape(pts, (None, 2), "waypoints")
    check_finite(pts, "waypoints")
    if len(pts) < 2:
        raise ValueError(f"waypoints: expected shape (K, 2) with K >= 2, got K = {len(pts)}")
    if speed is not None:
        if not (isinstance(speed, (int, float, np.floating, np.integer)) and 0.2 <= float(speed) <= 6.0):
            raise ValueError(f"speed: expected a number of m/s in [0.2, 6], got {speed!r}")
    if start is not None:
        pts = pts.copy()
        pts[0] = start[1][:2].numpy()
    hold = 0.5 if settle else 0.0
    meta = {"generator": "walk_path", "gait": gait, "waypoints": pts.tolist()}
    parts: list[Motion] = []
    distinct = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).max()) > 1e-6
    path = path_from_waypoints(pts) if distinct else None
    if start is None:
        heading0 = float(path.heading[0]) if path is not None else 0.0
        start = _default_start(body, pts[0], heading0)
    state = start
    if path is not None and path.length >= 0.15:
        _, _, heading_now = _state_of(body, state)
        if abs(float(_wrap(path.heading[0] - heading_now))) > math.radians(25):
            parts.append(_turn_segment(body, state, rng, float(_wrap(path.heading[0] - heading_now)), 0.0,
                                       {"generator": "turn_in_place"}))
            state = _last_pose(parts[-1])
        # The path restarts at the current root, ending at the last waypoint.
        _, root_xy, _ = _state_of(body, state)
        path_pts = pts.copy()
        path_pts[0] = root_xy
        path = path_from_waypoints(path_pts)
        stepping = end_heading is not None and end_turn == "steps"
        final_hold = hold if end_heading is None else 0.0
        parts.append(_locomotion_segment(body, state, rng, gait=gait, path=path, speed=speed,
                                         settle_hold=final_hold, meta={"generator": "locomotion"},
                                         end_heading=end_heading if stepping else None))
        state = _last_pose(parts[-1])
    if end_heading is not None:
        _, _, heading_now = _state_of(body, state)
        angle = float(_wrap(float(end_heading) - heading_now))
        # After turning steps only a turn the walk could not finish is done on the spot.
        if abs(angle) > math.radians(10 if end_turn == "steps" and parts else 3):
            parts.append(_turn_segment(body, state, rng, angle, hold, {"generator": "turn_in_place"}))
            state = _last_pose(parts[-1])
        elif hold > 0:
            parts.append(_idle_segment(body, state, rng, hold, True, {"generator": "settle"}))
    if not parts:
        parts.append(_idle_segment(body, state, rng, max(hold, 0.5), True, {"generator": "settle"}))
    return _join(parts, meta)


@single_threaded
def idle(duration: float, *, betas=None, seed=0, position=(0.0, 0.0), heading: float = 0.0, start=None) -> Motion:
    """Stand with subtle life: pelvis sway, breathing spine, arm drift, a wandering gaze.

    Args:
        duration: seconds (> 0).
        betas: ``(10,)`` body shape or None.
        seed: int or ``numpy.random.Generator``.
        position: ``(2,)`` ground position of the pelvis, metres (ignored when ``start`` is given).
        heading: radians, 0 faces +Y (ignored when ``start`` is given).
        start: optional ``(local_rotations (22, 3, 3), root_position (3,))``; frame 0 reproduces it.
    Returns:
        ``Motion`` labelled "idle" with both feet planted (in contact) throughout.
    """
    if not (isinstance(duration, (int, float, np.floating, np.integer)) and float(duration) > 0):
        raise ValueError(f"duration: expected a positive number of seconds, got {duration!r}")
    rng = _rng(seed)
    body = _Body(betas)
    start = _check_start(start)
    if start is None:
        start = _default_start(body, _positions(position, "position"), float(heading))
    return _idle_segment(body, start, rng, float(duration), False, {"generator": "idle"})


@single_threaded
def turn_in_place(angle: float, *, betas=None, seed=0, position=(0.0, 0.0), heading: float = 0.0,
                  start=None) -> Motion:
    """Turn on the spot by ``angle`` radians (positive: counter-clockwise seen from above, to the left).

    Small stepping turns of 40–55° each: the foot on the turning side opens first, the other
    follows, and the last step brings the feet back side by side.

    Args:
        angle: radians, any sign (|angle| up to 2π).
        betas, seed, position, heading, start: as in :func:`idle`.
    Returns:
        ``Motion`` labelled "turn", then "idle" for the last half second.
    """
    if not (isinstance(angle, (int, float, np.floating, np.integer)) and math.isfinite(angle)
            and abs(float(angle)) <= 2 * math.pi + 1e-9):
        raise ValueError(f"angle: expected a finite number of radians with |angle| <= 2*pi, got {angle!r}")
    rng = _rng(seed)
    body = _Body(betas)
    start = _check_start(start)
    if start is None:
        start = _default_start(body, _positions(position, "position"), float(heading))
    return _turn_segment(body, start, rng, float(angle), 0.5, {"generator": "turn_in_place"})


@single_threaded
def side_step(distance: float, *, betas=None, seed=0, position=(0.0, 0.0), heading: float = 0.0,
              start=None) -> Motion:
    """Step sideways ``distance`` metres (positive: to the character's right, +X local).

    The leading foot opens, the trailing foot closes, at about 0.3 m/s; the feet never cross.

    Args:
        distance: metres, non-zero, |distance| <= 5.
        betas, seed, position, heading, start: as in :func:`idle`.
    Returns:
        ``Motion`` labelled "side_step", then "idle" for the last half second.
    """
    if not (isinstance(distance, (int, float, np.floating, np.integer)) and 0.02 <= abs(float(distance)) <= 5.0):
        raise ValueError(f"distance: expected metres with 0.02 <= |distance| <= 5, got {distance!r}")
    rng = _rng(seed)
    body = _Body(betas)
    start = _check_start(start)
    if start is None:
        start = _default_start(body, _positions(position, "position"), float(heading))
    return _side_segment(body, start, rng, float(distance), 0.5, {"generator": "side_step"})
