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
from typing import Optional

import numpy as np

from ...infra.device import single_threaded
from ..._validate import as_tensor, check_choice, check_finite, check_shape
from ..kinematics import forward_kinematics
from ..motion import FPS, Motion, action_id
from ..rotations import yaw_of_matrix
from ..skeleton import NUM_JOINTS
from .footsteps import Footstep, assign_heel_off, footstep_plan, plan_footsteps
from .gait_body import SIDES, SIDE_JOINTS, GaitBody
from .gait_params import GAITS, IDLE_GAIT, SIDE_GAIT, TURN_GAIT, GaitParams, sample_style  # noqa: F401 (GaitParams)
from .gait_synthesis import RootPlan, synthesize
from .motion_math import min_jerk, right_xy, rot_z, seeded_rng, smoothstep, wrap_angle
from .paths import GroundPath, path_from_waypoints, path_speed_profile, speed_profile
from .poses import standing_pose

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


def _state_of(body: GaitBody, start):
    """Feet (ball xy, yaw) and root (xy, heading) of a start pose."""
    local, root = start
    glob, pos = forward_kinematics(local, root, body.offsets_torch.double())
    feet = {}
    for side in SIDES:
        ball = pos[SIDE_JOINTS[side]["foot"], :2].numpy().copy()
        yaw = float(yaw_of_matrix(glob[SIDE_JOINTS[side]["ankle"]]))
        feet[side] = (ball, yaw)
    heading = float(yaw_of_matrix(glob[0]))
    return feet, root[:2].numpy().copy(), heading


def _default_start(body: GaitBody, position, heading):
    local, root = standing_pose(body.betas, position=position, heading=heading)
    return local.double(), root.double()


def _positions(value, name):
    arr = np.asarray(value, dtype=np.float64)
    check_shape(arr, (2,), name)
    check_finite(arr, name)
    return arr


# --------------------------------------------------------------------------- clip builders

def _times(duration: float) -> np.ndarray:
    return np.arange(int(math.ceil(duration * FPS)) + 1) / FPS


# Least distance across the heading between the balls (and the ankles) of the feet in turning
# steps, metres (the most a foot is pushed out to keep it is ``footsteps._TURNING_PUSH``).
_TURNING_GAP = 0.12
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


def _turning_schedule(path: GroundPath, s_of_t, speed_of_t, stop: float, end_yaw: float):
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
        w = smoothstep((grid - begin) / max(end - begin, 1e-6))
        if np.all(w * left <= allowed + 1e-6):
            break

    def weight(t):
        return smoothstep((np.asarray(t, dtype=np.float64) - begin) / max(end - begin, 1e-6))

    return weight, float(end)


def _locomotion_segment(body: GaitBody, start, rng: np.random.Generator, *, gait: str, path: GroundPath,
                        speed: Optional[float], settle_hold: float, meta: dict,
                        end_heading: Optional[float] = None) -> Motion:
    """Walk or run along ``path`` from ``start`` and stop with both feet planted.

    With ``end_heading`` the body turns to it over the last steps while the root finishes the
    path (turning steps: the root's heading leaves the path's tangent as the walker slows down).
    """
    params = GAITS[gait]
    style = sample_style(rng, params)
    cruise = float(rng.uniform(*params.speed)) if speed is None else float(speed)
    feet, _, start_heading = _state_of(body, start)
    # Peak acceleration of the smooth ramps: 1.5 * speed / ramp time, ramp time = accel_time * speed.
    s_of_t, stop, speed_of_t = path_speed_profile(path, cruise, 1.0 / params.accel_time, params.lateral_accel,
                                                  params.min_turn_speed)
    step_length = body.hip_height * (params.step_ratio[0] + params.step_ratio[1] * cruise) * rng.uniform(0.94, 1.06)
    step_period = step_length / cruise
    heading0 = path.heading[0]
    start_offset = float(wrap_angle(start_heading - heading0))
    end_offset = 0.0 if end_heading is None else float(wrap_angle(float(end_heading) - path.heading[-1]))
    end_yaw = float(path.heading[-1]) + end_offset
    turning, still = None, stop
    if end_offset != 0.0:
        # Turning steps: the heading leaves the path's direction for ``end_heading`` as the
        # walker slows down, finishing with a short pivot where the turn is large.
        turning, still = _turning_schedule(path, s_of_t, speed_of_t, stop, end_yaw)

    def root_at(t):
        xy, yaw = path.at(s_of_t(t))
        t = np.asarray(t)
        yaw = yaw + start_offset * (1.0 - smoothstep(t / 0.5))
        if turning is not None:
            yaw = yaw + (end_yaw - yaw) * turning(t)
        return xy, yaw

    first = "left" if rng.random() < 0.5 else "right"
    steps = plan_footsteps(root_at, still, initial=feet, first_side=first, step_period=step_period,
                           duty=params.duty, half_width=params.half_width, over_foot=params.over_foot,
                           forward_offset=body.stand_ankle_forward, body=body,
                           min_gap=None if turning is None else _TURNING_GAP,
                           settle_step=None if turning is None else _TURNING_SETTLE_STEP)
    assign_heel_off(steps, style.heel_off, step_length)
    last_touch = max([s.start for s in steps if math.isfinite(s.start)], default=0.0)
    moving_end = max(still, last_touch) + 0.25
    times = _times(moving_end + settle_hold)
    xy, yaw = root_at(times)
    envelope = np.clip(speed_of_t(times) / cruise, 0.0, 1.0)
    root = RootPlan(times=times, xy=xy, yaw=yaw, envelope=envelope)
    actions = np.where(times <= moving_end, action_id(gait), action_id("idle"))
    meta = {**meta, "gait": gait, "speed": cruise, "step_length": step_length,
            "cadence": 1.0 / step_period, "path_length": path.length}
    if turning is not None:
        meta.update(turning_steps=end_offset, pivot=still - stop)
    return synthesize(body, root, steps, params, style, step_period, step_length, actions, start=start, meta=meta)


def _turn_segment(body: GaitBody, start, rng: np.random.Generator, angle: float, settle_hold: float,
                  meta: dict) -> Motion:
    """Turn on the spot by ``angle`` radians with small stepping turns."""
    params = TURN_GAIT
    style = sample_style(rng, params)
    feet, root_xy, heading0 = _state_of(body, start)
    n_steps = max(2, int(math.ceil(abs(angle) / math.radians(rng.uniform(40, 55)))))
    step_period = float(rng.uniform(0.42, 0.55))
    swing = 2 * step_period * (1 - params.duty)
    lift = 0.1
    duration = lift + swing + (n_steps - 1) * step_period + step_period * params.duty
    stop = duration - 0.5 * step_period

    def root_at(t):
        u = min_jerk((np.asarray(t) - 0.05) / max(stop - 0.05, 1e-3))
        return np.broadcast_to(root_xy, np.shape(t) + (2,)).copy(), heading0 + angle * u

    first = "left" if angle > 0 else "right"
    steps = plan_footsteps(root_at, stop, initial=feet, first_side=first, step_period=step_period,
                           duty=params.duty, half_width=params.half_width, over_foot=params.over_foot,
                           forward_offset=body.stand_ankle_forward, body=body, first_lift_off=lift)
    last_touch = max([s.start for s in steps if math.isfinite(s.start)], default=0.0)
    moving_end = max(stop, last_touch) + 0.2
    times = _times(moving_end + settle_hold)
    xy, yaw = root_at(times)
    envelope = np.full(len(times), 0.3)
    root = RootPlan(times=times, xy=xy, yaw=yaw, envelope=envelope)
    actions = np.where(times <= moving_end, action_id("turn"), action_id("idle"))
    meta = {**meta, "angle": float(angle), "steps": n_steps}
    return synthesize(body, root, steps, params, style, step_period, 0.5, actions, start=start, meta=meta)


def _side_segment(body: GaitBody, start, rng: np.random.Generator, distance: float, settle_hold: float,
                  meta: dict) -> Motion:
    """Shift ``distance`` metres to the character's right (negative: left) with side steps."""
    params = SIDE_GAIT
    style = sample_style(rng, params)
    feet, root_xy, heading = _state_of(body, start)
    step_period = float(rng.uniform(0.38, 0.46))
    # Feet never cross: the root moves less than the free width between the feet per step.
    cruise = min(float(rng.uniform(*params.speed)), (2 * params.half_width - 0.14) / step_period)
    s_of_t, stop, cruise_used = speed_profile(abs(distance), cruise, params.accel_time)
    direction = math.copysign(1.0, distance) * right_xy(heading)

    def root_at(t):
        return root_xy + s_of_t(t)[..., None] * direction, np.full(np.shape(t), heading)

    first = "right" if distance > 0 else "left"
    steps = plan_footsteps(root_at, stop, initial=feet, first_side=first, step_period=step_period,
                           duty=params.duty, half_width=params.half_width, over_foot=params.over_foot,
                           forward_offset=body.stand_ankle_forward, body=body)
    last_touch = max([s.start for s in steps if math.isfinite(s.start)], default=0.0)
    moving_end = max(stop, last_touch) + 0.2
    times = _times(moving_end + settle_hold)
    xy, yaw = root_at(times)
    envelope = np.clip(np.gradient(s_of_t(times), times) / cruise_used, 0.0, 1.0)
    root = RootPlan(times=times, xy=xy, yaw=yaw, envelope=envelope)
    actions = np.where(times <= moving_end, action_id("side_step"), action_id("idle"))
    meta = {**meta, "distance": float(distance), "speed": cruise_used}
    return synthesize(body, root, steps, params, style, step_period, 0.5, actions, start=start, meta=meta)


def _smooth_noise(rng: np.random.Generator, times: np.ndarray, amplitude: float, periods=(2.0, 6.0), terms: int = 4):
    """Sum of a few sinusoids of random period and phase: slow, smooth drift ``(T,)`` of RMS ``amplitude``."""
    out = np.zeros_like(times)
    for _ in range(terms):
        period = rng.uniform(*periods)
        out += np.sin(2 * np.pi * times / period + rng.uniform(0, 2 * np.pi))
    return amplitude * out * math.sqrt(2.0 / terms)


def _idle_segment(body: GaitBody, start, rng: np.random.Generator, duration: float, still: bool, meta: dict) -> Motion:
    """Stand on both feet: subtle sway, breathing and arm drift (none when ``still``)."""
    params = IDLE_GAIT
    style = sample_style(rng, params)
    feet, root_xy, heading = _state_of(body, start)
    times = _times(duration)
    T = len(times)
    # Root centred between the feet: the body stands over its support.
    ankle_mid = np.zeros(2)
    for side in SIDES:
        ball, yaw = feet[side]
        ankle_mid += 0.5 * (ball - (rot_z(yaw) @ body.foot[side])[:2])
    stand_mid = 0.5 * (body.stand_ankle["left"] + body.stand_ankle["right"])
    centre = ankle_mid - rot_z(heading)[:2, :2] @ stand_mid
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
        ease = smoothstep(times / 0.6)
        sway = sway * ease
        for key in style.noise:
            style.noise[key] = style.noise[key] * (ease if style.noise[key].ndim == 1 else ease[:, None])
    steps = [Footstep(side, -math.inf, math.inf, feet[side][0], feet[side][1]) for side in SIDES]
    root = RootPlan(times=times, xy=np.broadcast_to(centre, (T, 2)).copy(), yaw=np.full(T, heading),
                    envelope=np.zeros(T))
    actions = np.full(T, action_id("idle"))
    return synthesize(body, root, steps, params, style, 1.0, 0.5, actions, start=start, meta=meta,
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
    rng = seeded_rng(seed)
    body = GaitBody(betas)
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
        if abs(float(wrap_angle(path.heading[0] - heading_now))) > math.radians(25):
            parts.append(_turn_segment(body, state, rng, float(wrap_angle(path.heading[0] - heading_now)), 0.0,
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
        angle = float(wrap_angle(float(end_heading) - heading_now))
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
    rng = seeded_rng(seed)
    body = GaitBody(betas)
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
    rng = seeded_rng(seed)
    body = GaitBody(betas)
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
    rng = seeded_rng(seed)
    body = GaitBody(betas)
    start = _check_start(start)
    if start is None:
        start = _default_start(body, _positions(position, "position"), float(heading))
    return _side_segment(body, start, rng, float(distance), 0.5, {"generator": "side_step"})
