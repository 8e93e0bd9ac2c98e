"""Lying clips (:func:`lie`): sit down on a sofa as in ``sitting``, then tip sideways and roll
onto the back along the cushion (the spine bending up where an armrest is in the way), rest,
and optionally sit up, stand up and walk away.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np
import torch

from ...infra.device import single_threaded
from ..._validate import check_choice
from ..motion import FPS, Motion, action_id
from ..objects.categories import LYING
from ..rotations import axis_angle_to_matrix, matrix_to_axis_angle
from .approach import join_clips, walk_away
from .body_plan import (
    CHEST, ELBOW_POLE, FOOT_CONTACT, HEAD, NECK, PELVIS, PELVIS_CONTACT, SIGN, SPINE, UP, Plan, PlanBody, check_betas,
    check_index, check_object, describe_object, n_frames, plan_to_motion, second_hand_target, seed_record, upper_local,
)
from .motion_math import (
    bump, forward_xyz, heading_of, lerp, min_jerk, normalize, right_xyz, rot_axis, rot_x, rot_z, seeded_rng, smoothstep,
)
from .sitting import approach_seat, front_is_free, lift_path, lift_relax, seated_hands, sit_sequence

__all__ = ["LIE_STYLES", "lie"]

LIE_STYLES = ("on_back", "knees_up", "hands_behind_head")


def _free_length(obj, origin, direction, z, max_dist=1.5, step=0.01) -> float:
    """Distance from ``origin`` along horizontal ``direction`` (at height ``z``) to the first point inside ``obj``."""
    t = np.arange(0.0, max_dist + 1e-9, step)
    pts = origin[None] + t[:, None] * direction[None]
    pts[:, 2] = z
    inside = obj.sdf(pts) < 0
    return float(t[np.argmax(inside)]) if inside.any() else max_dist


def _lying_rotation(head_dir):
    """Pelvis orientation lying on the back with the head towards ``head_dir (3,)`` (face up)."""
    z = normalize(head_dir)
    y = UP.copy()
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=1)


def _lie_pose_search(body: PlanBody, obj, goal, head_dir, style):
    """Spine flexion (radians) that lifts the head and chest clear of an armrest, and the ankle reach.

    Lying on the back, forward flexion raises the chest and head (as when resting the head on
    the armrest). Returns ``(flexion, ankle_distance)``: the smallest flexion on a grid whose head,
    neck and chest joints keep their capsule radius clear of the object, and how far from the
    pelvis along ``-head_dir`` the ankles rest.
    """
    flex = np.radians(np.arange(0.0, 61.0, 3.0))
    N = len(flex)
    plan = Plan.empty(N)
    plan.root[:] = goal
    plan.pelvis[:] = _lying_rotation(head_dir)
    plan.spine[:, 0] = flex
    plan.neck[:, 0] = 0.4 * flex
    _, pos = body.fk(upper_local(plan, body), plan.root)
    clear = np.ones(N, dtype=bool)
    for joint, radius in ((HEAD, 0.09), (NECK, 0.06), (CHEST, 0.10)):
        clear &= obj.sdf(pos[:, joint]) > radius - 0.02
    k = int(np.argmax(clear)) if clear.any() else N - 1
    cushion = goal[2] - 0.10
    free = _free_length(obj, goal, -normalize(head_dir), cushion + 0.06)
    straight = 0.95 * float(body.leg_length.min())
    reach = 0.55 if style == "knees_up" else straight
    return float(flex[k]), float(min(reach, max(free - 0.15, 0.45)))


def _lie_down_plan(u, seat, seat_heading, posture, goal, head_dir, ankles_floor, feet_floor, flex, ankle_dist,
                   style, raised, action):
    """Frames of lying down from sitting (``u`` 0 → 1), or sitting up again (``u`` 1 → 0).

    ``ankles_floor`` are the seated ankles: planted on the floor, or resting on a deep cushion
    when ``raised`` (the feet then never touch the floor).
    """
    T = len(u)
    plan = Plan.empty(T)
    r_sit = rot_z(seat_heading) @ rot_x(-posture["pelvis"])
    head = normalize(head_dir)
    axis1 = normalize(np.cross(r_sit[:, 2], head))
    r_side = rot_axis(axis1, math.acos(float(np.clip(r_sit[:, 2] @ head, -1, 1)))) @ r_sit
    r_lie = _lying_rotation(head)
    w1 = min_jerk(u / 0.65)
    w2 = min_jerk((u - 0.3) / 0.7)
    step1 = matrix_to_axis_angle(torch.as_tensor(r_side @ r_sit.T)).numpy()
    step2 = matrix_to_axis_angle(torch.as_tensor(r_lie @ r_side.T)).numpy()
    d1 = axis_angle_to_matrix(torch.as_tensor(w1[:, None] * step1[None])).numpy()
    d2 = axis_angle_to_matrix(torch.as_tensor(w2[:, None] * step2[None])).numpy()
    plan.pelvis = d2 @ d1 @ r_sit
    move = min_jerk(u / 0.85)
    plan.root = lerp(np.broadcast_to(seat, (T, 3)), np.broadcast_to(goal, (T, 3)), move)
    lying = smoothstep((u - 0.4) / 0.6)
    plan.spine[:, 0] = posture["spine"] * (1.0 - smoothstep(u / 0.4)) + flex * lying + math.radians(10) * bump(u)
    plan.neck[:, 0] = -0.55 * (posture["pelvis"] + posture["spine"]) * (1.0 - smoothstep(u / 0.4)) + 0.4 * flex * lying
    # Legs swing from the floor onto the cushion, over the seat's front edge.
    lateral = np.cross(UP, head)  # the lying body's right
    lift = min_jerk((u - 0.1) / 0.75)
    hips_goal = goal - 0.09 * head
    for i in range(2):
        rest = hips_goal - ankle_dist * head + SIGN[i] * 0.10 * lateral
        rest[2] = goal[2] - 0.04 + (0.06 if style == "knees_up" else 0.0)
        plan.ankle[:, i] = lift_path(ankles_floor[i], rest, lift, 0.22)
        plan.relax[:, i] = 1.0 if raised else lift_relax(lift)
        sit_pole = forward_xyz(seat_heading) + 0.15 * SIGN[i] * right_xyz(seat_heading)
        if raised:
            sit_pole = UP + 0.3 * forward_xyz(seat_heading) + 0.2 * SIGN[i] * right_xyz(seat_heading)
        lie_pole = UP + 0.25 * SIGN[i] * lateral
        plan.knee_pole[:, i] = normalize(lerp(np.broadcast_to(sit_pole, (T, 3)), np.broadcast_to(lie_pole, (T, 3)),
                                              smoothstep(lift / 0.5)))
        plan.contacts[:, FOOT_CONTACT[i]] = (lift <= 0.0) & (not raised)
    plan.foot[:] = feet_floor
    # Hands: from the lap (the seated target) to the belly or under the head.
    seated_hands(plan, slice(None), "upright", 0, np.ones(T))
    for i in range(2):
        if style == "hands_behind_head":
            local = np.array([SIGN[i] * 0.09, -0.08, 0.03])
            joint, t = (HEAD, HEAD), 0.0
            # The elbow swings out sideways on its way up (a straight blend of the two poles
            # would pass the shoulder-wrist line and flip the elbow).
            swing = smoothstep((u - 0.4) / 0.6)
            pole = lerp(np.broadcast_to(ELBOW_POLE[i], (T, 3)),
                        np.broadcast_to(np.array([SIGN[i] * 1.0, 0.2, 0.7]), (T, 3)), swing)
            pole[:, 0] += SIGN[i] * 1.5 * bump(swing)
            plan.elbow_pole[:, i] = normalize(pole)
        else:
            local = np.array([SIGN[i] * 0.07, 0.15, 0.0])
            joint, t = (PELVIS, SPINE[1]), 0.6
        offset = np.einsum("tij,j->ti", plan.pelvis, local)
        mix = smoothstep((u - 0.3) / 0.7)
        second_hand_target(plan, slice(None), i, joint[0], joint[1], t, offset, mix)
        if style == "hands_behind_head":
            # Up in front of the chest and out, not through the shoulder, on the way to the head.
            arc = np.einsum("tij,j->ti", plan.pelvis, np.array([SIGN[i] * 0.20, 0.30, 0.0])) * bump(mix)[:, None]
            plan.hand_offset[:, i] += arc
            plan.hand2_offset[:, i] += arc
    plan.actions[:] = action_id(action)
    plan.contacts[:, PELVIS_CONTACT] = True
    return plan


@single_threaded
def lie(obj, *, betas=None, seed=0, style: Optional[str] = None, goal_index: Optional[int] = None,
        approach: bool = True, stand_up: bool = False, start_position=None, arrival: Optional[tuple] = None) -> Motion:
    """Walk to a sofa, sit down, lie down on the back along the cushion, and rest.

    Sequence (SAMP §4.1, lying styles of its Fig. S.1): approach and "sit_down" as in
    :func:`sit` onto the sit goal nearest the lie goal, a short "sit", then "lie_down": the torso
    tips sideways and rolls onto the back (the pelvis orientation follows two minimum-jerk
    rotations) while the pelvis moves to the lie goal and the legs swing onto the seat; "lie":
    settled, breathing. With ``stand_up`` the person sits up again ("stand_up", the lie-down in
    reverse), stands up and walks away.

    The pelvis at the first "lie" frame equals the lie goal position exactly;
    ``meta["anchor_frame"]`` is that frame. The spine bends up where an armrest is in the way
    of the head, and the knees bend where the cushion is shorter than the legs.

    Args:
        obj: a ``ToyObject`` of category "sofa" or "l_sofa" (``objects.LYING``), placed in the world.
        betas: ``(10,)`` toy body shape, or None.
        seed: int or ``numpy.random.Generator``.
        style: one of ``LIE_STYLES`` ("on_back" with the hands on the belly, "knees_up",
            "hands_behind_head"), or None to draw one.
        goal_index: which of ``obj.lie_goals``, or None to draw one.
        approach: walk to the sofa first.
        stand_up: sit up, stand up and walk away at the end.
        start_position: ``(2,)`` metres, where the approach starts (default: sampled).
        arrival: ``(lateral m, turn rad)`` off the spot where the approach stops (``sitting.approach_seat``).
    Returns:
        ``Motion`` with actions, contacts (pelvis from the settle on the seat to the end of the
        lying; feet while on the floor) and ``meta`` (kind, style, seed, object, goal_index,
        lie_goal, sit_goal, anchor_frame, sit_anchor_frame).
    """
    check_object(obj, LYING, "obj")
    rng = seeded_rng(seed)
    body = PlanBody(check_betas(betas))
    if style is None:
        style = str(rng.choice(LIE_STYLES))
    check_choice(style, LIE_STYLES, "style")
    positions, directions = obj.lie_goals
    if goal_index is None:
        k = int(rng.integers(len(positions)))
    else:
        k = check_index(goal_index, len(positions), "goal_index")
    goal = np.asarray(positions[k], dtype=np.float64)
    head_dir = normalize(np.array([directions[k][0], directions[k][1], 0.0]))
    sit_pos, sit_dir = obj.sit_goals
    # Sit where the pelvis has least far to go, on a seat facing across the lying direction.
    across = np.abs(sit_dir[:, :2] @ head_dir[:2]) < 0.5
    free = np.array([front_is_free(obj, p, normalize(np.array([d[0], d[1], 0.0]))) for p, d in zip(sit_pos, sit_dir)])
    dist = np.linalg.norm(sit_pos[:, :2] - goal[None, :2], axis=-1) + 10.0 * (~across) + 10.0 * (~free)
    s_idx = int(np.argmin(dist + rng.uniform(0.0, 0.05, len(dist))))
    seat = np.asarray(sit_pos[s_idx], dtype=np.float64)
    seat_dir = normalize(np.array([sit_dir[s_idx][0], sit_dir[s_idx][1], 0.0]))
    heading = heading_of(seat_dir)
    walk, (local0, root0), backing, state = approach_seat(body, obj, seat, seat_dir, rng, start_position, approach,
                                                          arrival)
    plans, info = sit_sequence(body, obj, seat, seat_dir, "upright", rng, *state, stand_up=False,
                               hold_seconds=(0.3, 0.6))
    plans = backing + plans
    info.settle += sum(len(p.root) for p in backing)
    posture = info.posture
    _, _, feet, _ = state
    flex, ankle_dist = _lie_pose_search(body, obj, goal, head_dir, style)
    lie_args = (seat, heading, posture, goal, head_dir, info.seated_ankles, feet, flex, ankle_dist, style,
                info.raised)
    n_down = n_frames(rng.uniform(1.6, 2.2))
    down = _lie_down_plan(np.arange(n_down) / n_down, *lie_args, "lie_down")
    n_lie = n_frames(rng.uniform(1.5, 2.3))
    rest = _lie_down_plan(np.ones(n_lie), *lie_args, "lie")
    times = np.arange(n_lie) / FPS
    rest.spine[:, 0] += math.radians(rng.uniform(0.8, 1.4)) * np.sin(2 * np.pi * times / rng.uniform(3.0, 4.5))
    n_sit = sum(len(p.root) for p in plans)
    plans = plans + [down, rest]
    if stand_up:
        n_up = n_frames(rng.uniform(1.5, 2.0))
        plans.append(_lie_down_plan(1.0 - (np.arange(n_up) + 1) / n_up, *lie_args, "stand_up"))
        plans.extend(info.rise(rng))
    interaction = plan_to_motion(Plan.concat(plans), body, start=(local0, root0))
    after = None
    if stand_up:
        after = walk_away(body, rng, interaction.local_rotations[-1].double().numpy(),
                          interaction.root_position[-1].double().numpy(), heading, rng.uniform(0.5, 0.8))
    meta = {"kind": "lie", "style": style, "seed": seed_record(seed), "object": describe_object(obj), "goal_index": k,
            "lie_goal": {"position": goal, "direction": head_dir},
            "sit_goal": {"position": seat, "direction": seat_dir, "index": s_idx},
            "deep_seat": info.deep_seat, "feet_hanging": info.feet_hanging}
    motion, first = join_clips(walk, interaction, after, meta)
    motion.meta["sit_anchor_frame"] = first + info.settle
    motion.meta["anchor_frame"] = first + n_sit + n_down
    motion.meta["interaction_start"] = first
    return motion
