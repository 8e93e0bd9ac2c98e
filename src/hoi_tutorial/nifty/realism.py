"""Motions as fixed-length feature vectors, for the classifier that stands in for NIFTY's user studies.

NIFTY's Fig. 5 (A/B preferences) and Appendix A.1 (Likert realism) asked people. The book asks a classifier
(:func:`hoi_tutorial.two_sample.classifier_two_sample_test`), which needs one vector per motion. People saw the
whole motion, body and object; the vector here holds the body's motion alone, so that sets of motions on different
objects can be compared and the object's shape cannot give a set away.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..world.features import canonicalize
from ..world.motion import Motion

__all__ = ["motion_features"]


def motion_features(motions: Sequence[Motion], frames: int, stride: int = 4) -> np.ndarray:
    """``(N, F * 66)`` features of ``N`` motions, ``F = ceil(frames / stride)``.

    Each motion keeps its last ``frames`` frames (it ends in the interaction) and is padded at the end with its
    last frame when shorter, as NIFTY pads its training sequences (Appendix B), so that data and generated
    motions have one length. Moved to the canonical frame of its first kept frame (standing at the origin, facing
    +Y), every ``stride``-th frame gives: the 21 joints other than the pelvis relative to the pelvis (63 numbers,
    metres), the pelvis height (m) and the pelvis's horizontal velocity (2 numbers, m/s; zero over the padding).
    """
    if isinstance(motions, Motion) or not len(motions):
        raise ValueError("motions: expected a non-empty sequence of Motion")
    if not isinstance(frames, (int, np.integer)) or frames < 2:
        raise ValueError(f"frames: expected an int >= 2, got {frames!r}")
    if not isinstance(stride, (int, np.integer)) or not 1 <= stride <= frames:
        raise ValueError(f"stride: expected an int from 1 to frames ({frames}), got {stride!r}")
    rows = []
    for i, motion in enumerate(motions):
        if not isinstance(motion, Motion):
            raise TypeError(f"motions[{i}]: expected a Motion, got {type(motion).__name__}")
        kept = motion.slice(max(0, len(motion) - frames), len(motion))
        joints = canonicalize(kept, 0).joints.detach().cpu().double().numpy()   # (T, 22, 3)
        velocity = np.zeros((len(joints), 2))
        velocity[:-1] = np.diff(joints[:, 0, :2], axis=0) * kept.fps                # forward difference, m/s
        per_frame = np.concatenate([(joints[:, 1:] - joints[:, :1]).reshape(len(joints), -1),
                                    joints[:, 0, 2:3], velocity], axis=1)           # (T, 66)
        if len(per_frame) < frames:  # the last frame held, standing still
            still = np.concatenate([per_frame[-1, :-2], np.zeros(2)])
            per_frame = np.concatenate([per_frame, np.repeat(still[None], frames - len(per_frame), axis=0)])
        rows.append(per_frame[::stride].reshape(-1))
    return np.stack(rows)
