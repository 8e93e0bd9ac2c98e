"""The machinery every interaction clip shares: the body's rest geometry (:class:`PlanBody`),
the per-frame plan of targets (:class:`Plan`) and its solution into a pose by exact two-bone IK
(:func:`plan_to_motion`), with the joint indices, argument checks and records the clips use.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import torch

from ..._validate import as_tensor, check_choice, check_finite, check_shape
from ..kinematics import forward_kinematics, solve_limb_ik
from ..motion import CONTACT_JOINTS, FPS, Motion
from ..rotations import axis_angle_to_matrix, matrix_to_axis_angle, yaw_of_matrix
from ..skeleton import NUM_BETAS, NUM_JOINTS, bone_offsets, joint_index
from .gait_body import SIDES
from .motion_math import forward_xyz, lerp, minimal_rotation, normalize, right_xyz, rot_x, rot_y, rot_z, smoothstep
from .poses import standing_pose

__all__ = [
    "SIDES", "SIGN", "PELVIS", "HIP", "KNEE", "ANKLE", "FOOT", "SHOULDER", "ELBOW", "WRIST", "SPINE", "CHEST",
    "NECK", "HEAD", "LEG_JOINTS", "FOOT_CONTACT", "WRIST_CONTACT", "PELVIS_CONTACT", "UP", "LEG_REACH",
    "ARM_REACH", "ELBOW_POLE", "seed_record", "n_frames", "describe_object", "check_object", "check_index",
    "check_betas", "check_hand", "PlanBody", "start_state", "Plan", "hand_on_joint", "second_hand_target",
    "hand_on_point", "upper_local", "plan_to_motion",
]

# Index 0 is the left side, 1 the right (``SIDES``).
SIGN = (-1.0, 1.0)  # +X is the character's right
PELVIS = 0
HIP = (joint_index("left_hip"), joint_index("right_hip"))
KNEE = (joint_index("left_knee"), joint_index("right_knee"))
ANKLE = (joint_index("left_ankle"), joint_index("right_ankle"))
FOOT = (joint_index("left_foot"), joint_index("right_foot"))
SHOULDER = (joint_index("left_shoulder"), joint_index("right_shoulder"))
ELBOW = (joint_index("left_elbow"), joint_index("right_elbow"))
WRIST = (joint_index("left_wrist"), joint_index("right_wrist"))
SPINE = (joint_index("spine1"), joint_index("spine2"), joint_index("spine3"))
CHEST = joint_index("spine3")
NECK, HEAD = joint_index("neck"), joint_index("head")
LEG_JOINTS = set(HIP + KNEE + ANKLE + FOOT)
FOOT_CONTACT = (CONTACT_JOINTS.index("left_foot"), CONTACT_JOINTS.index("right_foot"))
WRIST_CONTACT = (CONTACT_JOINTS.index("left_wrist"), CONTACT_JOINTS.index("right_wrist"))
PELVIS_CONTACT = CONTACT_JOINTS.index("pelvis")
UP = np.array([0.0, 0.0, 1.0])

# Fractions of the full limb length a target may ask for: the knees and elbows keep a bend.
LEG_REACH = 0.985
ARM_REACH = 0.93
# Share of the spine's pitch / roll / twist taken by spine1, spine2, spine3.
_SPINE_SHARE = np.array([0.35, 0.35, 0.30])
# Elbow bend direction in the chest frame (outwards, backwards, downwards), per side.
ELBOW_POLE = np.array([[-0.35, -1.0, -0.35], [0.35, -1.0, -0.35]])


# --------------------------------------------------------------------------- small helpers

def seed_record(seed):
    """The seed as ``meta`` records it: the int, or None for a generator."""
    return int(seed) if isinstance(seed, (int, np.integer)) else None


def n_frames(seconds: float) -> int:
    """Frames (at least 2) of a phase lasting ``seconds``."""
    return max(2, int(round(seconds * FPS)))


def describe_object(obj) -> dict:
    """What a clip records about its object: category, parameters and world pose (4, 4)."""
    return {"category": obj.category, "params": dict(obj.params), "pose": np.array(obj.pose, dtype=np.float64)}


def check_object(obj, allowed, name):
    for attr in ("category", "params", "pose", "sdf"):
        if not hasattr(obj, attr):
            raise TypeError(f"{name}: expected a ToyObject (world.objects.make_object), got {type(obj).__name__}")
    check_choice(obj.category, allowed, f"{name}.category")


def check_index(index, count: int, name: str) -> int:
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not 0 <= index < count:
        raise ValueError(f"{name}: expected an int in [0, {count}), got {index!r}")
    return int(index)


def check_betas(betas) -> torch.Tensor:
    out = torch.zeros(NUM_BETAS) if betas is None else as_tensor(betas, "betas").clone()
    check_shape(out, (NUM_BETAS,), "betas")
    check_finite(out, "betas")
    return out


def check_hand(hand, rng) -> int:
    """Index of the hand: ``hand`` ("left"/"right") or drawn from ``rng`` when None."""
    if hand is None:
        return int(rng.integers(2))
    check_choice(hand, SIDES, "hand")
    return SIDES.index(hand)


# --------------------------------------------------------------------------- the body

class PlanBody:
    """Rest geometry of one body shape (numpy float64)."""

    def __init__(self, betas):
        self.betas = betas
        self.offsets_torch = bone_offsets(betas).double()
        off = self.offsets_torch.numpy()
        self.offsets = off
        self.leg_length = np.array([np.linalg.norm(off[KNEE[i]]) + np.linalg.norm(off[ANKLE[i]]) for i in range(2)])
        self.arm_length = np.array([np.linalg.norm(off[ELBOW[i]]) + np.linalg.norm(off[WRIST[i]]) for i in range(2)])
        self.hip_offset = np.stack([off[HIP[0]], off[HIP[1]]])
        self.stand_local = standing_pose(betas)[0].double().numpy()

    def fk(self, local, root):
        """Batched FK in float64: ``local (..., 22, 3, 3)``, ``root (..., 3)`` numpy → (glob, pos) numpy."""
        glob, pos = forward_kinematics(torch.as_tensor(local), torch.as_tensor(root), self.offsets_torch)
        return glob.numpy(), pos.numpy()


def start_state(body: PlanBody, local, root):
    """Planted feet and heading of a standing pose: ankles (2, 3), foot rotations (2, 3, 3), heading."""
    glob, pos = body.fk(local, root)
    ankles = np.stack([pos[ANKLE[i]] for i in range(2)])
    feet = np.stack([glob[ANKLE[i]] for i in range(2)])
    heading = float(yaw_of_matrix(torch.as_tensor(glob[PELVIS])))
    return ankles, feet, heading


# --------------------------------------------------------------------------- the plan (per-frame targets)

_FIELDS = {
    # name: (trailing shape, default: None identity rotations, an int int64, else float)
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


@dataclass(eq=False)
class Plan:
    """Per-frame targets of an interaction clip of ``T`` frames, posed by :func:`plan_to_motion`.

    Every field is a numpy array with ``T`` rows (shapes and defaults in ``_FIELDS``): the
    pelvis (``root``, ``pelvis``), spine and neck angles, the ankle targets with their planted
    foot orientations, how far each lifted foot follows the shin (``relax``), knee poles, the
    wrist targets (``hand_*``, a second target ``hand2_*`` mixed in by ``hand_mix``, weighted by
    ``hand_weight``), hand directions, elbow poles, and the labels ``actions (T,)`` (indices
    into ``motion.ACTIONS``) and ``contacts (T, 5)`` (``motion.CONTACT_JOINTS``).
    """

    root: np.ndarray
    pelvis: np.ndarray
    spine: np.ndarray
    neck: np.ndarray
    ankle: np.ndarray
    foot: np.ndarray
    relax: np.ndarray
    knee_pole: np.ndarray
    hand_a: np.ndarray
    hand_b: np.ndarray
    hand_t: np.ndarray
    hand_offset: np.ndarray
    hand2_a: np.ndarray
    hand2_b: np.ndarray
    hand2_t: np.ndarray
    hand2_offset: np.ndarray
    hand_mix: np.ndarray
    hand_weight: np.ndarray
    hand_dir: np.ndarray
    hand_dir_weight: np.ndarray
    elbow_pole: np.ndarray
    actions: np.ndarray
    contacts: np.ndarray

    @classmethod
    def empty(cls, T: int) -> "Plan":
        """An empty plan of ``T`` frames: every ``_FIELDS`` entry at its default, no labels set."""
        arrays = {}
        for name, (shape, default) in _FIELDS.items():
            if default is None:
                arrays[name] = np.broadcast_to(np.eye(3), (T,) + shape).copy()
            elif isinstance(default, int):
                arrays[name] = np.full((T,) + shape, default, dtype=np.int64)
            else:
                arrays[name] = np.full((T,) + shape, float(default))
        arrays["elbow_pole"][:] = ELBOW_POLE
        arrays["actions"] = np.zeros(T, dtype=np.int64)
        arrays["contacts"] = np.zeros((T, len(CONTACT_JOINTS)), dtype=bool)
        return cls(**arrays)

    @classmethod
    def concat(cls, plans: list["Plan"]) -> "Plan":
        """Plans played one after the other."""
        return cls(**{f.name: np.concatenate([getattr(p, f.name) for p in plans]) for f in fields(cls)})

    def __len__(self) -> int:
        return len(self.root)


def hand_on_joint(plan: Plan, frames, side, a, b, t, offset, weight):
    """Drive a wrist to ``lerp(joint a, joint b, t) + offset`` (world offset; joints -1: a world point)."""
    plan.hand_a[frames, side] = a
    plan.hand_b[frames, side] = b
    plan.hand_t[frames, side] = t
    plan.hand_offset[frames, side] = offset
    plan.hand_weight[frames, side] = weight


def second_hand_target(plan: Plan, frames, side, a, b, t, offset, mix):
    """A second wrist target of the same form, blended in by ``mix``."""
    plan.hand2_a[frames, side] = a
    plan.hand2_b[frames, side] = b
    plan.hand2_t[frames, side] = t
    plan.hand2_offset[frames, side] = offset
    plan.hand_mix[frames, side] = mix


def hand_on_point(plan: Plan, frames, side, point, weight):
    """Drive a wrist to world points ``point``."""
    hand_on_joint(plan, frames, side, -1, -1, 0.0, point, weight)


def _spine_local(spine):
    """Local rotations ``(T, 3, 3, 3)`` of spine1..3 from (pitch, roll, twist) ``(T, 3)``."""
    out = []
    for share in _SPINE_SHARE:
        out.append(rot_z(spine[:, 2] * share) @ rot_y(spine[:, 1] * share) @ rot_x(-spine[:, 0] * share))
    return np.stack(out, 1)


def upper_local(plan: Plan, body: PlanBody):
    """Local rotations ``(T, 22, 3, 3)``: pelvis, spine, neck, head and hanging arms (legs at rest)."""
    T = len(plan.root)
    local = np.broadcast_to(body.stand_local, (T, NUM_JOINTS, 3, 3)).copy()
    local[:, PELVIS] = plan.pelvis
    local[:, list(SPINE)] = _spine_local(plan.spine)
    half = rot_z(plan.neck[:, 1] * 0.5) @ rot_x(-plan.neck[:, 0] * 0.5)
    local[:, NECK] = half
    local[:, HEAD] = half
    for j in LEG_JOINTS:
        local[:, j] = np.eye(3)
    return local


def _lower_root_for_legs(plan: Plan, body: PlanBody):
    """Lower the pelvis where a planted leg would over-extend (a safety net: the plans keep legs
    within reach; a lifted leg that cannot reach its target simply stretches towards it)."""
    root = plan.root.copy()
    hips = root[:, None, :] + np.einsum("tij,sj->tsi", plan.pelvis, body.hip_offset)
    for i in range(2):
        reach = LEG_REACH * body.leg_length[i]
        d_xy = np.linalg.norm(hips[:, i, :2] - plan.ankle[:, i, :2], axis=-1)
        max_z = plan.ankle[:, i, 2] + np.sqrt(np.clip(reach**2 - d_xy**2, 0.0, None))
        excess = np.clip(hips[:, i, 2] - max_z, 0.0, None) * plan.contacts[:, FOOT_CONTACT[i]]
        root[:, 2] -= excess
        hips[:, :, 2] -= excess[:, None]
    return root


def _hand_target(pos, a, b, t, offset):
    """World wrist targets ``(T, 3)`` from joint positions ``pos (T, 22, 3)``:
    ``lerp(joint a, joint b, t) + offset`` per frame (``offset`` alone where ``a < 0``)."""
    T = len(pos)
    target = offset.copy()
    on_body = a >= 0
    if np.any(on_body):
        pa = pos[np.arange(T), np.maximum(a, 0)]
        pb = pos[np.arange(T), np.maximum(b, 0)]
        target[on_body] += lerp(pa, pb, t)[on_body]
    return target


def _solve(plan: Plan, body: PlanBody, start=None, blend_seconds: float = 0.35):
    """Pose every frame of a plan: ``(local_rotations (T, 22, 3, 3), root (T, 3))`` torch float64.

    The upper body comes from the plan's angles, eased in from ``start`` (a pose
    ``(local (22, 3, 3), root (3,))``) over ``blend_seconds``; the legs by exact IK to the ankle
    targets with the plan's knee poles and foot orientations; the arms by exact IK to the hand
    targets, blended from a hanging arm by ``hand_weight``.
    """
    T = len(plan.root)
    root = _lower_root_for_legs(plan, body)
    local = upper_local(plan, body)
    if start is not None:
        n = min(T, n_frames(blend_seconds))
        w = 1.0 - smoothstep(np.arange(n) / max(n - 1, 1))
        start_local = np.asarray(start[0], dtype=np.float64)
        gen = local[:n]
        rel = np.swapaxes(gen, -1, -2) @ start_local[None]
        rel_aa = matrix_to_axis_angle(torch.as_tensor(rel)).numpy()
        blended = gen @ axis_angle_to_matrix(torch.as_tensor(rel_aa * w[:, None, None])).numpy()
        keep = [j for j in range(NUM_JOINTS) if j not in LEG_JOINTS]
        local[:n, keep] = blended[:, keep]
    local_t = torch.as_tensor(local)
    root_t = torch.as_tensor(root)
    offsets = body.offsets_torch
    for i, side in enumerate(SIDES):
        local_t = solve_limb_ik(local_t, root_t, f"{side}_leg", torch.as_tensor(plan.ankle[:, i]),
                                torch.as_tensor(plan.knee_pole[:, i]), offsets)
    glob, pos = forward_kinematics(local_t, root_t, offsets)
    glob_np = glob.numpy()
    for i in range(2):
        knee = glob_np[:, KNEE[i]]
        planted = np.swapaxes(knee, -1, -2) @ plan.foot[:, i]
        relaxed = np.broadcast_to(rot_x(-0.25), planted.shape)
        w = plan.relax[:, i]
        ankle_local = planted.copy()
        moving = np.nonzero(w > 0)[0]
        if len(moving):
            rel = np.swapaxes(planted[moving], -1, -2) @ relaxed[moving]
            aa = matrix_to_axis_angle(torch.as_tensor(rel)).numpy() * w[moving, None]
            ankle_local[moving] = planted[moving] @ axis_angle_to_matrix(torch.as_tensor(aa)).numpy()
        local_t[:, ANKLE[i]] = torch.as_tensor(ankle_local)
    glob, pos = forward_kinematics(local_t, root_t, offsets)
    glob_np, pos_np = glob.numpy(), pos.numpy()
    chest = glob_np[:, CHEST]
    chest_up = chest[:, :, 2]
    # Arms hang towards gravity when the chest tilts; blend from the animated arm by the tilt.
    tilt = np.arccos(np.clip(chest_up[:, 2], -1.0, 1.0))
    gravity = smoothstep((tilt - 0.15) / 0.6)
    heading = yaw_of_matrix(torch.as_tensor(plan.pelvis)).numpy()
    for i, side in enumerate(SIDES):
        shoulder = pos_np[:, SHOULDER[i]]
        wrist = pos_np[:, WRIST[i]]
        elbow = pos_np[:, ELBOW[i]]
        hang = shoulder + SIGN[i] * 0.07 * right_xyz(heading) + 0.06 * forward_xyz(heading) - 0.47 * UP
        base = lerp(wrist, hang, gravity)
        target = _hand_target(pos_np, plan.hand_a[:, i], plan.hand_b[:, i], plan.hand_t[:, i], plan.hand_offset[:, i])
        if np.any(plan.hand_mix[:, i] > 0):
            second = _hand_target(pos_np, plan.hand2_a[:, i], plan.hand2_b[:, i], plan.hand2_t[:, i],
                                  plan.hand2_offset[:, i])
            target = lerp(target, second, plan.hand_mix[:, i])
        weight = plan.hand_weight[:, i]
        goal = lerp(base, target, weight)
        # Pole: the current elbow side when nothing drives the arm, the chest-frame pole otherwise.
        line = normalize(wrist - shoulder)
        current = elbow - shoulder
        current = normalize(current - np.sum(current * line, -1, keepdims=True) * line)
        desired = normalize(np.einsum("tij,tj->ti", chest, plan.elbow_pole[:, i]))
        drive = np.maximum(weight, gravity)
        pole = normalize(lerp(current, desired, drive))
        local_t = solve_limb_ik(local_t, root_t, f"{side}_arm", torch.as_tensor(goal), torch.as_tensor(pole), offsets)
    hand_w = plan.hand_dir_weight
    if np.any(hand_w > 0):
        glob, pos = forward_kinematics(local_t, root_t, offsets)
        glob_np, pos_np = glob.numpy(), pos.numpy()
        for i in range(2):
            frames = np.nonzero(hand_w[:, i] > 0)[0]
            if len(frames) == 0:
                continue
            elbow_rot = glob_np[frames, ELBOW[i]]
            forearm = normalize(pos_np[frames, WRIST[i]] - pos_np[frames, ELBOW[i]])
            desired = normalize(plan.hand_dir[frames, i])
            full = minimal_rotation(forearm, desired)
            aa = matrix_to_axis_angle(torch.as_tensor(full)).numpy() * hand_w[frames, i][:, None]
            partial = axis_angle_to_matrix(torch.as_tensor(aa)).numpy()
            wrist_local = np.swapaxes(elbow_rot, -1, -2) @ partial @ elbow_rot
            local_t[frames, WRIST[i]] = torch.as_tensor(wrist_local)
    return local_t, root_t


def plan_to_motion(plan: Plan, body: PlanBody, start=None, meta=None) -> Motion:
    """Solve a plan into a labelled ``Motion`` (float32 rotations and root, the plan's labels)."""
    local, root = _solve(plan, body, start)
    motion = Motion(local_rotations=local.float(), root_position=root.float(), betas=body.betas, fps=FPS,
                    actions=plan.actions, contacts=plan.contacts, meta=dict(meta or {}))
    check_finite(motion.local_rotations, "local_rotations")
    return motion
