"""Lifting clips (:func:`lift`): walk to an object, bend (squat or stoop) until both hands are on
its two lift contacts, and rise carrying it to waist or chest height in front of the body.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from ...infra.device import single_threaded
from ..._validate import check_choice
from ..motion import FPS, Motion
from ..objects.categories import LIFTABLE
from .approach import join_clips, near_extent, walk_to_spot
from .body_plan import (
    ARM_REACH, ELBOW_POLE, SHOULDER, SIGN, UP, WRIST_CONTACT, Plan, PlanBody, check_betas, check_object,
    describe_object, hand_on_point, n_frames, plan_to_motion, seed_record, start_state, upper_local,
)
from .motion_math import (
    forward_xyz, heading_of, lerp, min_jerk, normalize, right_xyz, rot_z, seeded_rng, smoothstep, wrap_angle,
)
from .standing import bend_plan, chest_frames, choose_bend, reach_spot

__all__ = ["LIFT_STYLES", "lift"]

LIFT_STYLES = ("squat", "stoop")


def _carry_point(body: PlanBody, obj, stand_root, heading, contacts, near, rng):
    """Where the contacts' midpoint is carried: in front of the standing body at waist or chest height,
    within reach of both shoulders (searched on a small grid around a sampled preference)."""
    facing = forward_xyz(heading)
    m0 = contacts.mean(0)
    half = contacts - m0
    bottom = m0[2] - float(obj.bounds[0, 2])
    plan = Plan.empty(1)
    plan.root[:] = stand_root
    plan.pelvis[:] = rot_z(heading)
    _, pos = body.fk(upper_local(plan, body)[0], stand_root)
    forward = np.arange(near - 0.04, near + 0.40, 0.02)
    heights = np.arange(0.7, 1.46, 0.02)
    F, Z = np.meshgrid(forward, heights, indexing="ij")
    F, Z = F.ravel(), Z.ravel()
    points = stand_root[None] * np.array([1.0, 1.0, 0.0]) + F[:, None] * facing[None] + Z[:, None] * UP[None]
    slack = np.zeros(len(F))
    for i in range(2):
        dist = np.linalg.norm(points + half[i][None] - pos[SHOULDER[i]][None], axis=-1)
        slack += np.clip(dist - ARM_REACH * body.arm_length[i], 0.0, None)
    slack += np.clip(0.05 - (Z - bottom), 0.0, None)
    prefer_f, prefer_z = near + rng.uniform(0.17, 0.24), rng.uniform(0.95, 1.1)
    # Closer than 0.12 m the object presses into the belly: allowed (a hug) but avoided.
    cost = (F - prefer_f) ** 2 + (Z - prefer_z) ** 2 + 100.0 * slack + 10.0 * np.clip(near + 0.12 - F, 0.0, None)
    k = int(np.argmin(cost))
    return points[k]


@single_threaded
def lift(obj, *, betas=None, seed=0, style: Optional[str] = None, approach: bool = True,
         start_position=None) -> Motion:
    """Walk to an object, bend, take it with both hands and lift it to waist or chest height.

    Sequence (NIFTY's lifting, §4.2; BEHAVE-like): an approach walk that ends facing the object
    (``obj.lift_approach``) a foot's length from it; a bend ("squat": knees bent, or "stoop":
    hips hinged; the depth is searched so both shoulders reach the contacts, the legs reach the
    planted feet and the head and chest keep clear of the object); both wrists move onto the
    object's two ``lift_contacts`` EXACTLY (two-bone IK) — the first frame of contact is NIFTY's
    lifting anchor, ``meta["anchor_frame"]``; a short hold; then the body rises and the object,
    carried in the chest's frame, comes up to a carry point in front of the body while the hands
    stay on the moving contacts; a short hold. All interaction frames are labelled "lift".

    Args:
        obj: a liftable ``ToyObject`` (``objects.LIFTABLE``), placed in the world.
        betas: ``(10,)`` toy body shape, or None.
        seed: int or ``numpy.random.Generator``.
        style: one of ``LIFT_STYLES``, or None to draw one.
        approach: walk to the object first.
        start_position: ``(2,)`` metres, where the approach starts (default: sampled).
    Returns:
        ``Motion``; ``meta["object_poses"]`` is ``(T, 4, 4)`` world_from_object per frame (the
        placed pose until contact); hand contacts are true from the anchor on.
    """
    check_object(obj, LIFTABLE, "obj")
    rng = seeded_rng(seed)
    body = PlanBody(check_betas(betas))
    if style is None:
        style = str(rng.choice(LIFT_STYLES))
    check_choice(style, LIFT_STYLES, "style")
    contacts = np.asarray(obj.lift_contacts, dtype=np.float64)
    facing = normalize(np.array([obj.lift_approach[0], obj.lift_approach[1], 0.0]))
    heading = heading_of(facing)
    m0 = contacts.mean(0)
    near = near_extent([obj], m0, -facing, 0.5 * float(np.linalg.norm(contacts[1] - contacts[0])),
                       float(obj.bounds[1, 2]))
    targets = {0: contacts[0], 1: contacts[1]}
    spot, hug = reach_spot(body, [obj], m0, near, heading, targets, style, rng)
    centre = obj.bounds.mean(0)[:2]
    walk, (local0, root0) = walk_to_spot(body, rng, spot, heading, -facing, [obj], start_position, centre, approach)
    ankles, feet, heading0 = start_state(body, local0, root0)
    heading = heading0 + float(wrap_angle(heading - heading0))
    h, alpha, _, _ = choose_bend(body, root0, heading, ankles, targets, style, rng, obstacles=[obj], hug=hug)
    right = right_xyz(heading)
    hand_down = normalize(-UP + 0.3 * facing)
    pole = np.array([[-0.7, -0.7, -0.3], [0.7, -0.7, -0.3]])

    # Bend and reach: the hands come from outside and above onto the contacts.
    n_bend = n_frames(rng.uniform(0.9, 1.3))
    u = np.arange(n_bend) / n_bend
    bend = bend_plan(n_bend, root0, heading, ankles, feet, style, h * min_jerk(u), alpha * min_jerk(u), "lift")
    reach = smoothstep((u - 0.25) / 0.75)
    for i in range(2):
        approach_offset = (1.0 - reach)[:, None] * (SIGN[i] * 0.10 * right + 0.06 * UP)[None]
        hand_on_point(bend, slice(None), i, contacts[i][None] + approach_offset, reach)
        bend.hand_dir[:, i] = hand_down
        bend.hand_dir_weight[:, i] = reach
        bend.elbow_pole[:, i] = normalize(lerp(np.broadcast_to(ELBOW_POLE[i], (n_bend, 3)),
                                               np.broadcast_to(pole[i], (n_bend, 3)), reach))

    # Hold: exact contact, then rise with the object.
    n_hold = n_frames(rng.uniform(0.15, 0.3))
    n_rise = n_frames(rng.uniform(1.0, 1.5))
    n_end = n_frames(rng.uniform(0.5, 0.9))
    T = n_hold + n_rise + n_end
    rise_u = np.concatenate([np.zeros(n_hold), (np.arange(n_rise) + 1) / n_rise, np.ones(n_end)])
    s = min_jerk(rise_u)
    final_h, final_alpha = 0.01, math.radians(-3.0)
    carry = bend_plan(T, root0, heading, ankles, feet, style, h + (final_h - h) * s,
                      alpha + (final_alpha - alpha) * s, "lift")
    times = np.arange(T) / FPS
    carry.spine[:, 0] += math.radians(1.0) * np.sin(2 * np.pi * times / 3.5) * smoothstep(rise_u)
    chest_rot, chest_pos, _ = chest_frames(carry, body)
    stand_plan = bend_plan(1, root0, heading, ankles, feet, style, np.array([final_h]), np.array([final_alpha]),
                           "lift")
    m1 = _carry_point(body, obj, stand_plan.root[0], heading, contacts, near, rng)
    m_local0 = chest_rot[0].T @ (m0 - chest_pos[0])
    m_local1 = chest_rot[-1].T @ (m1 - chest_pos[-1])
    m_local = lerp(np.broadcast_to(m_local0, (T, 3)), np.broadcast_to(m_local1, (T, 3)), s)
    mid = chest_pos + np.einsum("tij,tj->ti", chest_rot, m_local)
    for i in range(2):
        hand_on_point(carry, slice(None), i, mid + (contacts[i] - m0)[None], np.ones(T))
        carry.hand_dir[:, i] = hand_down
        carry.hand_dir_weight[:, i] = 1.0
        carry.elbow_pole[:, i] = pole[i]
        carry.contacts[:, WRIST_CONTACT[i]] = True

    interaction = plan_to_motion(Plan.concat([bend, carry]), body, start=(local0, root0))
    meta = {"kind": "lift", "style": style, "seed": seed_record(seed), "object": describe_object(obj),
            "lift_contacts": contacts, "bend": {"pelvis_drop": h, "pelvis_pitch": alpha}}
    motion, first = join_clips(walk, interaction, None, meta)
    anchor = first + n_bend
    poses = np.broadcast_to(np.asarray(obj.pose, dtype=np.float64), (len(motion), 4, 4)).copy()
    poses[anchor:, :3, 3] += mid - m0[None]
    motion.meta.update({"anchor_frame": anchor, "interaction_start": first, "object_poses": poses})
    return motion
