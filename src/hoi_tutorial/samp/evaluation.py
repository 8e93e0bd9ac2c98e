"""SAMP's quantitative evaluation (§5.2): reaching goals on unseen objects, and how well.

- **Goal tasks**: a character stands 3–4 m from an unseen toy object (a new instance), roughly
  facing it, and is given one of the object's sitting (lying) goals; MotionNet's decoder runs until
  the time limit (the paper's limit is 3 minutes; ours is stated per call).
- **Execution time** (Table 2): "the time required to transition to the target action label from an
  idle state" — the first frame whose own action label (``t^a`` at the current sample) is the
  target's (``metrics.execution_time``).
- **Precision** (Table 3): the positional and rotational error at the goal, PE (cm) between the
  pelvis and the goal position in the ground plane and RE (degrees) between the root's forward and
  the goal direction (``metrics.goal_precision``), measured ``settle`` seconds after the action began (the character
  has sat down by then: the toy sit-down takes 1–1.5 s).
- **Diversity** (Table 1, Eq. 6): APD of the local pose features ``X' = {j^p, j^r, j^v}`` over the
  frames of ten runs from one start with one goal that carry the action's label
  (``metrics.average_pairwise_distance``), beside the same on ground-truth frames of that action; and the spread *between* runs frame by frame (:func:`run_spread`),
  which is zero for a deterministic model.
- **Realism** (Table 4, Eq. 9): Fréchet distance between generated and ground-truth frames of an
  action on ``X̃ = {j^p, j^r, j^v, t̃^p, t̃^d}`` (``metrics.frechet_distance``).
- A run **reaches** its goal when the action began within the time limit and PE is below
  ``reach_radius`` (ours: 30 cm; the paper reports no threshold, only ∞ for runs that never act).
  PE, RE and execution time are reported as the paper does (:func:`precision_summary`): PE and RE
  over every run that performed the action, a miss counting with its error; the execution time over
  every run, ∞ when any never acted. Two methods are compared run by run over the same tasks
  (:func:`paired_over_acted`).
"""
from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np
import torch

from .. import intervals
from .._validate import check_choice, check_shape
from ..metrics import average_pairwise_distance, execution_time, frechet_distance, goal_precision
from ..world import mocap
from ..world.features import SAMP_ACTIONS, SAMP_STATE_LAYOUT, SAMP_STATE_SIZE, samp_action_ids
from ..world.objects import ToyObject, make_object
from .core import MotionModel
from .motion_data import ARRIVAL, OBJECT_CATEGORIES, clip_states, lie_facing, make_clip, object_voxel_cells
from ..infra import load_or_build
from .runtime import GoalSequence, Rollout, content_digest, current_action, object_digest, rollout, standing_state

__all__ = ["GoalTask", "goal_tasks", "precision_summary", "paired_over_acted",
    "paired_execution_time",
    "captured_execution_times", "GoalRunResults", "run_goal_tasks", "measure_goal_runs", "LOCAL_POSE_FEATURES", "FD_FEATURES",
           "state_features", "action_fd", "direction_runs", "standing_runs", "action_frames", "repeated_goal_runs", "run_spread",
           "captured_states", "voxel_cells", "onset_windows", "onset_spread", "MeasuredRuns", "onset_in_goal_frame"]


@dataclass
class GoalTask:
    """One evaluation run: an object, its goal (world) and where the character starts.

    Attributes:
        action: "sit" or "lie".
        obj: the toy object (placed at the origin).
        goal_position: ``(3,)`` m; goal_direction ``(3,)`` unit (a lying goal's as :func:`lie_facing`).
        start_root: ``(3,)`` ``(x, y, heading)``.
    """

    action: str
    obj: ToyObject
    goal_position: np.ndarray
    goal_direction: np.ndarray
    start_root: np.ndarray


def goal_tasks(action: str, n: int, seed: int = 0, distance: tuple = (3.0, 4.0),
               facing_spread: float = math.radians(30.0)) -> list[GoalTask]:
    """``n`` runs on unseen objects of ``OBJECT_CATEGORIES[action]`` (new instances from ``seed``).

    Args:
        action: "sit" or "lie".
        n: number of tasks.
        seed: draws the objects, goals and starts (independent of the training clips' seeds).
        distance: ``(low, high)`` start distance from the goal, m.
        facing_spread: the start heading is within this angle of the direction to the goal (rad).
    """
    check_choice(action, tuple(OBJECT_CATEGORIES), "action")
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"n: expected a positive int, got {n!r}")
    tasks = []
    for i in range(n):
        rng = np.random.default_rng([int(seed), 9173, SAMP_ACTIONS.index(action), i])
        categories = OBJECT_CATEGORIES[action]
        obj = make_object(categories[int(rng.integers(len(categories)))], seed=int(rng.integers(2**31)))
        positions, directions = obj.sit_goals if action == "sit" else obj.lie_goals
        k = int(rng.integers(len(positions)))
        position = np.asarray(positions[k], dtype=np.float64)
        direction = np.asarray(directions[k], dtype=np.float64)
        if action == "lie":
            direction = lie_facing(direction)
        front = obj.pose[:2, 1] / np.linalg.norm(obj.pose[:2, 1])
        angle = math.atan2(-front[0], front[1]) + rng.uniform(-math.radians(60), math.radians(60))
        start = position[:2] + rng.uniform(*distance) * np.array([-math.sin(angle), math.cos(angle)])
        to_goal = position[:2] - start
        heading = math.atan2(-to_goal[0], to_goal[1]) + rng.uniform(-facing_spread, facing_spread)
        tasks.append(GoalTask(action, obj, position, direction, np.array([start[0], start[1], heading])))
    return tasks


def precision_summary(execution_time, position_error, rotation_error, reached) -> dict:
    """Table 2's and Table 3's numbers from per-run measurements, as the paper reports them.

    Args:
        execution_time: ``(B,)`` s, ``inf`` where the action never began; position_error ``(B,)`` cm;
        rotation_error ``(B,)`` degrees; reached ``(B,)`` bool.
    Returns:
        dict: ``runs``; ``acted`` (runs whose action began); ``reached`` (of those, PE below the
        reach radius); ``execution_time``, the mean over every run, ``inf`` when any run never began
        the action (Table 2: "∞ means the method failed to reach the goal within 3 minutes");
        ``execution_time_acted``, the mean over the runs that acted; ``PE`` and ``RE``, means over the
        runs that performed the action, a miss counting with its error (``inf`` when none acted);
        ``PE_reached``, ``RE_reached``, the means over the runs that reached (``inf`` when none did).
    """
    times, pe, re = (np.asarray(v, dtype=np.float64) for v in (execution_time, position_error, rotation_error))
    reached = np.asarray(reached, dtype=bool)
    acted = np.isfinite(times)
    mean = (lambda v, rows: float(np.mean(v[rows])) if rows.any() else math.inf)
    return {"runs": int(len(times)), "acted": int(acted.sum()), "reached": int(reached.sum()),
            "execution_time": float(np.mean(times)) if acted.all() else math.inf,
            "execution_time_acted": mean(times, acted), "PE": mean(pe, acted), "RE": mean(re, acted),
            "PE_reached": mean(pe, reached), "RE_reached": mean(re, reached)}


def paired_over_acted(a, b, measure: str, **kwargs):
    """``a`` minus ``b`` in ``measure`` (``"position_error"``, ``"rotation_error"`` or ``"execution_time"``),
    paired run by run over the runs of the same tasks where both performed the action: an
    :class:`~hoi_tutorial.intervals.Interval` (paired; ``kwargs`` go to
    ``intervals.paired_difference``), or None when fewer than two runs acted in both.

    ``a`` and ``b`` are :class:`GoalRunResults` (or room runs), or equally long sequences of them, one pair per set
    of tasks (the sit tasks and the lie tasks, say): the pairs are then pooled, every run paired with its own."""
    check_choice(measure, ("position_error", "rotation_error", "execution_time"), "measure")
    ours, theirs = [], []
    for x, y in _run_pairs(a, b):
        both = np.isfinite(x.execution_time) & np.isfinite(y.execution_time)
        ours.append(np.asarray(getattr(x, measure))[both])
        theirs.append(np.asarray(getattr(y, measure))[both])
    ours, theirs = np.concatenate(ours), np.concatenate(theirs)
    if len(ours) < 2:
        return None
    return intervals.paired_difference(ours, theirs, **kwargs)


def paired_execution_time(a, b, time_limit: float, **kwargs):
    """``a`` minus ``b`` in execution time (s), paired run by run over *every* run of the same tasks, a run that
    never acted counted as ``time_limit`` seconds (its whole length): a failure weighs as the slowest run, where
    :func:`paired_over_acted` leaves it out. ``a``, ``b`` and ``kwargs`` as there; None under two runs."""
    if not (np.isfinite(time_limit) and time_limit > 0):
        raise ValueError(f"time_limit: expected a positive number of seconds, got {time_limit!r}")
    ours, theirs = [], []
    for x, y in _run_pairs(a, b):
        ours.append(np.where(np.isfinite(x.execution_time), x.execution_time, float(time_limit)))
        theirs.append(np.where(np.isfinite(y.execution_time), y.execution_time, float(time_limit)))
    ours, theirs = np.concatenate(ours), np.concatenate(theirs)
    if len(ours) < 2:
        return None
    return intervals.paired_difference(ours, theirs, **kwargs)


def _run_pairs(a, b) -> list:
    """``[(a, b)]``, or the pairs of two equally long sequences of results, each pair of runs of the same tasks."""
    pooled = isinstance(a, (list, tuple))
    if pooled != isinstance(b, (list, tuple)) or (pooled and (len(a) != len(b) or not a)):
        raise ValueError("a, b: expected two results, or two equally long sequences of them")
    pairs = list(zip(a, b)) if pooled else [(a, b)]
    for x, y in pairs:
        if len(x.execution_time) != len(y.execution_time):
            raise ValueError(f"a, b: expected runs of the same tasks, got {len(x.execution_time)} and "
                             f"{len(y.execution_time)}")
    return pairs


class MeasuredRuns:
    """What the goal runs and the room runs share: per-run ``execution_time``, ``position_error``,
    ``rotation_error`` and ``reached`` arrays, read as the paper reports them."""

    @property
    def acted(self) -> np.ndarray:
        """``(B,)`` bool: the runs whose action began within the limit."""
        return np.isfinite(self.execution_time)

    def summary(self) -> dict:
        """Counts and means as the paper reports them (:func:`precision_summary`)."""
        return precision_summary(self.execution_time, self.position_error, self.rotation_error, self.reached)


@dataclass
class GoalRunResults(MeasuredRuns):
    """What :func:`run_goal_tasks` measured, one entry per task.

    Attributes:
        execution_time: seconds until the action began (``inf`` when it never did).
        position_error: PE, cm (``inf`` when the action never began).
        rotation_error: RE, degrees (``inf`` likewise).
        reached: the action began within the limit with PE below the reach radius.
        rollout: the generated motion (:class:`~hoi_tutorial.samp.runtime.Rollout`).
        reach_radius: m.
    """

    execution_time: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    reached: np.ndarray
    rollout: Rollout = field(repr=False)
    reach_radius: float = 0.3

    @property
    def success_rate(self) -> float:
        return float(np.mean(self.reached))



def run_goal_tasks(model: MotionModel, tasks: Sequence[GoalTask], seconds: float = 20.0, seed: int = 0,
                   latent_scale: float = 1.0, settle: float = 1.5, reach_radius: float = 0.3) -> GoalRunResults:
    """Run every task at once (one batch) for ``seconds`` and measure it (see the module docstring)."""
    if not tasks:
        raise ValueError("tasks: expected at least one GoalTask")
    fps = 30.0
    n_frames = int(round(seconds * fps))
    goals = GoalSequence.single(np.stack([t.goal_position for t in tasks]), np.stack([t.goal_direction for t in tasks]),
                                [t.action for t in tasks])
    cells = [voxel_cells(t.obj) for t in tasks]
    centres = torch.as_tensor(np.stack([c for c, _ in cells]))
    occupancy = torch.as_tensor(np.stack([o for _, o in cells]))
    roots = torch.as_tensor(np.stack([t.start_root for t in tasks]), dtype=torch.float32)
    out = rollout(model, standing_state(), roots, goals, n_frames, torch.Generator().manual_seed(int(seed)),
                  centres, occupancy, latent_scale=latent_scale)
    times, pe, re, reached = measure_goal_runs(out, [t.action for t in tasks], [t.goal_position for t in tasks],
                                               [t.goal_direction for t in tasks], settle, reach_radius)
    return GoalRunResults(times, pe, re, reached, out, reach_radius)


def measure_goal_runs(out: Rollout, actions: Sequence[str], goal_positions: Sequence, goal_directions: Sequence,
                      settle: float = 1.5, reach_radius: float = 0.3, fps: float = 30.0):
    """Execution time, PE, RE and reach of each run of a rollout (see the module docstring).

    Args:
        out: ``B`` runs; actions: the target action of each; goal_positions, goal_directions: ``(3,)`` each.
    Returns:
        ``(execution_time (B,) s, PE (B,) cm, RE (B,) degrees, reached (B,) bool)``, ``inf`` where
        the action never began.
    """
    n_frames = out.states.shape[1] - 1
    joints, forward = out.joints().double().numpy(), out.forward().double().numpy()
    labels = out.actions.numpy()
    times, pe, re = [], [], []
    for b, (action, position, direction) in enumerate(zip(actions, goal_positions, goal_directions)):
        t = execution_time(labels[b], SAMP_ACTIONS.index(action), fps=fps)
        times.append(t)
        if not math.isfinite(t):
            pe.append(math.inf)
            re.append(math.inf)
            continue
        frame = min(int(round((t + settle) * fps)), n_frames)
        error = goal_precision(joints[b, frame, 0], forward[b, frame], position, direction)
        pe.append(100.0 * error["position_error"])
        re.append(error["rotation_error"])
    pe, re, times = np.asarray(pe), np.asarray(re), np.asarray(times)
    return times, pe, re, np.isfinite(times) & (pe < 100.0 * reach_radius)


# ----------------------------------------------------------------------------- diversity and realism

LOCAL_POSE_FEATURES = ("joint_positions", "joint_rotations", "joint_velocities")  # X' of Eq. 6
FD_FEATURES = ("joint_positions", "joint_rotations", "joint_velocities", "goal_trajectory_positions",
               "goal_trajectory_directions")  # X̃ of Eq. 9


def state_features(states: torch.Tensor, parts: Sequence[str]) -> np.ndarray:
    """``(..., D)`` the named parts of states ``(..., 437)`` side by side (float64 numpy)."""
    for name in parts:
        check_choice(name, tuple(SAMP_STATE_LAYOUT), "parts")
    return torch.cat([states[..., SAMP_STATE_LAYOUT[name]] for name in parts], dim=-1).double().numpy()


def direction_runs(model: MotionModel, action: str, n_runs: int = 10, seconds: float = 15.0, seed: int = 0,
                   latent_scale: float = 1.0, spacing: float = 2.0) -> Rollout:
    """Table 1's locomotion protocol: from one standing start, ``n_runs`` runs in each of the four
    directions (front, left, back, right) for ``seconds``, ``action`` "walk" or "run".

    SAMP steers this with the user's controls; here each run follows waypoints ``spacing`` metres
    apart along its direction, each passed within one metre, so the goal always stays a few metres
    ahead (as far as the training clips' goals are). ``4 n_runs`` characters in one batch.
    """
    check_choice(action, ("walk", "run"), "action")
    n_frames = int(round(seconds * 30))
    n_goals = int(math.ceil(seconds * 4.0 / spacing)) + 1  # never runs out, even running
    sequences = []
    for k in range(4):
        angle = k * math.pi / 2
        d = np.array([-math.sin(angle), math.cos(angle), 0.0])
        sequences += [[(spacing * (g + 1) * d, d, action, 1.0) for g in range(n_goals)]] * n_runs
    goals = GoalSequence.from_lists(sequences)
    roots = torch.zeros(len(sequences), 3)
    return rollout(model, standing_state(), roots, goals, n_frames, torch.Generator().manual_seed(int(seed)),
                   latent_scale=latent_scale)


def standing_runs(model: MotionModel, n_runs: int = 10, seconds: float = 10.0, seed: int = 0,
                  latent_scale: float = 1.0) -> Rollout:
    """Idle: ``n_runs`` characters asked to stay where they stand, facing as they face (goal action
    "idle" on their own spot)."""
    if not isinstance(n_runs, int) or n_runs < 1:
        raise ValueError(f"n_runs: expected a positive int, got {n_runs!r}")
    goals = GoalSequence.single(torch.zeros(n_runs, 3), torch.tensor([[0.0, 1.0, 0.0]]).expand(n_runs, 3), ["idle"])
    return rollout(model, standing_state(), torch.zeros(n_runs, 3), goals, int(round(seconds * 30)),
                   torch.Generator().manual_seed(int(seed)), latent_scale=latent_scale)


def action_fd(states: torch.Tensor, action: str, reference) -> tuple[float, int]:
    """Realism (Table 4, Eq. 9): the Fréchet distance between the frames of ``states`` labelled ``action``
    (:func:`action_frames`) and ``reference``, on ``FD_FEATURES``, computed once (then from the cache: the
    matrix square root of a product of two 292×292 covariances takes a second).

    Args:
        states: ``(R, T, 437)`` runs (or ``(T, 437)``).
        action: one of ``SAMP_ACTIONS``.
        reference: ``(M, D)`` the ground truth's features (:func:`state_features` with ``FD_FEATURES``).
    Returns:
        ``(FD, frames)``: ``metrics.frechet_distance`` (``inf`` with fewer than two frames of the action) and
        how many generated frames it used.
    """
    check_choice(action, SAMP_ACTIONS, "action")
    states = torch.as_tensor(states)
    reference = np.asarray(reference)

    def build():
        frames = state_features(action_frames(states, action), FD_FEATURES)
        return {"fd": frechet_distance(frames, reference) if len(frames) >= 2 else math.inf, "frames": len(frames)}

    key = {"states": content_digest(states), "action": action, "reference": content_digest(reference)}
    out = load_or_build("samp_action_fd", key, build, verbose=False)
    return float(out["fd"]), int(out["frames"])


def action_frames(states: torch.Tensor, action: str, per_run: Optional[int] = None) -> torch.Tensor:
    """``(n, 437)`` the states of runs ``states (R, T, 437)`` whose own current label is ``action``.

    Args:
        per_run: keep at most the first ``per_run`` such frames of each run (e.g. as many as a
            ground-truth clip holds, so that a long hold after sitting down does not swamp the
            sit-down itself); None keeps all.
    """
    check_choice(action, SAMP_ACTIONS, "action")
    if states.dim() == 2:
        states = states[None]
    out = []
    for run in states:
        frames = run[current_action(run) == SAMP_ACTIONS.index(action)]
        out.append(frames if per_run is None else frames[:int(per_run)])
    return torch.cat(out)


def repeated_goal_runs(model: MotionModel, task: GoalTask, n_runs: int = 10, seconds: float = 15.0, seed: int = 0,
                       latent_scale: float = 1.0) -> GoalRunResults:
    """Table 1's interaction protocol: the same task (start, object, goal) ``n_runs`` times."""
    return run_goal_tasks(model, [task] * int(n_runs), seconds=seconds, seed=seed, latent_scale=latent_scale)


def run_spread(states: torch.Tensor) -> float:
    """How far runs from one start part ways: Eq. 6's APD of ``X'`` across the ``R`` runs at each
    frame, averaged over frames (0 for a deterministic model). ``states (R, T, 437)``."""
    features = state_features(states, LOCAL_POSE_FEATURES)  # (R, T, D)
    return float(np.mean(average_pairwise_distance(np.swapaxes(features, 0, 1))))


def captured_states(action: str, obj: ToyObject, n: int = 10, first_seed: int = 5000) -> list:
    """The ground truth of one object: ``n`` toy-mocap clips of ``action`` on ``obj`` (seeds ``first_seed``,
    ``first_seed + 1``, …; each draws its own style, start and goal), as state sequences ``(T_k, 437)``; made
    once (then from the cache)."""
    check_choice(action, tuple(OBJECT_CATEGORIES), "action")
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n: expected a positive int, got {n!r}")
    key = {"action": action, "object": object_digest(obj), "n": n, "first_seed": int(first_seed)}
    return load_or_build("samp_captured_states", key,
                         lambda: [clip_states(make_clip(action, first_seed + k, obj=obj)[0])[0] for k in range(n)])


def captured_execution_times(tasks: Sequence["GoalTask"], first_seed: int = 7000, fps: float = 30.0) -> np.ndarray:
    """Table 2's ground truth on the methods' own tasks: for each task, a toy-mocap clip of its action on its object,
    from its start position to its own goal on the object (``mocap.generate_clip`` with ``start_position`` and
    ``goal_index``, arriving as the training clips do), and the seconds from the clip's first frame to its first
    frame of the action; ``(len(tasks),)``, ``inf`` where the clip never performs it. Seeds ``first_seed + k``."""
    times = []
    for k, task in enumerate(tasks):
        check_choice(task.action, tuple(OBJECT_CATEGORIES), "task.action")
        goals = task.obj.sit_goals if task.action == "sit" else task.obj.lie_goals
        goal_index = int(np.argmin(np.linalg.norm(np.asarray(goals[0], dtype=np.float64) - task.goal_position, axis=1)))
        motion = mocap.generate_clip(task.action, seed=int(first_seed) + k, obj=task.obj, goal_index=goal_index,
                                     stand_up=False, start_position=np.asarray(task.start_root[:2], dtype=np.float64),
                                     arrival=ARRIVAL)
        acting = np.flatnonzero(samp_action_ids(motion.actions) == SAMP_ACTIONS.index(task.action))
        times.append(acting[0] / float(fps) if len(acting) else math.inf)
    return np.asarray(times, dtype=np.float64)


# A goal run's objects recur (every model runs the same tasks): their cells are made once per process.
_CELLS: "collections.OrderedDict[str, tuple]" = collections.OrderedDict()
_CELLS_KEPT = 256


def voxel_cells(obj: ToyObject) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~hoi_tutorial.samp.motion_data.object_voxel_cells` of ``obj``, made once per process for the same
    object (:func:`~hoi_tutorial.samp.runtime.object_digest`); the arrays are copies."""
    key = object_digest(obj)
    if key not in _CELLS:
        _CELLS[key] = object_voxel_cells(obj)
        while len(_CELLS) > _CELLS_KEPT:
            _CELLS.popitem(last=False)
    _CELLS.move_to_end(key)
    return tuple(a.copy() for a in _CELLS[key])


def onset_windows(runs, action: str, before: float = 1.0, after: float = 2.0, fps: float = 30.0) -> torch.Tensor:
    """The states around each run's action onset, aligned on it: ``(R', W, 437)``.

    Args:
        runs: ``(R, T, 437)`` states, or a list of ``(T_r, 437)`` (ground-truth clips of different lengths).
        action: the action whose first labelled frame (``t^a`` at the current sample) is the onset.
        before, after: seconds kept before and after the onset (``W = round((before + after) fps)``);
            a window that runs past a run's ends repeats its first or last frame.
    Returns:
        the windows of the runs that act (a run that never does is left out: ``R' ≤ R``).
    """
    check_choice(action, SAMP_ACTIONS, "action")
    if before < 0 or after <= 0:
        raise ValueError(f"before, after: expected before >= 0 and after > 0 seconds, got {before!r}, {after!r}")
    offsets = torch.arange(-int(round(before * fps)), int(round(after * fps)))
    windows = []
    for run in runs:
        onset = torch.nonzero(current_action(run) == SAMP_ACTIONS.index(action))
        if len(onset):
            windows.append(run[(int(onset[0, 0]) + offsets).clamp(0, len(run) - 1)])
    if not windows:
        return torch.zeros(0, len(offsets), SAMP_STATE_SIZE)
    return torch.stack(windows)


def onset_spread(runs, action: str, before: float = 1.0, after: float = 2.0) -> tuple[float, int]:
    """How differently the runs perform the action: :func:`run_spread` of their :func:`onset_windows`.

    Runs from one start with one goal part ways at different moments; aligned on the onset, the spread
    compares the actions themselves (the ways of sitting down), and it can be computed the same way for
    ground-truth clips of different lengths. A deterministic model's runs of one task coincide: 0.

    Returns:
        ``(spread, runs used)``; ``(nan, n)`` with fewer than two runs that act.
    """
    windows = onset_windows(runs, action, before, after)
    if len(windows) < 2:
        return math.nan, len(windows)
    return run_spread(windows), len(windows)


def onset_in_goal_frame(roots, actions, goal_position, goal_direction, action: str = "sit") -> dict:
    """Where a run (or a clip) began ``action``, seen from its goal: how far in front of the goal and
    to its side the root was, and how far it faced away from the goal's direction.

    Args:
        roots: ``(T, 3)`` ``(x, y, heading)`` world; actions: ``(T,)`` SAMP action ids of each frame
            (a rollout's ``actions[b]``, or ``MotionData.actions`` of one clip).
        goal_position, goal_direction: ``(3,)`` or ``(2,)`` world; the direction is the one the
            character faces when seated (away from the seat).
        action: one of ``SAMP_ACTIONS``.
    Returns:
        dict of floats: ``in_front`` (m, along the goal direction), ``aside`` (m, to the goal
        direction's left), ``facing_off`` (degrees between the root's forward and the goal direction);
        all ``nan`` when the run never began the action.
    """
    check_choice(action, SAMP_ACTIONS, "action")
    roots = torch.as_tensor(roots, dtype=torch.float64)
    check_shape(roots, (None, 3), "roots")
    labels = torch.as_tensor(actions)
    check_shape(labels, (roots.shape[0],), "actions")
    onset = torch.nonzero(labels == SAMP_ACTIONS.index(action))
    if not len(onset):
        return {"in_front": math.nan, "aside": math.nan, "facing_off": math.nan}
    x, y, heading = roots[int(onset[0, 0])].tolist()
    forward = np.array(goal_direction, dtype=np.float64).reshape(-1)[:2]
    forward /= np.linalg.norm(forward)
    left = np.array([-forward[1], forward[0]])  # the goal direction turned by +90° about z
    offset = np.array([x, y]) - np.asarray(goal_position, dtype=np.float64).reshape(-1)[:2]
    facing = np.array([-math.sin(heading), math.cos(heading)])  # the root's forward (runtime.Rollout.forward)
    return {"in_front": float(offset @ forward), "aside": float(offset @ left),
            "facing_off": math.degrees(math.acos(float(np.clip(facing @ forward, -1.0, 1.0))))}
