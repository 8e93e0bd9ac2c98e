"""SAMP's motion data augmentation (§4.2, Supp. F): one captured interaction, many objects.

"We detect the contacts of five key joints of the character skeleton. Namely, pelvis, hands, and
feet. We then augment our data by randomly switching or scaling the object ... For each new object
(scaled or switched), we project the contacts detected from the ground truth data to the new object.
Finally, we use an IK solver to recompute the full pose such that the contacts are maintained."
Supp. F: "When the object is replaced by a new one, we project the original contact by finding the
closest points on the surface of the new object. The new motion curve is computed by interpolation
and the whole full body pose is computed using CCD IK solver."

The algorithm box, as :func:`augment_clip` runs it on a toy clip:

1. **Contacts** (``motion.contacts``, ``CONTACT_JOINTS``): pelvis and wrists against the object,
   feet against the ground. For an object contact of joint ``x`` the contact point is the closest
   point ``p`` of the object's surface (:func:`closest_surface_point`) and ``o = x − p`` its offset.
2. **Projection**: ``p'`` is the point of the *new* object's surface closest to where the joint meets
   it along ``−o`` (ours: the surface point closest to ``p`` itself, as Supp. F words it, is the
   underside of a thin seat whenever ``p`` falls inside or under the new seat); the joint's target
   is ``x' = p' + o``, the same offset from the new surface.
3. **Motion curve**: the pelvis moves by ``d = x'_pelvis − x_pelvis`` on its contact frames; the
   displacement is interpolated linearly between contact frames, eased in over ``blend`` seconds
   before the first one and held after the last, and added to the root (the whole body follows).
4. **IK**: wrists in contact go to their targets, feet on the ground stay where they were (the
   ground did not change), by two-bone IK (``world.kinematics.solve_limb_ik``, analytic; SAMP uses
   CCD, which converges to the same pose for a two-bone chain that can reach its target).

Switching picks another toy object of the same category ("a random object of a similar size"); the
toy world's categories bound their sizes (``world.objects.CATEGORY_SIZES``). Scaling is the same
projection onto a copy with other sizes (``ToyObject.with_params``).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import torch

from ..world.kinematics import LIMBS, forward_kinematics, solve_limb_ik
from ..world.motion import CONTACT_JOINTS, Motion
from ..world.objects import ToyObject
from ..world.skeleton import JOINT_NAMES, bone_offsets

__all__ = ["OBJECT_CONTACT_JOINTS", "closest_surface_point", "augment_clip"]

OBJECT_CONTACT_JOINTS = ("pelvis", "left_wrist", "right_wrist")  # against the object; the feet are on the ground
_FOOT_LIMBS = {"left_foot": "left_leg", "right_foot": "right_leg"}
_HAND_LIMBS = {"left_wrist": "left_arm", "right_wrist": "right_arm"}


def closest_surface_point(obj: ToyObject, points: np.ndarray, iterations: int = 4, step: float = 1e-4) -> np.ndarray:
    """``(N, 3)`` the closest point of ``obj``'s surface to each of ``points (N, 3)`` (world, m).

    Newton steps on the signed distance, ``p ← p − sdf(p) ∇sdf(p)`` with a central-difference
    gradient of ``step`` metres: exact in one step on a flat face, a few at edges.
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3).copy()
    eye = np.eye(3) * step
    for _ in range(int(iterations)):
        d = obj.sdf(p)
        grad = np.stack([(obj.sdf(p + e) - obj.sdf(p - e)) / (2 * step) for e in eye], axis=-1)
        grad /= np.maximum(np.linalg.norm(grad, axis=-1, keepdims=True), 1e-9)
        p = p - d[:, None] * grad
    return p


def _facing_surface_point(obj: ToyObject, joints: np.ndarray, normals: np.ndarray, reach: float = 0.5) -> np.ndarray:
    """Where each joint ``(N, 3)`` meets ``obj``'s surface going against its contact normal ``(N, 3)``
    (sphere tracing; a joint inside the object first steps out along the normal). Joints whose ray
    misses within ``reach`` metres keep their own position (the caller projects it). Ours: Supp. F
    projects the contact point onto the closest surface point, which for a contact point inside a
    new, thin seat can be its underside; starting from the face the joint looks at avoids that."""
    n = normals / np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)
    q = np.asarray(joints, dtype=np.float64).copy()
    for _ in range(16):
        d = obj.sdf(q)
        if not (d < 0).any():
            break
        q[d < 0] += (1e-4 - d[d < 0])[:, None] * n[d < 0]
    start, travelled = q.copy(), np.zeros(len(q))
    for _ in range(64):
        d = np.maximum(obj.sdf(q), 0.0)
        step = np.where(travelled < reach, d, 0.0)
        q -= step[:, None] * n
        travelled += step
    hit = (obj.sdf(q) < 1e-3) & (travelled < reach)
    return np.where(hit[:, None], q, start)


def _limb_pole(positions: torch.Tensor, limb: str) -> torch.Tensor:
    """Keep the bend plane: the middle joint's offset from the upper-end midpoint, ``(T, 3)``."""
    upper, middle, end = LIMBS[limb]
    return positions[:, middle] - 0.5 * (positions[:, upper] + positions[:, end])


def augment_clip(motion: Motion, obj: ToyObject, new_obj: ToyObject, blend: float = 1.0) -> Motion:
    """The clip ``motion`` on ``obj`` moved onto ``new_obj`` with its contacts kept (module docstring).

    Args:
        motion: a clip with ``contacts`` (``(T, 5)``, ``CONTACT_JOINTS``).
        obj: the object the clip was made with; new_obj: the one to move it to (world frame both).
        blend: seconds over which the pelvis displacement eases in before its first contact.
    Returns:
        A new ``Motion`` (same length, labels and contacts; ``meta["augmented_from"]`` names the object;
        its ``meta["sit_goal"]`` or ``meta["lie_goal"]`` moved by the pelvis's displacement at the last
        frame, so that ``motion_data.clip_goals`` reads the goal on the new object).
    Raises:
        TypeError / ValueError: not a Motion with contacts, not ToyObjects, a negative blend.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
    if motion.contacts is None:
        raise ValueError("motion: expected contact labels (motion.contacts of CONTACT_JOINTS), got None")
    for name, o in (("obj", obj), ("new_obj", new_obj)):
        if not isinstance(o, ToyObject):
            raise TypeError(f"{name}: expected a ToyObject, got {type(o).__name__}")
    if not (np.isfinite(blend) and blend >= 0):
        raise ValueError(f"blend: expected non-negative seconds, got {blend!r}")
    T = len(motion)
    contacts = np.asarray(motion.contacts, dtype=bool)
    offsets = bone_offsets(motion.betas)
    _, positions = forward_kinematics(motion.local_rotations, motion.root_position, offsets)
    joints = positions.double().numpy()

    def targets(name: str) -> tuple[np.ndarray, np.ndarray]:
        """Frames where ``name`` touches the object, and its target there (steps 1–2)."""
        frames = np.flatnonzero(contacts[:, CONTACT_JOINTS.index(name)])
        x = joints[frames, JOINT_NAMES.index(name)]
        p = closest_surface_point(obj, x)
        return frames, closest_surface_point(new_obj, _facing_surface_point(new_obj, x, x - p)) + (x - p)

    # step 3: the pelvis displacement, interpolated over time
    frames, goal = targets("pelvis")
    shift = np.zeros((T, 3))
    if len(frames):
        d = goal - joints[frames, 0]
        t = np.arange(T)
        for k in range(3):
            shift[:, k] = np.interp(t, frames, d[:, k])
        ease = int(round(blend * motion.fps))
        before = t < frames[0]
        weight = np.clip((t - (frames[0] - ease)) / max(ease, 1), 0.0, 1.0)
        shift[before] *= weight[before, None]
    root = motion.root_position + torch.as_tensor(shift, dtype=motion.root_position.dtype)
    rotations = motion.local_rotations.clone()

    # step 4: IK for the wrists on the object and the feet on the ground
    for name, limb in {**_HAND_LIMBS, **_FOOT_LIMBS}.items():
        on = contacts[:, CONTACT_JOINTS.index(name)]
        if not on.any():
            continue
        end = LIMBS[limb][2]
        if name in _HAND_LIMBS:
            frames, goal = targets(name)
            target = torch.as_tensor(goal, dtype=root.dtype)
        else:
            frames = np.flatnonzero(on)
            target = positions[frames, end]  # the ankle stays where it was on the ground
        rows = torch.as_tensor(frames)
        _, moved = forward_kinematics(rotations[rows], root[rows], offsets)
        rotations[rows] = solve_limb_ik(rotations[rows], root[rows], limb, target.to(root.dtype),
                                        _limb_pole(moved, limb), offsets)
    # the goal moves with the object: a sit (lie) goal by the pelvis's displacement where the clip ends seated
    meta = {**motion.meta, "augmented_from": obj.category}
    for key in ("sit_goal", "lie_goal"):
        if key in meta:
            goal = dict(meta[key])
            goal["position"] = np.asarray(goal["position"], dtype=np.float64) + shift[-1]
            meta[key] = goal
    return dataclasses.replace(motion, local_rotations=rotations, root_position=root, meta=meta)
