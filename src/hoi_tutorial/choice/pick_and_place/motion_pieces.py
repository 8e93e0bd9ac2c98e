"""The motion pieces of CHOICE's pick-and-place demo (``demo``; §6, Fig. 6): steps 4–7 of the
algorithm box in that module's docstring, as wrist paths, bends and steps for the toy world's body planner.

- :func:`walk` (§6.2's matched walk with the limbs kept clear, :func:`limbs_clear`), :func:`settle` (a walk's last
  pose blended onto a stance) and :func:`hold_arm` (the carrying arm held by IK while walking, at
  :func:`hold_point`).
- :func:`plan_at_cabinet` (step 5): reach and grasp the handle, open the door turning and stepping behind it, reach,
  grasp and take out the bottle, let go of the door and stand up stepping back to :func:`exit_point`.
- :func:`plan_at_table` (step 7): lower the bottle onto its spot, let go and draw the hand back.
- :func:`attach_bottle`: the bottle's poses, rigid with the grasping wrist while held.

The constants are fields of ``demo_types.PickAndPlaceConfig``; what is ours is listed in that module's
docstring.
"""
from __future__ import annotations

import numpy as np
import torch

from ...world.kinematics import forward_kinematics, solve_limb_ik
from ...world.mocap.body_plan import ELBOW_POLE, SIDES, UP, PlanBody, hand_on_point, upper_local
from ...world.mocap.handles import handle_circle
from ...world.mocap.motion_math import (forward_xyz, heading_of, min_jerk, right_xyz, rot_x, rot_z, slerp_rot,
                                       smoothstep)
from ...world.mocap.poses import standing_pose
from ...world.mocap.standing import bend_params, bend_plan, chest_frames, standing_plan, step_feet
from ...world.motion import FPS, Motion, action_id
from ...world.scenes import Kitchen
from ...world.skeleton import joint_index
from . import environment as env
from . import locomotion
from .checks import handle_at
from .hand_paths import grip_target, planned_approach
from .demo_types import CabinetPlan, DemoSetting, PickAndPlaceConfig, Stance, TablePlan
from .stances import stance_bend, stance_pose

__all__ = [
    "n_frames", "settle", "pelvis_yaw", "hold_point", "along_path", "limbs_clear", "walk", "last_pose", "hold_arm",
    "plan_at_cabinet", "exit_point", "plan_at_table", "attach_bottle",
]


# ----------------------------------------------------------------------------- poses and blends


def n_frames(seconds: float) -> int:
    return max(2, int(round(seconds * FPS)))


def settle(motion_end: tuple, stance: tuple, body: PlanBody) -> Motion:
    """Blend the last walking pose ``(local (22, 3, 3), root (3,))`` into the standing pose on ``stance``
    ``(xy (2,), heading)``: root and rotations by a minimum-jerk weight (the feet slide over the gap)."""
    local0, root0 = motion_end
    local1, root1 = standing_pose(body.betas, position=tuple(stance[0]), heading=float(stance[1]))
    local1, root1 = local1.double().numpy(), root1.double().numpy()
    gap = float(np.linalg.norm(root1[:2] - root0[:2]))
    turn = abs(float(np.angle(np.exp(1j * (pelvis_yaw(local1[0]) - pelvis_yaw(local0[0]))))))
    n = n_frames(0.4 + 1.5 * gap + 0.3 * turn)
    w = min_jerk((np.arange(n) + 1) / n)
    local = slerp_rot(local0, local1, w)
    root = root0[None] + w[:, None] * (root1 - root0)[None]
    return Motion(torch.as_tensor(local).float(), torch.as_tensor(root).float(), betas=body.betas)


def pelvis_yaw(rotation) -> float:
    """Heading (radians, 0 faces +y) of a pelvis rotation (3, 3): that of its forward (+y) column."""
    return heading_of(np.asarray(rotation)[:, 1])


def hold_point(root, heading, side: int, hold) -> np.ndarray:
    """(..., 3) the carrying wrist's point in the heading frame of a root (..., 3)."""
    heading = np.asarray(heading, dtype=np.float64)
    sideways = (-1.0, 1.0)[side] * hold[0]
    return (np.asarray(root) + sideways * right_xyz(heading) + hold[1] * forward_xyz(heading)
            + hold[2] * UP)


def along_path(points, s) -> np.ndarray:
    """(n, 3) points along the polyline ``points`` (K, 3) at arc-length fractions ``s`` (n,)."""
    points = np.asarray(points, dtype=np.float64)
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    total = max(float(lengths.sum()), 1e-12)
    cum = np.concatenate([[0.0], np.cumsum(lengths)]) / total
    s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    return np.stack([np.interp(s, cum, points[:, k]) for k in range(3)], axis=-1)


# ----------------------------------------------------------------------------- the motion pieces


def limbs_clear(kitchen: Kitchen, config: PickAndPlaceConfig):
    """``clear(points (n, 10, 3)) -> bool`` for ``locomotion.follow_path``: the limb joints keep ``body_radius``
    from every object of ``kitchen`` and the walls."""
    walls = env.room_sdf(kitchen.size, floor=False)

    def clear(points) -> bool:
        flat = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return bool(min(float(np.min(walls(flat))), *(float(np.min(o.sdf(flat))) for o in kitchen.objects))
                    >= config.body_radius)
    return clear


def walk(grid, database, start, goal, goal_direction, start_heading, *, kitchen: Kitchen, config: PickAndPlaceConfig):
    """§6.2's walk from ``start`` to ``goal`` (``locomotion.follow_path``), the limbs kept clear of ``kitchen``."""
    return locomotion.follow_path(grid, database, start, goal, goal_direction, start_heading=start_heading,
                                  config=config.navigation, clear=limbs_clear(kitchen, config))


def last_pose(motion: Motion) -> tuple:
    return motion.local_rotations[-1].double().numpy(), motion.root_position[-1].double().numpy()


def hold_arm(motion: Motion, side: int, hold) -> Motion:
    """The carrying arm of ``motion`` posed by IK on the hold point of every frame (heading frame of the root)."""
    local = motion.local_rotations.double()
    root = motion.root_position.double()
    glob, _ = forward_kinematics(local, root)
    heading = np.array([pelvis_yaw(r) for r in glob[:, 0].numpy()])
    target = hold_point(root.numpy(), heading, side, hold)
    chest = glob[:, joint_index("spine3")].numpy()
    pole = np.einsum("tij,j->ti", chest, ELBOW_POLE[side])
    local = solve_limb_ik(local, root, f"{SIDES[side]}_arm", torch.as_tensor(target), torch.as_tensor(pole))
    return Motion(local.float(), motion.root_position, betas=motion.betas)


def plan_at_cabinet(setting: DemoSetting, stance_a: Stance, stance_b: Stance, exit_xy, bends: tuple,
                    rng: np.random.Generator) -> CabinetPlan:
    """The plan at the cabinet: at stance A reach and grasp the handle; pull the door open, turning to face the
    handle, then step to stance B while leaning in (the wrist on the handle's circle, the feet stepping under
    the pelvis, ``step_feet``; the bend keeping the handle in reach, ``choose_bend`` every 4th frame); reach
    (the other hand), grasp and take out the bottle; let go of the door; stand up stepping back to
    ``exit_xy`` with the bottle brought out in front of the cabinet, then to the hold point.

    ``bends`` are B1 (at A, on the handle), B2 and B3 (at B, :class:`~.demo_types.TakeStance`).

    Returns:
        :class:`~.demo_types.CabinetPlan`.
    """
    body, task, config = setting.body, setting.task, setting.config
    (xy_a, psi_a), (xy_b, psi_b) = stance_a, stance_b
    root_a, ankles, feet = stance_pose(body, xy_a, psi_a)
    cabinet = task.kitchen.furniture_of("cabinet")
    d, g = setting.door_side, setting.bottle_side
    reach, grasp, opening, lean_in, take_out, release, stand_up = (n_frames(s) for s in config.durations[:7])
    names = [("reach handle", reach, "reach"), ("grasp handle", grasp, "grasp"), ("open door", opening, "open_door"),
             ("lean in", lean_in, "reach"), ("reach bottle", reach, "reach"), ("grasp bottle", grasp, "grasp"),
             ("take out", take_out, "lift"),
             ("release door", release, "idle"), ("stand up", stand_up, "lift")]
    starts = np.cumsum([0] + [n for _, n, _ in names])
    T = int(starts[-1])
    span = {name: slice(int(a), int(a + n)) for (name, n, _), a in zip(names, starts)}
    u = {name: np.arange(n) / (n - 1) for name, n, _ in names}
    B0, (B1, B2, B3) = (0.0, 0.0), bends
    h, alpha = np.zeros(T), np.zeros(T)
    curve = [("reach handle", B0, B1), ("grasp handle", B1, B1), ("open door", B1, B1), ("lean in", B1, B2),
             ("reach bottle", B2, B2),
             ("grasp bottle", B2, B2), ("take out", B2, B3), ("release door", B3, B3), ("stand up", B3, B0)]
    for name, a, b in curve:
        # reaching for the handle the trunk bends ahead of the hand (done at 60 % of the reach), so the shoulder
        # is near enough for the planned path's swing
        w = min_jerk(np.clip(u[name] / 0.6, 0.0, 1.0) if name == "reach handle" else u[name])
        h[span[name]] = a[0] + w * (b[0] - a[0])
        alpha[span[name]] = a[1] + w * (b[1] - a[1])
    q_full = float(task.opening)
    door = np.zeros(T)
    door[span["open door"]] = q_full * min_jerk(u["open door"])
    door[span["open door"].stop:] = q_full
    handle = handle_at(cabinet, door)
    # the pelvis: at A turning to face the handle while the door's edge passes, then to B behind the door
    pelvis_xy, psi = _opening_path(door, (xy_a, psi_a), (xy_b, psi_b),
                                   slice(span["open door"].start, span["lean in"].stop), cabinet)
    pelvis_xy[span["stand up"]] = xy_b + min_jerk(u["stand up"])[:, None] * (np.asarray(exit_xy) - xy_b)
    # while the door swings and the body steps to B, the bend that keeps the handle within reach, every 4th frame
    moving = slice(span["open door"].start, span["lean in"].stop)
    keys = list(range(moving.start, moving.stop - 1, 4))[1:]
    key_bends = []
    for t in keys:
        stand_t = np.r_[pelvis_xy[t], root_a[2]]
        ank_t = stance_pose(body, pelvis_xy[t], psi[t])[1]
        key_bends.append(stance_bend(body, stand_t, psi[t], ank_t, {d: handle[t]},
                               [cabinet.with_params(door_angle=float(door[t]))], style=config.style, rng=rng)[:2])
    xs = [moving.start] + keys + [moving.stop - 1]
    hs = [B1[0]] + [b[0] for b in key_bends] + [B2[0]]
    als = [B1[1]] + [b[1] for b in key_bends] + [B2[1]]
    frames_m = np.arange(moving.start, moving.stop)
    h[moving] = np.interp(frames_m, xs, hs)
    alpha[moving] = np.interp(frames_m, xs, als)
    plan = standing_plan(T, root_a, psi_a, ankles, feet, "idle")
    ankle_t, foot_t, contact_t = step_feet(np.arange(T) / FPS, pelvis_xy, psi, ankles, feet, psi_a, rng)
    back, spine = bend_params(config.style, h, alpha)
    stand = np.concatenate([pelvis_xy, np.full((T, 1), root_a[2])], axis=1)
    plan.root = stand - back[:, None] * forward_xyz(psi) - h[:, None] * UP[None]
    plan.pelvis = rot_z(psi) @ rot_x(-alpha)
    plan.spine[:, 0] = spine
    plan.neck[:, 0] = -0.45 * (alpha + spine)
    plan.ankle, plan.foot = ankle_t, foot_t
    for i in range(2):
        plan.knee_pole[:, i] = forward_xyz(psi) + 0.15 * (-1.0, 1.0)[i] * right_xyz(psi)
        plan.contacts[:, i + 1] = contact_t[:, i]
    for (name, n, action), a in zip(names, starts):
        plan.actions[a:a + n] = action_id(action)
    front = cabinet.rotation[:, 1]
    # the door hand: from where it hangs to the handle along the approach §4's planner plans among the kitchen's
    # things (the door closed; the handle a ball the grid can see, hand_paths.grip_target), on the handle while it
    # swings, then let go
    handle0 = task.auxiliary.contact
    hanging = body.fk(upper_local(plan, body)[0], plan.root[0])[1][joint_index(f"{SIDES[d]}_wrist")]
    handle_path = planned_approach(setting.planner, grip_target(handle0), _door_closed_scene(task), hanging, handle0,
                                   SIDES[d], "grasp", grid_yaw=env.object_yaw(cabinet), grid_centre=handle0,
                                   seed=setting.seed)
    hand_on_point(plan, span["reach handle"], d, along_path(handle_path.path, min_jerk(u["reach handle"])),
                  np.ones(reach))
    frames = slice(span["grasp handle"].start, span["release door"].start)
    hand_on_point(plan, frames, d, handle[frames], np.ones(frames.stop - frames.start))
    # letting go: the hand draws 10 cm off the door on the body's side, then hangs
    _, sign, _ = handle_circle(cabinet)
    normal = rot_z(sign * q_full) @ front
    normal = normal * np.sign((np.r_[np.asarray(xy_b), 0.0] - handle[-1]) @ normal)
    ug = u["release door"]
    off = handle[-1] + (0.10 * min_jerk(np.clip(ug / 0.5, 0.0, 1.0)))[:, None] * normal
    hand_on_point(plan, span["release door"], d, off, 1.0 - smoothstep((ug - 0.4) / 0.6))
    # the bottle hand: in along the reverse of the way out, grasp, out along the way, then up in front
    contact, carry = task.target.contact, task.carry
    way = [contact, contact + config.scheduler.lift * UP, carry]
    # until then the free hand waits beside the belly (a hanging arm would swing into the cabinet when bending)
    waiting = slice(span["grasp handle"].start, span["reach bottle"].start)
    sign_g = (-1.0, 1.0)[g]
    rest = (plan.root + sign_g * 0.05 * right_xyz(psi) + 0.25 * forward_xyz(psi) + 0.15 * UP)
    n_wait = waiting.stop - waiting.start
    hand_on_point(plan, waiting, g, rest[waiting], smoothstep(np.arange(n_wait) / min(20, n_wait)))
    # in: the approach §4's planner plans in this scene (hand_paths), minimum-jerk along it
    bottle_path = planned_approach(setting.planner, task.kitchen.items[0], _door_open_scene(task),
                                   rest[waiting.stop - 1], contact, SIDES[g], "grasp",
                                   grid_yaw=env.object_yaw(cabinet), seed=setting.seed)
    reaching = along_path(bottle_path.path, min_jerk(u["reach bottle"]))
    hand_on_point(plan, span["reach bottle"], g, reaching, np.ones(reach))
    hand_on_point(plan, span["grasp bottle"], g, np.broadcast_to(contact, (grasp, 3)), np.ones(grasp))
    hand_on_point(plan, span["take out"], g, along_path(way, min_jerk(u["take out"])), np.ones(take_out))
    hand_on_point(plan, span["release door"], g, np.broadcast_to(carry, (release, 3)), np.ones(release))
    # up and out in front of the cabinet, then to the hold point in front of the body stepping back
    up = span["stand up"]
    moving_root = np.concatenate([pelvis_xy[up], np.full((stand_up, 1), root_a[2])], axis=1)
    hold = hold_point(moving_root, psi[up], g, config.hold)
    out = carry + 0.12 * front + 0.05 * UP
    s_up = min_jerk(u["stand up"])
    first_leg = along_path([carry, out], np.clip(s_up / 0.4, 0, 1))
    w = smoothstep((s_up - 0.3) / 0.7)[:, None]
    hand_on_point(plan, up, g, (1 - w) * first_leg + w * hold, np.ones(stand_up))
    _door_elbow(plan, body, cabinet, door, d, slice(span["reach handle"].start, span["release door"].stop))
    for name in ("grasp handle", "open door", "lean in", "reach bottle", "grasp bottle", "take out"):
        plan.contacts[span[name], 3 + d] = True
    for name in ("grasp bottle", "take out", "release door", "stand up"):
        plan.contacts[span[name], 3 + g] = True
    return CabinetPlan(plan, [(name, n) for name, n, _ in names], door, int(span["grasp bottle"].start), bottle_path,
                       handle_path)


def _door_closed_scene(task) -> list:
    """Everything in the task's kitchen, the cabinet's door closed: the obstacles the door hand's approach to the
    handle is planned among."""
    kitchen = task.kitchen
    return list(kitchen.furniture) + list(kitchen.obstacles) + list(kitchen.items)


def _door_open_scene(task) -> list:
    """Everything in the task's kitchen but the bottle (item 0), the cabinet with its door at ``task.opening``: the
    obstacles the hands' approaches are planned among."""
    kitchen, cabinet = task.kitchen, task.kitchen.furniture_of("cabinet")
    opened = cabinet.with_params(door_angle=float(task.opening))
    return ([opened if f is cabinet else f for f in kitchen.furniture] + list(kitchen.obstacles)
            + list(kitchen.items[1:]))


def exit_point(scene, grid, xy, clearance: float) -> np.ndarray:
    """(2,) the centre of the cell nearest ``xy`` that is ``clearance`` from every footprint of ``scene`` and free
    on the walking ``grid``."""
    xy = np.asarray(xy, dtype=np.float64)
    free = ~np.asarray(scene.inflated_occupancy(clearance), dtype=bool) & ~grid.blocked
    centres = grid.centres()[free]
    if len(centres) == 0:
        raise ValueError("kitchen: no free cell to walk from")
    return centres[int(np.argmin(np.linalg.norm(centres - xy, axis=1)))]


def _door_elbow(plan, body, cabinet, door, side: int, frames) -> None:
    """Bend the door arm's elbow away from the door panel (on the shoulder's side of it, and down) over
    ``frames``, so that the forearm does not lie along the door it holds."""
    glob, pos = chest_frames(plan, body)[0], chest_frames(plan, body)[2]
    _, sign, _ = handle_circle(cabinet)
    normal = np.einsum("tij,j->ti", rot_z(sign * door), cabinet.rotation[:, 1])
    handle = handle_at(cabinet, door)
    shoulder = pos[:, (joint_index("left_shoulder"), joint_index("right_shoulder"))[side]]
    away = np.sign(np.sum((shoulder - handle) * normal, axis=-1))[:, None] * normal - 0.5 * UP
    away /= np.linalg.norm(away, axis=-1, keepdims=True)
    local = np.einsum("tji,tj->ti", glob, away)  # into the chest frame
    plan.elbow_pole[frames, side] = local[frames]


def _opening_path(door, stance_a, stance_b, frames, cabinet) -> tuple:
    """Pelvis ``(xy (T, 2), heading (T,))`` for door angles ``door`` (T,): at stance A, turning to face the handle
    while the door's edge passes in front of the body (the first half of the door's swing, the first third of
    ``frames``), then stepping to stance B behind the opened door (the rest of ``frames``); at B afterwards."""
    xy_a, psi_a = np.asarray(stance_a[0], dtype=np.float64), float(stance_a[1])
    xy_b, psi_b = np.asarray(stance_b[0], dtype=np.float64), float(stance_b[1])
    T = len(door)
    handle = handle_at(cabinet, door)
    n = frames.stop - frames.start
    u = np.arange(n) / max(n - 1, 1)
    xy = np.broadcast_to(xy_a, (T, 2)).copy()
    psi = np.full(T, psi_a)
    towards = handle[frames, :2] - xy_a
    facing = psi_a + np.angle(np.exp(1j * (np.arctan2(-towards[:, 0], towards[:, 1]) - psi_a)))
    first = min_jerk(np.clip(u / _TURN_SHARE, 0.0, 1.0))
    second = min_jerk(np.clip((u - _TURN_SHARE) / (1.0 - _TURN_SHARE), 0.0, 1.0))
    turned = psi_a + first * (facing - psi_a)
    psi[frames] = turned + second * np.angle(np.exp(1j * (psi_b - turned)))
    xy[frames] = xy_a + second[:, None] * (xy_b - xy_a)
    xy[frames.stop:], psi[frames.stop:] = xy_b, psi_b
    return xy, psi


_TURN_SHARE = 1.0 / 3.0  # of the opening and leaning in: turning at A; the rest: stepping to B


def plan_at_table(setting: DemoSetting, stance: Stance, bend: tuple, spot, place_at) -> TablePlan:
    """The plan at the table: lower the bottle onto ``spot`` (the bottle hand's wrist to ``place_at``), let go
    and draw the hand back while standing up (:class:`~.demo_types.TablePlan`)."""
    body, config, side = setting.body, setting.config, setting.bottle_side
    xy, heading = stance
    root, ankles, feet = stance_pose(body, xy, heading)
    place, let_go = n_frames(config.durations[7]), n_frames(config.durations[8])
    T = place + let_go
    u_place, u_go = np.arange(place) / (place - 1), np.arange(let_go) / (let_go - 1)
    h = np.concatenate([bend[0] * min_jerk(u_place), bend[0] * (1 - min_jerk(u_go))])
    alpha = np.concatenate([bend[1] * min_jerk(u_place), bend[1] * (1 - min_jerk(u_go))])
    plan = bend_plan(T, root, heading, ankles, feet, config.style, h, alpha, "idle")
    plan.actions[:place] = action_id("grasp")
    plan.actions[place:] = action_id("idle")
    hold = hold_point(root, heading, side, config.hold)
    # down: the approach §4's planner plans to the spot, with the bottle where it will stand as the target
    kitchen, bottle = setting.task.kitchen, setting.task.kitchen.items[0]
    standing = np.array(bottle.pose)
    # turned with the body, as it is carried
    standing[:3, :3] = rot_z(heading - env.object_yaw(kitchen.furniture_of("cabinet"))) @ bottle.rotation
    standing[:3, 3] = spot
    place_path = planned_approach(setting.planner, bottle.with_pose(standing), _door_open_scene(setting.task), hold,
                                  place_at, SIDES[side], "place",
                                  grid_yaw=env.object_yaw(kitchen.furniture_of("table")), seed=setting.seed)
    hand_on_point(plan, slice(0, place), side, along_path(place_path.path, min_jerk(u_place)), np.ones(place))
    back = place_at - 0.10 * forward_xyz(heading) + 0.04 * UP
    s = min_jerk(np.clip(u_go / 0.5, 0, 1))
    hand_on_point(plan, slice(place, T), side, along_path([place_at, back], s), 1.0 - smoothstep((u_go - 0.4) / 0.6))
    plan.contacts[:place, 3 + side] = True
    return TablePlan(plan, [("place", place), ("release bottle", let_go)], place_path)


def attach_bottle(bottle, wrists: np.ndarray, yaws: np.ndarray, first: int, last: int) -> np.ndarray:
    """(T, 4, 4) bottle poses: at rest before ``first``; from ``first`` to ``last`` rigid with the wrist's
    position and the body's heading (upright); at rest where it was put after ``last``."""
    T = len(wrists)
    pose = np.broadcast_to(bottle.pose, (T, 4, 4)).copy()
    offset = bottle.translation - wrists[first]
    for t in range(first, last + 1):
        turn = rot_z(yaws[t] - yaws[first])
        pose[t, :3, :3] = turn @ bottle.rotation
        pose[t, :3, 3] = wrists[t] + turn @ offset
    pose[last + 1:] = pose[last]
    return pose
