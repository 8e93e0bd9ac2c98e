"""Anchor poses for sitting and lifting (NIFTY §3.3, "Anchor Pose Selection").

An *anchor* is the frame that captures the core of an interaction: for sitting, the moment the
person settles on the seat; for lifting, the first contact of the hands with the object. NIFTY
picks 174 sitting and 72 lifting anchors by hand from BEHAVE (7 subjects). Here the toy mocap
labels the anchor frame of every interaction clip (``meta["anchor_frame"]``), so anchors are
collected automatically across toy subjects (body shapes) and object instances.

Each anchor keeps the frame after it as well: played backwards, the pair gives the velocities of
the reversed motion at the anchor, which the time-reversed prior needs to start a rollout.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import torch

from .._validate import check_choice
from ..world.mocap import generate_clip, sample_betas
from ..world.motion import Motion
from ..world.objects import ToyObject, make_object
from .motion_prior import PoseTrack

__all__ = ["Anchor", "ANCHOR_OBJECTS", "collect_anchors", "stack_anchor_poses"]

# Object categories each interaction is anchored on (BEHAVE's chairs/stools/balls and boxes).
ANCHOR_OBJECTS = {
    "sit": ("chair", "armchair", "stool", "sofa", "yoga_ball"),
    "lift": ("box", "suitcase", "stool", "chair", "yoga_ball"),
}


@dataclass
class Anchor:
    """One anchor pose and what it came from.

    Attributes:
        action: ``"sit"`` or ``"lift"``.
        pose: the anchor frame (a single-frame :class:`PoseTrack`: ``(22, 3, 3)``, ``(3,)``, ``(22, 3)``).
        next_pose: the frame after the anchor in real time (the previous one in reversed time).
        betas: ``(10,)`` body shape of the subject.
        subject: index of the toy subject.
        obj: the object, placed where the clip used it (world frame).
        clip: the source clip (real time), for figures and for the data-quality comparison.
    """

    action: str
    pose: PoseTrack
    next_pose: PoseTrack
    betas: torch.Tensor
    subject: int
    obj: ToyObject
    clip: Motion


def _frame(motion: Motion, t: int) -> PoseTrack:
    return PoseTrack(motion.local_rotations[t], motion.root_position[t], motion.joints[t])


def collect_anchors(action: str, n_subjects: int, anchors_per_subject: int, seed: int,
                    rounds: int = 1) -> list[Anchor]:
    """Generate interaction clips and take their anchor frames.

    Subject ``s`` gets a body shape from ``mocap.sample_betas``; each of its anchors uses a new
    object instance (category cycling through ``ANCHOR_OBJECTS[action]``) and a new clip seed,
    so styles, seats and hand placements vary.

    Args:
        action: ``"sit"`` or ``"lift"``.
        n_subjects: number of toy subjects (NIFTY: 7).
        anchors_per_subject: anchors per subject and round (NIFTY: about 25 sitting, 10 lifting).
        seed: base seed.
        rounds: rounds of anchors; round ``r`` gives each subject its anchors
            ``r * anchors_per_subject ...`` (the same subjects, more of their clips), so the
            first round does not depend on how many follow.
    Returns:
        ``rounds * n_subjects * anchors_per_subject`` anchors, round-major, then subject-major.
    """
    check_choice(action, tuple(ANCHOR_OBJECTS), "action")
    for name, value in (("n_subjects", n_subjects), ("anchors_per_subject", anchors_per_subject),
                        ("rounds", rounds)):
        if not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"{name}: expected a positive int, got {value!r}")
    seq = np.random.SeedSequence([int(seed), 7 if action == "sit" else 11])
    subject_seeds = seq.spawn(n_subjects)
    categories = ANCHOR_OBJECTS[action]
    per_subject = []
    for s, subject_seq in enumerate(subject_seeds):
        rng = np.random.default_rng(subject_seq)
        betas = sample_betas(rng)
        anchors = []
        for i in range(anchors_per_subject * rounds):
            category = categories[(s + i) % len(categories)]
            obj = make_object(category, seed=rng)
            clip = generate_clip(action, seed=int(rng.integers(2**31)), betas=betas, obj=obj)
            a = int(clip.meta["anchor_frame"])
            if a + 1 >= len(clip):
                raise RuntimeError(f"{action} clip ends at its anchor frame; expected frames after it")
            anchors.append(Anchor(action, _frame(clip, a), _frame(clip, a + 1), clip.betas, s, obj, clip))
        per_subject.append(anchors)
    k = anchors_per_subject
    return [anchor for r in range(rounds) for anchors in per_subject for anchor in anchors[r * k:(r + 1) * k]]


def stack_anchor_poses(anchors: Sequence[Anchor]) -> tuple[PoseTrack, PoseTrack]:
    """Batch the anchors' (next_pose, pose) pairs as reversed-time ``(prev, start)`` of a rollout."""
    def stack(poses):
        return PoseTrack(
            torch.stack([p.local_rotations for p in poses]),
            torch.stack([p.root_position for p in poses]),
            torch.stack([p.joints for p in poses]),
        )
    return stack([a.next_pose for a in anchors]), stack([a.pose for a in anchors])
