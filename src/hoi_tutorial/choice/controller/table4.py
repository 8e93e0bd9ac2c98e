"""Table 4's protocol (CHOICE §8.3.1) and Table 2's labels (§7): the controller's goal-phase variants on unseen
reach-and-grasp clips, and the measures they are compared by.

Measures: unsmoothness (mean joint acceleration), foot sliding over planted frames, the Fréchet distance of 2 s
pose windows against the training clips, and the working wrist's RMS curvature over its approach
(:func:`motion_measures`); Table 2's share of frames per key-joint label (:func:`label_distribution`).
"""
from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np
import torch

from ... import metrics
from ...infra import load_or_build
from ...world import mocap
from ...world.motion import FPS
from ..planner import baselines
from . import features, kalman, network, phase, runtime
from .features import WINDOW, WRIST_JOINTS

__all__ = ["pose_window_features", "foot_contacts", "motion_measures", "KEY_JOINT_TASKS", "label_distribution",
           "TABLE4_ROWS", "straight_approach_goal", "table4_runs"]


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


# ----------------------------------------------------------------------------- Table 4's runs (§8.3.1)

TABLE4_ROWS = ("w/ KF + cuRobo", "w/o goal phase", "w/ matched goal", "w/ predicted goal", "w/ KF goal")
_ROW_VARIANT = {"w/ KF + cuRobo": "kalman", "w/o goal phase": "none", "w/ matched goal": "matched",
                "w/ predicted goal": "predicted", "w/ KF goal": "kalman"}


class _Joints:
    """A bare ``(joints, fps)`` motion for :func:`motion_measures`."""

    def __init__(self, joints, fps):
        self.joints, self.fps = joints, fps


def straight_approach_goal(goal, hand):
    """The goal with the working wrist's approach (the window's samples before the keyframe) replaced by the
    minimum-jerk path between the same two ends (``planner.baselines.minimum_jerk_plan`` without obstacles: the
    cuRobo stand-in's straight move; rotations kept).

    Args:
        goal: ``runtime.KeyJointGoal`` (positions (B, 13, 4, 3)).
        hand: (B,) 0 left, 1 right.
    Returns:
        a new ``runtime.KeyJointGoal``.
    """
    positions = goal.positions.clone()
    centre = WINDOW // 2
    for b in range(positions.shape[0]):
        k = 2 + int(hand[b])
        path = baselines.minimum_jerk_plan(positions[b, 0, k].double().numpy(), positions[b, centre, k].double().numpy(),
                                           centre + 1)
        positions[b, :centre + 1, k] = torch.as_tensor(path, dtype=positions.dtype)
    return goal._replace(positions=positions)


def table4_runs(controller_config, *, clips: int = 12, after: int = 15, seed: int = 0) -> dict:
    """The controller's variants of Table 4 on unseen reach-and-grasp clips, run once and then loaded from the cache.

    Each held-out clip (``world.mocap`` with the seed ``10 000 + seed``, never trained on) gives a start (its
    first frame, the future root trajectory on the straight line to the goal, ``runtime.toward_goal``) and a goal (its grasp keyframe, ``runtime.clip_goal``: the recorded key joints over the 2 s
    window, whose first half is the wrist's recorded approach — ours: it stands in for the INTP plan of the
    paper). Each row drives all clips in one batch from the start for ``anchor + after`` frames:
    ``"w/o goal phase"``, ``"w/ matched goal"``, ``"w/ predicted goal"`` and ``"w/ KF goal"`` are
    ``runtime.rollout``'s four goal-phase sources; ``"w/ KF + cuRobo"`` is the Kalman one with the wrist's
    approach replaced by the straight minimum-jerk path (:func:`straight_approach_goal`). The ``"Dataset"`` row
    measures the held-out clips themselves over the same frames.

    Measures (:func:`motion_measures`, each clip cut at its own ``anchor + after``; the working wrist's RMS
    curvature over the approach, frames ``[0, anchor]``): means over clips (sliding over the clips with a planted
    foot, ``"planted clips"``); the Fréchet distance pools every
    clip's 2 s windows of a row against those of the training clips (the dataset row's FD is the held-out
    clips' own, a floor). ``reach`` is the working wrist's closest approach to its grasp (metres).

    Returns:
        ``{"rows": {row: {"Unsmth.", "Slid.", "FD", "EE RMSC", "planted clips", "per clip" {measure: (clips,)},
        "reach" (clips,), "joints" [(T_i, 22, 3)]}},
        "hands" (clips,), "anchors" (clips,), "seconds" (per row, the rollout's wall time), "steps"}``.
    """
    if isinstance(clips, bool) or not isinstance(clips, int) or clips < 1:
        raise ValueError(f"clips: expected a positive int, got {clips!r}")
    if isinstance(after, bool) or not isinstance(after, int) or after < 0:
        raise ValueError(f"after: expected an int >= 0 (frames after the grasp), got {after!r}")

    def build():
        trained = network.trained_controller(controller_config)
        model = trained.model
        test = mocap.generate_dataset(clips, seed=10_000 + int(seed), kinds=("reach_grasp",))
        train = mocap.generate_dataset(controller_config.clips, seed=controller_config.seed,
                                       kinds=controller_config.kinds)  # the controller's training clips
        anchors = np.array([int(c.meta["anchor_frame"]) for c in test])
        ends = np.minimum(anchors + after, [len(c) - 1 for c in test])
        hands = np.array([int(c.meta["hand"] == "right") for c in test])
        reference = np.concatenate([pose_window_features(c) for c in train])
        goal = runtime.clip_goal(model, test)
        state = runtime.toward_goal(runtime.initial_state(model, test), goal)
        frames = int(ends.max())
        first = torch.stack([c.joints[0].float() for c in test])  # (B, 22, 3) frame 0, the start
        rows, seconds = {}, {}

        def measure(motions):
            per = [motion_measures(m, None, [(0, int(a) + 1)], ("left", "right")[h])
                   for m, a, h in zip(motions, anchors, hands)]
            out = {k: float(np.nanmean([p[k] for p in per])) for k in ("Unsmth.", "Slid.", "EE RMSC")}
            out["per clip"] = {k: np.array([p[k] for p in per]) for k in ("Unsmth.", "Slid.", "EE RMSC")}
            out["planted clips"] = int(np.sum(np.isfinite([p["Slid."] for p in per])))
            out["FD"] = float(metrics.frechet_distance(np.concatenate([pose_window_features(m) for m in motions]),
                                                       reference))
            return out

        for row in TABLE4_ROWS:
            g = straight_approach_goal(goal, hands) if row == "w/ KF + cuRobo" else goal
            clock = time.perf_counter()
            run = runtime.rollout(model, state, g, frames, _ROW_VARIANT[row], controller_config.blend_radius)
            seconds[row] = time.perf_counter() - clock
            # frame 0 is the start; step i gives frame i + 1
            joints = torch.cat([first[None], run.joints], dim=0).double().numpy()  # (frames + 1, B, 22, 3)
            motions = [_Joints(joints[:e + 1, b], FPS) for b, e in enumerate(ends)]
            rows[row] = measure(motions)
            reach = [np.linalg.norm(joints[:e + 1, b, WRIST_JOINTS[h]]
                                    - goal.positions[b, WINDOW // 2, 2 + h].double().numpy(), axis=-1).min()
                     for b, (e, h) in enumerate(zip(ends, hands))]
            rows[row]["reach"] = np.asarray(reach)
            rows[row]["joints"] = [m.joints for m in motions]
        dataset = [_Joints(c.joints[:e + 1].double().numpy(), FPS) for c, e in zip(test, ends)]
        rows["Dataset"] = measure(dataset)
        rows["Dataset"]["reach"] = np.zeros(len(test))
        rows["Dataset"]["joints"] = [m.joints for m in dataset]
        return {"rows": rows, "hands": hands, "anchors": anchors, "seconds": seconds, "steps": frames}

    key = {"controller": dataclasses.asdict(controller_config), "clips": clips, "after": after, "seed": int(seed)}
    return load_or_build("choice_table4", key, build,
                         code=(sys.modules[__name__], features, network, runtime, kalman, phase, baselines, mocap, metrics))
