"""Standing and bending plans for the interaction clips: standing with planted feet, stepping
the feet to stay under a moving pelvis, the bend search (pelvis drop and pitch) that brings the
shoulders within reach of hand targets without the head or chest touching anything, and the
standing spot from which such a bend reaches.
"""
from __future__ import annotations

import math

import numpy as np

from ..body import body_vertices
from ..kinematics import forward_kinematics
from ..motion import FPS, action_id
from .body_plan import (
    ANKLE, ARM_REACH, CHEST, FOOT_CONTACT, HEAD, HIP, KNEE, LEG_REACH, NECK, SHOULDER, SIGN, SPINE, UP, Plan, PlanBody,
    start_state, upper_local,
)
from .motion_math import forward_xyz, min_jerk, normalize, right_xyz, rot_x, rot_z, slerp_rot, wrap_angle
from .poses import standing_pose

__all__ = ["standing_plan", "step_feet", "bend_params", "choose_bend", "reach_spot", "bend_plan", "chest_frames"]


def standing_plan(T, root, heading, ankles, feet, action):
    """A plan of ``T`` frames standing still with planted feet."""
    plan = Plan.empty(T)
    plan.root[:] = root
    plan.pelvis[:] = rot_z(heading)
    plan.ankle[:] = ankles
    plan.foot[:] = feet
    for i in range(2):
        plan.knee_pole[:, i] = forward_xyz(heading) + 0.15 * SIGN[i] * right_xyz(heading)
    plan.actions[:] = action_id(action)
    plan.contacts[:, FOOT_CONTACT[0]] = True
    plan.contacts[:, FOOT_CONTACT[1]] = True
    return plan


def step_feet(times, pelvis_xy, heading, ankles0, feet0, heading0, rng, step_time=(0.38, 0.48), lift=0.06):
    """Footsteps that keep the feet under a moving pelvis: ankles, foot rotations and contacts.

    The feet start planted at ``ankles0 (2, 3)`` with orientations ``feet0 (2, 3, 3)`` under a
    pelvis at ``pelvis_xy[0]`` with ``heading0``. When the pelvis path ``(T, 2)`` (with headings
    ``(T,)``) moves away, feet step in turn (the foot on the side of the motion first) to where
    their rest offset beside the pelvis will be when they land; each swing follows a
    minimum-jerk arc of ``lift`` metres. A planted foot never moves. Returns ``(ankle (T, 2, 3),
    foot (T, 2, 3, 3), contact (T, 2) bool)``.
    """
    T = len(times)
    rot0 = rot_z(heading0)[:2, :2]
    home = np.stack([rot0.T @ (ankles0[i, :2] - pelvis_xy[0]) for i in range(2)])
    foot_local = np.stack([rot_z(heading0).T @ feet0[i] for i in range(2)])

    def home_at(k, i):
        return pelvis_xy[k] + rot_z(heading[k])[:2, :2] @ home[i]

    ankle = np.broadcast_to(ankles0, (T, 2, 3)).copy()
    foot = np.broadcast_to(feet0, (T, 2, 3, 3)).copy()
    contact = np.ones((T, 2), dtype=bool)
    travel = max(np.linalg.norm(home_at(T - 1, i) - ankles0[i, :2]) for i in range(2))
    turn = abs(float(wrap_angle(heading[-1] - heading0)))
    if travel < 0.06 and turn < 0.25:
        return ankle, foot, contact
    n_steps = max(2, int(math.ceil(travel / 0.22)) + 1, int(math.ceil(turn / 0.6)) + 1)
    motion = rot0.T @ (pelvis_xy[-1] - pelvis_xy[0])
    first = 1 if motion[0] > 0.02 else 0 if motion[0] < -0.02 else int(rng.integers(2))
    duration = times[-1]
    swing = min(rng.uniform(*step_time), 0.9 * duration / n_steps * 2.0)
    starts = np.linspace(0.05 * duration, duration - swing - 0.02, n_steps)
    for k, t0 in enumerate(starts):
        i = (first + k) % 2
        a = int(np.searchsorted(times, t0))
        b = int(np.searchsorted(times, t0 + swing))
        b = min(max(b, a + 2), T - 1)
        land = min(T - 1, b + int(0.2 * FPS))
        start_xy = ankle[a, i, :2].copy()
        start_rot = foot[a, i].copy()
        target_xy = home_at(land, i)
        target_rot = rot_z(heading[land]) @ foot_local[i]
        phase = (times[a:b + 1] - times[a]) / max(times[b] - times[a], 1e-6)
        # The foot rises before it travels and lands before it stops: no sliding near the ground.
        s = min_jerk((phase - 0.2) / 0.6)
        ankle[a:b + 1, i, :2] = start_xy[None] + s[:, None] * (target_xy - start_xy)[None]
        ankle[a:b + 1, i, 2] = ankles0[i, 2] + lift * np.sin(np.pi * phase)
        ankle[b + 1:, i, :2] = target_xy
        ankle[b + 1:, i, 2] = ankles0[i, 2]
        foot[a:b + 1, i] = slerp_rot(start_rot, target_rot, s)
        foot[b + 1:, i] = target_rot
        contact[a + 1:b, i] = False
    return ankle, foot, contact


def bend_params(style: str, h, alpha):
    """Pelvis back shift and spine flexion for a bend of pelvis drop ``h`` (m) and pelvis pitch ``alpha`` (rad)."""
    if style == "squat":
        back = 0.42 * h + 0.05 * np.sin(alpha)
    else:
        back = 0.12 * np.sin(alpha) + 0.2 * h
    spine = 0.3 * alpha
    return back, spine


def _bent_root(stand_root, heading, style, h, alpha):
    """Pelvis positions ``(N, 3)`` and spine flexion ``(N,)`` of bends ``(h, alpha)`` from a standing pelvis."""
    back, spine = bend_params(style, h, alpha)
    root = stand_root[None] - back[:, None] * forward_xyz(heading)[None] - h[:, None] * UP[None]
    return root, spine


def choose_bend(body: PlanBody, stand_root, heading, ankles, targets: dict, style: str, rng,
                obstacles=(), max_alpha=math.radians(80), max_drop=0.6, hug: bool = False):
    """Pelvis drop ``h`` and pitch ``alpha`` that bring the shoulders within reach of hand targets.

    A grid of bends is posed by FK; a bend is feasible when every target ``{side index: point
    (3,)}`` is within ``ARM_REACH`` of its shoulder, both legs can still reach their planted
    ankles, and the head and chest keep clear of the ``obstacles`` (objects with ``sdf``). Among
    feasible bends the style picks: "squat" prefers bending the knees, "stoop" hinging the hips.
    With ``hug`` the chest and head may lean onto the object by a few centimetres (a large ball
    is taken by its sides only by leaning over it).
    Returns ``(h, alpha, feasible, cost)`` (the least-bad bend when none is feasible).
    """
    alphas = np.radians(np.arange(0.0, math.degrees(max_alpha) + 1e-6, 3.0))
    drops = np.arange(0.0, max_drop + 1e-6, 0.02)
    A, H = np.meshgrid(alphas, drops, indexing="ij")
    A, H = A.ravel(), H.ravel()
    N = len(A)
    roots, spine = _bent_root(stand_root, heading, style, H, A)
    plan = Plan.empty(N)
    plan.root = roots
    plan.pelvis = rot_z(np.full(N, heading)) @ rot_x(-A)
    plan.spine[:, 0] = spine
    plan.neck[:, 0] = -0.5 * (A + spine)
    local = upper_local(plan, body)
    _, pos = body.fk(local, roots)
    slack = np.zeros(N)
    feasible = np.ones(N, dtype=bool)
    for side, point in targets.items():
        dist = np.linalg.norm(pos[:, SHOULDER[side]] - point[None], axis=-1)
        margin = ARM_REACH * body.arm_length[side] - dist
        feasible &= margin >= 0
        slack += np.clip(-margin, 0.0, None)
    knees = []
    for i in range(2):
        leg = np.linalg.norm(pos[:, HIP[i]] - ankles[i][None], axis=-1)
        feasible &= (leg <= LEG_REACH * body.leg_length[i]) & (leg >= 0.42 * body.leg_length[i])
        slack += np.clip(leg - LEG_REACH * body.leg_length[i], 0.0, None)
        knees.append(_knee_position(body, i, pos[:, HIP[i]], np.broadcast_to(ankles[i], (N, 3)),
                                    forward_xyz(heading) + 0.15 * SIGN[i] * right_xyz(heading)))
    torso = 0.05 if hug else 0.12
    probes = [(pos[:, HEAD], 0.03 if hug else 0.10), (pos[:, NECK], 0.5 * torso), (pos[:, CHEST], torso),
              (pos[:, SPINE[1]], torso), (knees[0], 0.06), (knees[1], 0.06)]
    points = np.concatenate([p for p, _ in probes])
    radii = np.repeat([r for _, r in probes], N)
    for obj in obstacles:
        clear = (obj.sdf(points) - radii).reshape(len(probes), N).min(0)
        feasible &= clear > 0.0
        slack += np.clip(-clear, 0.0, None)
    if style == "squat":
        cost = 2.0 * A**2 + 0.6 * (H / 0.4) ** 2
    else:
        cost = 0.8 * A**2 + 2.0 * (H / 0.4) ** 2
    cost = cost * rng.uniform(0.9, 1.1)
    if np.any(feasible):
        k = int(np.argmin(np.where(feasible, cost, np.inf)))
    else:
        k = int(np.argmin(slack + 1e-3 * cost))
    return float(H[k]), float(A[k]), bool(feasible[k]), float(cost[k])


def _knee_position(body: PlanBody, side, hip, ankle, pole):
    """Where two-bone IK puts the knee (numpy, ``(N, 3)``) for hips, ankles and a pole direction."""
    l1 = np.linalg.norm(body.offsets[KNEE[side]])
    l2 = np.linalg.norm(body.offsets[ANKLE[side]])
    reach = ankle - hip
    d = np.clip(np.linalg.norm(reach, axis=-1), abs(l1 - l2) + 1e-4, l1 + l2 - 1e-4)
    u = normalize(reach)
    w = pole - np.sum(pole * u, -1, keepdims=True) * u
    w = normalize(w)
    cos_a = np.clip((l1**2 + d**2 - l2**2) / (2 * l1 * d), -1.0, 1.0)
    return hip + l1 * (cos_a[:, None] * u + np.sqrt(1 - cos_a**2)[:, None] * w)


def _standing_vertices(body: PlanBody, heading):
    """Body surface vertices ``(V, 3)`` of the standing pose at the origin facing ``heading``."""
    local, root = standing_pose(body.betas, heading=heading)
    glob, pos = forward_kinematics(local, root, body.offsets_torch.float())
    return body_vertices(glob, pos, body.betas).double().numpy()


def reach_spot(body: PlanBody, obstacles, point, near, heading, targets, style, rng, lateral=0.0,
               gaps=(0.24, 0.32)):
    """Standing pelvis position ``(2,)`` facing ``point`` (the hand targets' centre, ``near`` metres
    behind the object's near face) from which a bend of ``style`` reaches every hand target.

    Tries gaps between the ankles and the near face (a sampled preferred one, smaller and larger
    ones), each with a bend search on the standing pose at that spot, and keeps the feasible one
    with the least bend (plus a small cost for straying from the preferred gap); ``lateral``
    shifts the spot to the character's right (metres). Returns ``(spot, hug)``: ``hug`` is True
    when only a bend leaning onto the object reaches.
    """
    facing = forward_xyz(heading)
    first = rng.uniform(*gaps)
    candidates = [first] + [g for g in (0.20, 0.16, 0.28, 0.12, 0.36, 0.44, 0.52) if abs(g - first) > 0.02]
    if len(targets) == 1:
        # One hand: stand where the arm reaches the target comfortably extended (82 % of its
        # length) when that needs no bend; lower targets fall back to the gap list.
        side, target = next(iter(targets.items()))
        local, root = standing_pose(body.betas, heading=heading)
        _, pos = body.fk(local.double().numpy(), root.double().numpy())
        shoulder = pos[SHOULDER[side]]
        side_offset = float(shoulder @ right_xyz(heading)) + lateral
        ahead = float(shoulder @ facing)
        rise = float(shoulder[2] - target[2])
        across = 0.82 * body.arm_length[side] * rng.uniform(0.95, 1.02)
        horizontal = across**2 - rise**2 - side_offset**2
        if horizontal > 0.0:
            comfortable = math.sqrt(horizontal) + ahead - near + 0.05
            if comfortable > 0.1:
                candidates = [comfortable] + candidates
    standing = _standing_vertices(body, heading)
    for hug in (False, True):
        best, best_cost = None, np.inf
        for gap in candidates:
            spot = point[:2] - facing[:2] * (near + gap - 0.05) + lateral * right_xyz(heading)[:2]
            # Walking in, the swinging legs reach about 7 cm past the standing body, and the walk
            # stops with the knees a little bent: keep a few centimetres more clear.
            walk_in = standing + np.append(spot + 0.12 * facing[:2], 0.0)[None]
            if any(np.min(obj.sdf(walk_in)) < 0.01 for obj in obstacles):
                continue
            local, root = standing_pose(body.betas, position=spot, heading=heading)
            local, root = local.double().numpy(), root.double().numpy()
            ankles, _, _ = start_state(body, local, root)
            # The walk ends with the pelvis a little lower than the straight-legged rest pose.
            root = root - np.array([0.0, 0.0, 0.01])
            _, _, ok, cost = choose_bend(body, root, heading, ankles, targets, style, rng, obstacles=obstacles,
                                         hug=hug)
            cost += 4.0 * (gap - candidates[0]) ** 2
            if ok and cost < best_cost:
                best, best_cost = spot, cost
        if best is not None:
            return best, hug
    return point[:2] - facing[:2] * (near + first - 0.05) + lateral * right_xyz(heading)[:2], True


def bend_plan(T, stand_root, heading, ankles, feet, style, h_curve, alpha_curve, action):
    """Standing plan whose pelvis drops by ``h_curve (T,)`` and pitches by ``alpha_curve (T,)``."""
    plan = standing_plan(T, stand_root, heading, ankles, feet, action)
    root, spine = _bent_root(stand_root, heading, style, h_curve, alpha_curve)
    plan.root = root
    plan.pelvis = rot_z(np.full(T, heading)) @ rot_x(-alpha_curve)
    plan.spine[:, 0] = spine
    plan.neck[:, 0] = -0.45 * (alpha_curve + spine)
    return plan


def chest_frames(plan, body: PlanBody):
    """Chest (spine3) rotations ``(T, 3, 3)`` and positions ``(T, 3)`` of a plan's upper body."""
    local = upper_local(plan, body)
    glob, pos = body.fk(local, plan.root)
    return glob[:, CHEST], pos[:, CHEST], pos
