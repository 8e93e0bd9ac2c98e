"""``Motion``: one clip of toy-world motion with its per-frame labels.

A motion is stored the way an animator would: local joint rotations and a root (pelvis)
trajectory, plus the body shape. Joint positions, global rotations and velocities are derived
with forward kinematics on demand. Labels follow the toy-mocap contract: one action id per frame
(``ACTIONS``) and five contact flags per frame (``CONTACT_JOINTS``, SAMP Eq. 1's ``c_i``).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np
import torch

from .._validate import as_tensor, check_finite, check_shape
from .kinematics import forward_kinematics
from .rotations import rotation_about_z
from .skeleton import NUM_BETAS, NUM_JOINTS, bone_offsets, joint_index

__all__ = ["Motion", "ACTIONS", "CONTACT_JOINTS", "action_id", "FPS", "motion_payload", "motion_from_payload"]

FPS = 30.0

ACTIONS: tuple[str, ...] = (
    "idle", "walk", "run", "turn", "side_step", "sit_down", "sit", "stand_up",
    "lie_down", "lie", "lift", "reach", "grasp", "open_door", "open_drawer",
)

# Joints whose contact is labelled per frame, in this order (SAMP Eq. 1: pelvis, feet, hands).
CONTACT_JOINTS: tuple[str, ...] = ("pelvis", "left_foot", "right_foot", "left_wrist", "right_wrist")


def action_id(name: str) -> int:
    """Index of an action label in ``ACTIONS``."""
    if name not in ACTIONS:
        raise ValueError(f"action: expected one of {list(ACTIONS)}, got {name!r}")
    return ACTIONS.index(name)


@dataclass
class Motion:
    """A clip of ``T`` frames.

    Attributes:
        local_rotations: ``(T, 22, 3, 3)`` local joint rotations.
        root_position: ``(T, 3)`` pelvis position, metres.
        betas: ``(10,)`` toy body shape.
        fps: frames per second (30 throughout the book).
        actions: ``(T,)`` int64 indices into ``ACTIONS``, or ``None``.
        contacts: ``(T, 5)`` bool, contact of ``CONTACT_JOINTS`` (feet with the ground, pelvis
            and hands with an object), or ``None``.
        meta: free-form description (generator name, style, object, seed ...).
    """

    local_rotations: torch.Tensor
    root_position: torch.Tensor
    betas: torch.Tensor = field(default_factory=lambda: torch.zeros(NUM_BETAS))
    fps: float = FPS
    actions: Optional[np.ndarray] = None
    contacts: Optional[np.ndarray] = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.local_rotations = as_tensor(self.local_rotations, "local_rotations")
        self.root_position = as_tensor(self.root_position, "root_position")
        self.betas = as_tensor(self.betas, "betas")
        check_shape(self.local_rotations, (None, NUM_JOINTS, 3, 3), "local_rotations")
        T = self.local_rotations.shape[0]
        check_shape(self.root_position, (T, 3), "root_position")
        check_shape(self.betas, (NUM_BETAS,), "betas")
        for name in ("local_rotations", "root_position", "betas"):  # a NaN would reach every metric unnoticed
            check_finite(getattr(self, name), name)
        if self.actions is not None:
            self.actions = np.asarray(self.actions, dtype=np.int64)
            check_shape(self.actions, (T,), "actions")
            if self.actions.size and (self.actions.min() < 0 or self.actions.max() >= len(ACTIONS)):
                raise ValueError(f"actions: expected ids in [0, {len(ACTIONS)}), got range "
                                 f"[{self.actions.min()}, {self.actions.max()}]")
        if self.contacts is not None:
            self.contacts = np.asarray(self.contacts, dtype=bool)
            check_shape(self.contacts, (T, len(CONTACT_JOINTS)), "contacts")
        self._fk_cache = None

    def __len__(self) -> int:
        return int(self.local_rotations.shape[0])

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return len(self) / self.fps

    def _fk(self):
        if self._fk_cache is None:
            offsets = bone_offsets(self.betas)
            self._fk_cache = forward_kinematics(self.local_rotations, self.root_position, offsets)
        return self._fk_cache

    @property
    def global_rotations(self) -> torch.Tensor:
        """``(T, 22, 3, 3)`` joint orientations in the world."""
        return self._fk()[0]

    @property
    def joints(self) -> torch.Tensor:
        """``(T, 22, 3)`` joint positions in metres."""
        return self._fk()[1]

    def joint_velocities(self) -> torch.Tensor:
        """``(T, 22, 3)`` m/s by central differences (one-sided at the ends)."""
        return _central_difference(self.joints, self.fps)

    def root_velocity(self) -> torch.Tensor:
        """``(T, 3)`` pelvis velocity, m/s."""
        return _central_difference(self.root_position, self.fps)

    def joint(self, name: str) -> torch.Tensor:
        """``(T, 3)`` trajectory of one joint by SMPL name."""
        return self.joints[:, joint_index(name)]

    def action_names(self) -> list[str]:
        """Per-frame action labels as strings."""
        if self.actions is None:
            raise ValueError("actions: this motion carries no action labels")
        return [ACTIONS[i] for i in self.actions]

    def slice(self, start: int, stop: int) -> "Motion":
        """Frames ``[start, stop)`` as a new motion."""
        if not (0 <= start < stop <= len(self)):
            raise ValueError(f"slice: expected 0 <= start < stop <= {len(self)}, got ({start}, {stop})")
        return replace(
            self,
            local_rotations=self.local_rotations[start:stop],
            root_position=self.root_position[start:stop],
            actions=None if self.actions is None else self.actions[start:stop],
            contacts=None if self.contacts is None else self.contacts[start:stop],
            meta=dict(self.meta),
        )

    def reversed(self) -> "Motion":
        """The clip played backwards (velocities change sign when recomputed)."""
        return replace(
            self,
            local_rotations=self.local_rotations.flip(0),
            root_position=self.root_position.flip(0),
            actions=None if self.actions is None else self.actions[::-1].copy(),
            contacts=None if self.contacts is None else self.contacts[::-1].copy(),
            meta={**self.meta, "reversed": not self.meta.get("reversed", False)},
        )

    def transformed(self, yaw: float = 0.0, translation=(0.0, 0.0, 0.0)) -> "Motion":
        """Rotate the whole clip by ``yaw`` radians about +Z through the origin, then translate (metres)."""
        rot = rotation_about_z(torch.tensor(float(yaw))).to(self.local_rotations)
        trans = torch.as_tensor(translation, dtype=self.root_position.dtype)
        check_shape(trans, (3,), "translation")
        local = self.local_rotations.clone()
        local[:, 0] = rot @ local[:, 0]
        root = self.root_position @ rot.T + trans
        return replace(self, local_rotations=local, root_position=root, meta=dict(self.meta))

    @staticmethod
    def concatenate(motions: list["Motion"]) -> "Motion":
        """Join clips of the same body end to end (labels kept when all clips have them)."""
        if not motions:
            raise ValueError("motions: expected at least one Motion")
        first = motions[0]
        for m in motions[1:]:
            if not torch.equal(m.betas, first.betas) or m.fps != first.fps:
                raise ValueError("motions: expected clips with the same betas and fps")
        actions = None if any(m.actions is None for m in motions) else np.concatenate([m.actions for m in motions])
        contacts = None if any(m.contacts is None for m in motions) else np.concatenate([m.contacts for m in motions])
        return Motion(
            local_rotations=torch.cat([m.local_rotations for m in motions]),
            root_position=torch.cat([m.root_position for m in motions]),
            betas=first.betas, fps=first.fps, actions=actions, contacts=contacts,
            meta={"parts": [m.meta for m in motions]},
        )


def _central_difference(x: torch.Tensor, fps: float) -> torch.Tensor:
    """Time derivative of ``(T, ...)`` by central differences, one-sided at the ends."""
    if x.shape[0] < 2:
        return torch.zeros_like(x)
    v = torch.empty_like(x)
    v[1:-1] = (x[2:] - x[:-2]) * (fps / 2.0)
    v[0] = (x[1] - x[0]) * fps
    v[-1] = (x[-1] - x[-2]) * fps
    return v


def motion_payload(motion: Motion) -> dict:
    """Every field of ``motion`` as the artifact cache stores it (``infra.load_or_build``): tensors, arrays, numbers
    and the ``meta`` dict as they are, dtypes kept. :func:`motion_from_payload` gives the motion back, bit for bit."""
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
    return {"local_rotations": motion.local_rotations, "root_position": motion.root_position, "betas": motion.betas,
            "fps": motion.fps, "actions": motion.actions, "contacts": motion.contacts, "meta": dict(motion.meta)}


def motion_from_payload(payload: dict) -> Motion:
    """The :class:`Motion` that :func:`motion_payload` stored."""
    fields = ("local_rotations", "root_position", "betas", "fps", "actions", "contacts", "meta")
    if not isinstance(payload, dict) or set(payload) != set(fields):
        raise ValueError(f"payload: expected a dict with the keys {list(fields)} (motion_payload), got "
                         f"{sorted(payload) if isinstance(payload, dict) else type(payload).__name__}")
    return Motion(**{name: payload[name] for name in fields})

