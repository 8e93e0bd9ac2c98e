"""Footstep planning for locomotion: alternating stances that follow a root trajectory
(:func:`footstep_plan`), the heel roll at lift-off, and the per-frame track of each foot (planted
stance, heel roll about the fixed ball, minimum-jerk swing) that the gait synthesis poses.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..._validate import check_choice
from ..skeleton import FOOT_JOINT_HEIGHT
from .gait_body import SIDES, SIDE_SIGN, GaitBody
from .motion_math import forward_xy, min_jerk, right_xy, rot_x, rot_z, smoothstep, wrap_angle

__all__ = ["Footstep", "footstep_plan", "plan_footsteps", "assign_heel_off", "foot_track"]

# Turning steps (``min_gap``): the most a foot is pushed out to keep its gap from the other, metres.
_TURNING_PUSH = 0.2


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
    return plan_footsteps(root_at, stop_time, initial=initial, first_side=first_side, step_period=step_period,
                          duty=duty, half_width=half_width, over_foot=over_foot, forward_offset=forward_offset,
                          body=GaitBody(betas), first_lift_off=first_lift_off, min_step=min_step,
                          max_steps=max_steps)


def plan_footsteps(root_at, stop_time: float, *, initial: dict, first_side: str, step_period: float,
                   duty: float, half_width: float, over_foot: float, forward_offset: float, body: GaitBody,
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
            ankle_xy = xy + (rot_z(yaw)[:2, :2] @ body.stand_ankle[side])
        else:
            ankle_xy = xy + SIDE_SIGN[side] * half_width * right_xy(yaw) + forward_offset * forward_xy(yaw)
        ball = body.ball_from_ankle_xy(side, ankle_xy, yaw)
        if min_gap is not None:
            # Both the ball and the ankle keep to their side: a foot turned across the other
            # (a pivot step) must not land on it.
            other_side = "right" if side == "left" else "left"
            other = stances[other_side][-1]
            other_ankle = other.ball - (rot_z(other.yaw) @ body.foot[other_side])[:2]
            across = min(SIDE_SIGN[side] * float(np.dot(ball - other.ball, right_xy(yaw))),
                         SIDE_SIGN[side] * float(np.dot(ankle_xy - other_ankle, right_xy(yaw))))
            if across < min_gap:
                ball = ball + min(min_gap - across, _TURNING_PUSH) * SIDE_SIGN[side] * right_xy(yaw)
        prev = stances[side][-1]
        turn = abs(float(wrap_angle(yaw - prev.yaw)))
        step_min, turn_min = min_step, math.radians(6.0)
        if final and settle_step is not None:
            step_min, turn_min = settle_step, math.radians(12.0)
        if np.linalg.norm(ball - prev.ball) >= step_min or turn >= turn_min:
            prev.end = touch_down - swing
            stances[side].append(Footstep(side, touch_down, math.inf, ball,
                                          float(prev.yaw + wrap_angle(yaw - prev.yaw))))
        if final:
            done[side] = True
            if all(done.values()):
                break
    return stances["left"] + stances["right"]


def assign_heel_off(steps: list[Footstep], heel_off: float, stride: float) -> None:
    """Heel roll at lift-off, scaled by how far forward the foot's next step goes."""
    for side in SIDES:
        seq = [s for s in steps if s.side == side]
        for a, b in zip(seq[:-1], seq[1:]):
            ahead = float(np.dot(b.ball - a.ball, forward_xy(a.yaw)))
            a.heel_off = heel_off * float(np.clip(ahead / max(stride, 1e-6), 0.0, 1.0))


# --------------------------------------------------------------------------- per-frame foot tracks

def foot_track(body: GaitBody, side: str, steps: list[Footstep], times: np.ndarray, swing_height: float,
               heel_off_fraction: float, toe_up: float, stance_duration: float):
    """One foot's ankle target ``(T, 3)``, ankle rotation ``(T, 3, 3)``, ground contact ``(T,)`` and
    ``fold (T,)``: how freely the swing may be pulled towards the hip (0 on the ground, 1 mid-swing)."""
    seq = sorted([s for s in steps if s.side == side], key=lambda s: s.start)
    T = len(times)
    ankle = np.zeros((T, 3))
    rot = np.zeros((T, 3, 3))
    contact = np.zeros(T, dtype=bool)
    fold = np.zeros(T)

    solved = {}  # (step, pitch) -> ankle and rotation: a foot on the ground keeps its pitch for most frames

    def stance_pose(step, t):
        pitch = 0.0
        if step.heel_off > 0 and math.isfinite(step.end):
            # A stance that began before the clip rolls over the gait's usual stance duration.
            duration = step.end - step.start if math.isfinite(step.start) else stance_duration
            roll_start = max(step.end - heel_off_fraction * duration, 0.0)
            u = np.clip((t - roll_start) / max(step.end - roll_start, 1e-6), 0.0, 1.0)
            pitch = step.heel_off * u**1.5
        key = (id(step), float(pitch).hex())
        if key not in solved:  # the same step and pitch give the same pose: solved once (read-only below)
            ball = np.array([step.ball[0], step.ball[1], FOOT_JOINT_HEIGHT])
            solved[key] = body.ankle_from_ball(side, ball, step.yaw, pitch)
        a, r = solved[key]
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
        m = min_jerk((u - 0.06) / 0.88)
        pos = a0 + (a1 - a0) * m
        # Asymmetric lift: the foot rises quickly after toe-off and lands softly.
        lift_u = u**0.75
        pos[2] = a0[2] + (a1[2] - a0[2]) * smoothstep(u) + swing_height * 4.0 * lift_u * (1.0 - lift_u)
        yaw = cur.yaw + (nxt.yaw - cur.yaw) * m
        pitch = pitch0 * (1.0 - smoothstep(u / 0.5)) - toe_up * math.sin(math.pi * np.clip((u - 0.35) / 0.6, 0, 1))
        ankle[f] = pos
        rot[f] = rot_z(yaw) @ rot_x(-pitch)
        fold[f] = smoothstep(u / 0.08) * smoothstep((1.0 - u) / 0.1)
    return ankle, rot, contact, fold
