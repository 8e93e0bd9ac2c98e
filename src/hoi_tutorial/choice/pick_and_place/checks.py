"""The checks of CHOICE's pick-and-place demo (``demo``; §6, Fig. 6): the body's sample points
(:func:`body_points`), their distances to the kitchen (the cabinet at each frame's door angle) and to the carried
bottle (:func:`body_distances`), and :func:`evaluate`, a run's checks: the door opened as far as the scheduler
asked, the bottle out of the cabinet and standing on the table, the clearances of body and bottle, and the door
hand on the handle. Also :func:`handle_at`, the cabinet's handle at given door angles, which the demo's wrist
paths follow and the checks measure the door hand against.

Collision measure (a choice of ours, like those the demo's docstring lists): body sample points are the 22
joints plus ``bone_samples`` points along each bone, with radius ``body_radius`` (3 cm, a thin limb; the torso
is thicker, so this under-counts torso contacts); the scene is every object of the kitchen but the bottle (the
cabinet at the frame's door angle), the walls and the floor (not for the shins and feet). Points within
``contact_radius`` (12 cm: the hand and the wrist end of the forearm) of a wrist that is on the handle (resp.
the bottle's grasp point) may touch the cabinet (resp. the bottle). The bottle collides when it sinks more than
``tolerance`` into anything (it stands on boards and on the table at zero clearance). The body against itself
(:func:`arm_measures`): the two arms' sample points (shoulder to wrist) against each other with the same radius,
and how far each wrist passes the body's midline (between the shoulders) to the other side and whether the wrists'
left-right order swaps (crossed arms); the torso against the arms is not checked (the upper arms hang within a limb
radius of it). The constants are fields of ``demo_types.PickAndPlaceConfig``.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ...world.kinematics import forward_kinematics
from ...world.mocap.body_plan import SIDES
from ...world.mocap.handles import handle_circle
from ...world.mocap.motion_math import rot_z
from ...world.motion import Motion
from ...world.scenes import Kitchen
from ...world.skeleton import JOINT_NAMES, NUM_JOINTS, PARENTS, joint_index
from .demo_types import BodyDistances, PickAndPlace, PickAndPlaceConfig
from .environment import room_sdf

__all__ = [
    "handle_at",
    "bone_table",
    "body_points",
    "body_distances",
    "arm_measures",
    "evaluate",
    "distance_to_polyline",
]


# ----------------------------------------------------------------------------- a wrist against its path


def distance_to_polyline(points, polyline) -> np.ndarray:
    """(n,) each of ``points`` (n, 3)'s distance (metres) to the nearest segment of ``polyline`` (K ≥ 2, 3): how far a
    wrist in the frames is from the path it was to follow."""
    points, polyline = (np.asarray(v, dtype=np.float64) for v in (points, polyline))
    if points.ndim != 2 or points.shape[-1] != 3 or polyline.ndim != 2 or polyline.shape[-1] != 3 or len(polyline) < 2:
        raise ValueError(f"points, polyline: expected (n, 3) points and a (K >= 2, 3) polyline, got "
                         f"{points.shape} and {polyline.shape}")
    a, ab = polyline[:-1], np.diff(polyline, axis=0)
    t = np.einsum("nkd,kd->nk", points[:, None] - a[None], ab) / np.maximum((ab * ab).sum(-1), 1e-12)
    closest = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    return np.linalg.norm(points[:, None] - closest, axis=-1).min(axis=1)


# ----------------------------------------------------------------------------- the cabinet's handle


def handle_at(cabinet, q) -> np.ndarray:
    """(..., 3) the handle of the cabinet (closed in ``cabinet``) at door angles ``q`` (...)."""
    centre, sign, handle0 = handle_circle(cabinet)
    q = np.asarray(q, dtype=np.float64)
    return centre + np.einsum("...ij,j->...i", rot_z(sign * q), handle0 - centre)


# ----------------------------------------------------------------------------- body sample points


@functools.lru_cache(maxsize=None)
def bone_table(samples: int):
    """(joint a, joint b, fraction) of every sample point: the joints, then ``samples`` points per bone."""
    rows = [(j, j, 0.0) for j in range(NUM_JOINTS)]
    for j in range(1, NUM_JOINTS):
        for k in range(samples):
            rows.append((PARENTS[j], j, (k + 1) / (samples + 1)))
    a, b, t = (np.array(c) for c in zip(*rows))
    return a.astype(np.int64), b.astype(np.int64), t.astype(np.float64)


_LOWER_LEG = {joint_index(n) for n in ("left_ankle", "right_ankle", "left_foot", "right_foot")}


def body_points(motion: Motion, samples: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """The body's sample points: ``(points (T, P, 3) metres, lower_leg (P,) bool)`` — the 22 joints, then
    ``samples`` evenly spaced points along each bone; ``lower_leg`` marks points on the shins and feet (which
    may touch the floor)."""
    joints = forward_kinematics(motion.local_rotations.double(), motion.root_position.double())[1].numpy()
    a, b, t = bone_table(int(samples))
    points = joints[:, a] + t[None, :, None] * (joints[:, b] - joints[:, a])
    lower = np.array([(bj in _LOWER_LEG) for bj in b]) | np.array([aj in _LOWER_LEG for aj in a])
    knees = {joint_index("left_knee"), joint_index("right_knee")}
    lower |= np.array([(aj in knees and bj in _LOWER_LEG) for aj, bj in zip(a, b)])
    return points, lower

def arm_measures(motion: Motion, samples: int = 4, radius: float = 0.03) -> dict:
    """The arms against each other and against the body's midline, per frame.

    The lateral axis of a frame is the horizontal direction from the left shoulder to the right one; the midline
    is the shoulders' midpoint.

    Returns a dictionary of (T,) arrays, metres:
        left_across, right_across: how far the wrist is past the midline on the other arm's side (negative: on
            its own side).
        crossed: how far the left wrist is right of the right wrist along the lateral axis (positive: the
            wrists' order is swapped, the arms cross).
        arm_clearance: the least distance between a point of the left arm and one of the right arm (shoulder,
            elbow, wrist and ``samples`` points along each bone), minus ``2 radius`` (negative: the arms touch).
    """
    points = body_points(motion, samples)[0]
    a, b, _ = bone_table(int(samples))
    joints = {side: {joint_index(f"{side}_{n}") for n in ("shoulder", "elbow", "wrist")} for side in SIDES}
    arm = {side: np.nonzero([(aj in joints[side] and bj in joints[side]) for aj, bj in zip(a, b)])[0]
           for side in SIDES}
    shoulder = {side: points[:, joint_index(f"{side}_shoulder")] for side in SIDES}
    lateral = shoulder["right"] - shoulder["left"]
    lateral[:, 2] = 0.0
    lateral /= np.linalg.norm(lateral, axis=-1, keepdims=True)
    middle = 0.5 * (shoulder["left"] + shoulder["right"])
    along = {side: np.einsum("ti,ti->t", points[:, joint_index(f"{side}_wrist")] - middle, lateral) for side in SIDES}
    pairs = np.linalg.norm(points[:, arm["left"], None] - points[:, None, arm["right"]], axis=-1)
    return {"left_across": along["left"], "right_across": -along["right"],
            "crossed": along["left"] - along["right"],
            "arm_clearance": pairs.min(axis=(1, 2)) - 2.0 * radius}


# ----------------------------------------------------------------------------- the checks


def _transform(pose: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(T, P, 3) points (P, 3) under poses (T, 4, 4)."""
    return np.einsum("tij,pj->tpi", pose[:, :3, :3], points) + pose[:, None, :3, 3]


def _scene_sdf(kitchen: Kitchen, points: np.ndarray, door_angle: np.ndarray, skip_cabinet=None) -> np.ndarray:
    """(T, P) signed distance of points (T, P, 3) to the kitchen without its bottle (item 0), the cabinet at
    each frame's ``door_angle`` (T,), and the walls; ``skip_cabinet`` (T, P) bool leaves the cabinet out."""
    T, P = points.shape[:2]
    flat = points.reshape(-1, 3)
    cabinet = kitchen.furniture_of("cabinet")
    others = [o for o in kitchen.objects if o is not cabinet and o is not kitchen.items[0]]
    d = room_sdf(kitchen.size, floor=False)(flat)
    for o in others:
        d = np.minimum(d, o.sdf(flat))
    d = d.reshape(T, P)
    angles = np.round(np.asarray(door_angle, dtype=np.float64), 6)
    for q in np.unique(angles):
        frames = np.nonzero(angles == q)[0]
        dc = cabinet.with_params(door_angle=float(q)).sdf(points[frames].reshape(-1, 3)).reshape(len(frames), P)
        if skip_cabinet is not None:
            dc = np.where(skip_cabinet[frames], np.inf, dc)
        d[frames] = np.minimum(d[frames], dc)
    return d


def body_distances(kitchen: Kitchen, motion: Motion, door, pose, *, hands: dict, contact,
                   config: PickAndPlaceConfig) -> BodyDistances:
    """``(scene (T, P), bottle (T, P))`` (:class:`~.demo_types.BodyDistances`): distances of the body sample points to
    the scene (the cabinet at each frame's ``door`` angle; the floor except for shins and feet) and to the bottle at
    its poses ``pose`` (T, 4, 4), the exempt contacts at infinity: points within ``contact_radius`` of the door
    hand's wrist while that wrist is on the handle (cabinet), and of the bottle hand's wrist while it is on the
    bottle's grasp point ``contact`` (3,) (given as it stands at first) (bottle)."""
    bottle = kitchen.items[0]
    cabinet = kitchen.furniture_of("cabinet")
    points, lower = body_points(motion, config.bone_samples)
    T, P = points.shape[:2]
    door_side, bottle_side = SIDES.index(hands["door"]), SIDES.index(hands["bottle"])
    wrists = points[:, [joint_index("left_wrist"), joint_index("right_wrist")]]
    near = [np.linalg.norm(points - wrists[:, i, None], axis=-1) < config.contact_radius for i in range(2)]
    handle = handle_at(cabinet, door)
    on_handle = np.linalg.norm(wrists[:, door_side] - handle, axis=-1) < config.contact_radius
    skip_cabinet = near[door_side] & on_handle[:, None]
    contact_local = np.linalg.solve(bottle.pose, np.append(contact, 1.0))[:3]
    grasp = _transform(pose, contact_local[None])[:, 0]
    on_bottle = np.linalg.norm(wrists[:, bottle_side] - grasp, axis=-1) < config.contact_radius
    skip_bottle = near[bottle_side] & on_bottle[:, None]
    d = _scene_sdf(kitchen, points, door, skip_cabinet)
    d = np.where(lower[None], d, np.minimum(d, points[..., 2]))
    local_points = np.einsum("tij,tpj->tpi", np.swapaxes(pose[:, :3, :3], -1, -2), points - pose[:, None, :3, 3])
    db = bottle.canonical_sdf(local_points.reshape(-1, 3)).reshape(T, P)
    return BodyDistances(d, np.where(skip_bottle, np.inf, db))


def evaluate(result: PickAndPlace, *, door_angle=None, bottle_pose=None) -> dict:
    """The checks of a run, or of the same motion with another ``door_angle`` (T,) or ``bottle_pose``
    (T, 4, 4) (to see the detector flag a door kept shut or a bottle moved through a wall).

    Returns a dictionary:
        door_asked, door_peak, door_final: radians: the scheduler's opening, the largest and the last.
        door_opened: the peak reaches the scheduler's opening.
        bottle_out: at the end no point of the bottle is inside the cabinet's box (door closed).
        placed: at the end the bottle stands upright on the table top (its base within ``tolerance`` of the
            top, its centre over it).
        body_clearance: metres: the least scene distance of a body sample point, minus ``body_radius``
            (the exempt contacts left out).
        bottle_clearance: metres: the bottle's least distance to the scene while carried (off its start and
            end poses by more than ``lift / 2``).
        bottle_penetration: metres: the deepest the bottle sinks into the scene at any frame.
        body_in_bottle: metres: the least distance of a (not exempt) body point to the bottle, minus the radius.
        min_clearance: the least of ``body_clearance`` and ``bottle_clearance``.
        collision: a body point closer than ``body_radius`` to the scene or the bottle, or the bottle sinking
            more than ``tolerance``.
        worst_body_frame, worst_body_point, worst_bottle_frame: where the least clearances are.
        door_hand_error: metres: the largest distance of the door hand's wrist from the handle while it holds
            it (the arm IK falls short when the handle is out of reach).
        door_hand_across: metres: the farthest the door hand's wrist passes the body's midline to the other
            arm's side while it holds the handle (:func:`arm_measures`; negative: it stays on its own side).
        arms_crossed: at some frame the wrists' left-right order is swapped (``crossed`` > 0).
        arm_clearance: metres: the least distance between the two arms minus two limb radii, over the run.
        self_contact: the arms touch (``arm_clearance`` < 0).
    """
    config = result.config
    kitchen = result.kitchen
    T = len(result.motion)
    door = result.door_angle if door_angle is None else np.asarray(door_angle, dtype=np.float64)
    pose = result.bottle_pose if bottle_pose is None else np.asarray(bottle_pose, dtype=np.float64)
    if door.shape != (T,):
        raise ValueError(f"door_angle: expected shape ({T},) (one angle per frame), got {door.shape}")
    if pose.shape != (T, 4, 4):
        raise ValueError(f"bottle_pose: expected shape ({T}, 4, 4), got {pose.shape}")
    bottle = kitchen.items[0]
    cabinet = kitchen.furniture_of("cabinet")
    d, db = body_distances(kitchen, result.motion, door, pose, hands=result.hands, contact=result.plan.task.target.contact,
                           config=config)
    body_clearance = float(np.min(d)) - config.body_radius
    body_in_bottle = float(np.min(db)) - config.body_radius
    # the bottle against the scene
    surface = np.asarray(bottle.to_canonical(bottle.surface_points(256, seed=0)), dtype=np.float64)
    moved = _transform(pose, surface)
    dbs = _scene_sdf(kitchen, moved, door).min(axis=1)
    penetration = float(max(0.0, -np.min(dbs)))
    lift = config.scheduler.lift
    off = (np.linalg.norm(pose[:, :3, 3] - pose[0, :3, 3], axis=-1) > lift / 2) & \
          (np.linalg.norm(pose[:, :3, 3] - pose[-1, :3, 3], axis=-1) > lift / 2)
    bottle_clearance = float(np.min(dbs[off])) if np.any(off) else float("nan")
    # the end state
    final_surface = moved[-1]
    carcass = cabinet.with_params(door_angle=0.0).bounds
    inside = np.all((final_surface >= carcass[0]) & (final_surface <= carcass[1]), axis=-1)
    table = kitchen.furniture_of("table")
    top = table.support_surfaces[0]
    base = table.to_canonical(pose[-1, :3, 3][None])[0]
    upright = float(pose[-1, 2, 2]) > math.cos(math.radians(2.0))
    over = top[1] <= base[0] <= top[2] and top[3] <= base[1] <= top[4]
    placed = bool(upright and over and abs(base[2] - top[0]) <= config.tolerance)
    asked = float(result.plan.task.opening)
    checks = {
        "door_asked": asked, "door_peak": float(np.max(door)), "door_final": float(door[-1]),
        "door_opened": bool(np.max(door) >= asked - 1e-6),
        "bottle_out": bool(not np.any(inside)),
        "placed": placed,
        "body_clearance": body_clearance,
        "bottle_clearance": bottle_clearance,
        "bottle_penetration": penetration,
        "body_in_bottle": body_in_bottle,
        "min_clearance": float(np.nanmin([body_clearance, bottle_clearance])),
    }
    checks["collision"] = bool(body_clearance < 0 or body_in_bottle < 0 or penetration > config.tolerance)
    starts = {n: (a, b) for n, a, b in result.phases}
    held = slice(starts["grasp handle"][0], starts["release door"][0])
    wrist = result.motion.joints[held, joint_index(f"{result.hands['door']}_wrist")].double().numpy()
    checks["door_hand_error"] = float(np.max(np.linalg.norm(wrist - handle_at(cabinet, door[held]), axis=-1)))
    arms = arm_measures(result.motion, config.bone_samples, config.body_radius)
    checks["door_hand_across"] = float(np.max(arms[f"{result.hands['door']}_across"][held]))
    checks["arms_crossed"] = bool(np.max(arms["crossed"]) > 0.0)
    checks["arm_clearance"] = float(np.min(arms["arm_clearance"]))
    checks["self_contact"] = bool(checks["arm_clearance"] < 0.0)
    worst = np.unravel_index(int(np.argmin(d)), d.shape)
    a, b, t = bone_table(config.bone_samples)
    checks["worst_body_frame"] = int(worst[0])
    checks["worst_body_point"] = JOINT_NAMES[a[worst[1]]] if a[worst[1]] == b[worst[1]] else \
        f"{JOINT_NAMES[a[worst[1]]]}-{JOINT_NAMES[b[worst[1]]]} at {t[worst[1]]:.1f}"
    checks["worst_bottle_frame"] = int(np.argmin(dbs))
    return checks
