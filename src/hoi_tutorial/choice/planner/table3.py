"""Table 3's protocol (CHOICE §8.2.2): planners on unseen layouts and reshaped furniture.

The test scenes are the test split's interactions (other clips: other items, supports, clutter),
changed as §8.2.2 says:

- **unseen layouts**: each obstacle on the furniture (the clutter) shifted by at most 5 cm, turned
  by at most ±90° and rescaled 0.8–1.25×;
- **reshaping**: in addition, the container (the shelf or table) rescaled to 70–150 % of its width,
  depth and height, the items standing on it moving with their board;

keeping the "pickable" cases: the goal (the demonstration's contact, moved with its item) at least
1 cm from every obstacle, the start (the demonstration's wrist where it enters the grid) outside
every obstacle, no clutter item inside the target. A case's ``c`` is its own: the goal height of a
reshaped case is its moved goal's.

Every planner is judged by the same rules:

- its path starts at the case's start, the wrist at the planning frame (the implicit planner's path
  walks from there to its ``x_s``: ``intp.WristPlan.from_wrist``);
- **collision-free**: the wrist never inside an obstacle and, on a segment that carries the item (a
  pick's leave, a place's approach), the item's surface points, carried with the wrist, never more than
  ``ITEM_REST_TOLERANCE`` inside one (at the contact the item stands on its board);
- **success**: collision-free and ending within 2 cm of the goal.

Measures (``metrics``): unsmoothness (the wrist's mean acceleration, m/s²), the spare safety distance
("from the hand and object": the nearest obstacle's distance to the wrist and, while it is carried, to
the item, averaged over the frames within 20 cm of the goal, over the successful runs; cm) and the
success rate. Ours where CHOICE is silent: the wrist point stands for the hand, the item is carried by
translation (the baselines plan no orientation), the 2 cm reach tolerance, both segments (approach and
leave) of a pick as cases.
"""
from __future__ import annotations

import dataclasses
import functools
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ... import metrics
from ...infra import load_or_build
from ...world.objects import CATEGORY_SIZES, object_from_description
from . import baselines, fields, interactions, intp
from .interactions import InteractionSet

__all__ = [
    "ITEM_REST_TOLERANCE",
    "REACH",
    "PlanningCase",
    "scale_object",
    "planning_cases",
    "RunMeasures",
    "measure_run",
    "summarise",
    "PLANNER_VARIANTS",
    "CONDITIONS",
    "table3_runs",
    "table3_builds",
    "condition_runs",
    "runs_from_rows",
]


ITEM_REST_TOLERANCE = 0.005  # metres a carried item's points may lie inside an obstacle (ours: it rests on its board)
ITEM_POINTS = 32  # surface points of a carried item checked for collisions (ours)
REACH = 0.02  # metres: a successful run ends this close to the goal (ours)


@dataclass
class PlanningCase:
    """One test planning problem.

    Attributes:
        source: index of the test interaction it comes from.
        target, obstacles: the (changed) scene's objects.
        scene: its fields (``D_toa`` not computed: the planners never see it).
        start: (3,) metres, the wrist where the plan starts.
        goal: (3,) metres, the contact.
        condition: (4,) ``c`` (its goal height ``goal[2]``).
        reshaped: whether the container was reshaped.
        item_points: (M, 3) metres, the item's surface points at the contact, when the segment carries it
            (a pick's leave or a place's approach); else None.
    """

    source: int
    target: object
    obstacles: list
    scene: fields.SceneFields
    start: np.ndarray
    goal: np.ndarray
    condition: np.ndarray
    reshaped: bool
    item_points: Optional[np.ndarray] = None

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
        condition = inter.condition.copy()
        condition[0] = goal[2]  # c's goal height follows a reshaped goal
        carries = (action == "grasp") == (float(inter.condition[3]) > 0.5)  # a pick's leave, a place's approach
        item_points = new_target.surface_points(ITEM_POINTS, seed=0) if carries else None
        cases.append(PlanningCase(k, new_target, obstacles, scene, start, goal, condition, reshape, item_points))
    return cases


@dataclass
class RunMeasures:
    """One planned path's measures (Table 3's columns before averaging)."""

    unsmoothness: float  # m/s², mean acceleration of the wrist
    safety: float  # metres, mean clearance within 20 cm of the goal
    min_clearance: float  # metres, smallest clearance of the wrist along the path (negative: a collision)
    end_error: float  # metres, from the last frame to the goal
    success: bool
    frames: int
    item_clearance: float = float("nan")  # metres, smallest clearance of the carried item (nan: none carried)

    @property
    def collided(self) -> bool:
        """The wrist inside an obstacle, or the carried item deeper than ``ITEM_REST_TOLERANCE`` in one."""
        return bool(self.min_clearance <= 0 or self.item_clearance < -ITEM_REST_TOLERANCE)


def measure_run(path, case: PlanningCase, fps: float = 30.0, reach: float = REACH) -> RunMeasures:
    """Table 3's measures of one wrist path (T, 3) metres on ``case``, the contact last (module docstring).

    The path's frames are checked for collisions, and four points between each pair; the carried item
    (``case.item_points``) moves with the wrist by the wrist's displacement from the goal.
    """
    path = np.asarray(path, dtype=np.float64)
    if path.ndim != 2 or path.shape[1] != 3 or len(path) < 3:
        raise ValueError(f"path: expected a (T >= 3, 3) wrist path, got shape {path.shape}")
    if np.linalg.norm(path[0] - case.start) > 1e-6:
        raise ValueError(f"path: expected a path starting at the case's start {case.start.round(3).tolist()} "
                         f"(the wrist at the planning frame), got one starting at {path[0].round(3).tolist()}")
    between = path[:-1, None] + np.linspace(0, 1, 5, endpoint=False)[None, :, None] * np.diff(path, axis=0)[:, None]
    dense = np.concatenate([between.reshape(-1, 3), path[-1:]])
    clearance = case.obstacle_sdf(path)
    min_clearance = float(min(clearance.min(), case.obstacle_sdf(dense).min()))
    item_clearance = float("nan")
    if case.item_points is not None:  # the item rides with the wrist: its points shifted by (x_t - goal)
        carried = lambda p: case.obstacle_sdf(case.item_points[None] + (p - case.goal)[:, None]).min(axis=1)
        per_frame = carried(path)
        clearance = np.minimum(clearance, per_frame)  # the hand and the object
        item_clearance = float(min(per_frame.min(), carried(dense).min()))
    end_error = float(np.linalg.norm(path[-1] - case.goal))
    near = metrics.near_endpoint_mask(path, case.goal, 0.2)
    measures = RunMeasures(
        unsmoothness=float(metrics.unsmoothness(path, fps, has_joint_axis=False)),
        safety=float(metrics.safety_distance(clearance, near)),
        min_clearance=min_clearance, end_error=end_error, success=False, frames=len(path),
        item_clearance=item_clearance)
    measures.success = bool(not measures.collided and end_error < reach)
    return measures


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


CONDITIONS = {"w/o reshaping": False, "w/ reshaping": True}  # Table 3's two halves: label -> reshape


def table3_runs(data_config, planner_config, policy_config, *, seed: int = 0, device="cpu") -> dict:
    """Every planner of Table 3 on the test cases with and without reshaping: :func:`condition_runs` for each
    condition (each built once, then loaded from the cache; :func:`table3_builds` builds them in parallel).

    Every planner starts at the case's start (the wrist). The minimum-jerk optimiser (the cuRobo stand-in)
    plans from there to the goal over the frames the straight distance takes at the training
    demonstrations' mean wrist speed; the diffusion policy (``baselines.trained_diffusion_policy`` with
    ``policy_config``) is rolled out ``planner_config.inits`` times per case (each rollout's own sampling
    noise; a condition's cases and repeats in one batch); each planner variant is trained
    (``intp.trained_planner`` with its channels) and plans with each of its ``planner_config.inits`` latent
    initialisations, its path walking from the wrist to ``x_s`` first (``intp.WristPlan.from_wrist``).

    Returns:
        ``{"w/o reshaping" | "w/ reshaping": {planner: {"runs": (inits or 1, cases, 7) measures
        [unsmoothness, safety, min_clearance, end_error, success, frames, item_clearance], "seconds": plan
        times}}}`` and ``"cases"``: the number of cases per condition. The auto-decoders' entries also hold
        ``"runs from x_s"``: the same plans judged from their own ``x_s``, the walk from the wrist left out (a
        control: what the walk costs them).
    """
    out = {"cases": {}}
    for label, reshape in CONDITIONS.items():
        rows = dict(condition_runs(data_config, planner_config, policy_config, reshape, seed=seed, device=device))
        out["cases"][label] = int(rows.pop("cases"))
        out[label] = rows
    return out


def table3_builds(data_config, planner_config, policy_config, *, seed: int = 0, device="cpu") -> tuple[list, list]:
    """The independent builds behind :func:`table3_runs`, for ``infra.warm_cache``: the models (the Diffusion
    Policy and each planner variant), then the two conditions' runs, which need the models. Each build runs on
    one thread, so two at a time give the numbers one after the other gives."""
    models = [functools.partial(baselines.trained_diffusion_policy, data_config, policy_config, device=device)]
    models += [functools.partial(intp.trained_planner, data_config, dataclasses.replace(planner_config, channels=ch),
                                 device=device) for ch in PLANNER_VARIANTS.values()]
    runs = [functools.partial(condition_runs, data_config, planner_config, policy_config, reshape, seed=seed,
                              device=device) for reshape in CONDITIONS.values()]
    return models, runs


def condition_runs(data_config, planner_config, policy_config, reshape: bool, *, seed: int = 0,
                   device="cpu") -> dict:
    """One condition of :func:`table3_runs` (``reshape``: the furniture reshaped or not), built once and then
    loaded from the cache: ``{planner: {"runs", "seconds"[, "runs from x_s"]}, "cases": n}``."""
    if not isinstance(reshape, bool):
        raise ValueError(f"reshape: expected True or False, got {reshape!r}")

    def build():
        train = interactions.interaction_set(data_config, "train")
        test = interactions.interaction_set(data_config, "test")
        speed = float(np.mean([np.linalg.norm(np.diff(i.wrist, axis=0), axis=-1).mean() * 30.0 for i in train.interactions]))
        models = {name: intp.trained_planner(data_config, dataclasses.replace(planner_config, channels=ch), device=device).model
                  for name, ch in PLANNER_VARIANTS.items()}
        policy = baselines.trained_diffusion_policy(data_config, policy_config, device=device).model
        cases = planning_cases(test, data_config.field, reshape=reshape, seed=seed)
        repeats = [(k, case) for k in range(planner_config.inits) for case in cases]
        clock = time.perf_counter()
        policy_paths = baselines.diffusion_policy_rollout(
            policy, [c.scene for _, c in repeats], [c.start for _, c in repeats], [c.goal for _, c in repeats],
            [c.condition for _, c in repeats], seed=seed + int(reshape))  # each condition its own noise
        policy_seconds = (time.perf_counter() - clock) / len(repeats)
        rows = {"cases": len(cases)}
        per_repeat = [[_as_row(measure_run(path, case)) for (k, case), path in zip(repeats, policy_paths) if k == r]
                      for r in range(planner_config.inits)]
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
            from_start = [[] for _ in range(cfg.inits)]
            seconds = []
            for case in cases:
                plans = intp.plan_each_init(models[name], cfg, train, case.scene, case.condition, case.start,
                                            case.goal, inits=range(cfg.inits))
                seconds.append(np.mean([p.seconds for p in plans]))
                for k, plan in enumerate(plans):
                    per_init[k].append(_as_row(measure_run(plan.from_wrist(case.start), case)))
                    # the control: the integrated path alone, judged from its own x_s
                    own_start = dataclasses.replace(case, start=plan.start)
                    from_start[k].append(_as_row(measure_run(plan.positions, own_start)))
            rows[name] = {"runs": np.asarray(per_init), "seconds": np.asarray(seconds),
                          "runs from x_s": np.asarray(from_start)}
        return rows

    key = {"data": dataclasses.asdict(data_config), "planner": dataclasses.asdict(planner_config),
           "policy": dataclasses.asdict(policy_config), "reshape": reshape, "seed": int(seed)}
    return load_or_build("choice_table3", key, build)


_ROW = ("unsmoothness", "safety", "min_clearance", "end_error", "success", "frames", "item_clearance")


def _as_row(m: RunMeasures) -> list:
    return [m.unsmoothness, m.safety, m.min_clearance, m.end_error, float(m.success), float(m.frames),
            m.item_clearance]


def runs_from_rows(rows) -> list[RunMeasures]:
    """:class:`RunMeasures` back from ``table3_runs``' rows (cases, 7)."""
    return [RunMeasures(float(r[0]), float(r[1]), float(r[2]), float(r[3]), bool(r[4] > 0.5), int(r[5]), float(r[6]))
            for r in np.asarray(rows)]
