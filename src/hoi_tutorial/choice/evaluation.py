"""Table 3's protocol (CHOICE §8.2.2): planners on unseen layouts and reshaped furniture.

The test scenes are the test split's interactions (other clips: other items, supports, clutter),
changed as §8.2.2 says:

- **unseen layouts**: each obstacle on the furniture (the clutter) shifted by at most 5 cm, turned
  by at most ±90° and rescaled 0.8–1.25×;
- **reshaping**: in addition, the container (the shelf or table) rescaled to 70–150 % of its width,
  depth and height, the items standing on it moving with their board;

keeping the "pickable" cases: the goal (the demonstration's contact, moved with its item) at least
1 cm from every obstacle, the start (the demonstration's wrist where it enters the grid) outside
every obstacle, no clutter item inside the target.

Measures (``metrics``): unsmoothness (the wrist's mean acceleration, m/s²), the spare safety distance
(the wrist's distance to the nearest obstacle, averaged over the frames within 20 cm of the goal, over
the successful runs; cm) and the success rate (collision-free — the wrist never inside an obstacle —
and ending within 2 cm of the goal). Ours where CHOICE is silent: the wrist point stands for "the hand
and object", the 2 cm reach tolerance, both segments (approach and leave) of a pick as cases.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch

from .. import metrics
from ..infra import load_or_build
from ..world.objects import CATEGORY_SIZES, object_from_description
from . import fields
from .data import InteractionSet

__all__ = [
    "PlanningCase",
    "scale_object",
    "planning_cases",
    "RunMeasures",
    "measure_run",
    "summarise",
    "PLANNER_VARIANTS",
    "table3_runs",
    "runs_from_rows",
    "pose_window_features",
    "foot_contacts",
    "motion_measures",
    "KEY_JOINT_TASKS",
    "label_distribution",
    "TABLE4_ROWS",
    "straight_approach_goal",
    "table4_runs",
]


@dataclass
class PlanningCase:
    """One test planning problem.

    Attributes:
        source: index of the test interaction it comes from.
        target, obstacles: the (changed) scene's objects.
        scene: its fields (``D_toa`` not computed: the planners never see it).
        start: (3,) metres, the wrist where the plan starts.
        goal: (3,) metres, the contact.
        condition: (4,) ``c``.
        reshaped: whether the container was reshaped.
    """

    source: int
    target: object
    obstacles: list
    scene: fields.SceneFields
    start: np.ndarray
    goal: np.ndarray
    condition: np.ndarray
    reshaped: bool

    def obstacle_sdf(self, points):
        """Signed distance to the nearest obstacle (numpy or torch points (..., 3))."""
        return fields.sdf_union(self.obstacles)(points)


def scale_object(obj, factors):
    """The same object with its lengths scaled by ``factors`` (x, y, z) (its size parameters by the
    axis each belongs to, as ``make_object``'s ``size_scale`` does), same pose."""
    sx, sy, sz = (float(f) for f in factors)
    axis = {"x": sx, "y": sy, "z": sz, "xy": np.sqrt(sx * sy), "xyz": np.cbrt(sx * sy * sz)}
    spec = CATEGORY_SIZES[obj.category]
    params = {k: (v * axis[spec[k].axis] if k in spec and spec[k].axis is not None else v)
              for k, v in obj.params.items()}
    return object_from_description({"category": obj.category, "params": params, "pose": obj.pose})


def _rot_z(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _moved(obj, support_before, support_after, factors):
    """``obj`` standing on ``support_before`` carried onto ``support_after`` (its position in the support's
    frame scaled by ``factors``)."""
    local = np.linalg.inv(support_before.pose) @ obj.pose
    local[:3, 3] *= np.asarray(factors)
    return obj.with_pose(support_after.pose @ local)


def planning_cases(test: InteractionSet, config_field: fields.FieldConfig, *, reshape: bool, seed: int = 0,
                   actions=("grasp",)) -> list[PlanningCase]:
    """The test cases of §8.2.2 from the test interactions (one per interaction whose action is in
    ``actions``; a place is a pick played backwards and adds no new geometry)."""
    rng = np.random.default_rng([seed, int(reshape)])
    cases = []
    for k, inter in enumerate(test.interactions):
        action = "grasp" if inter.condition[2] < 0.5 else "place"
        draws = (rng.uniform(0.7, 1.5, size=3), rng.uniform(size=(8, 4)))  # drawn for every case: same stream
        if action not in actions:
            continue
        target = inter.target_object()
        support, *clutter = inter.obstacle_objects()
        new_support, new_target = support, target
        if reshape:
            factors = draws[0]
            new_support = scale_object(support, factors)
            new_target = _moved(target, support, new_support, factors)
            clutter = [_moved(o, support, new_support, factors) for o in clutter]
        moved = []
        for c, u in zip(clutter, draws[1]):
            shift = support.rotation[:, :2] @ ((u[:2] * 2 - 1) * 0.05 / np.sqrt(2))
            pose = c.pose.copy()
            pose[:3, :3] = _rot_z((u[2] * 2 - 1) * np.pi / 2) @ pose[:3, :3]
            pose[:3, 3] += shift
            moved.append(scale_object(c.with_pose(pose), [0.8 + 0.45 * u[3]] * 3))
        obstacles = [new_support] + moved
        goal = new_target.pose @ np.linalg.inv(target.pose) @ np.append(inter.wrist[-1], 1.0)
        goal = goal[:3]
        grid = fields.object_grid(new_target, config_field, yaw=inter.grid.yaw)
        inside = grid.contains(inter.wrist)
        if not inside.any():
            continue
        start = inter.wrist[np.flatnonzero(inside)[0]]
        obstacle_sdf = fields.sdf_union(obstacles)
        pickable = (grid.contains(goal) and float(obstacle_sdf(goal)) > 0.01 and float(obstacle_sdf(start)) > 0
                    and float(new_target.sdf(start)) > 0
                    and all(np.min(new_target.sdf(o.surface_points(64, seed=0))) > 0.005 for o in moved))
        if not pickable:
            continue
        scene = fields.scene_fields(grid, new_target, obstacles, None, 30.0, config_field)
        cases.append(PlanningCase(k, new_target, obstacles, scene, start, goal, inter.condition.copy(), reshape))
    return cases


@dataclass
class RunMeasures:
    """One planned path's measures (Table 3's columns before averaging)."""

    unsmoothness: float  # m/s², mean acceleration of the wrist
    safety: float  # metres, mean clearance within 20 cm of the goal
    min_clearance: float  # metres, smallest clearance along the path (negative: a collision)
    end_error: float  # metres, from the last frame to the goal
    success: bool
    frames: int


def measure_run(path, case: PlanningCase, fps: float = 30.0, reach: float = 0.02) -> RunMeasures:
    """Table 3's measures of one wrist path (T, 3) metres on ``case`` (the path's frames are checked,
    and four points between each pair, for collisions)."""
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != 3 or len(path) < 3:
        raise ValueError(f"path: expected a (T >= 3, 3) wrist path, got shape {path.shape}")
    between = path[:-1, None] + np.linspace(0, 1, 5, endpoint=False)[None, :, None] * np.diff(path, axis=0)[:, None]
    dense = np.concatenate([between.reshape(-1, 3), path[-1:]])
    clearance = case.obstacle_sdf(path)
    min_clearance = float(min(clearance.min(), case.obstacle_sdf(dense).min()))
    end_error = float(np.linalg.norm(path[-1] - case.goal))
    near = metrics.near_endpoint_mask(path, case.goal, 0.2)
    return RunMeasures(
        unsmoothness=float(metrics.unsmoothness(path, fps, has_joint_axis=False)),
        safety=float(metrics.safety_distance(clearance, near)),
        min_clearance=min_clearance, end_error=end_error,
        success=bool(min_clearance > 0 and end_error < reach), frames=len(path))


def summarise(runs: list[RunMeasures]) -> dict:
    """Table 3's row from runs: mean unsmoothness (m/s²), mean safety distance over the successful runs
    (cm), success rate (%) and the counts behind it."""
    ok = [r for r in runs if r.success]
    return {
        "unsmoothness (m/s^2)": float(np.mean([r.unsmoothness for r in runs])) if runs else float("nan"),
        "safety distance (cm)": 100 * float(np.nanmean([r.safety for r in ok])) if ok else float("nan"),
        "success (%)": metrics.success_rate([r.success for r in runs]),
        "successes": len(ok),
        "runs": len(runs),
    }


# ----------------------------------------------------------------------------- Table 3, cached

PLANNER_VARIANTS = {  # Table 3's rows that are configurations of one planner (§8.2.3)
    "INTP-2Ch-D_t": ("t", "toa"),
    "INTP-2Ch-D_o'": ("o'", "toa"),
    "INTP-3Channels": ("t", "o", "toa"),
}


def table3_runs(data_config, planner_config, policy_config, *, seed: int = 0, device="cpu") -> dict:
    """Every planner of Table 3 on the test cases with and without reshaping, built once and then loaded
    from the cache.

    The minimum-jerk optimiser (the cuRobo stand-in) plans from the start to the goal over the frames
    the straight distance takes at the training demonstrations' mean wrist speed; the diffusion policy
    (``baselines.trained_diffusion_policy`` with ``policy_config``) is rolled out ``planner_config.inits``
    times per case (each rollout's own sampling noise; all cases and repeats in one batch); each planner
    variant is trained (``planner.trained_planner`` with its channels) and plans with each of its
    ``planner_config.inits`` latent initialisations.

    Returns:
        ``{"w/o reshaping" | "w/ reshaping": {planner: {"runs": (inits or 1, cases, 6) measures
        [unsmoothness, safety, min_clearance, end_error, success, frames], "seconds": plan times}}}``
        and ``"cases"``: the number of cases per condition.
    """
    import dataclasses
    import sys

    from . import baselines, data, planner

    def build():
        train = data.interaction_set(data_config, "train")
        test = data.interaction_set(data_config, "test")
        speed = float(np.mean([np.linalg.norm(np.diff(i.wrist, axis=0), axis=-1).mean() * 30.0 for i in train.interactions]))
        models = {name: planner.trained_planner(data_config, dataclasses.replace(planner_config, channels=ch), device=device).model
                  for name, ch in PLANNER_VARIANTS.items()}
        policy = baselines.trained_diffusion_policy(data_config, policy_config, device=device).model
        conditions = {label: planning_cases(test, data_config.field, reshape=reshape, seed=seed)
                      for label, reshape in (("w/o reshaping", False), ("w/ reshaping", True))}
        repeats = [(label, k, case) for k in range(planner_config.inits) for label, cases in conditions.items()
                   for case in cases]
        clock = time.perf_counter()
        policy_paths = baselines.diffusion_policy_rollout(
            policy, [c.scene for *_, c in repeats], [c.start for *_, c in repeats], [c.goal for *_, c in repeats],
            [c.condition for *_, c in repeats], seed=seed)
        policy_seconds = (time.perf_counter() - clock) / len(repeats)
        out = {"cases": {}}
        for label, cases in conditions.items():
            out["cases"][label] = len(cases)
            rows = {}
            per_repeat = [[_as_row(measure_run(path, case)) for (lab, k, case), path in zip(repeats, policy_paths)
                           if lab == label and k == r] for r in range(planner_config.inits)]
            rows["Diffusion Policy"] = {"runs": np.asarray(per_repeat), "seconds": np.full(len(cases), policy_seconds)}
            runs, seconds = [], []
            for case in cases:
                clock = time.perf_counter()
                n = max(3, int(np.ceil(np.linalg.norm(case.goal - case.start) / speed * 30.0)) + 1)
                path = baselines.minimum_jerk_plan(case.start, case.goal, n, case.obstacle_sdf)
                seconds.append(time.perf_counter() - clock)
                runs.append(_as_row(measure_run(path, case)))
            rows["cuRobo-like minimum jerk"] = {"runs": np.asarray([runs]), "seconds": np.asarray(seconds)}
            for name, ch in PLANNER_VARIANTS.items():
                cfg = dataclasses.replace(planner_config, channels=ch)
                per_init = [[] for _ in range(cfg.inits)]
                seconds = []
                for case in cases:
                    plans = planner.plan_each_init(models[name], cfg, train, case.scene, case.condition, case.start,
                                                   case.goal, inits=range(cfg.inits))
                    seconds.append(np.mean([p.seconds for p in plans]))
                    for k, plan in enumerate(plans):
                        per_init[k].append(_as_row(measure_run(plan.positions, case)))
                rows[name] = {"runs": np.asarray(per_init), "seconds": np.asarray(seconds)}
            out[label] = rows
        return out

    key = {"data": dataclasses.asdict(data_config), "planner": dataclasses.asdict(planner_config),
           "policy": dataclasses.asdict(policy_config), "seed": int(seed)}
    return load_or_build("choice_table3", key, build, code=(sys.modules[__name__], baselines, planner, data, fields))


_ROW = ("unsmoothness", "safety", "min_clearance", "end_error", "success", "frames")


def _as_row(m: RunMeasures) -> list:
    return [m.unsmoothness, m.safety, m.min_clearance, m.end_error, float(m.success), float(m.frames)]


def runs_from_rows(rows) -> list[RunMeasures]:
    """:class:`RunMeasures` back from ``table3_runs``' rows (cases, 6)."""
    return [RunMeasures(float(r[0]), float(r[1]), float(r[2]), float(r[3]), bool(r[4] > 0.5), int(r[5])) for r in np.asarray(rows)]


# ----------------------------------------------------------------------------- Table 4 (§8.3.1) and Table 2 (§7)


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
    from ..world.features import root_frame, to_heading_frame

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
    from ..world.skeleton import joint_index

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
    from ..world.skeleton import joint_index

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
    from ..world.motion import ACTIONS

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
    minimum-jerk path between the same two ends (``baselines.minimum_jerk_plan`` without obstacles: the
    cuRobo stand-in's straight move; rotations kept).

    Args:
        goal: ``controller.Goal`` (positions (B, 13, 4, 3)).
        hand: (B,) 0 left, 1 right.
    Returns:
        a new ``controller.Goal``.
    """
    from . import baselines
    from .controller import WINDOW

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
    first frame, the future root trajectory on the straight line to the goal, ``controller.toward_goal``) and a goal (its grasp keyframe, ``controller.clip_goal``: the recorded key joints over the 2 s
    window, whose first half is the wrist's recorded approach — ours: it stands in for the INTP plan of the
    paper). Each row drives all clips in one batch from the start for ``anchor + after`` frames:
    ``"w/o goal phase"``, ``"w/ matched goal"``, ``"w/ predicted goal"`` and ``"w/ KF goal"`` are
    ``controller.rollout``'s four goal-phase sources; ``"w/ KF + cuRobo"`` is the Kalman one with the wrist's
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
    import dataclasses
    import sys

    from .. import metrics
    from ..world import mocap
    from ..world.motion import FPS
    from . import controller, kalman, phase

    if isinstance(clips, bool) or not isinstance(clips, int) or clips < 1:
        raise ValueError(f"clips: expected a positive int, got {clips!r}")
    if isinstance(after, bool) or not isinstance(after, int) or after < 0:
        raise ValueError(f"after: expected an int >= 0 (frames after the grasp), got {after!r}")

    def build():
        trained = controller.trained_controller(controller_config)
        model = trained.model
        test = mocap.generate_dataset(clips, seed=10_000 + int(seed), kinds=("reach_grasp",))
        train = mocap.generate_dataset(controller_config.clips, seed=controller_config.seed,
                                       kinds=controller_config.kinds)  # the controller's training clips
        anchors = np.array([int(c.meta["anchor_frame"]) for c in test])
        ends = np.minimum(anchors + after, [len(c) - 1 for c in test])
        hands = np.array([int(c.meta["hand"] == "right") for c in test])
        reference = np.concatenate([pose_window_features(c) for c in train])
        goal = controller.clip_goal(model, test)
        state = controller.toward_goal(controller.initial_state(model, test), goal)
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
            run = controller.rollout(model, state, g, frames, _ROW_VARIANT[row], controller_config.blend_radius)
            seconds[row] = time.perf_counter() - clock
            # frame 0 is the start; step i gives frame i + 1
            joints = torch.cat([first[None], run.joints], dim=0).double().numpy()  # (frames + 1, B, 22, 3)
            motions = [_Joints(joints[:e + 1, b], FPS) for b, e in enumerate(ends)]
            rows[row] = measure(motions)
            reach = [np.linalg.norm(joints[:e + 1, b, controller._WRISTS[h]]
                                    - goal.positions[b, controller.WINDOW // 2, 2 + h].double().numpy(), axis=-1).min()
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
                         code=(sys.modules[__name__], controller, kalman, phase, mocap, metrics))
