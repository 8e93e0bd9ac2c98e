"""The stances of CHOICE's pick-and-place demo (``demo``; §6, Fig. 6): step 3 of the algorithm
box in that module's docstring, where the body stands and how far it bends at the cabinet and at the table.

- :func:`open_stance`, stance A, to take the handle: §6.3's walk goal (the first matched keyframe's pelvis)
  facing the cabinet, or the nearest 5 cm shift of it from which a bend reaches the closed handle and the body
  stays clear of the door's first half swing, its feet (points below 15 cm) of the whole swing.
- :func:`take_stance`, the stances B, to hold the opened door and take the bottle (the co-temporal schedule of
  §6.3, Eq. 24): positions and headings in front of the cabinet from which bends reach the opened handle with the
  door hand and the bottle, then the carry point, with the body clear of the opened cabinet there and of the
  swinging door on the step from A; the first eight found, most clearance first (the demo tries them in turn).
- :func:`table_stance`, the stance at the table (for step 7's place): a free spot on the table top with a free
  stance out from its edge from which a bend reaches, nearest to where the carry starts.

Also the helpers the demo shares with them: :func:`stance_pose` (the standing pose on a stance),
:func:`stance_bend` (``world.mocap.standing.choose_bend`` for hand goals) and :func:`item_radius`. The clearances use the body sample points of ``checks``; the
constants are fields of ``demo_types.PickAndPlaceConfig``.
"""
from __future__ import annotations

import numpy as np

from ...world.mocap.body_plan import SIDES, PlanBody, hand_on_point, plan_to_motion, start_state
from ...world.mocap.motion_math import forward_xyz, heading_of, min_jerk, right_xyz, rot_z
from ...world.mocap.poses import standing_pose
from ...world.mocap.standing import bend_plan, choose_bend
from ...world.skeleton import joint_index
from .checks import body_points, bone_table
from .demo_types import DemoSetting, OpenStance, PickAndPlaceConfig, Stance, TableStance, TakeStance

__all__ = [
    "open_stance",
    "take_stance",
    "table_stance",
    "stance_pose",
    "stance_bend",
    "item_radius",
]


# ----------------------------------------------------------------------------- shared helpers

_FEET_HEIGHT = 0.15  # metres: sample points below this are the feet, which stay put while the door opens (ours)


def item_radius(item) -> float:
    """The radius (metres) about its vertical axis that an item's canonical bounds reach sideways."""
    lo, hi = item.canonical_bounds
    return float(np.max(np.abs(np.concatenate([lo[:2], hi[:2]]))))


def stance_pose(body: PlanBody, xy, heading: float):
    """The standing pose on ``xy`` facing ``heading``: ``(root (3,), ankles (2, 3), feet (2, 3, 3))``."""
    local, root = standing_pose(body.betas, position=tuple(np.asarray(xy, dtype=float)), heading=heading)
    local, root = local.double().numpy(), root.double().numpy()
    ankles, feet, _ = start_state(body, local, root)
    return root, ankles, feet


def stance_bend(body, root, heading, ankles, targets, obstacles, *, style: str, rng: np.random.Generator):
    """``(h, alpha, feasible)``: ``choose_bend`` for ``targets`` {side index: point (3,)}."""
    h, alpha, ok, _ = choose_bend(body, root, heading, ankles, targets, style, rng, obstacles=obstacles)
    return h, alpha, ok


def _trunk_points(body: PlanBody, root, heading, ankles, feet, bends, style) -> np.ndarray:
    """(N, P, 3) sample points (no forearms) of the standing pose bent by each ``(h, alpha)`` of ``bends``."""
    n = len(bends)
    h = np.array([b[0] for b in bends])
    alpha = np.array([b[1] for b in bends])
    plan = bend_plan(n, root, heading, ankles, feet, style, h, alpha, "idle")
    motion = plan_to_motion(plan, body)
    points, _ = body_points(motion, 2)
    wrists = {joint_index(f"{s}_wrist") for s in SIDES}
    a, b, _ = bone_table(2)
    keep = np.array([bj not in wrists for bj in b])
    return points[:, keep]


def _clear(points: np.ndarray, objects, margin: float) -> bool:
    flat = points.reshape(-1, 3)
    return min(float(np.min(o.sdf(flat))) for o in objects) >= margin


def open_stance(setting: DemoSetting, cabinet, base_xy, grid, rng: np.random.Generator) -> OpenStance:
    """Stance A (:class:`~.demo_types.OpenStance`) to take the handle with the door hand: the first matched keyframe's pelvis
    (§6.3's walk goal) facing the cabinet, or the nearest 5 cm shift of it (sideways, back; free on the walking
    grid) from which a bend reaches the closed handle and the body keeps ``stance_margin`` from the door over
    the first half of its swing, the feet over the whole swing (the door's lower edge passes over the toes)."""
    body, task, config, door_side = setting.body, setting.task, setting.config, setting.door_side
    front = cabinet.rotation[:, 1]
    heading = heading_of(-front)
    q = float(task.opening)
    sweep = [cabinet.with_params(door_angle=float(a)) for a in np.linspace(0.0, q / 2, 4)]
    full_sweep = sweep + [cabinet.with_params(door_angle=float(a)) for a in np.linspace(q / 2, q, 5)[1:]]
    base = np.asarray(base_xy, dtype=np.float64)[:2]
    right = right_xyz(heading)[:2]
    offsets = sorted(((a, b) for a in 0.05 * np.arange(-6, 7) for b in 0.05 * np.arange(-2, 9)),
                     key=lambda o: (np.hypot(*o), o))
    for side, back in offsets:
        xy = base + side * right + back * front[:2]
        if not grid.free(xy):
            continue
        root, ankles, feet = stance_pose(body, xy, heading)
        h, alpha, ok = stance_bend(body, root, heading, ankles, {door_side: task.auxiliary.contact}, [cabinet],
                             style=config.style, rng=rng)
        if not ok:
            continue
        points = _trunk_points(body, root, heading, ankles, feet, [(0.0, 0.0), (h, alpha)], config.style)
        margin = config.stance_margin + config.body_radius
        low = points[:1, points[0, :, 2] < _FEET_HEIGHT]  # the feet stay planted while the whole door swings
        if not (_clear(points[:1], sweep, margin) and _clear(points[1:], sweep[:2], margin)
                and _clear(low, full_sweep, margin)):
            continue
        source = "keyframe" if side == 0 and back == 0 else f"keyframe shifted {side:+.2f} m right, {back:+.2f} m back"
        return OpenStance(xy, heading, (h, alpha), source)
    raise ValueError("kitchen: no stance in front of the cabinet reaches its handle clear of the door")


def _posed_points(body, root, heading, ankles, feet, bends, targets, config: PickAndPlaceConfig) -> np.ndarray:
    """(N, 3) body sample points of the standing pose bent by each of ``bends`` with the wrists on ``targets``
    ({side index: point (3,)} per bend), less the points within ``contact_radius`` of a wrist on its target."""
    n = len(bends)
    plan = bend_plan(n, root, heading, ankles, feet, config.style, np.array([b[0] for b in bends]),
                     np.array([b[1] for b in bends]), "idle")
    for i, goal in enumerate(targets):
        for side, point in goal.items():
            hand_on_point(plan, slice(i, i + 1), side, np.asarray(point)[None], np.ones(1))
    points, _ = body_points(plan_to_motion(plan, body), config.bone_samples)
    keep = []
    for i, goal in enumerate(targets):
        near = np.zeros(points.shape[1], dtype=bool)
        for side in goal:
            near |= np.linalg.norm(points[i] - points[i, joint_index(f"{SIDES[side]}_wrist")], axis=-1) \
                < config.contact_radius
        keep.append(points[i, ~near])
    return np.concatenate(keep)


def _path_clearance(body, xy0, psi0, xy1, psi1, obstacles, config: PickAndPlaceConfig, n: int = 4) -> float:
    """The least distance of the standing body (no forearms) to ``obstacles(w)`` (the scene at fraction ``w`` of
    the step) at ``n`` poses on the straight step from ``(xy0, psi0)`` to ``(xy1, psi1)``, metres."""
    out = np.inf
    for w in np.linspace(0.0, 1.0, n + 2)[1:-1]:
        psi = psi0 + w * float(np.angle(np.exp(1j * (psi1 - psi0))))
        xy = np.asarray(xy0) + w * (np.asarray(xy1) - np.asarray(xy0))
        root, ankles, feet = stance_pose(body, xy, psi)
        points = _trunk_points(body, root, psi, ankles, feet, [(0.0, 0.0)], config.style).reshape(-1, 3)
        out = min(out, min(float(np.min(o.sdf(points))) for o in obstacles(w)))
    return out


_TAKE_CANDIDATES = 8  # feasible stances B weighed; the one farthest from the cabinet and the swinging door wins


def take_stance(setting: DemoSetting, cabinet, start: Stance, rng: np.random.Generator) -> list[TakeStance]:
    """The stances B (:class:`~.demo_types.TakeStance`, best first) to take the bottle out with the door held open: positions every
    10 cm in front of the cabinet and headings every 15° within 75° of facing it, nearest to stance A first,
    from which bends reach the opened handle with the door hand and the bottle (B2), then the carry point (B3);
    of the first eight, the one whose body keeps farthest from the cabinet and the door,
    the body keeping ``stance_margin`` from the opened cabinet there and, standing, from the swinging door on the
    way from A, ``start`` (the second half of the door's swing)."""
    body, task, config = setting.body, setting.task, setting.config
    from_xy, from_heading = start
    front = cabinet.rotation[:, 1]
    q = float(task.opening)
    opened = cabinet.with_params(door_angle=q)
    d, g = setting.door_side, setting.bottle_side
    handle = opened.handle_point

    def swinging(w):  # the door while the body steps from A to B (the second half of the opening)
        return [cabinet.with_params(door_angle=float(q * min_jerk(0.5 + 0.5 * w)))]
    contact, carry = task.target.contact, task.carry
    centre = 0.5 * (handle + contact)[:2]
    facing = heading_of(-front)
    side_axis = right_xyz(facing)[:2]
    candidates = []
    for a in 0.1 * np.arange(-6, 7):
        for b in 0.1 * np.arange(0, 10):
            xy = centre + a * side_axis + b * front[:2]
            if (xy - cabinet.translation[:2]) @ front[:2] < cabinet.params["depth"] / 2 + 0.15:
                continue  # not in front of the cabinet
            for turn in np.radians(np.arange(-75, 76, 15)):
                candidates.append((float(np.linalg.norm(xy - from_xy)) + 0.1 * abs(turn), xy, facing + turn))
    candidates.sort(key=lambda c: c[0])
    reach = 0.93 * float(body.arm_length.max()) + 0.45
    failed = {"beyond reach": 0, "no bend": 0, "too near the cabinet": 0, "door in the way": 0}
    found = []
    for _, xy, heading in candidates:
        if any(np.linalg.norm(point[:2] - xy) > reach for point in (handle, contact, carry)) \
                or (contact[:2] - xy) @ forward_xyz(heading)[:2] < 0.0:
            failed["beyond reach"] += 1
            continue
        root, ankles, feet = stance_pose(body, xy, heading)
        h2, a2, ok = stance_bend(body, root, heading, ankles, {d: handle, g: contact}, [opened], style=config.style,
                                 rng=rng)
        if ok:
            h3, a3, ok = stance_bend(body, root, heading, ankles, {d: handle, g: carry}, [opened], style=config.style,
                                     rng=rng)
        if not ok:
            failed["no bend"] += 1
            continue
        points = _trunk_points(body, root, heading, ankles, feet, [(0.0, 0.0)], config.style).reshape(-1, 3)
        posed = _posed_points(body, root, heading, ankles, feet, [(h2, a2), (h3, a3)],
                              [{d: handle, g: contact}, {d: handle, g: carry}], config)
        margin = config.stance_margin + config.body_radius
        there = float(np.min(opened.sdf(np.concatenate([points, posed]))))
        if there < margin:
            failed["too near the cabinet"] += 1
            continue
        on_the_way = _path_clearance(body, from_xy, from_heading, xy, heading, swinging, config)
        if on_the_way < margin:
            failed["door in the way"] += 1
            continue
        found.append((min(there, on_the_way), xy, float(heading), ((h2, a2), (h3, a3))))
        if len(found) == _TAKE_CANDIDATES:
            break
    if found:
        return [TakeStance(*f[1:]) for f in sorted(found, key=lambda f: -f[0])]
    raise ValueError("kitchen: no stance in front of the cabinet reaches the opened handle and the bottle at once ("
                     + ", ".join(f"{v} {k}" for k, v in failed.items()) + ")")


def table_stance(setting: DemoSetting, kitchen, grid, start: Stance, contact_offset,
                 rng: np.random.Generator) -> TableStance:
    """The table's stance (:class:`~.demo_types.TableStance`) for the bottle hand coming from ``start``, the stance B
    it took the bottle at (``contact_offset``, the grasp from the bottle's centre, turns with the body): spots
    ``table_inset`` in from each edge of the top, every 10 cm, clear of the other items, with a free stance
    ``table_gap`` out from the edge from which a bend reaches; the one nearest ``start`` first."""
    body, config, bottle_side = setting.body, setting.config, setting.bottle_side
    from_xy, cabinet_heading = start
    table = kitchen.furniture_of("table")
    z, x0, x1, y0, y1, _ = table.support_surfaces[0]
    bottle = kitchen.items[0]
    r = item_radius(bottle)
    others = [(it, item_radius(it)) for it in kitchen.items[1:] if kitchen.holder_of(kitchen.items.index(it)) is table]
    candidates = []
    for normal, along, edge, (lo, hi) in (((1, 0), 1, x1, (y0, y1)), ((-1, 0), 1, x0, (y0, y1)),
                                          ((0, 1), 0, y1, (x0, x1)), ((0, -1), 0, y0, (x0, x1))):
        n_local = np.array([normal[0], normal[1], 0.0])
        for t in np.arange(lo + r + 0.05, hi - r - 0.05 + 1e-9, 0.10):
            local = np.zeros(3)
            local[along] = t
            local[1 - along] = edge
            local[2] = z
            spot = table.to_world(local - config.table_inset * n_local)
            out = table.rotation @ n_local
            stance = table.to_world(local + config.table_gap * n_local)[:2]
            candidates.append((float(np.linalg.norm(stance - from_xy)), spot, stance, out))
    candidates.sort(key=lambda c: c[0])
    for _, spot, stance, out in candidates:
        if not grid.free(stance):
            continue
        if any(np.linalg.norm(spot[:2] - it.translation[:2]) < r + ri + 0.03 for it, ri in others):
            continue
        heading = heading_of(-out)
        place_at = spot + rot_z(heading - cabinet_heading) @ contact_offset
        root, ankles, _ = stance_pose(body, stance, heading)
        h, alpha, ok = stance_bend(body, root, heading, ankles, {bottle_side: place_at}, [table], style=config.style, rng=rng)
        if ok:
            return TableStance(stance, heading, (h, alpha), spot, place_at)
    raise ValueError("kitchen: no free spot on the table with a stance that reaches it")
