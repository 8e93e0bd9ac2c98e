"""Table 4's measures (CHOICE §8.3.1) and Table 2's labels (§7): what the controller's goal-phase variants are
compared by (their runs are ``pick_and_place.table4``'s: the goals come from §6.1's matching).

Measures: unsmoothness (mean joint acceleration), foot sliding over planted frames, the Fréchet distance of 2 s
pose windows against the training clips, and the working wrist's RMS curvature over its approach
(:func:`motion_measures`); Table 2's share of frames per key-joint label (:func:`label_distribution`).
"""
from __future__ import annotations

import numpy as np
import torch

from ... import metrics

__all__ = ["pose_window_features", "foot_contacts", "motion_measures", "KEY_JOINT_TASKS", "label_distribution"]


def _joints(motion) -> np.ndarray:
    joints = np.asarray(motion.joints, dtype=np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (22, 3):
        raise ValueError(f"motion: expected joints of shape (T, 22, 3), got {joints.shape}")
    return joints


def pose_window_features(motion, seconds: float = 2.0, sample_every: int = 10, stride: int = 5) -> np.ndarray:
    """(N, D) Table 4's Fréchet-distance features: "each 2 s sliding time-window's pose as the feature vector".

    Each frame's pose is its joints in its own root frame (``world.features.root_frame``: translation on the
    ground and heading removed), flattened (66); a window holds the poses at every ``sample_every``-th frame
    over ``seconds`` (7 poses at 30 fps, D = 462), and windows start every ``stride`` frames. Ours: the
    paper states the 2 s window only (sub-sampling keeps D below the number of windows of a toy clip set).

    Args:
        motion: a ``world.motion.Motion`` (or anything with ``joints`` (T, 22, 3) metres and ``fps``).
    Returns:
        (N, 66 · (seconds·fps / sample_every + 1)) metres; N = 0 when the clip is shorter than the window.
    """
    from ...world.features import root_frame, to_heading_frame

    joints = _joints(motion)
    fps = float(motion.fps)
    span = int(round(seconds * fps))
    if sample_every < 1 or span % sample_every:
        raise ValueError(f"sample_every: expected a divisor of the window's {span} frames, got {sample_every}")
    joints_t = torch.as_tensor(joints)
    origin, heading = root_frame(joints_t)
    local = to_heading_frame(joints_t - origin[:, None], heading[:, None].expand(-1, joints_t.shape[1]))
    flat = local.reshape(len(joints), -1).numpy()
    starts = np.arange(0, len(joints) - span, stride)
    offsets = np.arange(0, span + 1, sample_every)
    return flat[starts[:, None] + offsets[None]].reshape(len(starts), -1)


def foot_contacts(motion, height: float = 0.01) -> np.ndarray:
    """(T, 2) bool: a foot (left, right) is on the ground where it is within ``height`` of its lowest point in
    the clip (ours: a generated motion has no contact labels; height alone, so that a sliding foot still counts
    as planted — on the toy walks it agrees with the mocap's labels in 98 % of the frames)."""
    from ...world.skeleton import joint_index

    joints = _joints(motion)
    feet = joints[:, [joint_index("left_foot"), joint_index("right_foot")]]
    return feet[..., 2] <= feet[..., 2].min(axis=0) + height


def motion_measures(motion, dataset_features=None, wrist_segments=(), hand: str = "right") -> dict:
    """Table 4's measures of one motion (§8.3.1), in the paper's units.

    - ``Unsmth.``: the mean acceleration over all joints (``metrics.unsmoothness``), cm/s²;
    - ``Slid.``: the feet's mean acceleration while planted (``metrics.foot_sliding`` with
      :func:`foot_contacts`), cm/s² (the caption "sums up"; a mean here, so that clips of any length compare);
    - ``FD``: the Fréchet distance (``metrics.frechet_distance``) between the motion's
      :func:`pose_window_features` and ``dataset_features`` (None: not computed);
    - ``EE RMSC``: the ``hand`` wrist's RMS curvature (``metrics.rms_curvature``) averaged over
      ``wrist_segments`` (``(start, stop)`` frame ranges of approaches and leaves; none: the whole clip), cm⁻¹.
    """
    from ...world.skeleton import joint_index

    if hand not in ("left", "right"):
        raise ValueError(f"hand: expected 'left' or 'right', got {hand!r}")
    joints = _joints(motion)
    fps = float(motion.fps)
    feet = joints[:, [joint_index("left_foot"), joint_index("right_foot")]]
    wrist = joints[:, joint_index(f"{hand}_wrist")]
    segments = list(wrist_segments) or [(0, len(joints))]
    for start, stop in segments:
        if not 0 <= start < stop <= len(joints) or stop - start < 3:
            raise ValueError(f"wrist_segments: expected (start, stop) ranges of at least 3 frames within "
                             f"{len(joints)}, got {(start, stop)}")
    curvature = [metrics.rms_curvature(wrist[a:b], fps) for a, b in segments]
    fd = float("nan")
    if dataset_features is not None:
        fd = metrics.frechet_distance(pose_window_features(motion), dataset_features)
    return {"Unsmth.": 100 * float(metrics.unsmoothness(joints, fps)),
            "Slid.": 100 * float(metrics.foot_sliding(feet, foot_contacts(motion), fps)),
            "FD": fd, "EE RMSC": float(np.nanmean(curvature)) / 100}


# Table 2's rows and which toy-mocap labels (``world.motion.ACTIONS``) count for each (ours: the toy labels
# are one per frame for the whole body; the hip's "walk" is locomotion, its "idle" everything else).
KEY_JOINT_TASKS = (
    ("hands", "Object Manipulate", "Grasp/Place", ("reach", "grasp", "lift")),
    ("hands", "Object Manipulate", "Cook", ()),
    ("hands", "Object Manipulate", "Drink", ()),
    ("hands", "Object Manipulate", "Pour", ()),
    ("hands", "Door Manipulate", "Door opening/closing", ("open_door",)),
    ("hands", "Draw", "Drawer Drag", ("open_drawer",)),
    ("hip", "Idle", "Turn/Stand/Squat", None),
    ("hip", "Walk", "Approach", ("walk", "run", "side_step")),
)


def label_distribution(motions) -> list:
    """Table 2 for a set of clips: per key-joint action and task, the seconds labelled and their share of all
    seconds (%). Rows ``(key joint action, task, seconds, %)`` in the paper's order; the hip's "idle" is every
    frame not labelled walking (so the hip's two rows sum to 100 %)."""
    from ...world.motion import ACTIONS

    counts = np.zeros(len(ACTIONS))
    seconds = 0.0
    for motion in motions:
        labels = np.asarray(motion.actions, dtype=np.int64)
        counts += np.bincount(labels, minlength=len(ACTIONS)) / float(motion.fps)
        seconds += len(labels) / float(motion.fps)
    if seconds == 0:
        raise ValueError("motions: expected at least one clip with frames")
    walking = sum(counts[ACTIONS.index(a)] for a in KEY_JOINT_TASKS[-1][3])
    rows = []
    for _, action, task, labels in KEY_JOINT_TASKS:
        value = seconds - walking if labels is None else sum(counts[ACTIONS.index(a)] for a in labels)
        rows.append((action, task, float(value), 100.0 * float(value) / seconds))
    return rows
