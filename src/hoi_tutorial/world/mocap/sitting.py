"""Sitting clips (:func:`sit`): the approach that arrives with the back to the seat, sitting down
(onto a deep seat with a scoot back, onto a high one with the feet leaving the floor), the
seated styles, standing up and walking away. Lying down (``lying``) reuses the sit-down.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np

from ...infra.device import single_threaded
from ..._validate import check_choice
from ..body import body_from_motion
from ..motion import FPS, Motion, action_id
from ..objects.categories import SITTABLE
from .approach import approach_waypoints, extent_along, extents_along, join_clips, walk_away
from .body_plan import (
    FOOT_CONTACT, HIP, KNEE, LEG_REACH, PELVIS_CONTACT, SIDES, SIGN, UP, Plan, PlanBody, check_betas, check_index,
    check_object, describe_object, hand_on_joint, n_frames, plan_to_motion, seed_record, start_state,
)
from .gait import walk_path
from .motion_math import (
    bump, forward_xyz, heading_of, lerp, min_jerk, normalize, right_xyz, rot_x, rot_z, seeded_rng, smoothstep,
    wrap_angle,
)
from .poses import standing_pose
from .standing import standing_plan, step_feet

__all__ = ["SIT_STYLES", "sit", "SitInfo", "sit_sequence", "approach_seat", "front_is_free", "seated_hands",
           "lift_path", "lift_relax", "lowest_clearance"]

SIT_STYLES = ("hands_on_knees", "leaning_back", "crossed_legs", "upright")

# How far the standing body reaches behind the pelvis joint, by height above the ground (metres):
# heels, calves, thighs and the buttocks.
_BACK_PROFILE = ((0.03, 0.15), (0.12, 0.08), (0.35, 0.08), (0.55, 0.09), (0.75, 0.12), (0.95, 0.14))
# Half the width of a walking body (feet beside the path, thighs, swinging hands), metres.
_WALK_HALF_WIDTH = 0.23


def _sit_stand_distances(body: PlanBody, obj, goal, direction, rng) -> tuple[float, float]:
    """Distances in front of a sit goal: where the sitter stands to sit down, and where the walk ends.

    The standing spot keeps the body standing with its back to the seat (``_BACK_PROFILE``)
    clear of the object, yet near enough that the seated legs still reach the planted feet. The
    walk passes along the object's front on a lane where a walking body clears every part of the
    object below 1.1 m; its turning steps then come in to the standing spot (``approach_seat``).
    Extents are measured along ``direction`` on a swath 0.4 m wide and every 3 cm of height.
    """
    heights = np.arange(0.02, 1.12, 0.03)
    right = np.cross(direction, UP)
    extents = np.max([extents_along([obj], goal + lateral * right, direction, tuple(heights), max_dist=1.5,
                                    step=0.02) for lateral in (-0.2, -0.1, 0.0, 0.1, 0.2)], axis=0)
    profile_z, profile_back = np.array(_BACK_PROFILE).T
    back = np.interp(heights, profile_z, profile_back)
    need = float(np.max(np.where(extents > 0, extents + back + 0.02, 0.0)))
    hip_drop = -float(np.mean(body.hip_offset[:, 2]))
    ankle_z = 0.09
    vertical = goal[2] - hip_drop - ankle_z
    reach = 0.96 * LEG_REACH * float(body.leg_length.min())
    max_dist = math.sqrt(max(reach**2 - vertical**2, 0.0)) - 0.01
    # When the seated legs cannot reach as far as a clear standing spot, stand a little closer
    # (the calves touch the seat, as when backing up to it); much closer and the sitter's feet
    # leave the floor instead (see _seated_reach).
    seat = need + rng.uniform(0.0, 0.05)
    if max_dist < seat:
        seat = max_dist if max_dist >= need - 0.08 else need
    walk = float(max(seat, extents.max() + _WALK_HALF_WIDTH))
    return float(seat), walk


def _step_plan(T, root, heading, ankles, feet, shift, rng, action):
    """Step the feet so the pelvis moves by ``shift (2,)`` metres over ``T`` frames, facing ``heading``.

    Returns the plan and the end state ``(root (3,), ankles (2, 3), feet (2, 3, 3))``.
    """
    times = np.arange(T) / FPS
    u = min_jerk(times / times[-1])
    pelvis_xy = root[None, :2] + u[:, None] * np.asarray(shift)[None]
    ankle, foot, contact = step_feet(times, pelvis_xy, np.full(T, heading), ankles, feet, heading, rng,
                                     lift=0.05)
    plan = standing_plan(T, root, heading, ankles, feet, action)
    plan.root[:, :2] = pelvis_xy
    plan.ankle, plan.foot = ankle, foot
    plan.contacts[:, list(FOOT_CONTACT)] = contact
    end_root = np.array([pelvis_xy[-1, 0], pelvis_xy[-1, 1], root[2]])
    return plan, (end_root, ankle[-1].copy(), foot[-1].copy())


def _backrest_distance(obj, goal, direction) -> Optional[float]:
    """Distance behind a seated pelvis to a backrest at chest height, or None when there is none."""
    back = -direction
    t = np.arange(0.0, 0.6, 0.01)
    for z in (0.25, 0.35):
        pts = goal[None] + t[:, None] * back[None] + np.array([0.0, 0.0, z])
        inside = obj.sdf(pts) < 0
        if inside.any():
            return float(t[np.argmax(inside)])
    return None


def seated_hands(plan, frames, style, cross_side, weight):
    """Hand targets of a seated style on the body: knees, thighs or the lap."""
    for i in range(2):
        if style == "hands_on_knees":
            hand_on_joint(plan, frames, i, KNEE[i], KNEE[i], 0.0, np.array([0.0, 0.0, 0.075]), weight)
        elif style == "crossed_legs":
            hand_on_joint(plan, frames, i, HIP[i], KNEE[cross_side], 0.75, np.array([0.0, 0.0, 0.085]), weight)
        elif style == "leaning_back":
            hand_on_joint(plan, frames, i, HIP[i], KNEE[i], 0.45, np.array([0.0, 0.0, 0.085]), weight)
        else:
            hand_on_joint(plan, frames, i, HIP[i], KNEE[i], 0.6, np.array([0.0, 0.0, 0.085]), weight)


def _sit_down_plan(u, stand_root, seat, heading_from, heading_to, ankles, feet, posture, lean_peak, style,
                   cross_side, action, hanging=None):
    """Frames of sitting down (``u`` 0 → 1) or standing up (``u`` 1 → 0) between a standing pelvis and a seat.

    ``hanging (2, 3)``: on a seat too high for the feet to stay on the floor, the ankles leave
    the planted ``ankles`` early in the sit-down for these positions (feet off the floor).
    """
    T = len(u)
    plan = Plan.empty(T)
    along = smoothstep(u / 0.7)
    plan.root[:, :2] = stand_root[None, :2] + along[:, None] * (seat[None, :2] - stand_root[None, :2])
    plan.root[:, 2] = stand_root[2] + min_jerk(u) * (seat[2] - stand_root[2])
    heading = heading_from + float(wrap_angle(heading_to - heading_from)) * smoothstep(u / 0.5)
    settle = smoothstep(u)
    pitch = lean_peak * bump(u) + posture["pelvis"] * settle
    spine = 0.35 * lean_peak * bump(u) + posture["spine"] * settle
    plan.pelvis = rot_z(heading) @ rot_x(-pitch)
    plan.spine[:, 0] = spine
    plan.neck[:, 0] = -0.5 * (pitch + spine)
    plan.ankle[:] = ankles
    plan.foot[:] = feet
    for i in range(2):
        plan.knee_pole[:, i] = forward_xyz(heading) + 0.15 * SIGN[i] * right_xyz(heading)
    start = 0.2 if style == "hands_on_knees" else 0.35
    seated_hands(plan, slice(None), style, cross_side, smoothstep((u - start) / (1.0 - start)))
    plan.actions[:] = action_id(action)
    plan.contacts[:, list(FOOT_CONTACT)] = True
    if hanging is not None:
        lift = min_jerk((u - 0.1) / 0.7)
        for i in range(2):
            plan.ankle[:, i] = lift_path(ankles[i], hanging[i], lift, 0.05)
            plan.relax[:, i] = lift_relax(lift)
            plan.contacts[:, FOOT_CONTACT[i]] = lift <= 0.0
    return plan


def _sit_hold_plan(T, seat, heading, ankles, feet, posture, style, cross_side, rng, unwind: bool, backrest,
                   raised: bool = False):
    """Seated frames: the style's settled motion (lean back, cross the legs) and breathing.

    With ``raised`` the legs rest stretched on a deep cushion (``ankles`` are their rest
    positions, the feet off the floor) and "crossed_legs" crosses the ankles.
    """
    plan = Plan.empty(T)
    times = np.arange(T) / FPS
    end = times[-1]
    plan.root[:] = seat
    ramp = np.ones(T)
    if style in ("leaning_back", "crossed_legs"):
        start, dur = rng.uniform(0.1, 0.3), rng.uniform(0.6, 0.9)
        ramp = min_jerk((times - start) / dur)
        if unwind:
            back_dur = rng.uniform(0.55, 0.8)
            ramp = ramp * (1.0 - min_jerk((times - (end - 0.1 - back_dur)) / back_dur))
    period, phase = rng.uniform(3.0, 4.5), rng.uniform(0, 6.3)
    breathing = math.radians(rng.uniform(0.8, 1.5)) * np.sin(2 * np.pi * times / period + phase)
    pitch = np.full(T, posture["pelvis"])
    spine = posture["spine"] + breathing
    if style == "leaning_back":
        if backrest is None:
            lean = math.radians(rng.uniform(6.0, 10.0))
        else:
            # Tilt until the chest's back (about 0.13 m behind spine3, 0.36 m up) meets the backrest.
            reach = (backrest - 0.13) / 0.36
            lean = math.asin(float(np.clip(reach, math.sin(math.radians(6)), math.sin(math.radians(28)))))
        pitch = pitch + (-lean - posture["pelvis"]) * ramp
        spine = spine + (-0.03 - posture["spine"]) * ramp
    plan.pelvis = rot_z(np.full(T, heading)) @ rot_x(-pitch)
    plan.spine[:, 0] = spine
    plan.neck[:, 0] = -0.55 * (pitch + spine)
    look = math.radians(rng.uniform(-15, 15)) * bump(times / max(end, 1e-6))
    plan.neck[:, 1] = look
    plan.ankle[:] = ankles
    plan.foot[:] = feet
    for i in range(2):
        plan.knee_pole[:, i] = forward_xyz(heading) + 0.15 * SIGN[i] * right_xyz(heading)
        if raised:
            plan.knee_pole[:, i] = normalize(UP + 0.3 * forward_xyz(heading) + 0.2 * SIGN[i] * right_xyz(heading))
    plan.contacts[:, list(FOOT_CONTACT)] = not raised
    plan.relax[:] = 1.0 if raised else 0.0
    if style == "crossed_legs":
        c, o = cross_side, 1 - cross_side
        toward_other = -SIGN[c] * right_xyz(heading)
        if raised:
            crossed = ankles[o] + 0.02 * toward_other + 0.03 * forward_xyz(heading) + np.array([0.0, 0.0, 0.08])
        else:
            crossed = ankles[o] + 0.10 * toward_other + 0.07 * forward_xyz(heading) + np.array([0.0, 0.0, 0.19])
        lift = min_jerk(ramp)
        plan.ankle[:, c] = lerp(np.broadcast_to(ankles[c], (T, 3)), np.broadcast_to(crossed, (T, 3)), lift)
        plan.ankle[:, c, 2] += 0.08 * bump(ramp) * (ramp < 1.0)
        if not raised:
            plan.relax[:, c] = smoothstep(ramp / 0.4)
            pole = normalize(forward_xyz(heading) + 1.3 * UP + 0.4 * toward_other)
            plan.knee_pole[:, c] = normalize(lerp(plan.knee_pole[:, c], np.broadcast_to(pole, (T, 3)),
                                                  smoothstep(ramp / 0.3)))
            plan.contacts[:, FOOT_CONTACT[c]] = ramp <= 0.0
    seated_hands(plan, slice(None), style, cross_side, np.ones(T))
    plan.actions[:] = action_id("sit")
    plan.contacts[:, PELVIS_CONTACT] = True
    return plan


def _seat_front(obj, goal, direction) -> float:
    """Distance from a sit goal to the front edge of the seat cushion (metres)."""
    return extent_along([obj], goal, direction, (goal[2] - 0.12,), max_dist=1.2)


def _edge_goal(obj, goal, direction):
    """Where the pelvis first sits: the goal itself, or on a deep seat (front edge more than 0.45 m
    ahead, farther than the thighs reach) 0.40 m behind the edge, from where the sitter scoots back."""
    front = _seat_front(obj, goal, direction)
    if front <= 0.45:
        return goal.copy()
    return goal + (front - 0.40) * direction


def lift_path(start, end, lift, arc):
    """Ankle path ``(T, 3)`` lifting a foot from ``start (3,)`` to ``end (3,)`` as ``lift (T,)`` goes
    0 → 1: it rises before it travels (no sliding near the floor) over an arc of ``arc`` metres."""
    along = min_jerk((lift - 0.25) / 0.75)
    path = start[None] + along[:, None] * (end - start)[None]
    path[:, 2] = start[2] + min_jerk(lift / 0.8) * (end[2] - start[2]) + arc * bump(lift) * (lift < 1.0)
    path[:, 2] += 0.05 * np.sin(np.pi * np.clip(lift / 0.5, 0.0, 1.0))
    return path


def lift_relax(lift):
    """How far a lifted foot has relaxed (turned to follow the shin) once off the floor."""
    return smoothstep((lift - 0.3) / 0.4)


def _seated_reach(body: PlanBody, goal) -> float:
    """Farthest horizontal distance from a sit goal at which the seated legs reach feet on the floor."""
    hip_drop = -float(np.mean(body.hip_offset[:, 2]))
    vertical = goal[2] - hip_drop - 0.09
    reach = 0.97 * LEG_REACH * float(body.leg_length.min())
    return math.sqrt(max(reach**2 - vertical**2, 0.0))


def _hanging_ankles(body: PlanBody, obj, goal, heading):
    """Rest positions ``(2, 3)`` of feet hanging off a seat too high to reach the floor from."""
    forward = forward_xyz(heading)
    hip_z = goal[2] + float(np.mean(body.hip_offset[:, 2]))
    front = extent_along([obj], goal, forward, tuple(np.linspace(0.1, max(hip_z - 0.15, 0.12), 6)), max_dist=1.0)
    reach = 0.9 * float(body.leg_length.min())
    ahead = float(np.clip(front + 0.1, 0.3, 0.85 * reach))
    out = np.zeros((2, 3))
    for i in range(2):
        out[i] = goal + ahead * forward + SIGN[i] * 0.11 * right_xyz(heading)
        out[i, 2] = max(0.12, hip_z - math.sqrt(max(reach**2 - ahead**2, 0.0)))
    return out


def _raised_ankles(body: PlanBody, goal, heading):
    """Rest positions ``(2, 3)`` of the ankles with the legs stretched on a deep cushion."""
    hip_drop = -float(np.mean(body.hip_offset[:, 2]))
    out = np.zeros((2, 3))
    for i in range(2):
        out[i] = goal + (0.05 + 0.9 * body.leg_length[i]) * forward_xyz(heading) + SIGN[i] * 0.11 * right_xyz(heading)
        out[i, 2] = goal[2] - hip_drop + 0.06
    return out


def _scoot_plan(u, edge, goal, heading, ankles, feet, rest, posture, style, cross_side, action):
    """Frames sliding back from the seat's front part to a deep goal while the legs come up onto the
    cushion (``u`` 0 → 1), or the reverse (``u`` 1 → 0)."""
    T = len(u)
    plan = Plan.empty(T)
    move = min_jerk(u)
    plan.root = lerp(np.broadcast_to(edge, (T, 3)), np.broadcast_to(goal, (T, 3)), move)
    pitch = posture["pelvis"] - math.radians(8.0) * bump(u)
    plan.pelvis = rot_z(np.full(T, heading)) @ rot_x(-pitch)
    plan.spine[:, 0] = posture["spine"]
    plan.neck[:, 0] = -0.55 * (pitch + posture["spine"])
    lift = min_jerk(u / 0.85)
    for i in range(2):
        plan.ankle[:, i] = lift_path(ankles[i], rest[i], lift, 0.06)
        plan.relax[:, i] = lift_relax(lift)
        floor_pole = forward_xyz(heading) + 0.15 * SIGN[i] * right_xyz(heading)
        up_pole = UP + 0.3 * forward_xyz(heading) + 0.2 * SIGN[i] * right_xyz(heading)
        plan.knee_pole[:, i] = normalize(lerp(np.broadcast_to(floor_pole, (T, 3)), np.broadcast_to(up_pole, (T, 3)),
                                              smoothstep(lift / 0.5)))
        plan.contacts[:, FOOT_CONTACT[i]] = lift <= 0.0
    plan.foot[:] = feet
    seated_hands(plan, slice(None), style, cross_side, np.ones(T))
    plan.actions[:] = action_id(action)
    plan.contacts[:, PELVIS_CONTACT] = True  # sliding on the cushion
    return plan


def _sit_posture(style, rng):
    """Seated pelvis pitch and spine flexion (radians, forward positive) of a style."""
    if style == "hands_on_knees":
        return {"pelvis": math.radians(rng.uniform(0.0, 8.0)), "spine": math.radians(rng.uniform(15.0, 25.0))}
    if style == "upright":
        return {"pelvis": math.radians(rng.uniform(-6.0, 2.0)), "spine": math.radians(rng.uniform(0.0, 8.0))}
    return {"pelvis": math.radians(rng.uniform(-6.0, 0.0)), "spine": math.radians(rng.uniform(0.0, 8.0))}


def front_is_free(obj, goal, direction) -> bool:
    """Whether a person can stand in front of a sit goal: the object reaches less than 0.7 m ahead of it
    (the corner seat of an L-sofa faces its chaise and is sat on from the side, which this generator
    does not do)."""
    heights = (0.1, 0.3, max(goal[2] - 0.12, 0.12))
    return extent_along([obj], goal, direction, heights, max_dist=1.2, step=0.02) < 0.7


def _sit_goal(obj, goal_index, rng):
    """The sit goal to use: ``(index, pelvis position (3,), forward (3,))``, drawn among free ones."""
    positions, directions = obj.sit_goals
    unit = [normalize(np.array([d[0], d[1], 0.0])) for d in directions]
    free = [k for k in range(len(positions)) if front_is_free(obj, positions[k], unit[k])]
    if goal_index is None:
        if not free:
            raise ValueError(f"obj: no sit goal of this {obj.category} has free space in front of it")
        k = int(free[int(rng.integers(len(free)))])
    else:
        k = check_index(goal_index, len(positions), "goal_index")
        if k not in free:
            raise ValueError(f"goal_index: sit goal {k} of this {obj.category} has the object in front of it "
                             f"(free goals: {free})")
    return k, np.asarray(positions[k], dtype=np.float64), unit[k]


@dataclass(eq=False)
class SitInfo:
    """What :func:`sit_sequence` reports besides its plans."""

    cross_side: str             # "left" or "right": the leg that crosses over ("crossed_legs")
    posture: dict               # seated pelvis pitch and spine flexion (radians): {"pelvis", "spine"}
    backrest: Optional[float]   # distance behind the seated pelvis to a backrest, metres (None: none)
    settle: int                 # frame (from the first plan) at which the pelvis settles on the goal
    deep_seat: bool             # the pelvis landed near the front edge and scooted back
    feet_hanging: bool          # the seat is too high for the feet to stay on the floor
    raised: bool                # seated with the feet off the floor (deep seat or hanging feet)
    seated_ankles: np.ndarray   # (2, 3) ankle positions while seated
    rise: Callable              # rise(rng) -> plans from seated back to standing ("stand_up")


def sit_sequence(body: PlanBody, obj, goal, direction, style, rng, start_root, ankles, feet, heading0, *,
                 stand_up: bool, hold_seconds: tuple):
    """Plans for sitting down on ``goal`` from a standing pose (pelvis ``start_root``, planted
    ``ankles`` and ``feet``, ``heading0``), holding, and optionally standing up.

    On a deep seat (see :func:`_edge_goal`) the pelvis first lands near the front edge, then
    scoots back onto the goal while the legs come up onto the cushion (still "sit_down").
    """
    heading = heading_of(direction)
    posture = _sit_posture(style, rng)
    cross_side = int(rng.integers(2))
    edge = _edge_goal(obj, goal, direction)
    deep = bool(np.linalg.norm(edge - goal) > 1e-9)
    # A brisk sit-down; onto a deep seat a shorter one, as the scoot back onto the goal follows.
    n_down = n_frames(rng.uniform(0.9, 1.2) if deep else rng.uniform(1.0, 1.5))
    lean_peak = math.radians(rng.uniform(22.0, 38.0))
    u = np.arange(n_down) / n_down
    feet_mid = 0.5 * (ankles[0] + ankles[1])
    hanging = None
    if np.linalg.norm(feet_mid[:2] - edge[:2]) > _seated_reach(body, edge) + 0.02:
        hanging = _hanging_ankles(body, obj, edge, heading)
    plans = [_sit_down_plan(u, start_root, edge, heading0, heading, ankles, feet, posture, lean_peak, style,
                            cross_side, "sit_down", hanging=hanging)]
    seated_ankles = ankles if hanging is None else hanging
    if deep:
        seated_ankles = _raised_ankles(body, goal, heading)
        n_scoot = n_frames(rng.uniform(0.5, 0.7))
        plans.append(_scoot_plan(np.arange(n_scoot) / n_scoot, edge, goal, heading, ankles, feet, seated_ankles,
                                 posture, style, cross_side, "sit_down"))
    settle = sum(len(p.root) for p in plans)
    hold_t = rng.uniform(*hold_seconds)
    if style in ("leaning_back", "crossed_legs"):
        hold_t += 1.0 + (0.8 if stand_up else 0.0)
    backrest = _backrest_distance(obj, goal, direction) if style == "leaning_back" else None
    raised = deep or hanging is not None
    plans.append(_sit_hold_plan(n_frames(hold_t), goal, heading, seated_ankles, feet, posture, style, cross_side, rng,
                                stand_up, backrest, raised=raised))

    def rise(rng):
        """Plans from seated on the goal to standing where the sit-down started ("stand_up")."""
        out = []
        if deep:
            n_scoot = n_frames(rng.uniform(0.7, 1.0))
            out.append(_scoot_plan(1.0 - (np.arange(n_scoot) + 1) / n_scoot, edge, goal, heading, ankles, feet,
                                   seated_ankles, posture, style, cross_side, "stand_up"))
        n_up = n_frames(rng.uniform(1.0, 1.4))
        u_up = 1.0 - (np.arange(n_up) + 1) / n_up
        out.append(_sit_down_plan(u_up, start_root, edge, heading, heading, ankles, feet, posture,
                                  math.radians(rng.uniform(25.0, 40.0)), style, cross_side, "stand_up",
                                  hanging=hanging))
        return out

    if stand_up:
        plans.extend(rise(rng))
    info = SitInfo(cross_side=SIDES[cross_side], posture=posture, backrest=backrest, settle=settle, deep_seat=deep,
                   feet_hanging=hanging is not None, raised=raised, seated_ankles=seated_ankles, rise=rise)
    return plans, info


def lowest_clearance(motion: Motion, obj, frames) -> float:
    """Smallest signed distance (metres) from ``obj`` to the body surface over ``frames`` of ``motion``."""
    vertices = body_from_motion(motion, frames).double().numpy().reshape(-1, 3)
    return float(obj.sdf(vertices).min()) if len(vertices) else math.inf


def _check_arrival(arrival) -> tuple[float, float]:
    values = tuple(arrival) if isinstance(arrival, (tuple, list)) else ()
    if len(values) != 2 or not all(isinstance(v, (int, float)) and math.isfinite(v) and v >= 0 for v in values):
        raise ValueError(f"arrival: expected (lateral metres, turn radians), two non-negative numbers, got {arrival!r}")
    return float(values[0]), float(values[1])


def approach_seat(body: PlanBody, obj, goal, direction, rng, start_position, approach: bool,
                  arrival: Optional[tuple] = None):
    """Walk to the front of a seat, arriving with the back to it, and (rarely) back up to it.

    ``arrival = (lateral, turn)``: the walk stops up to ``lateral`` metres to either side of the
    spot and turned up to ``turn`` radians from the seat's facing (both uniform), and the sit-down
    that follows takes the pelvis from there onto the seat; None (the default, no draws): on the spot.

    The walk passes along the seat's front, where a walking body clears the object, and its last
    steps turn the walker to face away from the seat while they come in to the spot the sit-down
    starts from (``walk_path(..., end_turn="steps")``). When those turning steps would
    brush the object, the walk ends on the walking body's lane instead and the sitter backs up to
    the seat in two quick steps.

    Returns ``(walk or None, (local, root) at the walk's end, backing plans, (stand_root, ankles,
    feet, heading))`` with the last the state the sit-down starts from.
    """
    edge = _edge_goal(obj, goal, direction)
    seat_dist, walk_dist = _sit_stand_distances(body, obj, edge, direction, rng)
    heading = heading_of(direction)
    spot = edge[:2] + seat_dist * direction[:2]
    if arrival is not None:
        lateral, turn = _check_arrival(arrival)
        spot = spot + rng.uniform(-lateral, lateral) * np.array([-direction[1], direction[0]])
        heading = heading + rng.uniform(-turn, turn)
    lane = max(walk_dist - seat_dist, 0.0)
    back = 0.0
    walk = None
    if approach:
        waypoints = approach_waypoints(spot, direction, rng, [obj], start_position, goal[:2], True, lane=lane)
        walk = walk_path(waypoints, betas=body.betas, seed=rng, end_heading=heading, settle=False,
                         end_turn="steps")
        if lane > 0.03:
            # The frames that leave the lane for the spot (the last 0.55 m of the walk) may come
            # no closer than standing on the spot does (where the calves may touch a seat too
            # high for the seated legs to reach farther), and never more than 1.5 cm into it.
            near = np.linalg.norm(walk.root_position[:, :2].double().numpy() - spot[None], axis=-1) < 0.55
            standing = lowest_clearance(walk, obj, [len(walk) - 1])
            limit = max(min(standing, 0.0) - 0.005, -0.015)
            if lowest_clearance(walk, obj, np.flatnonzero(near)) < limit:
                back = lane
                waypoints = waypoints.copy()
                waypoints[-1] = waypoints[-1] + lane * direction[:2]
                walk = walk_path(waypoints, betas=body.betas, seed=rng, end_heading=heading, settle=False,
                                 end_turn="steps")
        local0, root0 = walk.local_rotations[-1].double().numpy(), walk.root_position[-1].double().numpy()
    else:
        local0, root0 = standing_pose(body.betas, position=spot, heading=heading)
        local0, root0 = local0.double().numpy(), root0.double().numpy()
    ankles, feet, heading0 = start_state(body, local0, root0)
    backing = []
    if back > 0.0:
        n_back = n_frames(rng.uniform(0.5, 0.7))
        plan, (root0_, ankles, feet) = _step_plan(n_back, root0, heading0, ankles, feet, -back * direction[:2], rng,
                                                  "walk")
        backing.append(plan)
        return walk, (local0, root0), backing, (root0_, ankles, feet, heading0)
    return walk, (local0, root0), backing, (root0, ankles, feet, heading0)


@single_threaded
def sit(obj, *, betas=None, seed=0, style: Optional[str] = None, goal_index: Optional[int] = None,
        approach: bool = True, stand_up: bool = True, start_position=None, arrival: Optional[tuple] = None) -> Motion:
    """Walk to a seat, sit down in a style, stay seated, optionally stand up and walk away.

    Sequence (SAMP §4.1): an approach walk from a start at least 1.5 m away (``start_position``
    or sampled in front of the seat) to a spot in front of the sit goal, whose last steps turn
    the walker round to face away from the seat ("walk"; where those steps would brush the
    object, the walk ends a few centimetres farther out and two quick steps back up to the seat);
    "sit_down" (1–1.5 s; onto a deep seat 0.9–1.2 s and a scoot back): the pelvis lowers and
    moves back onto the goal along a smooth curve while the torso leans forward and back and the
    feet stay planted;
    "sit": settled, the style's motion (leaning back against the backrest, crossing the legs,
    hands on the knees or thighs) and breathing; "stand_up" (the sit-down curve in reverse) and a
    short walk away.

    The pelvis at the settle frame equals the sit goal position exactly; that frame is NIFTY's
    sitting anchor (§3.3, "the moment a person settles in a chair"), ``meta["anchor_frame"]``.

    Args:
        obj: a sittable ``ToyObject`` (``objects.SITTABLE``), placed in the world.
        betas: ``(10,)`` toy body shape, or None for the mean body.
        seed: int or ``numpy.random.Generator``.
        style: one of ``SIT_STYLES``, or None to draw one from the seed.
        goal_index: which of ``obj.sit_goals`` to use, or None to draw one.
        approach: walk to the seat first; without it the clip starts standing at the spot.
        stand_up: stand up and walk away at the end.
        start_position: ``(2,)`` metres, where the approach starts (default: sampled).
        arrival: ``(lateral m, turn rad)``: the approach stops off the spot and turned by up to these
            (uniform), and the sit-down corrects it (:func:`approach_seat`); None: on the spot.
    Returns:
        ``Motion`` with actions, contacts (pelvis while seated; feet while planted) and ``meta``
        (kind, style, seed, object, goal_index, sit_goal, anchor_frame).
    """
    check_object(obj, SITTABLE, "obj")
    rng = seeded_rng(seed)
    body = PlanBody(check_betas(betas))
    if style is None:
        style = str(rng.choice(SIT_STYLES))
    check_choice(style, SIT_STYLES, "style")
    k, goal, direction = _sit_goal(obj, goal_index, rng)
    heading = heading_of(direction)
    walk, (local0, root0), backing, state = approach_seat(body, obj, goal, direction, rng, start_position, approach,
                                                          arrival)
    plans, info = sit_sequence(body, obj, goal, direction, style, rng, *state, stand_up=stand_up,
                               hold_seconds=(0.8, 1.6))
    interaction = plan_to_motion(Plan.concat(backing + plans), body, start=(local0, root0))
    info.settle += sum(len(p.root) for p in backing)
    after = None
    if stand_up:
        after = walk_away(body, rng, interaction.local_rotations[-1].double().numpy(),
                          interaction.root_position[-1].double().numpy(), heading, rng.uniform(0.5, 0.8))
    meta = {"kind": "sit", "style": style, "seed": seed_record(seed), "object": describe_object(obj), "goal_index": k,
            "sit_goal": {"position": goal, "direction": direction}, "cross_side": info.cross_side,
            "deep_seat": info.deep_seat, "feet_hanging": info.feet_hanging}
    motion, first = join_clips(walk, interaction, after, meta)
    motion.meta["anchor_frame"] = first + info.settle
    motion.meta["interaction_start"] = first
    return motion
