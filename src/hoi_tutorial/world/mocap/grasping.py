"""Reach-and-grasp clips (:func:`reach_grasp`): put a small object on a table or shelf board,
walk there, reach with one hand onto its grasp point, grasp it and optionally pick it up.
"""
from __future__ import annotations

from typing import Optional

import numpy as np

from ...infra.device import single_threaded
from ..motion import Motion
from ..objects import make_object
from ..objects.categories import GRASPABLE
from .approach import join_clips, near_extent, walk_to_spot
from .body_plan import (
    SHOULDER, SIDES, SIGN, UP, WRIST_CONTACT, Plan, PlanBody, check_betas, check_hand, check_index, check_object,
    describe_object, hand_on_point, n_frames, plan_to_motion, seed_record, start_state,
)
from .motion_math import (
    forward_xyz, heading_of, lerp, min_jerk, normalize, right_xyz, rot_z, seeded_rng, smoothstep, wrap_angle,
)
from .standing import bend_plan, chest_frames, choose_bend, reach_spot

__all__ = ["reach_grasp"]


def _place_on_support(obj, rng, grasp_index):
    """Put a small object standing on the floor onto a table or a shelf board, its grasp point
    towards the reacher. Returns ``(placed object, support object or None, towards_person (3,))``."""
    canonical = obj.annotations["grasp_points"][grasp_index]
    offset = np.array([canonical[0], canonical[1], 0.0])
    local_dir = normalize(offset) if np.linalg.norm(offset) > 0.02 else np.array([0.0, 1.0, 0.0])
    towards = normalize(obj.rotation @ local_dir * np.array([1.0, 1.0, 0.0]))
    if obj.translation[2] > 0.05:
        return obj, None, towards
    height = float(obj.canonical_bounds[1, 2])
    radius = float(np.max(np.abs(obj.canonical_bounds[:, :2])))
    support = None
    if rng.random() < 0.5:
        shelf = make_object("shelf", rng)
        boards = [row for row in shelf.support_surfaces if 0.6 <= row[0] <= 1.45 and row[5] >= height + 0.06]
        if boards:
            support, board = shelf, boards[int(rng.integers(len(boards)))]
    if support is None:
        support = make_object("table", rng)
        board = support.support_surfaces[0]
    z, x0, x1, y0, y1 = (float(v) for v in board[:5])
    x = rng.uniform(x0 + radius + 0.05, x1 - radius - 0.05) if x1 - x0 > 2 * radius + 0.1 else 0.5 * (x0 + x1)
    y = y1 - radius - rng.uniform(0.04, 0.10)
    yaw = heading_of(towards)
    centre = obj.translation[:2] - (rot_z(yaw)[:2, :2] @ np.array([x, y]))
    support = support.placed(float(centre[0]), float(centre[1]), yaw)
    pose = np.array(obj.pose, dtype=np.float64)
    pose[2, 3] = z
    return obj.with_pose(pose), support, towards


@single_threaded
def reach_grasp(obj, *, hand: Optional[str] = None, betas=None, seed=0, pick_up: Optional[bool] = None,
                grasp_index: Optional[int] = None, approach: bool = True, start_position=None) -> Motion:
    """Walk to a small object on a table or shelf, reach with one hand, grasp it, optionally pick it up.

    A bare object (standing on the floor, as ``make_object`` returns it) is first put on a
    support in front of the character: a table top or a shelf board at 0.6–1.45 m, drawn from
    the seed, with the object near the front edge and its grasp point towards the reacher; the
    support is in ``meta["support"]``. An object already lifted off the floor (``placed(...,
    z=...)``) is used as it is. Sequence: approach facing the support, then "reach" (the torso
    bends as needed, searched so the shoulder reaches the grasp point without the head or chest
    touching anything, and the wrist comes in from the front onto the grasp point EXACTLY), then
    "grasp": hand contact from the anchor frame on; with ``pick_up`` the object, held by the
    wrist, is lifted off the support and brought in front of the chest while the body straightens.

    Args:
        obj: a graspable ``ToyObject`` ("bottle", "mug", "teapot").
        hand: "left", "right" or None (drawn from the seed).
        betas: ``(10,)`` toy body shape, or None.
        seed: int or ``numpy.random.Generator``.
        pick_up: lift the object after grasping; None: drawn (60 % yes).
        grasp_index: which of ``obj.grasp_points``; None: drawn.
        approach: walk to the support first.
        start_position: ``(2,)`` metres, where the approach starts (default: sampled).
    Returns:
        ``Motion`` with ``meta``: kind, hand, pick_up, grasp_index, grasp_point, object (as placed),
        support, anchor_frame (first grasp frame), object_poses ``(T, 4, 4)``.
    """
    check_object(obj, GRASPABLE, "obj")
    rng = seeded_rng(seed)
    body = PlanBody(check_betas(betas))
    side = check_hand(hand, rng)
    if pick_up is None:
        pick_up = bool(rng.random() < 0.6)
    n_points = len(obj.annotations["grasp_points"])
    if grasp_index is None:
        k = int(rng.integers(n_points))
    else:
        k = check_index(grasp_index, n_points, "grasp_index")
    obj, support, towards = _place_on_support(obj, rng, k)
    obstacles = [obj] + ([support] if support is not None else [])
    point = np.asarray(obj.grasp_points[k], dtype=np.float64)
    facing = -towards
    heading = heading_of(facing)
    near = near_extent(obstacles, point, towards, 0.2, point[2] + 0.1)
    targets = {side: point}
    # Reaching over a surface hinges at the hips; squatting would push the knees into the support.
    style = "stoop"
    lateral = -SIGN[side] * rng.uniform(0.10, 0.18)
    spot, hug = reach_spot(body, obstacles, point, near, heading, targets, style, rng, lateral=lateral,
                           gaps=(0.14, 0.24))
    walk, (local0, root0) = walk_to_spot(body, rng, spot, heading, towards, obstacles, start_position,
                                         obj.translation[:2], approach)
    ankles, feet, heading0 = start_state(body, local0, root0)
    heading = heading0 + float(wrap_angle(heading - heading0))
    h, alpha, _, _ = choose_bend(body, root0, heading, ankles, targets, style, rng, obstacles=obstacles, hug=hug)
    hand_dir = normalize(forward_xyz(heading) - 0.4 * UP)

    n_reach = n_frames(rng.uniform(0.7, 1.1))
    u = np.arange(n_reach) / n_reach
    reach = bend_plan(n_reach, root0, heading, ankles, feet, style, h * min_jerk(u), alpha * min_jerk(u), "reach")
    w = smoothstep(u / 0.9)
    pre = (1.0 - w)[:, None] * (0.10 * towards + 0.05 * UP)[None]
    hand_on_point(reach, slice(None), side, point[None] + pre, w)
    reach.hand_dir[:, side] = hand_dir
    reach.hand_dir_weight[:, side] = w

    n_hold = n_frames(rng.uniform(0.25, 0.45))
    n_lift = n_frames(rng.uniform(0.8, 1.2)) if pick_up else 0
    n_end = n_frames(rng.uniform(0.5, 0.9))
    T = n_hold + n_lift + n_end
    lift_u = np.concatenate([np.zeros(n_hold), (np.arange(n_lift) + 1) / max(n_lift, 1), np.ones(n_end)])
    if not pick_up:
        lift_u[:] = 0.0
    s = min_jerk(lift_u)
    grasp = bend_plan(T, root0, heading, ankles, feet, style, h + (0.01 - h) * s, alpha * (1.0 - s), "grasp")
    chest_rot, chest_pos, _ = chest_frames(grasp, body)
    if pick_up:
        stand = bend_plan(1, root0, heading, ankles, feet, style, np.array([0.01]), np.zeros(1), "grasp")
        _, _, stand_pos = chest_frames(stand, body)
        shoulder = stand_pos[0, SHOULDER[side]]
        held = shoulder + 0.30 * forward_xyz(heading) - SIGN[side] * 0.08 * right_xyz(heading) - 0.30 * UP
        local0_pt = chest_rot[0].T @ (point - chest_pos[0])
        local1_pt = chest_rot[-1].T @ (held - chest_pos[-1])
        local_pts = lerp(np.broadcast_to(local0_pt, (T, 3)), np.broadcast_to(local1_pt, (T, 3)), s)
        wrist = chest_pos + np.einsum("tij,tj->ti", chest_rot, local_pts)
        # Lift clear of the support before moving in: a vertical bump that fades by the end.
        wrist[:, 2] += 0.08 * np.sin(np.pi * np.clip(lift_u / 0.7, 0.0, 1.0)) * (lift_u < 0.7)
    else:
        wrist = np.broadcast_to(point, (T, 3)).copy()
    hand_on_point(grasp, slice(None), side, wrist, np.ones(T))
    grasp.hand_dir[:, side] = hand_dir
    grasp.hand_dir_weight[:, side] = 1.0
    grasp.contacts[:, WRIST_CONTACT[side]] = True

    interaction = plan_to_motion(Plan.concat([reach, grasp]), body, start=(local0, root0))
    meta = {"kind": "reach_grasp", "style": style, "hand": SIDES[side], "pick_up": pick_up, "seed": seed_record(seed),
            "object": describe_object(obj), "support": None if support is None else describe_object(support),
            "grasp_index": k, "grasp_point": point}
    motion, first = join_clips(walk, interaction, None, meta)
    anchor = first + n_reach
    poses = np.broadcast_to(np.asarray(obj.pose, dtype=np.float64), (len(motion), 4, 4)).copy()
    poses[anchor:, :3, 3] += wrist - point[None]
    motion.meta.update({"anchor_frame": anchor, "interaction_start": first, "object_poses": poses})
    return motion
