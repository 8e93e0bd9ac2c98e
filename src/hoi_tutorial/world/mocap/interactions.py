"""Procedural interaction clips for the toy mocap: sit, lie down, lift, reach and grasp, open a door or drawer.

These clips stand in for the interaction captures the three papers learn from: BEHAVE's sitting
and lifting (NIFTY §3.3 picks its *anchor poses* there: "the moment a person settles in a chair"
and the moment a person "contacts an object before lifting"), the SAMP capture (§4.1: walk to an
object, sit or lie down in several styles, get up, walk away) and the CHOICE capture (reaching,
grasping, opening cabinet doors and drawers).

Every clip is built the way a procedural animation system builds one:

1. an *approach*: ``gait.walk_path`` from a start at least 1.5 m away to a standing spot chosen
   from the object's geometry (in front of a seat, facing a box, a handle or a small prop); a
   sitter's last steps turn it round so it arrives with its back to the seat;
2. a *plan* of the interaction, frame by frame: the pelvis position and orientation follow smooth
   (minimum-jerk) curves between key poses, the spine leans, the feet stay planted where the
   approach left them (or step along a footstep plan), and the hands get targets: object contact
   points (lift contacts, grasp points, handles), or spots on the body (knees, thighs);
3. the *pose*: the legs and arms are solved with exact analytic two-bone IK
   (``kinematics.solve_limb_ik``) with the knees bending forward and the elbows backward, so a
   planted foot never slides and a hand on an object is exactly on its contact point.

Labels follow ``motion.ACTIONS`` and ``motion.CONTACT_JOINTS``: feet are in contact while planted,
the pelvis while seated or lying, a wrist while it holds the object. ``meta`` records the kind,
style, seed, a description of the object, ``anchor_frame`` (NIFTY's anchor: the settle frame of a
sit or lie, the first hand-contact frame of a lift, grasp, door or drawer), and for moving objects
``object_poses`` ``(T, 4, 4)`` world_from_object per frame and ``articulation`` ``(T,)`` (door
angle in radians or drawer opening in metres).

All randomness comes from ``seed`` (an int or a ``numpy.random.Generator``): the same seed gives
identical arrays; different seeds change the style, timing, speeds, the goal among an object's sit
goals, the hand used and the start of the approach.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np
import torch

from ...infra.device import single_threaded
from ..._validate import as_tensor, check_choice, check_finite, check_shape
from ..kinematics import forward_kinematics, solve_limb_ik
from ..motion import CONTACT_JOINTS, FPS, Motion, action_id
from ..rotations import axis_angle_to_matrix, matrix_to_axis_angle, yaw_of_matrix
from ..skeleton import NUM_BETAS, NUM_JOINTS, bone_offsets, joint_index
from . import gait
from .gait import _min_jerk, _rng, _rot_x, _rot_y, _rot_z, _wrap
from .gait import _smoothstep as _smooth
from .poses import standing_pose

__all__ = [
    "SIT_STYLES",
    "LIE_STYLES",
    "LIFT_STYLES",
    "sit",
    "lie",
    "lift",
    "reach_grasp",
    "open_door",
    "open_drawer",
]

SIT_STYLES = ("hands_on_knees", "leaning_back", "crossed_legs", "upright")
LIE_STYLES = ("on_back", "knees_up", "hands_behind_head")
LIFT_STYLES = ("squat", "stoop")

SIDES = ("left", "right")
_SIGN = (-1.0, 1.0)  # +X is the character's right
_PELVIS = 0
_HIP = (joint_index("left_hip"), joint_index("right_hip"))
_KNEE = (joint_index("left_knee"), joint_index("right_knee"))
_ANKLE = (joint_index("left_ankle"), joint_index("right_ankle"))
_FOOT = (joint_index("left_foot"), joint_index("right_foot"))
_SHOULDER = (joint_index("left_shoulder"), joint_index("right_shoulder"))
_ELBOW = (joint_index("left_elbow"), joint_index("right_elbow"))
_WRIST = (joint_index("left_wrist"), joint_index("right_wrist"))
_SPINE = (joint_index("spine1"), joint_index("spine2"), joint_index("spine3"))
_CHEST = joint_index("spine3")
_NECK, _HEAD = joint_index("neck"), joint_index("head")
_LEG_JOINTS = set(_HIP + _KNEE + _ANKLE + _FOOT)
_FOOT_CONTACT = (CONTACT_JOINTS.index("left_foot"), CONTACT_JOINTS.index("right_foot"))
_WRIST_CONTACT = (CONTACT_JOINTS.index("left_wrist"), CONTACT_JOINTS.index("right_wrist"))
_PELVIS_CONTACT = CONTACT_JOINTS.index("pelvis")
_UP = np.array([0.0, 0.0, 1.0])

# Fractions of the full limb length a target may ask for: the knees and elbows keep a bend.
_LEG_REACH = 0.985
_ARM_REACH = 0.93
# Share of the spine's pitch / roll / twist taken by spine1, spine2, spine3.
_SPINE_SHARE = np.array([0.35, 0.35, 0.30])
# Elbow bend direction in the chest frame (outwards, backwards, downwards), per side.
_ELBOW_POLE = np.array([[-0.35, -1.0, -0.35], [0.35, -1.0, -0.35]])


# --------------------------------------------------------------------------- small helpers

def _seed_record(seed):
    return int(seed) if isinstance(seed, (int, np.integer)) else None


def _frames(seconds: float) -> int:
    return max(2, int(round(seconds * FPS)))


def _bump(x):
    """``sin^2(pi x)`` on [0, 1]: 0 at both ends, 1 in the middle, flat ends."""
    return np.sin(np.pi * np.clip(x, 0.0, 1.0)) ** 2


def _rot_axis(axis, angle):
    """Rotations ``(..., 3, 3)`` about unit ``axis (3,)`` by ``angle (...)`` radians (Rodrigues)."""
    axis = np.asarray(axis, dtype=np.float64)
    angle = np.asarray(angle, dtype=np.float64)[..., None, None]
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def _forward(heading):
    """Ground direction ``(..., 3)`` that a heading faces (heading 0 faces +Y)."""
    heading = np.asarray(heading, dtype=np.float64)
    return np.stack([-np.sin(heading), np.cos(heading), np.zeros_like(heading)], -1)


def _right(heading):
    heading = np.asarray(heading, dtype=np.float64)
    return np.stack([np.cos(heading), np.sin(heading), np.zeros_like(heading)], -1)


def _heading_of(direction) -> float:
    return float(math.atan2(-direction[0], direction[1]))


def _unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def _expand(w, like):
    """Weights ``(T,)`` broadcast over the trailing dimensions of ``like (T, ...)``."""
    w = np.asarray(w, dtype=np.float64)
    return w.reshape(w.shape + (1,) * (np.ndim(like) - np.ndim(w)))


def _mix(a, b, w):
    """``a + w (b - a)`` with per-frame weights ``w (T,)``."""
    return a + _expand(w, b) * (b - a)


def _slerp_rot(r0, r1, w):
    """Rotations ``(T, 3, 3)`` from ``r0 (3, 3)`` to ``r1 (3, 3)`` at weights ``w (T,)``."""
    rel = torch.as_tensor(np.asarray(r0).T @ np.asarray(r1))
    axis_angle = matrix_to_axis_angle(rel[None]).numpy()[0]
    steps = axis_angle_to_matrix(torch.as_tensor(np.asarray(w)[:, None] * axis_angle[None])).numpy()
    return np.asarray(r0)[None] @ steps


def _describe(obj) -> dict:
    """What a clip records about its object: category, parameters and world pose (4, 4)."""
    return {"category": obj.category, "params": dict(obj.params), "pose": np.array(obj.pose, dtype=np.float64)}


def _check_object(obj, allowed, name):
    for attr in ("category", "params", "pose", "sdf"):
        if not hasattr(obj, attr):
            raise TypeError(f"{name}: expected a ToyObject (world.objects.make_object), got {type(obj).__name__}")
    check_choice(obj.category, allowed, f"{name}.category")


def _check_index(index, count: int, name: str) -> int:
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < count:
        raise ValueError(f"{name}: expected an int in [0, {count}), got {index!r}")
    return int(index)


def _check_betas(betas) -> torch.Tensor:
    out = torch.zeros(NUM_BETAS) if betas is None else as_tensor(betas, "betas").clone()
    check_shape(out, (NUM_BETAS,), "betas")
    check_finite(out, "betas")
    return out


# --------------------------------------------------------------------------- the body

class _Body:
    """Rest geometry of one body shape (numpy float64)."""

    def __init__(self, betas):
        self.betas = betas
        self.offsets_torch = bone_offsets(betas).double()
        off = self.offsets_torch.numpy()
        self.offsets = off
        self.leg_length = np.array([np.linalg.norm(off[_KNEE[i]]) + np.linalg.norm(off[_ANKLE[i]]) for i in range(2)])
        self.arm_length = np.array([np.linalg.norm(off[_ELBOW[i]]) + np.linalg.norm(off[_WRIST[i]]) for i in range(2)])
        self.hip_offset = np.stack([off[_HIP[0]], off[_HIP[1]]])
        self.stand_local = standing_pose(betas)[0].double().numpy()

    def fk(self, local, root):
        """Batched FK in float64: ``local (..., 22, 3, 3)``, ``root (..., 3)`` numpy → (glob, pos) numpy."""
        glob, pos = forward_kinematics(torch.as_tensor(local), torch.as_tensor(root), self.offsets_torch)
        return glob.numpy(), pos.numpy()


def _start_state(body: _Body, local, root):
    """Planted feet and heading of a standing pose: ankles (2, 3), foot rotations (2, 3, 3), heading."""
    glob, pos = body.fk(local, root)
    ankles = np.stack([pos[_ANKLE[i]] for i in range(2)])
    feet = np.stack([glob[_ANKLE[i]] for i in range(2)])
    heading = float(yaw_of_matrix(torch.as_tensor(glob[_PELVIS])))
    return ankles, feet, heading


# --------------------------------------------------------------------------- the plan (per-frame targets)

_FIELDS = {
    # name: (trailing shape, default)
    "root": ((3,), 0.0),
    "pelvis": ((3, 3), None),
    "spine": ((3,), 0.0),           # forward pitch, roll to the right, twist to the left (radians)
    "neck": ((2,), 0.0),            # forward pitch, yaw to the left
    "ankle": ((2, 3), 0.0),
    "foot": ((2, 3, 3), None),      # global orientation of each planted foot
    "relax": ((2,), 0.0),           # 1: the foot follows the shin (lifted leg)
    "knee_pole": ((2, 3), 0.0),
    "hand_a": ((2,), -1),           # wrist target = lerp(joint a, joint b, t) + offset (joints -1: world)
    "hand_b": ((2,), -1),
    "hand_t": ((2,), 0.0),
    "hand_offset": ((2, 3), 0.0),
    "hand2_a": ((2,), -1),          # a second target of the same form, mixed in by hand_mix
    "hand2_b": ((2,), -1),
    "hand2_t": ((2,), 0.0),
    "hand2_offset": ((2, 3), 0.0),
    "hand_mix": ((2,), 0.0),
    "hand_weight": ((2,), 0.0),     # 0: the arm hangs, 1: the wrist is exactly on its target
    "hand_dir": ((2, 3), 0.0),      # desired direction of the hand (zero: continue the forearm)
    "hand_dir_weight": ((2,), 0.0),
    "elbow_pole": ((2, 3), 0.0),    # chest frame
}


def _plan(T: int) -> dict:
    """An empty plan of ``T`` frames: every ``_FIELDS`` entry at its default, no labels set."""
    plan = {}
    for name, (shape, default) in _FIELDS.items():
        if default is None:
            plan[name] = np.broadcast_to(np.eye(3), (T,) + shape).copy()
        elif isinstance(default, int):
            plan[name] = np.full((T,) + shape, default, dtype=np.int64)
        else:
            plan[name] = np.full((T,) + shape, float(default))
    plan["elbow_pole"][:] = _ELBOW_POLE
    plan["actions"] = np.zeros(T, dtype=np.int64)
    plan["contacts"] = np.zeros((T, len(CONTACT_JOINTS)), dtype=bool)
    return plan


def _concat(plans: list[dict]) -> dict:
    """Plans played one after the other."""
    return {k: np.concatenate([p[k] for p in plans]) for k in plans[0]}


def _hand_on_joint(plan, frames, side, a, b, t, offset, weight):
    """Drive a wrist to ``lerp(joint a, joint b, t) + offset`` (world offset; joints -1: a world point)."""
    plan["hand_a"][frames, side] = a
    plan["hand_b"][frames, side] = b
    plan["hand_t"][frames, side] = t
    plan["hand_offset"][frames, side] = offset
    plan["hand_weight"][frames, side] = weight


def _second_hand_target(plan, frames, side, a, b, t, offset, mix):
    """A second wrist target of the same form, blended in by ``mix``."""
    plan["hand2_a"][frames, side] = a
    plan["hand2_b"][frames, side] = b
    plan["hand2_t"][frames, side] = t
    plan["hand2_offset"][frames, side] = offset
    plan["hand_mix"][frames, side] = mix


def _hand_on_point(plan, frames, side, point, weight):
    """Drive a wrist to world points ``point``."""
    _hand_on_joint(plan, frames, side, -1, -1, 0.0, point, weight)


def _spine_local(spine):
    """Local rotations ``(T, 3, 3, 3)`` of spine1..3 from (pitch, roll, twist) ``(T, 3)``."""
    out = []
    for share in _SPINE_SHARE:
        out.append(_rot_z(spine[:, 2] * share) @ _rot_y(spine[:, 1] * share) @ _rot_x(-spine[:, 0] * share))
    return np.stack(out, 1)


def _upper_local(plan, body: _Body):
    """Local rotations ``(T, 22, 3, 3)``: pelvis, spine, neck, head and hanging arms (legs at rest)."""
    T = len(plan["root"])
    local = np.broadcast_to(body.stand_local, (T, NUM_JOINTS, 3, 3)).copy()
    local[:, _PELVIS] = plan["pelvis"]
    local[:, list(_SPINE)] = _spine_local(plan["spine"])
    half = _rot_z(plan["neck"][:, 1] * 0.5) @ _rot_x(-plan["neck"][:, 0] * 0.5)
    local[:, _NECK] = half
    local[:, _HEAD] = half
    for j in _LEG_JOINTS:
        local[:, j] = np.eye(3)
    return local


def _minimal_rotation(p, q):
    """Smallest rotations ``(..., 3, 3)`` turning unit directions ``p`` onto ``q`` (both ``(..., 3)``)."""
    p, q = _unit(p), _unit(q)
    axis = np.cross(p, q)
    s = np.linalg.norm(axis, axis=-1)
    c = np.sum(p * q, axis=-1)
    angle = np.arctan2(s, c)
    axis = axis / np.maximum(s, 1e-12)[..., None]
    aa = axis * angle[..., None]
    return axis_angle_to_matrix(torch.as_tensor(aa)).numpy()


def _lower_root_for_legs(plan, body: _Body):
    """Lower the pelvis where a planted leg would over-extend (a safety net: the plans keep legs
    within reach; a lifted leg that cannot reach its target simply stretches towards it)."""
    root = plan["root"].copy()
    hips = root[:, None, :] + np.einsum("tij,sj->tsi", plan["pelvis"], body.hip_offset)
    for i in range(2):
        reach = _LEG_REACH * body.leg_length[i]
        d_xy = np.linalg.norm(hips[:, i, :2] - plan["ankle"][:, i, :2], axis=-1)
        max_z = plan["ankle"][:, i, 2] + np.sqrt(np.clip(reach**2 - d_xy**2, 0.0, None))
        excess = np.clip(hips[:, i, 2] - max_z, 0.0, None) * plan["contacts"][:, _FOOT_CONTACT[i]]
        root[:, 2] -= excess
        hips[:, :, 2] -= excess[:, None]
    return root


def _hand_target(plan, pos, side, prefix):
    """World wrist targets ``(T, 3)``: ``lerp(joint a, joint b, t) + offset`` (offset alone when a < 0)."""
    T = len(pos)
    a, b = plan[f"{prefix}_a"][:, side], plan[f"{prefix}_b"][:, side]
    target = plan[f"{prefix}_offset"][:, side].copy()
    on_body = a >= 0
    if np.any(on_body):
        pa = pos[np.arange(T), np.maximum(a, 0)]
        pb = pos[np.arange(T), np.maximum(b, 0)]
        target[on_body] += _mix(pa, pb, plan[f"{prefix}_t"][:, side])[on_body]
    return target


def _solve(plan: dict, body: _Body, start=None, blend_seconds: float = 0.35):
    """Pose every frame of a plan: ``(local_rotations (T, 22, 3, 3), root (T, 3))`` torch float64.

    The upper body comes from the plan's angles, eased in from ``start`` (a pose
    ``(local (22, 3, 3), root (3,))``) over ``blend_seconds``; the legs by exact IK to the ankle
    targets with the plan's knee poles and foot orientations; the arms by exact IK to the hand
    targets, blended from a hanging arm by ``hand_weight``.
    """
    T = len(plan["root"])
    root = _lower_root_for_legs(plan, body)
    local = _upper_local(plan, body)
    if start is not None:
        n = min(T, _frames(blend_seconds))
        w = 1.0 - _smooth(np.arange(n) / max(n - 1, 1))
        start_local = np.asarray(start[0], dtype=np.float64)
        gen = local[:n]
        rel = np.swapaxes(gen, -1, -2) @ start_local[None]
        rel_aa = matrix_to_axis_angle(torch.as_tensor(rel)).numpy()
        blended = gen @ axis_angle_to_matrix(torch.as_tensor(rel_aa * w[:, None, None])).numpy()
        keep = [j for j in range(NUM_JOINTS) if j not in _LEG_JOINTS]
        local[:n, keep] = blended[:, keep]
    local_t = torch.as_tensor(local)
    root_t = torch.as_tensor(root)
    offsets = body.offsets_torch
    for i, side in enumerate(SIDES):
        local_t = solve_limb_ik(local_t, root_t, f"{side}_leg", torch.as_tensor(plan["ankle"][:, i]),
                                torch.as_tensor(plan["knee_pole"][:, i]), offsets)
    glob, pos = forward_kinematics(local_t, root_t, offsets)
    glob_np = glob.numpy()
    for i in range(2):
        knee = glob_np[:, _KNEE[i]]
        planted = np.swapaxes(knee, -1, -2) @ plan["foot"][:, i]
        relaxed = np.broadcast_to(_rot_x(-0.25), planted.shape)
        w = plan["relax"][:, i]
        ankle_local = planted.copy()
        moving = np.nonzero(w > 0)[0]
        if len(moving):
            rel = np.swapaxes(planted[moving], -1, -2) @ relaxed[moving]
            aa = matrix_to_axis_angle(torch.as_tensor(rel)).numpy() * w[moving, None]
            ankle_local[moving] = planted[moving] @ axis_angle_to_matrix(torch.as_tensor(aa)).numpy()
        local_t[:, _ANKLE[i]] = torch.as_tensor(ankle_local)
    glob, pos = forward_kinematics(local_t, root_t, offsets)
    glob_np, pos_np = glob.numpy(), pos.numpy()
    chest = glob_np[:, _CHEST]
    chest_up = chest[:, :, 2]
    # Arms hang towards gravity when the chest tilts; blend from the animated arm by the tilt.
    tilt = np.arccos(np.clip(chest_up[:, 2], -1.0, 1.0))
    gravity = _smooth((tilt - 0.15) / 0.6)
    heading = yaw_of_matrix(torch.as_tensor(plan["pelvis"])).numpy()
    for i, side in enumerate(SIDES):
        shoulder = pos_np[:, _SHOULDER[i]]
        wrist = pos_np[:, _WRIST[i]]
        elbow = pos_np[:, _ELBOW[i]]
        hang = shoulder + _SIGN[i] * 0.07 * _right(heading) + 0.06 * _forward(heading) - 0.47 * _UP
        base = _mix(wrist, hang, gravity)
        target = _hand_target(plan, pos_np, i, "hand")
        if np.any(plan["hand_mix"][:, i] > 0):
            target = _mix(target, _hand_target(plan, pos_np, i, "hand2"), plan["hand_mix"][:, i])
        weight = plan["hand_weight"][:, i]
        goal = _mix(base, target, weight)
        # Pole: the current elbow side when nothing drives the arm, the chest-frame pole otherwise.
        line = _unit(wrist - shoulder)
        current = elbow - shoulder
        current = _unit(current - np.sum(current * line, -1, keepdims=True) * line)
        desired = _unit(np.einsum("tij,tj->ti", chest, plan["elbow_pole"][:, i]))
        drive = np.maximum(weight, gravity)
        pole = _unit(_mix(current, desired, drive))
        local_t = solve_limb_ik(local_t, root_t, f"{side}_arm", torch.as_tensor(goal), torch.as_tensor(pole), offsets)
    hand_w = plan["hand_dir_weight"]
    if np.any(hand_w > 0):
        glob, pos = forward_kinematics(local_t, root_t, offsets)
        glob_np, pos_np = glob.numpy(), pos.numpy()
        for i in range(2):
            frames = np.nonzero(hand_w[:, i] > 0)[0]
            if len(frames) == 0:
                continue
            elbow_rot = glob_np[frames, _ELBOW[i]]
            forearm = _unit(pos_np[frames, _WRIST[i]] - pos_np[frames, _ELBOW[i]])
            desired = _unit(plan["hand_dir"][frames, i])
            full = _minimal_rotation(forearm, desired)
            aa = matrix_to_axis_angle(torch.as_tensor(full)).numpy() * hand_w[frames, i][:, None]
            partial = axis_angle_to_matrix(torch.as_tensor(aa)).numpy()
            wrist_local = np.swapaxes(elbow_rot, -1, -2) @ partial @ elbow_rot
            local_t[frames, _WRIST[i]] = torch.as_tensor(wrist_local)
    return local_t, root_t


def _to_motion(plan, body: _Body, start=None, meta=None) -> Motion:
    """Solve a plan into a labelled ``Motion`` (float32 rotations and root, the plan's labels)."""
    local, root = _solve(plan, body, start)
    motion = Motion(local_rotations=local.float(), root_position=root.float(), betas=body.betas, fps=FPS,
                    actions=plan["actions"], contacts=plan["contacts"], meta=dict(meta or {}))
    check_finite(motion.local_rotations, "local_rotations")
    return motion


# --------------------------------------------------------------------------- standing plans and bending

def _standing_plan(T, root, heading, ankles, feet, action):
    """A plan of ``T`` frames standing still with planted feet."""
    plan = _plan(T)
    plan["root"][:] = root
    plan["pelvis"][:] = _rot_z(heading)
    plan["ankle"][:] = ankles
    plan["foot"][:] = feet
    for i in range(2):
        plan["knee_pole"][:, i] = _forward(heading) + 0.15 * _SIGN[i] * _right(heading)
    plan["actions"][:] = action_id(action)
    plan["contacts"][:, _FOOT_CONTACT[0]] = True
    plan["contacts"][:, _FOOT_CONTACT[1]] = True
    return plan


def _bend_params(style: str, h, alpha):
    """Pelvis back shift and spine flexion for a bend of pelvis drop ``h`` (m) and pelvis pitch ``alpha`` (rad)."""
    if style == "squat":
        back = 0.42 * h + 0.05 * np.sin(alpha)
    else:
        back = 0.12 * np.sin(alpha) + 0.2 * h
    spine = 0.3 * alpha
    return back, spine


def _bent_root(stand_root, heading, style, h, alpha):
    """Pelvis positions ``(N, 3)`` and spine flexion ``(N,)`` of bends ``(h, alpha)`` from a standing pelvis."""
    back, spine = _bend_params(style, h, alpha)
    root = stand_root[None] - back[:, None] * _forward(heading)[None] - h[:, None] * _UP[None]
    return root, spine


def _choose_bend(body: _Body, stand_root, heading, ankles, targets: dict, style: str, rng,
                 obstacles=(), max_alpha=math.radians(80), max_drop=0.6, hug: bool = False):
    """Pelvis drop ``h`` and pitch ``alpha`` that bring the shoulders within reach of hand targets.

    A grid of bends is posed by FK; a bend is feasible when every target ``{side index: point
    (3,)}`` is within ``_ARM_REACH`` of its shoulder, both legs can still reach their planted
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
    plan = _plan(N)
    plan["root"] = roots
    plan["pelvis"] = _rot_z(np.full(N, heading)) @ _rot_x(-A)
    plan["spine"][:, 0] = spine
    plan["neck"][:, 0] = -0.5 * (A + spine)
    local = _upper_local(plan, body)
    _, pos = body.fk(local, roots)
    slack = np.zeros(N)
    feasible = np.ones(N, dtype=bool)
    for side, point in targets.items():
        dist = np.linalg.norm(pos[:, _SHOULDER[side]] - point[None], axis=-1)
        margin = _ARM_REACH * body.arm_length[side] - dist
        feasible &= margin >= 0
        slack += np.clip(-margin, 0.0, None)
    knees = []
    for i in range(2):
        leg = np.linalg.norm(pos[:, _HIP[i]] - ankles[i][None], axis=-1)
        feasible &= (leg <= _LEG_REACH * body.leg_length[i]) & (leg >= 0.42 * body.leg_length[i])
        slack += np.clip(leg - _LEG_REACH * body.leg_length[i], 0.0, None)
        knees.append(_knee_position(body, i, pos[:, _HIP[i]], np.broadcast_to(ankles[i], (N, 3)),
                                    _forward(heading) + 0.15 * _SIGN[i] * _right(heading)))
    torso = 0.05 if hug else 0.12
    probes = [(pos[:, _HEAD], 0.03 if hug else 0.10), (pos[:, _NECK], 0.5 * torso), (pos[:, _CHEST], torso),
              (pos[:, _SPINE[1]], torso), (knees[0], 0.06), (knees[1], 0.06)]
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


def _knee_position(body: _Body, side, hip, ankle, pole):
    """Where two-bone IK puts the knee (numpy, ``(N, 3)``) for hips, ankles and a pole direction."""
    l1 = np.linalg.norm(body.offsets[_KNEE[side]])
    l2 = np.linalg.norm(body.offsets[_ANKLE[side]])
    reach = ankle - hip
    d = np.clip(np.linalg.norm(reach, axis=-1), abs(l1 - l2) + 1e-4, l1 + l2 - 1e-4)
    u = _unit(reach)
    w = pole - np.sum(pole * u, -1, keepdims=True) * u
    w = _unit(w)
    cos_a = np.clip((l1**2 + d**2 - l2**2) / (2 * l1 * d), -1.0, 1.0)
    return hip + l1 * (cos_a[:, None] * u + np.sqrt(1 - cos_a**2)[:, None] * w)


def _standing_vertices(body: _Body, heading):
    """Body surface vertices ``(V, 3)`` of the standing pose at the origin facing ``heading``."""
    from ..body import body_vertices

    local, root = standing_pose(body.betas, heading=heading)
    glob, pos = forward_kinematics(local, root, body.offsets_torch.float())
    return body_vertices(glob, pos, body.betas).double().numpy()


def _reach_spot(body: _Body, obstacles, point, near, heading, targets, style, rng, lateral=0.0,
                gaps=(0.24, 0.32)):
    """Standing pelvis position ``(2,)`` facing ``point`` (the hand targets' centre, ``near`` metres
    behind the object's near face) from which a bend of ``style`` reaches every hand target.

    Tries gaps between the ankles and the near face (a sampled preferred one, smaller and larger
    ones), each with a bend search on the standing pose at that spot, and keeps the feasible one
    with the least bend (plus a small cost for straying from the preferred gap); ``lateral``
    shifts the spot to the character's right (metres). Returns ``(spot, hug)``: ``hug`` is True
    when only a bend leaning onto the object reaches.
    """
    facing = _forward(heading)
    first = rng.uniform(*gaps)
    candidates = [first] + [g for g in (0.20, 0.16, 0.28, 0.12, 0.36, 0.44, 0.52) if abs(g - first) > 0.02]
    if len(targets) == 1:
        # One hand: stand where the arm reaches the target comfortably extended (82 % of its
        # length) when that needs no bend; lower targets fall back to the gap list.
        side, target = next(iter(targets.items()))
        local, root = standing_pose(body.betas, heading=heading)
        _, pos = body.fk(local.double().numpy(), root.double().numpy())
        shoulder = pos[_SHOULDER[side]]
        side_offset = float(shoulder @ _right(heading)) + lateral
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
            spot = point[:2] - facing[:2] * (near + gap - 0.05) + lateral * _right(heading)[:2]
            # Walking in, the swinging legs reach about 7 cm past the standing body, and the walk
            # stops with the knees a little bent: keep a few centimetres more clear.
            walk_in = standing + np.append(spot + 0.12 * facing[:2], 0.0)[None]
            if any(np.min(obj.sdf(walk_in)) < 0.01 for obj in obstacles):
                continue
            local, root = standing_pose(body.betas, position=spot, heading=heading)
            local, root = local.double().numpy(), root.double().numpy()
            ankles, _, _ = _start_state(body, local, root)
            # The walk ends with the pelvis a little lower than the straight-legged rest pose.
            root = root - np.array([0.0, 0.0, 0.01])
            _, _, ok, cost = _choose_bend(body, root, heading, ankles, targets, style, rng, obstacles=obstacles,
                                          hug=hug)
            cost += 4.0 * (gap - candidates[0]) ** 2
            if ok and cost < best_cost:
                best, best_cost = spot, cost
        if best is not None:
            return best, hug
    return point[:2] - facing[:2] * (near + first - 0.05) + lateral * _right(heading)[:2], True


def _bend_plan(T, stand_root, heading, ankles, feet, style, h_curve, alpha_curve, action):
    """Standing plan whose pelvis drops by ``h_curve (T,)`` and pitches by ``alpha_curve (T,)``."""
    plan = _standing_plan(T, stand_root, heading, ankles, feet, action)
    root, spine = _bent_root(stand_root, heading, style, h_curve, alpha_curve)
    plan["root"] = root
    plan["pelvis"] = _rot_z(np.full(T, heading)) @ _rot_x(-alpha_curve)
    plan["spine"][:, 0] = spine
    plan["neck"][:, 0] = -0.45 * (alpha_curve + spine)
    return plan


def _chest_frames(plan, body: _Body):
    """Chest (spine3) rotations ``(T, 3, 3)`` and positions ``(T, 3)`` of a plan's upper body."""
    local = _upper_local(plan, body)
    glob, pos = body.fk(local, plan["root"])
    return glob[:, _CHEST], pos[:, _CHEST], pos


# --------------------------------------------------------------------------- geometry queries

def _extents_along(obstacles, origin_xy, direction, z_values, max_dist=2.0, step=0.01, margin=0.0):
    """Per height in ``z_values``: the largest ``t`` in [0, max_dist] with ``origin + t * direction``
    (at that height) inside an obstacle, 0 when none; numpy ``(len(z_values),)`` metres."""
    t = np.arange(0.0, max_dist + 1e-9, step)
    xy = origin_xy[None, :2] + t[:, None] * direction[None, :2]
    pts = np.concatenate([np.concatenate([xy, np.full((len(t), 1), z)], 1) for z in z_values])
    inside = np.zeros(len(pts), dtype=bool)
    for obj in obstacles:
        inside |= obj.sdf(pts) < margin
    inside = inside.reshape(len(z_values), len(t))
    return np.array([float(t[row].max()) if row.any() else 0.0 for row in inside])


def _extent_along(obstacles, origin_xy, direction, z_values, max_dist=2.0, step=0.01, margin=0.0):
    """Largest ``t`` in [0, max_dist] with a point ``origin + t * direction`` at some height inside an obstacle."""
    return float(_extents_along(obstacles, origin_xy, direction, z_values, max_dist, step, margin).max())


def _path_clear(waypoints, obstacles, skip_end: float, trust_end: float, clearance: float = 0.36,
                end_clearance: float = 0.17) -> bool:
    """Whether the walking path through ``waypoints`` keeps clear of every obstacle.

    The path must keep ``clearance`` metres from the obstacles, easing to ``end_clearance`` over
    its last ``skip_end`` metres (where it comes alongside the object); its last ``trust_end``
    metres are not checked (the standing spot was chosen clear of the object).
    """
    path = gait.path_from_waypoints(np.asarray(waypoints, dtype=np.float64))
    s = np.arange(0.0, max(path.length - trust_end, 0.0), 0.05)
    if len(s) == 0:
        return True
    xy, _ = path.at(s)
    ease = np.clip((path.length - skip_end - s) / 0.6, 0.0, 1.0)
    need = end_clearance + (clearance - end_clearance) * ease
    heights = (0.1, 0.5, 0.9, 1.3)
    pts = np.concatenate([np.concatenate([xy, np.full((len(xy), 1), z)], 1) for z in heights])
    need = np.tile(need, len(heights))
    return all(np.all(obj.sdf(pts) >= need) for obj in obstacles)


# --------------------------------------------------------------------------- approach

def _approach_waypoints(spot_xy, out_dir, rng, obstacles, start_position, centre_xy, sideways: bool,
                        lane: float = 0.0):
    """Waypoints from a start at least 1.5 m from ``centre_xy`` to the standing spot ``spot_xy``.

    ``out_dir (3,)`` points from the spot away from the object: starts are drawn within ±75° of
    it. The walker arrives along ``-out_dir`` (facing the object), or, when ``sideways``, straight
    from the start's side (a sitter then turns less to face away from the seat), along a lane
    ``lane`` metres farther out than the spot that the last half metre leaves for the spot (the
    turning steps of a sitter come in a little closer than a walking body may pass). A path that
    passes within 0.32 m of an obstacle gets a detour corner beside the object.
    """
    if start_position is not None:
        start = np.asarray(start_position, dtype=np.float64).reshape(-1)
        if start.shape != (2,) or not np.all(np.isfinite(start)):
            raise ValueError(f"start_position: expected 2 finite numbers (metres), got {start_position!r}")
        candidates = [start]
    else:
        candidates = []
        for _ in range(16):
            direction = _rot_z(rng.uniform(-1.3, 1.3))[:2, :2] @ out_dir[:2]
            candidates.append(centre_xy + direction * rng.uniform(1.6, 2.1))

    def pre_points(start):
        if not sideways:
            return [spot_xy + 0.5 * out_dir[:2]]
        # Along the object's front, from the start's side first: the final turn then swings the
        # toes away from the object, never into it. Where a straight lane is blocked (armrests),
        # the last metre comes in at a slant from a little farther out.
        to_start = start - spot_xy
        side = 1.0 if out_dir[0] * to_start[1] - out_dir[1] * to_start[0] >= 0 else -1.0
        return [spot_xy + across * (_rot_z(sign * np.pi / 2)[:2, :2] @ out_dir[:2]) + (lane + out) * out_dir[:2]
                for sign in (side, -side) for across, out in ((0.5, 0.0), (0.55, 0.25))]

    # Coming straight in, the last steps end on the spot that was checked for the walking body;
    # turning steps that leave the lane are checked by the caller.
    trust_end = (0.3 if lane > 0.0 else 0.05) if sideways else 0.35
    for start in candidates:
        for pre in pre_points(start):
            way = [start, pre, spot_xy]
            if _path_clear(way, obstacles, skip_end=0.55, trust_end=trust_end):
                return np.stack(way)
        side = 1.0 if (out_dir[0] * (start - spot_xy)[1] - out_dir[1] * (start - spot_xy)[0]) >= 0 else -1.0
        lateral = _rot_z(side * np.pi / 2)[:2, :2] @ out_dir[:2]
        reach = _extent_along(obstacles, centre_xy, np.append(lateral, 0.0), (0.1, 0.5, 0.9)) + 0.6
        corner = centre_xy + lateral * reach + out_dir[:2] * 0.6
        way = [start, corner, spot_xy + 0.5 * out_dir[:2], spot_xy]
        if _path_clear(way, obstacles, skip_end=0.55, trust_end=0.35):
            return np.stack(way)
    # No simple path (a start boxed in by an L-sofa, say): route around on a grid.
    for start in candidates:
        for pre in pre_points(start):
            outside = pre + 0.3 * out_dir[:2]
            route = _grid_route(start, outside, obstacles)
            if route is not None:
                return np.stack([start] + route + [outside, pre, spot_xy])
    start = candidates[0]
    return np.stack([start, pre_points(start)[0], spot_xy])


def _grid_route(start, goal, obstacles, clearance: float = 0.3, cell: float = 0.1):
    """Intermediate waypoints (a list of ``(2,)``) of a shortest 8-connected grid path from ``start``
    to ``goal`` that keeps ``clearance`` metres from the obstacles, or None when there is none."""
    import heapq

    lo = np.minimum(start, goal) - 2.5
    shape = tuple(np.ceil((np.maximum(start, goal) + 2.5 - lo) / cell).astype(int) + 1)
    ix, iy = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    xy = lo + cell * np.stack([ix, iy], -1).reshape(-1, 2)
    pts = np.concatenate([np.concatenate([xy, np.full((len(xy), 1), z)], 1) for z in (0.1, 0.5, 0.9, 1.3)])
    free = np.ones(len(pts), dtype=bool)
    for obj in obstacles:
        free &= obj.sdf(pts) >= clearance
    free = free.reshape(4, *shape).all(0)
    a = tuple(np.round((start - lo) / cell).astype(int))
    b = tuple(np.round((goal - lo) / cell).astype(int))
    if not (free[a] and free[b]):
        return None
    cost = {a: 0.0}
    parent = {}
    queue = [(0.0, a)]
    steps = [(dx, dy, math.hypot(dx, dy)) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    while queue:
        c, node = heapq.heappop(queue)
        if node == b:
            break
        if c > cost[node]:
            continue
        for dx, dy, length in steps:
            nxt = (node[0] + dx, node[1] + dy)
            if not (0 <= nxt[0] < shape[0] and 0 <= nxt[1] < shape[1]) or not free[nxt]:
                continue
            if c + length < cost.get(nxt, np.inf):
                cost[nxt] = c + length
                parent[nxt] = node
                heapq.heappush(queue, (c + length, nxt))
    if b not in parent:
        return None
    cells = [b]
    while cells[-1] != a:
        cells.append(parent[cells[-1]])
    path = lo + cell * np.array(cells[::-1], dtype=np.float64)
    # Keep every ~0.5 m of the grid path between the ends as waypoints.
    return [p for p in path[5:-5:5]]


def _approach(body: _Body, rng, spot_xy, heading, out_dir, obstacles, start_position, centre_xy, approach: bool,
              sideways: bool = False):
    """The walk to the standing spot (a ``Motion``, or ``None`` without approach) and its last pose (numpy)."""
    if not approach:
        local, root = standing_pose(body.betas, position=spot_xy, heading=heading)
        return None, (local.double().numpy(), root.double().numpy())
    waypoints = _approach_waypoints(spot_xy, out_dir, rng, obstacles, start_position, centre_xy, sideways)
    walk = gait.walk_path(waypoints, betas=body.betas, seed=rng, end_heading=heading, settle=False)
    return walk, (walk.local_rotations[-1].double().numpy(), walk.root_position[-1].double().numpy())


def _walk_away(body: _Body, rng, last_local, last_root, heading, distance):
    """A short walk of ``distance`` metres from the last pose, roughly straight ahead."""
    angle = rng.uniform(-0.3, 0.3)
    direction = _forward(heading + angle)[:2]
    waypoints = np.stack([last_root[:2], last_root[:2] + distance * direction])
    return gait.walk_path(waypoints, betas=body.betas, seed=rng, start=(torch.as_tensor(last_local),
                                                                        torch.as_tensor(last_root)), settle=False)


def _join(approach_motion, interaction: Motion, after: Optional[Motion], meta: dict):
    """Concatenate approach (without its last frame, which the interaction reproduces), interaction, after.

    Returns the motion and the index of the interaction's first frame.
    """
    parts = []
    first = 0
    if approach_motion is not None:
        parts.append(approach_motion.slice(0, len(approach_motion) - 1))
        first = len(approach_motion) - 1
    parts.append(interaction)
    if after is not None and len(after) > 1:
        parts.append(after.slice(1, len(after)))
    motion = Motion.concatenate(parts) if len(parts) > 1 else parts[0]
    motion.meta = dict(meta)
    return motion, first


# --------------------------------------------------------------------------- sit

# How far the standing body reaches behind the pelvis joint, by height above the ground (metres):
# calves, thighs and the buttocks.
# How far the standing body reaches behind the pelvis joint, by height above the ground (metres):
# heels, calves, thighs and the buttocks.
_BACK_PROFILE = ((0.03, 0.15), (0.12, 0.08), (0.35, 0.08), (0.55, 0.09), (0.75, 0.12), (0.95, 0.14))
# Half the width of a walking body (feet beside the path, thighs, swinging hands), metres.
_WALK_HALF_WIDTH = 0.23


def _sit_stand_distances(body: _Body, obj, goal, direction, rng) -> tuple[float, float]:
    """Distances in front of a sit goal: where the sitter stands to sit down, and where the walk ends.

    The standing spot keeps the body standing with its back to the seat (``_BACK_PROFILE``)
    clear of the object, yet near enough that the seated legs still reach the planted feet. The
    walk passes along the object's front on a lane where a walking body clears every part of the
    object below 1.1 m; its turning steps then come in to the standing spot (``_approach_seat``).
    Extents are measured along ``direction`` on a swath 0.4 m wide and every 3 cm of height.
    """
    heights = np.arange(0.02, 1.12, 0.03)
    right = np.cross(direction, _UP)
    extents = np.max([_extents_along([obj], goal + lateral * right, direction, tuple(heights), max_dist=1.5,
                                     step=0.02) for lateral in (-0.2, -0.1, 0.0, 0.1, 0.2)], axis=0)
    profile_z, profile_back = np.array(_BACK_PROFILE).T
    back = np.interp(heights, profile_z, profile_back)
    need = float(np.max(np.where(extents > 0, extents + back + 0.02, 0.0)))
    hip_drop = -float(np.mean(body.hip_offset[:, 2]))
    ankle_z = 0.09
    vertical = goal[2] - hip_drop - ankle_z
    reach = 0.96 * _LEG_REACH * float(body.leg_length.min())
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
    u = _min_jerk(times / times[-1])
    pelvis_xy = root[None, :2] + u[:, None] * np.asarray(shift)[None]
    ankle, foot, contact = _step_feet(times, pelvis_xy, np.full(T, heading), ankles, feet, heading, rng,
                                      lift=0.05)
    plan = _standing_plan(T, root, heading, ankles, feet, action)
    plan["root"][:, :2] = pelvis_xy
    plan["ankle"], plan["foot"] = ankle, foot
    plan["contacts"][:, list(_FOOT_CONTACT)] = contact
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


def _seated_hands(plan, frames, style, cross_side, weight):
    """Hand targets of a seated style on the body: knees, thighs or the lap."""
    for i in range(2):
        if style == "hands_on_knees":
            _hand_on_joint(plan, frames, i, _KNEE[i], _KNEE[i], 0.0, np.array([0.0, 0.0, 0.075]), weight)
        elif style == "crossed_legs":
            _hand_on_joint(plan, frames, i, _HIP[i], _KNEE[cross_side], 0.75, np.array([0.0, 0.0, 0.085]), weight)
        elif style == "leaning_back":
            _hand_on_joint(plan, frames, i, _HIP[i], _KNEE[i], 0.45, np.array([0.0, 0.0, 0.085]), weight)
        else:
            _hand_on_joint(plan, frames, i, _HIP[i], _KNEE[i], 0.6, np.array([0.0, 0.0, 0.085]), weight)


def _sit_down_plan(u, stand_root, seat, heading_from, heading_to, ankles, feet, posture, lean_peak, style,
                   cross_side, action, hanging=None):
    """Frames of sitting down (``u`` 0 → 1) or standing up (``u`` 1 → 0) between a standing pelvis and a seat.

    ``hanging (2, 3)``: on a seat too high for the feet to stay on the floor, the ankles leave
    the planted ``ankles`` early in the sit-down for these positions (feet off the floor).
    """
    T = len(u)
    plan = _plan(T)
    along = _smooth(u / 0.7)
    plan["root"][:, :2] = stand_root[None, :2] + along[:, None] * (seat[None, :2] - stand_root[None, :2])
    plan["root"][:, 2] = stand_root[2] + _min_jerk(u) * (seat[2] - stand_root[2])
    heading = heading_from + float(_wrap(heading_to - heading_from)) * _smooth(u / 0.5)
    settle = _smooth(u)
    pitch = lean_peak * _bump(u) + posture["pelvis"] * settle
    spine = 0.35 * lean_peak * _bump(u) + posture["spine"] * settle
    plan["pelvis"] = _rot_z(heading) @ _rot_x(-pitch)
    plan["spine"][:, 0] = spine
    plan["neck"][:, 0] = -0.5 * (pitch + spine)
    plan["ankle"][:] = ankles
    plan["foot"][:] = feet
    for i in range(2):
        plan["knee_pole"][:, i] = _forward(heading) + 0.15 * _SIGN[i] * _right(heading)
    start = 0.2 if style == "hands_on_knees" else 0.35
    _seated_hands(plan, slice(None), style, cross_side, _smooth((u - start) / (1.0 - start)))
    plan["actions"][:] = action_id(action)
    plan["contacts"][:, list(_FOOT_CONTACT)] = True
    if hanging is not None:
        lift = _min_jerk((u - 0.1) / 0.7)
        for i in range(2):
            plan["ankle"][:, i] = _lift_path(ankles[i], hanging[i], lift, 0.05)
            plan["relax"][:, i] = _lift_relax(lift)
            plan["contacts"][:, _FOOT_CONTACT[i]] = lift <= 0.0
    return plan


def _sit_hold_plan(T, seat, heading, ankles, feet, posture, style, cross_side, rng, unwind: bool, backrest,
                   raised: bool = False):
    """Seated frames: the style's settled motion (lean back, cross the legs) and breathing.

    With ``raised`` the legs rest stretched on a deep cushion (``ankles`` are their rest
    positions, the feet off the floor) and "crossed_legs" crosses the ankles.
    """
    plan = _plan(T)
    times = np.arange(T) / FPS
    end = times[-1]
    plan["root"][:] = seat
    ramp = np.ones(T)
    if style in ("leaning_back", "crossed_legs"):
        start, dur = rng.uniform(0.1, 0.3), rng.uniform(0.6, 0.9)
        ramp = _min_jerk((times - start) / dur)
        if unwind:
            back_dur = rng.uniform(0.55, 0.8)
            ramp = ramp * (1.0 - _min_jerk((times - (end - 0.1 - back_dur)) / back_dur))
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
    plan["pelvis"] = _rot_z(np.full(T, heading)) @ _rot_x(-pitch)
    plan["spine"][:, 0] = spine
    plan["neck"][:, 0] = -0.55 * (pitch + spine)
    look = math.radians(rng.uniform(-15, 15)) * _bump(times / max(end, 1e-6))
    plan["neck"][:, 1] = look
    plan["ankle"][:] = ankles
    plan["foot"][:] = feet
    for i in range(2):
        plan["knee_pole"][:, i] = _forward(heading) + 0.15 * _SIGN[i] * _right(heading)
        if raised:
            plan["knee_pole"][:, i] = _unit(_UP + 0.3 * _forward(heading) + 0.2 * _SIGN[i] * _right(heading))
    plan["contacts"][:, list(_FOOT_CONTACT)] = not raised
    plan["relax"][:] = 1.0 if raised else 0.0
    if style == "crossed_legs":
        c, o = cross_side, 1 - cross_side
        toward_other = -_SIGN[c] * _right(heading)
        if raised:
            crossed = ankles[o] + 0.02 * toward_other + 0.03 * _forward(heading) + np.array([0.0, 0.0, 0.08])
        else:
            crossed = ankles[o] + 0.10 * toward_other + 0.07 * _forward(heading) + np.array([0.0, 0.0, 0.19])
        lift = _min_jerk(ramp)
        plan["ankle"][:, c] = _mix(np.broadcast_to(ankles[c], (T, 3)), np.broadcast_to(crossed, (T, 3)), lift)
        plan["ankle"][:, c, 2] += 0.08 * _bump(ramp) * (ramp < 1.0)
        if not raised:
            plan["relax"][:, c] = _smooth(ramp / 0.4)
            pole = _unit(_forward(heading) + 1.3 * _UP + 0.4 * toward_other)
            plan["knee_pole"][:, c] = _unit(_mix(plan["knee_pole"][:, c], np.broadcast_to(pole, (T, 3)),
                                                 _smooth(ramp / 0.3)))
            plan["contacts"][:, _FOOT_CONTACT[c]] = ramp <= 0.0
    _seated_hands(plan, slice(None), style, cross_side, np.ones(T))
    plan["actions"][:] = action_id("sit")
    plan["contacts"][:, _PELVIS_CONTACT] = True
    return plan


def _seat_front(obj, goal, direction) -> float:
    """Distance from a sit goal to the front edge of the seat cushion (metres)."""
    return _extent_along([obj], goal, direction, (goal[2] - 0.12,), max_dist=1.2)


def _edge_goal(obj, goal, direction):
    """Where the pelvis first sits: the goal itself, or on a deep seat (front edge more than 0.45 m
    ahead, farther than the thighs reach) 0.40 m behind the edge, from where the sitter scoots back."""
    front = _seat_front(obj, goal, direction)
    if front <= 0.45:
        return goal.copy()
    return goal + (front - 0.40) * direction


def _lift_path(start, end, lift, arc):
    """Ankle path ``(T, 3)`` lifting a foot from ``start (3,)`` to ``end (3,)`` as ``lift (T,)`` goes
    0 → 1: it rises before it travels (no sliding near the floor) over an arc of ``arc`` metres."""
    along = _min_jerk((lift - 0.25) / 0.75)
    path = start[None] + along[:, None] * (end - start)[None]
    path[:, 2] = start[2] + _min_jerk(lift / 0.8) * (end[2] - start[2]) + arc * _bump(lift) * (lift < 1.0)
    path[:, 2] += 0.05 * np.sin(np.pi * np.clip(lift / 0.5, 0.0, 1.0))
    return path


def _lift_relax(lift):
    """How far a lifted foot has relaxed (turned to follow the shin) once off the floor."""
    return _smooth((lift - 0.3) / 0.4)


def _seated_reach(body: _Body, goal) -> float:
    """Farthest horizontal distance from a sit goal at which the seated legs reach feet on the floor."""
    hip_drop = -float(np.mean(body.hip_offset[:, 2]))
    vertical = goal[2] - hip_drop - 0.09
    reach = 0.97 * _LEG_REACH * float(body.leg_length.min())
    return math.sqrt(max(reach**2 - vertical**2, 0.0))


def _hanging_ankles(body: _Body, obj, goal, heading):
    """Rest positions ``(2, 3)`` of feet hanging off a seat too high to reach the floor from."""
    forward = _forward(heading)
    hip_z = goal[2] + float(np.mean(body.hip_offset[:, 2]))
    front = _extent_along([obj], goal, forward, tuple(np.linspace(0.1, max(hip_z - 0.15, 0.12), 6)), max_dist=1.0)
    reach = 0.9 * float(body.leg_length.min())
    ahead = float(np.clip(front + 0.1, 0.3, 0.85 * reach))
    out = np.zeros((2, 3))
    for i in range(2):
        out[i] = goal + ahead * forward + _SIGN[i] * 0.11 * _right(heading)
        out[i, 2] = max(0.12, hip_z - math.sqrt(max(reach**2 - ahead**2, 0.0)))
    return out


def _raised_ankles(body: _Body, goal, heading):
    """Rest positions ``(2, 3)`` of the ankles with the legs stretched on a deep cushion."""
    hip_drop = -float(np.mean(body.hip_offset[:, 2]))
    out = np.zeros((2, 3))
    for i in range(2):
        out[i] = goal + (0.05 + 0.9 * body.leg_length[i]) * _forward(heading) + _SIGN[i] * 0.11 * _right(heading)
        out[i, 2] = goal[2] - hip_drop + 0.06
    return out


def _scoot_plan(u, edge, goal, heading, ankles, feet, rest, posture, style, cross_side, action):
    """Frames sliding back from the seat's front part to a deep goal while the legs come up onto the
    cushion (``u`` 0 → 1), or the reverse (``u`` 1 → 0)."""
    T = len(u)
    plan = _plan(T)
    move = _min_jerk(u)
    plan["root"] = _mix(np.broadcast_to(edge, (T, 3)), np.broadcast_to(goal, (T, 3)), move)
    pitch = posture["pelvis"] - math.radians(8.0) * _bump(u)
    plan["pelvis"] = _rot_z(np.full(T, heading)) @ _rot_x(-pitch)
    plan["spine"][:, 0] = posture["spine"]
    plan["neck"][:, 0] = -0.55 * (pitch + posture["spine"])
    lift = _min_jerk(u / 0.85)
    for i in range(2):
        plan["ankle"][:, i] = _lift_path(ankles[i], rest[i], lift, 0.06)
        plan["relax"][:, i] = _lift_relax(lift)
        floor_pole = _forward(heading) + 0.15 * _SIGN[i] * _right(heading)
        up_pole = _UP + 0.3 * _forward(heading) + 0.2 * _SIGN[i] * _right(heading)
        plan["knee_pole"][:, i] = _unit(_mix(np.broadcast_to(floor_pole, (T, 3)), np.broadcast_to(up_pole, (T, 3)),
                                             _smooth(lift / 0.5)))
        plan["contacts"][:, _FOOT_CONTACT[i]] = lift <= 0.0
    plan["foot"][:] = feet
    _seated_hands(plan, slice(None), style, cross_side, np.ones(T))
    plan["actions"][:] = action_id(action)
    plan["contacts"][:, _PELVIS_CONTACT] = True  # sliding on the cushion
    return plan


def _sit_posture(style, rng):
    """Seated pelvis pitch and spine flexion (radians, forward positive) of a style."""
    if style == "hands_on_knees":
        return {"pelvis": math.radians(rng.uniform(0.0, 8.0)), "spine": math.radians(rng.uniform(15.0, 25.0))}
    if style == "upright":
        return {"pelvis": math.radians(rng.uniform(-6.0, 2.0)), "spine": math.radians(rng.uniform(0.0, 8.0))}
    return {"pelvis": math.radians(rng.uniform(-6.0, 0.0)), "spine": math.radians(rng.uniform(0.0, 8.0))}


def _front_is_free(obj, goal, direction) -> bool:
    """Whether a person can stand in front of a sit goal: the object reaches less than 0.7 m ahead of it
    (the corner seat of an L-sofa faces its chaise and is sat on from the side, which this generator
    does not do)."""
    heights = (0.1, 0.3, max(goal[2] - 0.12, 0.12))
    return _extent_along([obj], goal, direction, heights, max_dist=1.2, step=0.02) < 0.7


def _sit_goal(obj, goal_index, rng):
    """The sit goal to use: ``(index, pelvis position (3,), forward (3,))``, drawn among free ones."""
    positions, directions = obj.sit_goals
    unit = [_unit(np.array([d[0], d[1], 0.0])) for d in directions]
    free = [k for k in range(len(positions)) if _front_is_free(obj, positions[k], unit[k])]
    if goal_index is None:
        if not free:
            raise ValueError(f"obj: no sit goal of this {obj.category} has free space in front of it")
        k = int(free[int(rng.integers(len(free)))])
    else:
        k = _check_index(goal_index, len(positions), "goal_index")
        if k not in free:
            raise ValueError(f"goal_index: sit goal {k} of this {obj.category} has the object in front of it "
                             f"(free goals: {free})")
    return k, np.asarray(positions[k], dtype=np.float64), unit[k]


def _sit_sequence(body: _Body, obj, goal, direction, style, rng, start_root, ankles, feet, heading0, *,
                  stand_up: bool, hold_seconds: tuple):
    """Plans for sitting down on ``goal`` from a standing pose (pelvis ``start_root``, planted
    ``ankles`` and ``feet``, ``heading0``), holding, and optionally standing up.

    On a deep seat (see :func:`_edge_goal`) the pelvis first lands near the front edge, then
    scoots back onto the goal while the legs come up onto the cushion (still "sit_down").
    """
    heading = _heading_of(direction)
    posture = _sit_posture(style, rng)
    cross_side = int(rng.integers(2))
    edge = _edge_goal(obj, goal, direction)
    deep = bool(np.linalg.norm(edge - goal) > 1e-9)
    # A brisk sit-down; onto a deep seat a shorter one, as the scoot back onto the goal follows.
    n_down = _frames(rng.uniform(0.9, 1.2) if deep else rng.uniform(1.0, 1.5))
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
        n_scoot = _frames(rng.uniform(0.5, 0.7))
        plans.append(_scoot_plan(np.arange(n_scoot) / n_scoot, edge, goal, heading, ankles, feet, seated_ankles,
                                 posture, style, cross_side, "sit_down"))
    settle = sum(len(p["root"]) for p in plans)
    hold_t = rng.uniform(*hold_seconds)
    if style in ("leaning_back", "crossed_legs"):
        hold_t += 1.0 + (0.8 if stand_up else 0.0)
    backrest = _backrest_distance(obj, goal, direction) if style == "leaning_back" else None
    raised = deep or hanging is not None
    plans.append(_sit_hold_plan(_frames(hold_t), goal, heading, seated_ankles, feet, posture, style, cross_side, rng,
                                stand_up, backrest, raised=raised))

    def rise(rng):
        """Plans from seated on the goal to standing where the sit-down started ("stand_up")."""
        out = []
        if deep:
            n_scoot = _frames(rng.uniform(0.7, 1.0))
            out.append(_scoot_plan(1.0 - (np.arange(n_scoot) + 1) / n_scoot, edge, goal, heading, ankles, feet,
                                   seated_ankles, posture, style, cross_side, "stand_up"))
        n_up = _frames(rng.uniform(1.0, 1.4))
        u_up = 1.0 - (np.arange(n_up) + 1) / n_up
        out.append(_sit_down_plan(u_up, start_root, edge, heading, heading, ankles, feet, posture,
                                  math.radians(rng.uniform(25.0, 40.0)), style, cross_side, "stand_up",
                                  hanging=hanging))
        return out

    if stand_up:
        plans.extend(rise(rng))
    info = {"cross_side": SIDES[cross_side], "posture": posture, "backrest": backrest, "settle": settle,
            "deep_seat": deep, "feet_hanging": hanging is not None, "raised": raised,
            "seated_ankles": seated_ankles, "rise": rise}
    return plans, info


def _lowest_clearance(motion: Motion, obj, frames) -> float:
    """Smallest signed distance (metres) from ``obj`` to the body surface over ``frames`` of ``motion``."""
    from ..body import body_from_motion

    vertices = body_from_motion(motion, frames).double().numpy().reshape(-1, 3)
    return float(obj.sdf(vertices).min()) if len(vertices) else math.inf


def _approach_seat(body: _Body, obj, goal, direction, rng, start_position, approach: bool):
    """Walk to the front of a seat, arriving with the back to it, and (rarely) back up to it.

    The walk passes along the seat's front, where a walking body clears the object, and its last
    steps turn the walker to face away from the seat while they come in to the spot the sit-down
    starts from (``gait.walk_path(..., end_turn="steps")``). When those turning steps would
    brush the object, the walk ends on the walking body's lane instead and the sitter backs up to
    the seat in two quick steps.

    Returns ``(walk or None, (local, root) at the walk's end, backing plans, (stand_root, ankles,
    feet, heading))`` with the last the state the sit-down starts from.
    """
    edge = _edge_goal(obj, goal, direction)
    seat_dist, walk_dist = _sit_stand_distances(body, obj, edge, direction, rng)
    heading = _heading_of(direction)
    spot = edge[:2] + seat_dist * direction[:2]
    lane = max(walk_dist - seat_dist, 0.0)
    back = 0.0
    walk = None
    if approach:
        waypoints = _approach_waypoints(spot, direction, rng, [obj], start_position, goal[:2], True, lane=lane)
        walk = gait.walk_path(waypoints, betas=body.betas, seed=rng, end_heading=heading, settle=False,
                              end_turn="steps")
        if lane > 0.03:
            # The frames that leave the lane for the spot (the last 0.55 m of the walk) may come
            # no closer than standing on the spot does (where the calves may touch a seat too
            # high for the seated legs to reach farther), and never more than 1.5 cm into it.
            near = np.linalg.norm(walk.root_position[:, :2].double().numpy() - spot[None], axis=-1) < 0.55
            standing = _lowest_clearance(walk, obj, [len(walk) - 1])
            limit = max(min(standing, 0.0) - 0.005, -0.015)
            if _lowest_clearance(walk, obj, np.flatnonzero(near)) < limit:
                back = lane
                waypoints = waypoints.copy()
                waypoints[-1] = waypoints[-1] + lane * direction[:2]
                walk = gait.walk_path(waypoints, betas=body.betas, seed=rng, end_heading=heading, settle=False,
                                      end_turn="steps")
        local0, root0 = walk.local_rotations[-1].double().numpy(), walk.root_position[-1].double().numpy()
    else:
        local0, root0 = standing_pose(body.betas, position=spot, heading=heading)
        local0, root0 = local0.double().numpy(), root0.double().numpy()
    ankles, feet, heading0 = _start_state(body, local0, root0)
    backing = []
    if back > 0.0:
        n_back = _frames(rng.uniform(0.5, 0.7))
        plan, (root0_, ankles, feet) = _step_plan(n_back, root0, heading0, ankles, feet, -back * direction[:2], rng,
                                                   "walk")
        backing.append(plan)
        return walk, (local0, root0), backing, (root0_, ankles, feet, heading0)
    return walk, (local0, root0), backing, (root0, ankles, feet, heading0)


@single_threaded
def sit(obj, *, betas=None, seed=0, style: Optional[str] = None, goal_index: Optional[int] = None,
        approach: bool = True, stand_up: bool = True, start_position=None) -> Motion:
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
    Returns:
        ``Motion`` with actions, contacts (pelvis while seated; feet while planted) and ``meta``
        (kind, style, seed, object, goal_index, sit_goal, anchor_frame).
    """
    from ..objects import SITTABLE

    _check_object(obj, SITTABLE, "obj")
    rng = _rng(seed)
    body = _Body(_check_betas(betas))
    if style is None:
        style = str(rng.choice(SIT_STYLES))
    check_choice(style, SIT_STYLES, "style")
    k, goal, direction = _sit_goal(obj, goal_index, rng)
    heading = _heading_of(direction)
    walk, (local0, root0), backing, state = _approach_seat(body, obj, goal, direction, rng, start_position, approach)
    plans, info = _sit_sequence(body, obj, goal, direction, style, rng, *state, stand_up=stand_up,
                                hold_seconds=(0.8, 1.6))
    interaction = _to_motion(_concat(backing + plans), body, start=(local0, root0))
    info["settle"] += sum(len(p["root"]) for p in backing)
    after = None
    if stand_up:
        after = _walk_away(body, rng, interaction.local_rotations[-1].double().numpy(),
                           interaction.root_position[-1].double().numpy(), heading, rng.uniform(0.5, 0.8))
    meta = {"kind": "sit", "style": style, "seed": _seed_record(seed), "object": _describe(obj), "goal_index": k,
            "sit_goal": {"position": goal, "direction": direction}, "cross_side": info["cross_side"],
            "deep_seat": info["deep_seat"], "feet_hanging": info["feet_hanging"]}
    motion, first = _join(walk, interaction, after, meta)
    motion.meta["anchor_frame"] = first + info["settle"]
    motion.meta["interaction_start"] = first
    return motion


# --------------------------------------------------------------------------- lie

def _free_length(obj, origin, direction, z, max_dist=1.5, step=0.01) -> float:
    """Distance from ``origin`` along horizontal ``direction`` (at height ``z``) to the first point inside ``obj``."""
    t = np.arange(0.0, max_dist + 1e-9, step)
    pts = origin[None] + t[:, None] * direction[None]
    pts[:, 2] = z
    inside = obj.sdf(pts) < 0
    return float(t[np.argmax(inside)]) if inside.any() else max_dist


def _lying_rotation(head_dir):
    """Pelvis orientation lying on the back with the head towards ``head_dir (3,)`` (face up)."""
    z = _unit(head_dir)
    y = _UP.copy()
    x = np.cross(y, z)
    return np.stack([x, y, z], axis=1)


def _lie_pose_search(body: _Body, obj, goal, head_dir, style):
    """Spine flexion (radians) that lifts the head and chest clear of an armrest, and the ankle reach.

    Lying on the back, forward flexion raises the chest and head (as when resting the head on
    the armrest). Returns ``(flexion, ankle_distance)``: the smallest flexion on a grid whose head,
    neck and chest joints keep their capsule radius clear of the object, and how far from the
    pelvis along ``-head_dir`` the ankles rest.
    """
    flex = np.radians(np.arange(0.0, 61.0, 3.0))
    N = len(flex)
    plan = _plan(N)
    plan["root"][:] = goal
    plan["pelvis"][:] = _lying_rotation(head_dir)
    plan["spine"][:, 0] = flex
    plan["neck"][:, 0] = 0.4 * flex
    _, pos = body.fk(_upper_local(plan, body), plan["root"])
    clear = np.ones(N, dtype=bool)
    for joint, radius in ((_HEAD, 0.09), (_NECK, 0.06), (_CHEST, 0.10)):
        clear &= obj.sdf(pos[:, joint]) > radius - 0.02
    k = int(np.argmax(clear)) if clear.any() else N - 1
    cushion = goal[2] - 0.10
    free = _free_length(obj, goal, -_unit(head_dir), cushion + 0.06)
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
    plan = _plan(T)
    r_sit = _rot_z(seat_heading) @ _rot_x(-posture["pelvis"])
    head = _unit(head_dir)
    axis1 = _unit(np.cross(r_sit[:, 2], head))
    r_side = _rot_axis(axis1, math.acos(float(np.clip(r_sit[:, 2] @ head, -1, 1)))) @ r_sit
    r_lie = _lying_rotation(head)
    w1 = _min_jerk(u / 0.65)
    w2 = _min_jerk((u - 0.3) / 0.7)
    step1 = matrix_to_axis_angle(torch.as_tensor(r_side @ r_sit.T)).numpy()
    step2 = matrix_to_axis_angle(torch.as_tensor(r_lie @ r_side.T)).numpy()
    d1 = axis_angle_to_matrix(torch.as_tensor(w1[:, None] * step1[None])).numpy()
    d2 = axis_angle_to_matrix(torch.as_tensor(w2[:, None] * step2[None])).numpy()
    plan["pelvis"] = d2 @ d1 @ r_sit
    move = _min_jerk(u / 0.85)
    plan["root"] = _mix(np.broadcast_to(seat, (T, 3)), np.broadcast_to(goal, (T, 3)), move)
    lying = _smooth((u - 0.4) / 0.6)
    plan["spine"][:, 0] = posture["spine"] * (1.0 - _smooth(u / 0.4)) + flex * lying + math.radians(10) * _bump(u)
    plan["neck"][:, 0] = -0.55 * (posture["pelvis"] + posture["spine"]) * (1.0 - _smooth(u / 0.4)) + 0.4 * flex * lying
    # Legs swing from the floor onto the cushion, over the seat's front edge.
    lateral = np.cross(_UP, head)  # the lying body's right
    lift = _min_jerk((u - 0.1) / 0.75)
    hips_goal = goal - 0.09 * head
    for i in range(2):
        rest = hips_goal - ankle_dist * head + _SIGN[i] * 0.10 * lateral
        rest[2] = goal[2] - 0.04 + (0.06 if style == "knees_up" else 0.0)
        plan["ankle"][:, i] = _lift_path(ankles_floor[i], rest, lift, 0.22)
        plan["relax"][:, i] = 1.0 if raised else _lift_relax(lift)
        sit_pole = _forward(seat_heading) + 0.15 * _SIGN[i] * _right(seat_heading)
        if raised:
            sit_pole = _UP + 0.3 * _forward(seat_heading) + 0.2 * _SIGN[i] * _right(seat_heading)
        lie_pole = _UP + 0.25 * _SIGN[i] * lateral
        plan["knee_pole"][:, i] = _unit(_mix(np.broadcast_to(sit_pole, (T, 3)), np.broadcast_to(lie_pole, (T, 3)),
                                             _smooth(lift / 0.5)))
        plan["contacts"][:, _FOOT_CONTACT[i]] = (lift <= 0.0) & (not raised)
    plan["foot"][:] = feet_floor
    # Hands: from the lap (the seated target) to the belly or under the head.
    _seated_hands(plan, slice(None), "upright", 0, np.ones(T))
    for i in range(2):
        if style == "hands_behind_head":
            local = np.array([_SIGN[i] * 0.09, -0.08, 0.03])
            joint, t = (_HEAD, _HEAD), 0.0
            # The elbow swings out sideways on its way up (a straight blend of the two poles
            # would pass the shoulder-wrist line and flip the elbow).
            swing = _smooth((u - 0.4) / 0.6)
            pole = _mix(np.broadcast_to(_ELBOW_POLE[i], (T, 3)),
                        np.broadcast_to(np.array([_SIGN[i] * 1.0, 0.2, 0.7]), (T, 3)), swing)
            pole[:, 0] += _SIGN[i] * 1.5 * _bump(swing)
            plan["elbow_pole"][:, i] = _unit(pole)
        else:
            local = np.array([_SIGN[i] * 0.07, 0.15, 0.0])
            joint, t = (_PELVIS, _SPINE[1]), 0.6
        offset = np.einsum("tij,j->ti", plan["pelvis"], local)
        mix = _smooth((u - 0.3) / 0.7)
        _second_hand_target(plan, slice(None), i, joint[0], joint[1], t, offset, mix)
        if style == "hands_behind_head":
            # Up in front of the chest and out, not through the shoulder, on the way to the head.
            arc = np.einsum("tij,j->ti", plan["pelvis"], np.array([_SIGN[i] * 0.20, 0.30, 0.0])) * _bump(mix)[:, None]
            plan["hand_offset"][:, i] += arc
            plan["hand2_offset"][:, i] += arc
    plan["actions"][:] = action_id(action)
    plan["contacts"][:, _PELVIS_CONTACT] = True
    return plan


@single_threaded
def lie(obj, *, betas=None, seed=0, style: Optional[str] = None, goal_index: Optional[int] = None,
        approach: bool = True, stand_up: bool = False, start_position=None) -> Motion:
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
    Returns:
        ``Motion`` with actions, contacts (pelvis from the settle on the seat to the end of the
        lying; feet while on the floor) and ``meta`` (kind, style, seed, object, goal_index,
        lie_goal, sit_goal, anchor_frame, sit_anchor_frame).
    """
    from ..objects import LYING

    _check_object(obj, LYING, "obj")
    rng = _rng(seed)
    body = _Body(_check_betas(betas))
    if style is None:
        style = str(rng.choice(LIE_STYLES))
    check_choice(style, LIE_STYLES, "style")
    positions, directions = obj.lie_goals
    if goal_index is None:
        k = int(rng.integers(len(positions)))
    else:
        k = _check_index(goal_index, len(positions), "goal_index")
    goal = np.asarray(positions[k], dtype=np.float64)
    head_dir = _unit(np.array([directions[k][0], directions[k][1], 0.0]))
    sit_pos, sit_dir = obj.sit_goals
    # Sit where the pelvis has least far to go, on a seat facing across the lying direction.
    across = np.abs(sit_dir[:, :2] @ head_dir[:2]) < 0.5
    free = np.array([_front_is_free(obj, p, _unit(np.array([d[0], d[1], 0.0]))) for p, d in zip(sit_pos, sit_dir)])
    dist = np.linalg.norm(sit_pos[:, :2] - goal[None, :2], axis=-1) + 10.0 * (~across) + 10.0 * (~free)
    s_idx = int(np.argmin(dist + rng.uniform(0.0, 0.05, len(dist))))
    seat = np.asarray(sit_pos[s_idx], dtype=np.float64)
    seat_dir = _unit(np.array([sit_dir[s_idx][0], sit_dir[s_idx][1], 0.0]))
    heading = _heading_of(seat_dir)
    walk, (local0, root0), backing, state = _approach_seat(body, obj, seat, seat_dir, rng, start_position, approach)
    plans, info = _sit_sequence(body, obj, seat, seat_dir, "upright", rng, *state, stand_up=False,
                                hold_seconds=(0.3, 0.6))
    plans = backing + plans
    info["settle"] += sum(len(p["root"]) for p in backing)
    posture = info["posture"]
    _, _, feet, _ = state
    flex, ankle_dist = _lie_pose_search(body, obj, goal, head_dir, style)
    lie_args = (seat, heading, posture, goal, head_dir, info["seated_ankles"], feet, flex, ankle_dist, style,
                info["raised"])
    n_down = _frames(rng.uniform(1.6, 2.2))
    down = _lie_down_plan(np.arange(n_down) / n_down, *lie_args, "lie_down")
    n_lie = _frames(rng.uniform(1.5, 2.3))
    rest = _lie_down_plan(np.ones(n_lie), *lie_args, "lie")
    times = np.arange(n_lie) / FPS
    rest["spine"][:, 0] += math.radians(rng.uniform(0.8, 1.4)) * np.sin(2 * np.pi * times / rng.uniform(3.0, 4.5))
    n_sit = sum(len(p["root"]) for p in plans)
    plans = plans + [down, rest]
    if stand_up:
        n_up = _frames(rng.uniform(1.5, 2.0))
        plans.append(_lie_down_plan(1.0 - (np.arange(n_up) + 1) / n_up, *lie_args, "stand_up"))
        plans.extend(info["rise"](rng))
    interaction = _to_motion(_concat(plans), body, start=(local0, root0))
    after = None
    if stand_up:
        after = _walk_away(body, rng, interaction.local_rotations[-1].double().numpy(),
                           interaction.root_position[-1].double().numpy(), heading, rng.uniform(0.5, 0.8))
    meta = {"kind": "lie", "style": style, "seed": _seed_record(seed), "object": _describe(obj), "goal_index": k,
            "lie_goal": {"position": goal, "direction": head_dir},
            "sit_goal": {"position": seat, "direction": seat_dir, "index": s_idx},
            "deep_seat": info["deep_seat"], "feet_hanging": info["feet_hanging"]}
    motion, first = _join(walk, interaction, after, meta)
    motion.meta["sit_anchor_frame"] = first + info["settle"]
    motion.meta["anchor_frame"] = first + n_sit + n_down
    motion.meta["interaction_start"] = first
    return motion


# --------------------------------------------------------------------------- lift

def _near_extent(obstacles, point, towards, half_width: float, top: float) -> float:
    """How far the obstacles reach from ``point`` towards the person (``towards (3,)``), metres.

    Measured on a swath ``2 * half_width`` wide around ``point`` and every 3 cm of height up to
    ``top``, so thin parts (a seat board, chair legs, a table top) are not missed.
    """
    side = np.cross(_UP, towards)
    heights = tuple(np.arange(0.02, top + 0.03, 0.03))
    return max(_extent_along(obstacles, point + lateral * side, towards, heights, max_dist=1.5, step=0.02)
               for lateral in np.linspace(-half_width, half_width, 5))


def _carry_point(body: _Body, obj, stand_root, heading, contacts, near, rng):
    """Where the contacts' midpoint is carried: in front of the standing body at waist or chest height,
    within reach of both shoulders (searched on a small grid around a sampled preference)."""
    facing = _forward(heading)
    m0 = contacts.mean(0)
    half = contacts - m0
    bottom = m0[2] - float(obj.bounds[0, 2])
    plan = _plan(1)
    plan["root"][:] = stand_root
    plan["pelvis"][:] = _rot_z(heading)
    _, pos = body.fk(_upper_local(plan, body)[0], stand_root)
    forward = np.arange(near - 0.04, near + 0.40, 0.02)
    heights = np.arange(0.7, 1.46, 0.02)
    F, Z = np.meshgrid(forward, heights, indexing="ij")
    F, Z = F.ravel(), Z.ravel()
    points = stand_root[None] * np.array([1.0, 1.0, 0.0]) + F[:, None] * facing[None] + Z[:, None] * _UP[None]
    slack = np.zeros(len(F))
    for i in range(2):
        dist = np.linalg.norm(points + half[i][None] - pos[_SHOULDER[i]][None], axis=-1)
        slack += np.clip(dist - _ARM_REACH * body.arm_length[i], 0.0, None)
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
    from ..objects import LIFTABLE

    _check_object(obj, LIFTABLE, "obj")
    rng = _rng(seed)
    body = _Body(_check_betas(betas))
    if style is None:
        style = str(rng.choice(LIFT_STYLES))
    check_choice(style, LIFT_STYLES, "style")
    contacts = np.asarray(obj.lift_contacts, dtype=np.float64)
    facing = _unit(np.array([obj.lift_approach[0], obj.lift_approach[1], 0.0]))
    heading = _heading_of(facing)
    m0 = contacts.mean(0)
    near = _near_extent([obj], m0, -facing, 0.5 * float(np.linalg.norm(contacts[1] - contacts[0])),
                        float(obj.bounds[1, 2]))
    targets = {0: contacts[0], 1: contacts[1]}
    spot, hug = _reach_spot(body, [obj], m0, near, heading, targets, style, rng)
    centre = obj.bounds.mean(0)[:2]
    walk, (local0, root0) = _approach(body, rng, spot, heading, -facing, [obj], start_position, centre, approach)
    ankles, feet, heading0 = _start_state(body, local0, root0)
    heading = heading0 + float(_wrap(heading - heading0))
    h, alpha, _, _ = _choose_bend(body, root0, heading, ankles, targets, style, rng, obstacles=[obj], hug=hug)
    right = _right(heading)
    hand_down = _unit(-_UP + 0.3 * facing)
    pole = np.array([[-0.7, -0.7, -0.3], [0.7, -0.7, -0.3]])

    # Bend and reach: the hands come from outside and above onto the contacts.
    n_bend = _frames(rng.uniform(0.9, 1.3))
    u = np.arange(n_bend) / n_bend
    bend = _bend_plan(n_bend, root0, heading, ankles, feet, style, h * _min_jerk(u), alpha * _min_jerk(u), "lift")
    reach = _smooth((u - 0.25) / 0.75)
    for i in range(2):
        approach_offset = (1.0 - reach)[:, None] * (_SIGN[i] * 0.10 * right + 0.06 * _UP)[None]
        _hand_on_point(bend, slice(None), i, contacts[i][None] + approach_offset, reach)
        bend["hand_dir"][:, i] = hand_down
        bend["hand_dir_weight"][:, i] = reach
        bend["elbow_pole"][:, i] = _unit(_mix(np.broadcast_to(_ELBOW_POLE[i], (n_bend, 3)),
                                              np.broadcast_to(pole[i], (n_bend, 3)), reach))

    # Hold: exact contact, then rise with the object.
    n_hold = _frames(rng.uniform(0.15, 0.3))
    n_rise = _frames(rng.uniform(1.0, 1.5))
    n_end = _frames(rng.uniform(0.5, 0.9))
    T = n_hold + n_rise + n_end
    rise_u = np.concatenate([np.zeros(n_hold), (np.arange(n_rise) + 1) / n_rise, np.ones(n_end)])
    s = _min_jerk(rise_u)
    final_h, final_alpha = 0.01, math.radians(-3.0)
    carry = _bend_plan(T, root0, heading, ankles, feet, style, h + (final_h - h) * s,
                       alpha + (final_alpha - alpha) * s, "lift")
    times = np.arange(T) / FPS
    carry["spine"][:, 0] += math.radians(1.0) * np.sin(2 * np.pi * times / 3.5) * _smooth(rise_u)
    chest_rot, chest_pos, _ = _chest_frames(carry, body)
    stand_plan = _bend_plan(1, root0, heading, ankles, feet, style, np.array([final_h]), np.array([final_alpha]),
                            "lift")
    m1 = _carry_point(body, obj, stand_plan["root"][0], heading, contacts, near, rng)
    m_local0 = chest_rot[0].T @ (m0 - chest_pos[0])
    m_local1 = chest_rot[-1].T @ (m1 - chest_pos[-1])
    m_local = _mix(np.broadcast_to(m_local0, (T, 3)), np.broadcast_to(m_local1, (T, 3)), s)
    mid = chest_pos + np.einsum("tij,tj->ti", chest_rot, m_local)
    for i in range(2):
        _hand_on_point(carry, slice(None), i, mid + (contacts[i] - m0)[None], np.ones(T))
        carry["hand_dir"][:, i] = hand_down
        carry["hand_dir_weight"][:, i] = 1.0
        carry["elbow_pole"][:, i] = pole[i]
        carry["contacts"][:, _WRIST_CONTACT[i]] = True

    interaction = _to_motion(_concat([bend, carry]), body, start=(local0, root0))
    meta = {"kind": "lift", "style": style, "seed": _seed_record(seed), "object": _describe(obj),
            "lift_contacts": contacts, "bend": {"pelvis_drop": h, "pelvis_pitch": alpha}}
    motion, first = _join(walk, interaction, None, meta)
    anchor = first + n_bend
    poses = np.broadcast_to(np.asarray(obj.pose, dtype=np.float64), (len(motion), 4, 4)).copy()
    poses[anchor:, :3, 3] += mid - m0[None]
    motion.meta.update({"anchor_frame": anchor, "interaction_start": first, "object_poses": poses})
    return motion


# --------------------------------------------------------------------------- reach and grasp

def _check_hand(hand, rng) -> int:
    """Index of the hand: ``hand`` ("left"/"right") or drawn from ``rng`` when None."""
    if hand is None:
        return int(rng.integers(2))
    check_choice(hand, SIDES, "hand")
    return SIDES.index(hand)


def _place_on_support(obj, rng, grasp_index):
    """Put a small object standing on the floor onto a table or a shelf board, its grasp point
    towards the reacher. Returns ``(placed object, support object or None, towards_person (3,))``."""
    from ..objects import make_object

    canonical = obj.annotations["grasp_points"][grasp_index]
    offset = np.array([canonical[0], canonical[1], 0.0])
    local_dir = _unit(offset) if np.linalg.norm(offset) > 0.02 else np.array([0.0, 1.0, 0.0])
    towards = _unit(obj.rotation @ local_dir * np.array([1.0, 1.0, 0.0]))
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
    yaw = _heading_of(towards)
    centre = obj.translation[:2] - (_rot_z(yaw)[:2, :2] @ np.array([x, y]))
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
    from ..objects import GRASPABLE

    _check_object(obj, GRASPABLE, "obj")
    rng = _rng(seed)
    body = _Body(_check_betas(betas))
    side = _check_hand(hand, rng)
    if pick_up is None:
        pick_up = bool(rng.random() < 0.6)
    n_points = len(obj.annotations["grasp_points"])
    if grasp_index is None:
        k = int(rng.integers(n_points))
    else:
        k = _check_index(grasp_index, n_points, "grasp_index")
    obj, support, towards = _place_on_support(obj, rng, k)
    obstacles = [obj] + ([support] if support is not None else [])
    point = np.asarray(obj.grasp_points[k], dtype=np.float64)
    facing = -towards
    heading = _heading_of(facing)
    near = _near_extent(obstacles, point, towards, 0.2, point[2] + 0.1)
    targets = {side: point}
    # Reaching over a surface hinges at the hips; squatting would push the knees into the support.
    style = "stoop"
    lateral = -_SIGN[side] * rng.uniform(0.10, 0.18)
    spot, hug = _reach_spot(body, obstacles, point, near, heading, targets, style, rng, lateral=lateral,
                            gaps=(0.14, 0.24))
    walk, (local0, root0) = _approach(body, rng, spot, heading, towards, obstacles, start_position,
                                      obj.translation[:2], approach)
    ankles, feet, heading0 = _start_state(body, local0, root0)
    heading = heading0 + float(_wrap(heading - heading0))
    h, alpha, _, _ = _choose_bend(body, root0, heading, ankles, targets, style, rng, obstacles=obstacles, hug=hug)
    hand_dir = _unit(_forward(heading) - 0.4 * _UP)

    n_reach = _frames(rng.uniform(0.7, 1.1))
    u = np.arange(n_reach) / n_reach
    reach = _bend_plan(n_reach, root0, heading, ankles, feet, style, h * _min_jerk(u), alpha * _min_jerk(u), "reach")
    w = _smooth(u / 0.9)
    pre = (1.0 - w)[:, None] * (0.10 * towards + 0.05 * _UP)[None]
    _hand_on_point(reach, slice(None), side, point[None] + pre, w)
    reach["hand_dir"][:, side] = hand_dir
    reach["hand_dir_weight"][:, side] = w

    n_hold = _frames(rng.uniform(0.25, 0.45))
    n_lift = _frames(rng.uniform(0.8, 1.2)) if pick_up else 0
    n_end = _frames(rng.uniform(0.5, 0.9))
    T = n_hold + n_lift + n_end
    lift_u = np.concatenate([np.zeros(n_hold), (np.arange(n_lift) + 1) / max(n_lift, 1), np.ones(n_end)])
    if not pick_up:
        lift_u[:] = 0.0
    s = _min_jerk(lift_u)
    grasp = _bend_plan(T, root0, heading, ankles, feet, style, h + (0.01 - h) * s, alpha * (1.0 - s), "grasp")
    chest_rot, chest_pos, _ = _chest_frames(grasp, body)
    if pick_up:
        stand = _bend_plan(1, root0, heading, ankles, feet, style, np.array([0.01]), np.zeros(1), "grasp")
        _, _, stand_pos = _chest_frames(stand, body)
        shoulder = stand_pos[0, _SHOULDER[side]]
        held = shoulder + 0.30 * _forward(heading) - _SIGN[side] * 0.08 * _right(heading) - 0.30 * _UP
        local0_pt = chest_rot[0].T @ (point - chest_pos[0])
        local1_pt = chest_rot[-1].T @ (held - chest_pos[-1])
        local_pts = _mix(np.broadcast_to(local0_pt, (T, 3)), np.broadcast_to(local1_pt, (T, 3)), s)
        wrist = chest_pos + np.einsum("tij,tj->ti", chest_rot, local_pts)
        # Lift clear of the support before moving in: a vertical bump that fades by the end.
        wrist[:, 2] += 0.08 * np.sin(np.pi * np.clip(lift_u / 0.7, 0.0, 1.0)) * (lift_u < 0.7)
    else:
        wrist = np.broadcast_to(point, (T, 3)).copy()
    _hand_on_point(grasp, slice(None), side, wrist, np.ones(T))
    grasp["hand_dir"][:, side] = hand_dir
    grasp["hand_dir_weight"][:, side] = 1.0
    grasp["contacts"][:, _WRIST_CONTACT[side]] = True

    interaction = _to_motion(_concat([reach, grasp]), body, start=(local0, root0))
    meta = {"kind": "reach_grasp", "style": style, "hand": SIDES[side], "pick_up": pick_up, "seed": _seed_record(seed),
            "object": _describe(obj), "support": None if support is None else _describe(support),
            "grasp_index": k, "grasp_point": point}
    motion, first = _join(walk, interaction, None, meta)
    anchor = first + n_reach
    poses = np.broadcast_to(np.asarray(obj.pose, dtype=np.float64), (len(motion), 4, 4)).copy()
    poses[anchor:, :3, 3] += wrist - point[None]
    motion.meta.update({"anchor_frame": anchor, "interaction_start": first, "object_poses": poses})
    return motion


# --------------------------------------------------------------------------- doors and drawers

def _step_feet(times, pelvis_xy, heading, ankles0, feet0, heading0, rng, step_time=(0.38, 0.48), lift=0.06):
    """Footsteps that keep the feet under a moving pelvis: ankles, foot rotations and contacts.

    The feet start planted at ``ankles0 (2, 3)`` with orientations ``feet0 (2, 3, 3)`` under a
    pelvis at ``pelvis_xy[0]`` with ``heading0``. When the pelvis path ``(T, 2)`` (with headings
    ``(T,)``) moves away, feet step in turn (the foot on the side of the motion first) to where
    their rest offset beside the pelvis will be when they land; each swing follows a
    minimum-jerk arc of ``lift`` metres. A planted foot never moves. Returns ``(ankle (T, 2, 3),
    foot (T, 2, 3, 3), contact (T, 2) bool)``.
    """
    T = len(times)
    rot0 = _rot_z(heading0)[:2, :2]
    home = np.stack([rot0.T @ (ankles0[i, :2] - pelvis_xy[0]) for i in range(2)])
    foot_local = np.stack([_rot_z(heading0).T @ feet0[i] for i in range(2)])

    def home_at(k, i):
        return pelvis_xy[k] + _rot_z(heading[k])[:2, :2] @ home[i]

    ankle = np.broadcast_to(ankles0, (T, 2, 3)).copy()
    foot = np.broadcast_to(feet0, (T, 2, 3, 3)).copy()
    contact = np.ones((T, 2), dtype=bool)
    travel = max(np.linalg.norm(home_at(T - 1, i) - ankles0[i, :2]) for i in range(2))
    turn = abs(float(_wrap(heading[-1] - heading0)))
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
        target_rot = _rot_z(heading[land]) @ foot_local[i]
        phase = (times[a:b + 1] - times[a]) / max(times[b] - times[a], 1e-6)
        # The foot rises before it travels and lands before it stops: no sliding near the ground.
        s = _min_jerk((phase - 0.2) / 0.6)
        ankle[a:b + 1, i, :2] = start_xy[None] + s[:, None] * (target_xy - start_xy)[None]
        ankle[a:b + 1, i, 2] = ankles0[i, 2] + lift * np.sin(np.pi * phase)
        ankle[b + 1:, i, :2] = target_xy
        ankle[b + 1:, i, 2] = ankles0[i, 2]
        foot[a:b + 1, i] = _slerp_rot(start_rot, target_rot, s)
        foot[b + 1:, i] = target_rot
        contact[a + 1:b, i] = False
    return ankle, foot, contact


def _handle_circle(obj):
    """Centre ``(3,)`` (on the hinge axis, at handle height) and the swing sign of a cabinet door's handle.

    The handle at door angle ``q`` is ``centre + R_z(sign q) (handle(0) - centre)``.
    """
    closed = obj.with_params(door_angle=0.0).handle_point
    quarter = obj.with_params(door_angle=math.pi / 2).handle_point
    sign = -float(obj.params["hinge_side"])
    rot = _rot_z(sign * math.pi / 2)[:2, :2]
    centre = np.linalg.solve(np.eye(2) - rot, quarter[:2] - rot @ closed[:2])
    return np.array([centre[0], centre[1], closed[2]]), sign, closed


def _handle_clip(kind: str, obj, *, betas, seed, hand, amount, approach, start_position) -> Motion:
    """Reach a door or drawer handle, pull it open while stepping back, and keep holding it."""
    rng = _rng(seed)
    body = _Body(_check_betas(betas))
    state = "door_angle" if kind == "open_door" else "drawer_open"
    low, high = ((math.radians(70.0), math.radians(100.0)) if kind == "open_door" else (0.25, 0.35))
    if amount is None:
        amount = float(rng.uniform(low, high))
    elif not (isinstance(amount, (int, float, np.floating, np.integer)) and low <= float(amount) <= high):
        unit = "radians" if kind == "open_door" else "metres"
        name = "angle" if kind == "open_door" else "distance"
        raise ValueError(f"{name}: expected {unit} in [{low:.3f}, {high:.3f}], got {amount!r}")
    closed = obj.with_params(**{state: 0.0})
    normal = _unit(closed.rotation @ np.array([0.0, 1.0, 0.0]))
    facing = -normal
    heading = _heading_of(facing)
    right = _right(heading)
    if kind == "open_door":
        centre, sign, handle0 = _handle_circle(closed)

        def handle_at(q):
            rot = _rot_z(sign * np.asarray(q))
            return centre[None] + np.einsum("tij,j->ti", rot, handle0 - centre)
        handle_side = float((handle0 - centre) @ right)
        side = (1 if handle_side > 0 else 0) if hand is None else _check_hand(hand, rng)
        lateral = _SIGN[side] * rng.uniform(0.0, 0.08) if side == (1 if handle_side > 0 else 0) else 0.0
    else:
        handle0 = closed.handle_point

        def handle_at(q):
            return handle0[None] + np.asarray(q)[:, None] * normal[None]
        side = _check_hand(hand, rng)
        lateral = -_SIGN[side] * rng.uniform(0.05, 0.15)
    style = str(rng.choice(LIFT_STYLES))
    targets = {side: handle0}
    spot, hug = _reach_spot(body, [closed], handle0, 0.0, heading, targets, style, rng, lateral=lateral,
                            gaps=(0.30, 0.40))
    walk, (local0, root0) = _approach(body, rng, spot, heading, normal, [closed], start_position,
                                      closed.translation[:2], approach)
    ankles, feet, heading0 = _start_state(body, local0, root0)
    heading = heading0 + float(_wrap(heading - heading0))
    h, alpha, _, _ = _choose_bend(body, root0, heading, ankles, targets, style, rng, obstacles=[closed], hug=hug)
    hand_dir = _unit(_forward(heading) - 0.2 * _UP)

    n_reach = _frames(rng.uniform(0.7, 1.0))
    u = np.arange(n_reach) / n_reach
    reach = _bend_plan(n_reach, root0, heading, ankles, feet, style, h * _min_jerk(u), alpha * _min_jerk(u), kind)
    w = _smooth(u / 0.9)
    pre = (1.0 - w)[:, None] * (0.10 * normal + 0.04 * _UP)[None]
    _hand_on_point(reach, slice(None), side, handle0[None] + pre, w)
    reach["hand_dir"][:, side] = hand_dir
    reach["hand_dir_weight"][:, side] = w

    # Pull: the handle moves; the body keeps its pose relative to the handle and steps along.
    n_hold = _frames(rng.uniform(0.1, 0.2))
    n_open = _frames(rng.uniform(1.3, 1.9) if kind == "open_door" else rng.uniform(1.0, 1.4))
    n_end = _frames(rng.uniform(0.4, 0.7))
    T = n_hold + n_open + n_end
    open_u = np.concatenate([np.zeros(n_hold), (np.arange(n_open) + 1) / n_open, np.ones(n_end)])
    q = amount * _min_jerk(open_u)
    handle = handle_at(q)
    turn = _SIGN[1 - side] * math.radians(rng.uniform(15.0, 30.0)) if kind == "open_door" else 0.0
    psi = heading + turn * _min_jerk(open_u)
    offset = _rot_z(heading)[:2, :2].T @ (handle0[:2] - root0[:2])
    pelvis_xy = handle[:, :2] - np.einsum("tij,j->ti", _rot_z(psi)[:, :2, :2], offset)
    times = np.arange(T) / FPS
    ankle_t, foot_t, contact_t = _step_feet(times, pelvis_xy, psi, ankles, feet, heading, rng)
    pull = _standing_plan(T, root0, heading, ankles, feet, kind)
    stand_roots = np.concatenate([pelvis_xy, np.full((T, 1), root0[2])], axis=1)
    back, spine = _bend_params(style, np.full(T, h), np.full(T, alpha))
    pull["root"] = stand_roots - back[:, None] * _forward(psi) - h * _UP[None]
    pull["pelvis"] = _rot_z(psi) @ _rot_x(np.full(T, -alpha))
    pull["spine"][:, 0] = spine
    pull["neck"][:, 0] = -0.45 * (alpha + spine)
    pull["ankle"] = ankle_t
    pull["foot"] = foot_t
    for i in range(2):
        pull["knee_pole"][:, i] = _forward(psi) + 0.15 * _SIGN[i] * _right(psi)
        pull["contacts"][:, _FOOT_CONTACT[i]] = contact_t[:, i]
    _hand_on_point(pull, slice(None), side, handle, np.ones(T))
    pull["hand_dir"][:, side] = _unit(_forward(psi) - 0.2 * _UP)
    pull["hand_dir_weight"][:, side] = 1.0
    pull["contacts"][:, _WRIST_CONTACT[side]] = True

    interaction = _to_motion(_concat([reach, pull]), body, start=(local0, root0))
    meta = {"kind": kind, "style": style, "hand": SIDES[side], "seed": _seed_record(seed), "object": _describe(closed),
            "articulation_name": state, "amount": amount}
    motion, first = _join(walk, interaction, None, meta)
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
    _check_object(cabinet, ("cabinet",), "cabinet")
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
    _check_object(drawer, ("drawer",), "drawer")
    return _handle_clip("open_drawer", drawer, betas=betas, seed=seed, hand=hand, amount=distance, approach=approach,
                        start_position=start_position)
