"""Door and drawer clips (:func:`open_door`, :func:`open_drawer`): walk to a cabinet or a chest of
drawers, take the handle and pull it open (on its circle about the hinge, or straight out) while
the wrist follows the handle exactly and the feet step back under the body.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ...infra.device import single_threaded
from ..motion import FPS, Motion
from .approach import join_clips, walk_to_spot
from .body_plan import (
    FOOT_CONTACT, SIDES, SIGN, UP, WRIST_CONTACT, Plan, PlanBody, check_betas, check_hand, check_object,
    describe_object, hand_on_point, n_frames, plan_to_motion, seed_record, start_state,
)
from .lifting import LIFT_STYLES
from .motion_math import (
    forward_xyz, heading_of, min_jerk, normalize, right_xyz, rot_x, rot_z, seeded_rng, smoothstep, wrap_angle,
)
from .standing import bend_params, bend_plan, choose_bend, reach_spot, standing_plan, step_feet

__all__ = ["open_door", "open_drawer", "handle_circle"]


def handle_circle(obj):
    """Centre ``(3,)`` (on the hinge axis, at handle height) and the swing sign of a cabinet door's handle.

    The handle at door angle ``q`` is ``centre + R_z(sign q) (handle(0) - centre)``.
    """
    closed = obj.with_params(door_angle=0.0).handle_point
    quarter = obj.with_params(door_angle=math.pi / 2).handle_point
    sign = -float(obj.params["hinge_side"])
    rot = rot_z(sign * math.pi / 2)[:2, :2]
    centre = np.linalg.solve(np.eye(2) - rot, quarter[:2] - rot @ closed[:2])
    return np.array([centre[0], centre[1], closed[2]]), sign, closed


def _handle_clip(kind: str, obj, *, betas, seed, hand, amount, approach, start_position) -> Motion:
    """Reach a door or drawer handle, pull it open while stepping back, and keep holding it."""
    rng = seeded_rng(seed)
    body = PlanBody(check_betas(betas))
    state = "door_angle" if kind == "open_door" else "drawer_open"
    low, high = ((math.radians(70.0), math.radians(100.0)) if kind == "open_door" else (0.25, 0.35))
    if amount is None:
        amount = float(rng.uniform(low, high))
    elif not (isinstance(amount, (int, float, np.floating, np.integer)) and low <= float(amount) <= high):
        unit = "radians" if kind == "open_door" else "metres"
        name = "angle" if kind == "open_door" else "distance"
        raise ValueError(f"{name}: expected {unit} in [{low:.3f}, {high:.3f}], got {amount!r}")
    closed = obj.with_params(**{state: 0.0})
    normal = normalize(closed.rotation @ np.array([0.0, 1.0, 0.0]))
    facing = -normal
    heading = heading_of(facing)
    right = right_xyz(heading)
    if kind == "open_door":
        centre, sign, handle0 = handle_circle(closed)

        def handle_at(q):
            rot = rot_z(sign * np.asarray(q))
            return centre[None] + np.einsum("tij,j->ti", rot, handle0 - centre)
        handle_side = float((handle0 - centre) @ right)
        side = (1 if handle_side > 0 else 0) if hand is None else check_hand(hand, rng)
        lateral = SIGN[side] * rng.uniform(0.0, 0.08) if side == (1 if handle_side > 0 else 0) else 0.0
    else:
        handle0 = closed.handle_point

        def handle_at(q):
            return handle0[None] + np.asarray(q)[:, None] * normal[None]
        side = check_hand(hand, rng)
        lateral = -SIGN[side] * rng.uniform(0.05, 0.15)
    style = str(rng.choice(LIFT_STYLES))
    targets = {side: handle0}
    spot, hug = reach_spot(body, [closed], handle0, 0.0, heading, targets, style, rng, lateral=lateral,
                           gaps=(0.30, 0.40))
    walk, (local0, root0) = walk_to_spot(body, rng, spot, heading, normal, [closed], start_position,
                                         closed.translation[:2], approach)
    ankles, feet, heading0 = start_state(body, local0, root0)
    heading = heading0 + float(wrap_angle(heading - heading0))
    h, alpha, _, _ = choose_bend(body, root0, heading, ankles, targets, style, rng, obstacles=[closed], hug=hug)
    hand_dir = normalize(forward_xyz(heading) - 0.2 * UP)

    n_reach = n_frames(rng.uniform(0.7, 1.0))
    u = np.arange(n_reach) / n_reach
    reach = bend_plan(n_reach, root0, heading, ankles, feet, style, h * min_jerk(u), alpha * min_jerk(u), kind)
    w = smoothstep(u / 0.9)
    pre = (1.0 - w)[:, None] * (0.10 * normal + 0.04 * UP)[None]
    hand_on_point(reach, slice(None), side, handle0[None] + pre, w)
    reach.hand_dir[:, side] = hand_dir
    reach.hand_dir_weight[:, side] = w

    # Pull: the handle moves; the body keeps its pose relative to the handle and steps along.
    n_hold = n_frames(rng.uniform(0.1, 0.2))
    n_open = n_frames(rng.uniform(1.3, 1.9) if kind == "open_door" else rng.uniform(1.0, 1.4))
    n_end = n_frames(rng.uniform(0.4, 0.7))
    T = n_hold + n_open + n_end
    open_u = np.concatenate([np.zeros(n_hold), (np.arange(n_open) + 1) / n_open, np.ones(n_end)])
    q = amount * min_jerk(open_u)
    handle = handle_at(q)
    turn = SIGN[1 - side] * math.radians(rng.uniform(15.0, 30.0)) if kind == "open_door" else 0.0
    psi = heading + turn * min_jerk(open_u)
    offset = rot_z(heading)[:2, :2].T @ (handle0[:2] - root0[:2])
    pelvis_xy = handle[:, :2] - np.einsum("tij,j->ti", rot_z(psi)[:, :2, :2], offset)
    times = np.arange(T) / FPS
    ankle_t, foot_t, contact_t = step_feet(times, pelvis_xy, psi, ankles, feet, heading, rng)
    pull = standing_plan(T, root0, heading, ankles, feet, kind)
    stand_roots = np.concatenate([pelvis_xy, np.full((T, 1), root0[2])], axis=1)
    back, spine = bend_params(style, np.full(T, h), np.full(T, alpha))
    pull.root = stand_roots - back[:, None] * forward_xyz(psi) - h * UP[None]
    pull.pelvis = rot_z(psi) @ rot_x(np.full(T, -alpha))
    pull.spine[:, 0] = spine
    pull.neck[:, 0] = -0.45 * (alpha + spine)
    pull.ankle = ankle_t
    pull.foot = foot_t
    for i in range(2):
        pull.knee_pole[:, i] = forward_xyz(psi) + 0.15 * SIGN[i] * right_xyz(psi)
        pull.contacts[:, FOOT_CONTACT[i]] = contact_t[:, i]
    hand_on_point(pull, slice(None), side, handle, np.ones(T))
    pull.hand_dir[:, side] = normalize(forward_xyz(psi) - 0.2 * UP)
    pull.hand_dir_weight[:, side] = 1.0
    pull.contacts[:, WRIST_CONTACT[side]] = True

    interaction = plan_to_motion(Plan.concat([reach, pull]), body, start=(local0, root0))
    meta = {"kind": kind, "style": style, "hand": SIDES[side], "seed": seed_record(seed),
            "object": describe_object(closed), "articulation_name": state, "amount": amount}
    motion, first = join_clips(walk, interaction, None, meta)
    anchor = first + n_reach
    articulation = np.zeros(len(motion))
    articulation[anchor:] = q
    motion.meta.update({
        "anchor_frame": anchor, "interaction_start": first, "articulation": articulation,
        "object_poses": np.broadcast_to(np.asarray(closed.pose, dtype=np.float64), (len(motion), 4, 4)).copy(),
        "handle_trajectory": np.concatenate([np.broadcast_to(handle0, (anchor, 3)), handle]),
    })
    return motion


@single_threaded
def open_door(cabinet, *, hand: Optional[str] = None, betas=None, seed=0, angle: Optional[float] = None,
              approach: bool = True, start_position=None) -> Motion:
    """Walk to a cabinet, take the door handle and swing the door open, stepping back as it comes.

    Sequence (CHOICE's capture: opening cabinet doors): an approach facing the cabinet front,
    then "open_door": a bend (searched so the shoulder reaches the handle) while the wrist comes
    onto the handle EXACTLY (the anchor frame), then the door angle goes from 0 to ``angle``
    along a minimum-jerk profile: the handle moves on its circle about the hinge and the wrist
    follows it exactly in every frame, the body keeps its pose relative to the handle (turning
    up to 30° towards the hinge) and the feet step to stay under it; a short hold at the end.

    Args:
        cabinet: a ``ToyObject`` of category "cabinet" (its door is treated as closed at the start).
        hand: "left", "right", or None (the hand on the handle's side).
        betas: ``(10,)`` toy body shape, or None.
        seed: int or ``numpy.random.Generator``.
        angle: final door angle in radians within [70°, 100°]; None: drawn.
        approach: walk to the cabinet first.
        start_position: ``(2,)`` metres, where the approach starts (default: sampled).
    Returns:
        ``Motion``; ``meta["articulation"]`` ``(T,)`` door angle (radians) per frame,
        ``meta["object_poses"]`` ``(T, 4, 4)`` (the carcass does not move),
        ``meta["handle_trajectory"]`` ``(T, 3)``; the object with a frame's angle is
        ``cabinet.with_params(door_angle=meta["articulation"][t])``.
    """
    check_object(cabinet, ("cabinet",), "cabinet")
    return _handle_clip("open_door", cabinet, betas=betas, seed=seed, hand=hand, amount=angle, approach=approach,
                        start_position=start_position)


@single_threaded
def open_drawer(drawer, *, hand: Optional[str] = None, betas=None, seed=0, distance: Optional[float] = None,
                approach: bool = True, start_position=None) -> Motion:
    """Walk to a chest of drawers, take the top drawer's handle and pull it out, stepping back.

    As :func:`open_door`, with the handle moving on a straight line along the unit's front
    normal while ``drawer_open`` goes from 0 to ``distance`` metres (within [0.25, 0.35], the
    drawer's travel); labelled "open_drawer".

    Args:
        drawer: a ``ToyObject`` of category "drawer" (the drawer is treated as closed at the start).
        hand: "left", "right", or None (drawn).
        betas: ``(10,)`` toy body shape, or None.
        seed: int or ``numpy.random.Generator``.
        distance: final opening in metres within [0.25, 0.35]; None: drawn.
        approach: walk to the unit first.
        start_position: ``(2,)`` metres, where the approach starts (default: sampled).
    Returns:
        ``Motion``; ``meta["articulation"]`` ``(T,)`` drawer opening (metres) per frame,
        ``meta["object_poses"]``, ``meta["handle_trajectory"]`` as in :func:`open_door`.
    """
    check_object(drawer, ("drawer",), "drawer")
    return _handle_clip("open_drawer", drawer, betas=betas, seed=seed, hand=hand, amount=distance, approach=approach,
                        start_position=start_position)
