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

import dataclasses
import sys
import time
from dataclasses import dataclass

import numpy as np

from ... import metrics
from ...infra import load_or_build
from ...world.objects import CATEGORY_SIZES, object_from_description
from . import baselines, fields, interactions, intp
from .interactions import InteractionSet

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
    variant is trained (``intp.trained_planner`` with its channels) and plans with each of its
    ``planner_config.inits`` latent initialisations.

    Returns:
        ``{"w/o reshaping" | "w/ reshaping": {planner: {"runs": (inits or 1, cases, 6) measures
        [unsmoothness, safety, min_clearance, end_error, success, frames], "seconds": plan times}}}``
        and ``"cases"``: the number of cases per condition.
    """

    def build():
        train = interactions.interaction_set(data_config, "train")
        test = interactions.interaction_set(data_config, "test")
        speed = float(np.mean([np.linalg.norm(np.diff(i.wrist, axis=0), axis=-1).mean() * 30.0 for i in train.interactions]))
        models = {name: intp.trained_planner(data_config, dataclasses.replace(planner_config, channels=ch), device=device).model
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
                    plans = intp.plan_each_init(models[name], cfg, train, case.scene, case.condition, case.start,
                                                   case.goal, inits=range(cfg.inits))
                    seconds.append(np.mean([p.seconds for p in plans]))
                    for k, plan in enumerate(plans):
                        per_init[k].append(_as_row(measure_run(plan.positions, case)))
                rows[name] = {"runs": np.asarray(per_init), "seconds": np.asarray(seconds)}
            out[label] = rows
        return out

    key = {"data": dataclasses.asdict(data_config), "planner": dataclasses.asdict(planner_config),
           "policy": dataclasses.asdict(policy_config), "seed": int(seed)}
    return load_or_build("choice_table3", key, build, code=(sys.modules[__name__], baselines, intp, interactions, fields))


_ROW = ("unsmoothness", "safety", "min_clearance", "end_error", "success", "frames")


def _as_row(m: RunMeasures) -> list:
    return [m.unsmoothness, m.safety, m.min_clearance, m.end_error, float(m.success), float(m.frames)]


def runs_from_rows(rows) -> list[RunMeasures]:
    """:class:`RunMeasures` back from ``table3_runs``' rows (cases, 6)."""
    return [RunMeasures(float(r[0]), float(r[1]), float(r[2]), float(r[3]), bool(r[4] > 0.5), int(r[5])) for r in np.asarray(rows)]
