"""SAMP's whole pipeline in a cluttered room (Fig. 2, §3.3): a goal on the target, A*, MotionNet.

The algorithm box, as :func:`run_room_tasks` runs it:

1. **Goal**: a sitting goal on the room's target object (the object's own, or one GoalNet proposed,
   see ``goalnet.sample_goals``).
2. **Path planning** (§3.3): A* on the room's grid inflated by the body radius (``planning.plan_path``).
3. **Sub-tasks**: "each sub-task requires the character to walk to the next waypoint. The final
   sub-task requires the character to perform the desired action at the final waypoint." By default
   (``switch="demo"``) as SAMP's public demo runs it (``SAMP_Demo.cs``, ``SitLieDown``, with
   ``PathPlanningUtility.cs``): the path is planned to the sitting goal itself (:func:`demo_waypoints`: to the
   walkable point nearest it, corners within 0.5 m of it dropped); until the path's last corner is reached the
   character is *steered* along it with the walk action, by a walk goal that moves ahead on the path every frame
   and never asks it to stop (:class:`SteeredGoals`); from the last corner on, the goal is the sitting goal.
   Two earlier rules of the book stay for comparison (chapter 14), both planned to the standing spot in front of
   the seat (``Room.standing_point``): ``switch="waypoints"``, the waypoints as walk goals passed in turn within
   ``WAYPOINT_RADIUS`` (1 m, ours) and the sitting goal once the character is within ``action_radius`` of the
   spot; and ``switch="path"``, the waypoints simplified as a navigation mesh's corners would be
   (``planning.simplify_waypoints``) and the sitting goal as soon as the rest of the path to the spot is shorter
   than ``action_radius`` and the straight walk there is free (:class:`PathGoals`).
4. **MotionNet** steps the character (``runtime.rollout``) with the target's voxels; the NSM-like model
   of Table 5 senses every object of the room instead (:func:`room_voxel_cells`, ``samp.sensor``).

Without path planning (SAMP's §5.2 ablation, and NSM, which has none) the sitting goal is the only goal
from the start.

**Penetration** (§5.2, "the percentage of frames where a penetration happens"): a frame counts when the
body's surface (its capsules, ``samp.penetration``) reaches more than 2 cm into a wall or a piece of furniture
other than the target, over the whole run, the action included; the target, where the character sits, is
measured apart. The book's first measure, a *joint centre* more than 2 cm inside, up to the sit
(:func:`penetrating_frames`), is kept beside it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np
import torch

from .._validate import check_choice, check_shape
from ..world.primitives import union_sdf
from ..world.scenes import make_room, room_from_layout, room_layout
from .core import GoalNetCVAE, MotionModel
from .evaluation import MeasuredRuns, measure_goal_runs, voxel_cells
from .goalnet import sample_goals
from .penetration import TOLERANCE, body_depths, rollout_pose
from .planning import (check_room_point, nearest_walkable_point, plan_path, reaches, simplify_waypoints,
                       straight_walk_is_free)
from ..infra import load_or_build
from .runtime import GoalSequence, Rollout, content_digest, model_digest, object_digest, rollout, standing_state

__all__ = ["RoomTask", "ROOM_TARGETS", "cluttered_rooms", "room_tasks", "SWITCHES", "WAYPOINT_RADIUS", "DEMO_LOOKAHEAD", "demo_waypoints", "goals_along_path", "PathGoals", "SteeredGoals", "room_voxel_cells", "RoomRunResults",
           "penetrating_frames", "run_room_tasks"]

# How the sitting goal takes over from the walk (see the module docstring): SAMP's demo (the default), or the book's
# two earlier rules, kept for comparison.
SWITCHES = ("demo", "waypoints", "path")
# SAMP's demo (Assets/Demo/SAMP_Demo.cs, Assets/Scripts/Utility/PathPlanningUtility.cs), what we take from it:
# the goal on the seat moves onto the walkable area within 1 m (NavMesh.SamplePosition(goal, 1.0f));
DEMO_SAMPLE_RADIUS = 1.0
# corners within 0.5 m of the goal are dropped (PreProcessWayPoints);
DEMO_CORNER_PRUNE = 0.5
# a corner counts as reached within 0.5 m (GetNextTurn; GetNextMove checks 0.3 m first, the same frame);
DEMO_CORNER_REACHED = 0.5
# and the walk is steered by a goal trajectory that reaches about 2 m ahead of the root (ApplyDynamicGoal: 2 s of
# goal samples at unit speed). Our network takes one goal, not a goal trajectory: the walk goal is the point of the
# path this far ahead of the root's projection on it, with the path's direction there (ours).
DEMO_LOOKAHEAD = 2.0
# Ours (SAMP does not say how near a waypoint counts as reached): a walk goal is passed within 1 m. A walk clip ends
# standing on its last waypoint, so a walk goal ahead also reads "stop there"; with 0.5 m, runs that stopped a little
# short of a waypoint stood there until the time limit (chapter 14 compares the two).
WAYPOINT_RADIUS = 1.0
# The targets of :func:`cluttered_rooms`, in turn: SAMP's sittable categories of the toy world.
ROOM_TARGETS = ("chair", "armchair", "sofa", "stool")


@dataclass
class RoomTask:
    """One run in a room: where the character starts and which goal on the target it is given.

    Attributes:
        room: a ``world.scenes.Room``.
        goal_position, goal_direction: ``(3,)`` a sitting goal on ``room.target`` (world).
        start_root: ``(3,)`` ``(x, y, heading)``.
        room_index: the room's position in the list given to :func:`room_tasks`.
    """

    room: object
    goal_position: np.ndarray
    goal_direction: np.ndarray
    start_root: np.ndarray
    room_index: int = 0


def cluttered_rooms(n_rooms: int, seed: int = 0, targets: Sequence[str] = ROOM_TARGETS, n_clutter: int = 8) -> list:
    """``n_rooms`` cluttered rooms: room ``k`` is ``world.scenes.make_room(1000 * seed + k, n_clutter=n_clutter,
    target_category=targets[k % len(targets)])``. Made once, then from the cache: each room's layout (its size
    and every object's category, sizes and pose, and its footprint grid) rebuilt through
    ``world.scenes.room_from_layout``, the same rooms whether just made or loaded.

    Returns:
        a list of ``world.scenes.Room``.
    """
    if isinstance(n_rooms, bool) or not isinstance(n_rooms, int) or n_rooms < 1:
        raise ValueError(f"n_rooms: expected a positive int, got {n_rooms!r}")
    targets = tuple(targets)
    if not targets:
        raise ValueError("targets: expected at least one sittable category")

    def build():
        return [room_layout(make_room(1000 * int(seed) + k, n_clutter=int(n_clutter),
                                      target_category=targets[k % len(targets)])) for k in range(n_rooms)]

    key = {"n_rooms": n_rooms, "seed": int(seed), "targets": list(targets), "n_clutter": int(n_clutter)}
    return [room_from_layout(layout) for layout in load_or_build("samp_rooms", key, build)]


def room_tasks(rooms: Sequence, seed: int = 0, min_distance: float = 2.0, goalnet: Optional[GoalNetCVAE] = None,
               n_proposals: int = 32, facing_spread: float = math.radians(30.0),
               skip_missing: bool = False, cache: bool = True) -> list[RoomTask]:
    """One task per room: a sitting goal on the target that has a standing spot in front of it, and
    a start drawn among the room's free cells that reach it, at least ``min_distance`` metres from the
    goal, facing the goal within ``facing_spread`` radians (as the toy captures start, and as
    ``evaluation.goal_tasks``; SAMP does not state its start headings).

    Args:
        rooms: ``world.scenes.Room`` objects.
        seed: draws the starts (and GoalNet's latents).
        min_distance: metres between the start and the goal, at least.
        goalnet: a trained GoalNet (``goalnet.trained_goalnet(...).model``): the goal is the first of
            ``n_proposals`` GoalNet samples on the target with a standing spot (SAMP Fig. 2: GoalNet
            proposes, the planner walks there). ``None``: the target's own labelled sitting goals.
        n_proposals: GoalNet samples tried per room.
        facing_spread: the start heading's largest angle from the direction to the goal (radians).
        skip_missing: leave out a room with no goal whose standing spot a start reaches (the task's ``room_index``
            says which room each task is in) instead of raising.
        cache: draw the tasks once, then load their goals and starts from the cache (keyed by every room, bit
            for bit, GoalNet's weights and device, and the arguments).
    Raises:
        ValueError: a room whose target has no sitting goal with a standing spot (unless
            ``skip_missing``), or no start far enough from it.
    """
    args = {"seed": int(seed), "min_distance": float(min_distance), "n_proposals": int(n_proposals),
            "facing_spread": float(facing_spread), "skip_missing": bool(skip_missing)}
    rooms = list(rooms)
    if not cache:
        return _room_tasks(rooms, goalnet=goalnet, **args)

    def build():
        tasks = _room_tasks(rooms, goalnet=goalnet, **args)
        return {"room_index": np.array([t.room_index for t in tasks], dtype=np.int64),
                "goal_position": np.array([t.goal_position for t in tasks]).reshape(-1, 3),
                "goal_direction": np.array([t.goal_direction for t in tasks]).reshape(-1, 3),
                "start_root": np.array([t.start_root for t in tasks]).reshape(-1, 3)}

    # the device too: another device's kernels draw other proposals
    goalnet_key = None if goalnet is None else [model_digest(goalnet), str(next(goalnet.parameters()).device)]
    key = {"rooms": [_room_digest(room) for room in rooms], "goalnet": goalnet_key, **args}
    out = load_or_build("samp_room_tasks", key, build)
    return [RoomTask(rooms[k], position, direction, start, k) for k, position, direction, start
            in zip(out["room_index"].tolist(), out["goal_position"], out["goal_direction"], out["start_root"])]


def _room_tasks(rooms, seed, min_distance, goalnet, n_proposals, facing_spread, skip_missing) -> list[RoomTask]:
    tasks = []
    for k, room in enumerate(rooms):
        rng = np.random.default_rng([int(seed), 4411, k])
        if goalnet is None:
            positions, directions = room.target.sit_goals
            source = "sitting goal"
        else:
            generator = torch.Generator().manual_seed(int(rng.integers(2**31)))
            positions, directions = sample_goals(goalnet, room.target, n_proposals, generator=generator)
            source = f"GoalNet goal of {n_proposals}"
        starts = room.start_positions(64, seed=rng)
        start = None
        for position, direction in zip(positions, directions):
            try:
                spot = room.standing_point(position, direction)
            except ValueError:
                continue
            far = starts[np.linalg.norm(starts - np.asarray(position)[:2], axis=1) >= min_distance]
            ok = np.flatnonzero(reaches(room, far, spot))
            if len(ok):
                start = far[ok[0]]
                break
        if start is None:
            if skip_missing:
                continue
            raise ValueError(f"rooms[{k}]: the target {room.target.category} has no {source} with a standing spot "
                             f"reachable from a start {min_distance} m or more away (64 starts drawn)")
        to_goal = np.asarray(position)[:2] - start
        heading = math.atan2(-to_goal[0], to_goal[1]) + rng.uniform(-facing_spread, facing_spread)
        tasks.append(RoomTask(room, np.asarray(position, dtype=np.float64), np.asarray(direction, dtype=np.float64),
                              np.array([start[0], start[1], heading]), k))
    return tasks


def demo_waypoints(task: RoomTask, prune: float = DEMO_CORNER_PRUNE,
                   sample_radius: float = DEMO_SAMPLE_RADIUS) -> np.ndarray:
    """SAMP's demo path to the sitting goal itself (``PathPlanningUtility.ComputePath``): ``(M, 2)`` xy metres,
    the start first, the path's corners, the goal position on the seat last.

    The goal lies on the seat, inside the inflated footprint: the path is planned to the walkable point nearest it
    (within ``sample_radius``, :func:`~hoi_tutorial.samp.planning.nearest_walkable_point`), then the goal replaces
    that end point; corners within ``prune`` metres of the goal are dropped (``PreProcessWayPoints``).
    """
    start = check_room_point(task.room, np.asarray(task.start_root, dtype=np.float64)[:2], "start")
    goal = np.asarray(task.goal_position, dtype=np.float64)[:2]
    end = nearest_walkable_point(task.room, goal, start, max_distance=sample_radius)
    corners = plan_path(task.room, start, end).waypoints[1:-1]
    corners = [c for c in corners if np.linalg.norm(c - goal) > float(prune)]
    return np.stack([start, *corners, goal])


def goals_along_path(task: RoomTask, action: str = "sit", planning: bool = True,
                     waypoint_radius: float = WAYPOINT_RADIUS,
                     action_radius: float = 1.5, switch: str = "demo",
                     lookahead: float = DEMO_LOOKAHEAD) -> tuple[list, Optional[np.ndarray]]:
    """The goal list of one run (``runtime.GoalSequence.from_lists`` rows) and its waypoints.

    With ``switch="demo"`` (SAMP's demo, the default): two goals, the walk goal that :class:`SteeredGoals`
    moves along the path (here where it starts, ``lookahead`` metres along it) and the sitting goal; the
    waypoints are :func:`demo_waypoints`. A path with no corner is all last leg: both goals are the sitting goal.

    With ``switch="path"`` the waypoints are simplified (``planning.simplify_waypoints``, no leg shorter
    than ``waypoint_radius`` where the walk allows it) and every walk goal, the standing spot included, is
    passed within ``waypoint_radius``: :class:`PathGoals` hands over to the sitting goal earlier, by the
    rest of the path. With ``switch="waypoints"`` the string-pulled waypoints are kept and the last walk
    goal is passed within ``action_radius``.

    Returns:
        ``(goals, waypoints)``: goals as ``(position, direction, action, radius)``; waypoints ``(M, 2)``
        of the path, start first and standing spot last (None without planning).
    """
    check_choice(action, ("sit",), "action")
    check_choice(switch, SWITCHES, "switch")
    check_room_point(task.room, np.asarray(task.start_root, dtype=np.float64)[:2], "start")
    final = (task.goal_position, task.goal_direction, action, 0.0)
    if not planning:
        return [final], None
    if switch == "demo":
        points = demo_waypoints(task)
        if len(points) == 2:
            return [final, final], points
        position, direction = _along(points, float(lookahead))
        return [(np.r_[position, 0.0], np.r_[direction, 0.0], "walk", 0.0), final], points
    spot = task.room.standing_point(task.goal_position, task.goal_direction)
    points = plan_path(task.room, task.start_root[:2], spot).waypoints
    if switch == "path":
        points = simplify_waypoints(task.room, points, min_leg=waypoint_radius)
    goals = []
    for k in range(1, len(points)):
        leg = points[k] - points[k - 1]
        norm = float(np.linalg.norm(leg))
        direction = np.r_[leg / norm, 0.0] if norm > 1e-9 else np.r_[task.goal_direction[:2], 0.0]
        last = k == len(points) - 1 and switch == "waypoints"
        goals.append((np.r_[points[k], 0.0], direction, "walk", action_radius if last else waypoint_radius))
    goals.append(final)
    return goals, points


@dataclass
class PathGoals(GoalSequence):
    """Walk goals along planned paths, then the action (SAMP §3.3's sub-tasks), where the action takes over
    as soon as the rest of the path is short and free: from the root, the distance to a pending walk goal
    plus the path length from it to the standing spot (the least over the pending goals) is below
    ``action_radius``, and the straight walk from the root to the standing spot is free
    (``planning.straight_walk_is_free``). Pending waypoints are then skipped. Otherwise walk goals pass within their radii, as
    in :class:`~hoi_tutorial.samp.runtime.GoalSequence`.

    Attributes (beyond ``GoalSequence``'s):
        remaining: ``(B, G)`` metres, the path length from goal ``k`` to the standing spot (0 for the action).
        action_radius: metres.
        rooms: one room per character, for the line of sight.
    """

    remaining: Optional[torch.Tensor] = None
    action_radius: float = 1.5
    rooms: list = field(default_factory=list, repr=False)

    def __post_init__(self):
        super().__post_init__()
        check_shape(self.remaining, tuple(self.positions.shape[:2]), "remaining")
        if len(self.rooms) != self.positions.shape[0]:
            raise ValueError(f"rooms: expected one room per character ({self.positions.shape[0]}), got {len(self.rooms)}")
        self._blocked = [np.asarray(room.inflated_occupancy(room.body_radius), dtype=bool) for room in self.rooms]

    @classmethod
    def from_paths(cls, goals: list, waypoints: list, rooms: list, action_radius: float = 1.5) -> "PathGoals":
        """From :func:`goals_along_path`'s goals and waypoints, one list entry per character."""
        base = GoalSequence.from_lists(goals)
        remaining = torch.zeros(base.radii.shape)
        for b, points in enumerate(waypoints):
            legs = np.linalg.norm(np.diff(np.asarray(points, dtype=np.float64), axis=0), axis=1)
            to_spot = np.r_[np.cumsum(legs[::-1])[::-1], 0.0]  # from waypoint k to the spot
            remaining[b, :len(legs)] = torch.as_tensor(to_spot[1:])  # walk goal k is waypoint k + 1
        return cls(base.positions, base.directions, base.actions, base.radii, base.counts, remaining,
                   float(action_radius), list(rooms))

    def advance(self, index: torch.Tensor, roots: torch.Tensor) -> torch.Tensor:
        index = super().advance(index, roots)
        action = self.counts - 1
        # The rest of the path through the nearest pending walk goal: a waypoint walked past outside its
        # radius does not hold the action back.
        goal = torch.arange(self.positions.shape[1])
        pending = (goal[None] >= index[:, None]) & (goal[None] < action[:, None])
        through = (roots[:, None, :2] - self.positions[:, :, :2]).norm(dim=-1) + self.remaining
        rest = torch.where(pending, through, torch.full_like(through, math.inf)).min(dim=1).values
        index = index.clone()
        for b in torch.nonzero((index < action) & (rest < self.action_radius)).flatten().tolist():
            spot = self.positions[b, action[b] - 1, :2].double().numpy()
            if straight_walk_is_free(self.rooms[b], roots[b, :2].double().numpy(), spot, blocked=self._blocked[b]):
                index[b] = action[b]
        return index


def _along(points: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray]:
    """The point ``s`` metres along the polyline ``points (M, 2)`` (clamped to its ends) and the unit direction of
    its leg there."""
    legs = np.diff(points, axis=0)
    lengths = np.linalg.norm(legs, axis=1)
    ends = np.cumsum(lengths)
    s = min(max(float(s), 0.0), float(ends[-1]))
    k = min(int(np.searchsorted(ends, s)), len(legs) - 1)
    before = ends[k] - lengths[k]
    unit = legs[k] / max(lengths[k], 1e-9)
    return points[k] + unit * (s - before), unit


@dataclass
class SteeredGoals(GoalSequence):
    """SAMP's demo at run time (``SitLieDown`` with path planning): the character is steered along its path with
    the walk action until it reaches the path's last corner, then given the sitting goal (``ApplyStaticGoal``).

    Goal 0 of each character is the walk goal: every frame it moves to the point of the path ``lookahead`` metres
    ahead of the root's projection on the path (a moving goal, never a stop), facing along the path. Goal 1 is the
    sitting goal. The hand-over comes when the projection is within ``reach`` metres of the last corner (or past
    it); a path with no corner hands over at once. The projection only moves forward, and never past the walk goal
    by more than half a metre (a later leg that passes near the root is not jumped to). One rollout per instance:
    the progress is its state.

    Attributes (beyond ``GoalSequence``'s):
        waypoints: one ``(M, 2)`` array per character (:func:`demo_waypoints`).
        lookahead, reach: metres.
    """

    waypoints: list = field(default_factory=list, repr=False)
    lookahead: float = DEMO_LOOKAHEAD
    reach: float = DEMO_CORNER_REACHED

    def __post_init__(self):
        super().__post_init__()
        B = self.positions.shape[0]
        if len(self.waypoints) != B:
            raise ValueError(f"waypoints: expected one path per character ({B}), got {len(self.waypoints)}")
        if self.positions.shape[1] != 2:
            raise ValueError(f"positions: expected two goals per character (walk, action), got {self.positions.shape[1]}")
        for name in ("lookahead", "reach"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name}: expected a positive number of metres, got {value!r}")
        self.waypoints = [np.asarray(w, dtype=np.float64).reshape(-1, 2) for w in self.waypoints]
        self._ends = [np.cumsum(np.linalg.norm(np.diff(w, axis=0), axis=1)) for w in self.waypoints]
        self._progress = np.zeros(B)  # metres along each path, of the root's projection

    @classmethod
    def from_paths(cls, goals: list, waypoints: list, lookahead: float = DEMO_LOOKAHEAD,
                   reach: float = DEMO_CORNER_REACHED) -> "SteeredGoals":
        """From :func:`goals_along_path`'s goals (``switch="demo"``) and waypoints, one entry per character."""
        base = GoalSequence.from_lists(goals)
        return cls(base.positions, base.directions, base.actions, base.radii, base.counts, list(waypoints),
                   float(lookahead), float(reach))

    def _project(self, b: int, xy: np.ndarray) -> float:
        """Metres along path ``b`` of the point nearest ``xy``, no less than the last and at most the look-ahead
        plus half a metre more."""
        points, ends = self.waypoints[b], self._ends[b]
        best, best_s = math.inf, self._progress[b]
        for k in range(len(points) - 1):
            leg = points[k + 1] - points[k]
            length2 = max(float(leg @ leg), 1e-12)
            u = min(max(float((xy - points[k]) @ leg) / length2, 0.0), 1.0)
            s = ends[k] - math.sqrt(length2) * (1.0 - u)
            if self._progress[b] <= s <= self._progress[b] + self.lookahead + 0.5:
                gap = float(np.linalg.norm(points[k] + u * leg - xy))
                if gap < best:
                    best, best_s = gap, s
        return best_s

    def advance(self, index: torch.Tensor, roots: torch.Tensor) -> torch.Tensor:
        index = index.clone()
        for b in torch.nonzero(index == 0).flatten().tolist():
            points, ends = self.waypoints[b], self._ends[b]
            if len(points) <= 2:  # no corner: the sitting goal from the start
                index[b] = 1
                continue
            self._progress[b] = self._project(b, roots[b, :2].double().numpy())
            if self._progress[b] >= ends[-2] - self.reach:  # the last corner reached: the action's goal
                index[b] = 1
                continue
            position, direction = _along(points, self._progress[b] + self.lookahead)
            self.positions[b, 0, :2] = torch.as_tensor(position, dtype=self.positions.dtype)
            self.directions[b, 0, :2] = torch.as_tensor(direction, dtype=self.directions.dtype)
            self._xy[b, 0] = complex(*position)
            self._forward[b, 0] = complex(*direction)
        return index


def penetrating_frames(room, joints: np.ndarray, tolerance: float = 0.02) -> np.ndarray:
    """``(T,)`` bool: frames where a joint of ``joints (T, 22, 3)`` is more than ``tolerance`` metres
    inside a wall or an object other than the room's target."""
    points = np.asarray(joints, dtype=np.float64)
    inside = (union_sdf(points, room._walls) < -tolerance).reshape(-1)
    flat = points.reshape(-1, 3)
    for i, obj in enumerate(room.objects):
        if i == room.target_index:
            continue
        # a joint outside an object's bounding box is outside the object: only those within it are measured
        lo, hi = obj.bounds
        near = np.flatnonzero(np.all((flat >= lo) & (flat <= hi), axis=1))
        if len(near):
            inside[near] |= obj.sdf(flat[near]) < -tolerance
    return inside.reshape(points.shape[:-1]).any(axis=-1)


def room_voxel_cells(tasks: Sequence[RoomTask], every_object: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
    """The voxel cells a model is given in each task's room: the target's (MotionNet's interaction voxels),
    or with ``every_object`` those of every object in the room (what the NSM-like sensor senses).

    Returns:
        ``(centres (B, 512 M, 3), occupancy (B, 512 M))``, ``M`` the most objects of a room (1 for the target
        alone); a room with fewer objects repeats its first object's cells with zero occupancy.
    """
    per_task = []
    for t in tasks:
        objects = list(t.room.objects) if every_object else [t.room.target]
        per_task.append([voxel_cells(obj) for obj in objects])
    most = max(len(cells) for cells in per_task)
    centres, occupancy = [], []
    for cells in per_task:
        padding = [(cells[0][0], np.zeros_like(cells[0][1]))] * (most - len(cells))
        centres.append(np.concatenate([c for c, _ in cells + padding]))
        occupancy.append(np.concatenate([o for _, o in cells + padding]))
    return torch.as_tensor(np.stack(centres)), torch.as_tensor(np.stack(occupancy))


@dataclass
class RoomRunResults(MeasuredRuns):
    """What :func:`run_room_tasks` measured, one entry per task.

    Attributes:
        execution_time: seconds until the character's own label turned to "sit" (``inf`` if never).
        position_error, rotation_error: PE (cm) and RE (degrees) 1.5 s later (``inf`` if never).
        reached: sat within the limit with PE below ``reach_radius``.
        penetration: ``(n_tasks,)`` share of each run's frames (the whole run) in which the body reaches more
            than 2 cm into a wall or a non-target object (``samp.penetration``).
        target_penetration: ``(n_tasks,)`` the same share for the target alone.
        walking_penetration: ``(n_tasks,)`` the body's share (walls and non-target objects) over the frames up to
            the sit (the whole run when it never sat): the penetration while the character walks.
        joint_penetration: ``(n_tasks,)`` the book's first measure: the share of frames up to the sit (the
            whole run when it never sat) with a joint centre more than 2 cm inside (:func:`penetrating_frames`).
        rollout: the motion; waypoints: each run's A* waypoints (None without planning).
        action_goal: per run, the index of the action's goal among its goals (0 without planning).
    """

    execution_time: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    reached: np.ndarray
    penetration: np.ndarray
    target_penetration: np.ndarray
    walking_penetration: np.ndarray
    joint_penetration: np.ndarray
    rollout: Rollout = field(repr=False)
    waypoints: list = field(repr=False, default_factory=list)
    reach_radius: float = 0.3
    action_goal: list = field(repr=False, default_factory=list)

    def handover_frames(self) -> list:
        """Per run, the first frame under the action's goal (the seat), after the walk goals: 0 without
        planning, None where the character never passed its walk goals."""
        frames = []
        for b, action_goal in enumerate(self.action_goal):
            under = torch.nonzero(self.rollout.goal_index[b] == action_goal)
            frames.append(int(under[0, 0]) if len(under) else None)
        return frames

    @property
    def penetration_percent(self) -> float:
        """Frames with a penetration of the body over all runs' frames, percent. Every run has the same frames (the
        whole run), so the pooled share is also the mean of the runs' shares."""
        return float(100.0 * np.mean(self.penetration))


def run_room_tasks(model: MotionModel, tasks: Sequence[RoomTask], seconds: float = 30.0, seed: int = 0,
                   planning: bool = True, latent_scale: float = 1.0, settle: float = 1.5,
                   reach_radius: float = 0.3, switch: str = "demo", action_radius: float = 1.5,
                   waypoint_radius: float = WAYPOINT_RADIUS, lookahead: float = DEMO_LOOKAHEAD) -> RoomRunResults:
    """Run the tasks as one batch, with or without path planning, and measure them (module docstring);
    once (then from the cache: the plans, the motion and the measures, keyed by the model, every room's
    objects and the tasks, bit for bit, and the arguments).

    ``switch`` (with planning): ``"demo"`` (SAMP's demo: steered along the path to the goal itself, the
    sitting goal from its last corner on, :class:`SteeredGoals` with ``lookahead``), ``"path"``, the sitting
    goal takes over by the rest of the path (:class:`PathGoals`), or ``"waypoints"``, after every waypoint
    (:func:`goals_along_path`), within ``action_radius`` metres; walk waypoints before it are passed within
    ``waypoint_radius`` metres.
    """
    if not tasks:
        raise ValueError("tasks: expected at least one RoomTask")
    check_choice(switch, SWITCHES, "switch")
    args = {"seconds": float(seconds), "seed": int(seed), "planning": bool(planning), "latent_scale": float(latent_scale),
            "settle": float(settle), "reach_radius": float(reach_radius), "switch": switch,
            "action_radius": float(action_radius), "waypoint_radius": float(waypoint_radius),
            "lookahead": float(lookahead)}
    key = {"model": model_digest(model), "device": str(model.x_mean.device), "tasks": [_task_digest(t) for t in tasks],
           **args}

    def build():
        r = _run_room_tasks(model, tasks, **args)
        return {"execution_time": r.execution_time, "position_error": r.position_error,
                "rotation_error": r.rotation_error, "reached": r.reached, "penetration": r.penetration,
                "target_penetration": r.target_penetration, "walking_penetration": r.walking_penetration,
                "joint_penetration": r.joint_penetration,
                "states": r.rollout.states, "roots": r.rollout.roots, "goal_index": r.rollout.goal_index,
                "actions": r.rollout.actions, "waypoints": r.waypoints, "action_goal": r.action_goal}

    out = load_or_build("samp_room_runs", key, build)
    return RoomRunResults(out["execution_time"], out["position_error"], out["rotation_error"], out["reached"],
                          out["penetration"], out["target_penetration"], out["walking_penetration"],
                          out["joint_penetration"],
                          Rollout(out["states"], out["roots"], out["goal_index"], out["actions"]),
                          list(out["waypoints"]), float(reach_radius), list(out["action_goal"]))


def _room_digest(room) -> str:
    """What a room is, bit for bit: its size, grid and objects."""
    return content_digest(np.asarray(room.size, dtype=np.float64), int(room.target_index), float(room.cell_size),
                          float(room.body_radius), *[object_digest(obj) for obj in room.objects])


def _task_digest(task: RoomTask) -> str:
    """What a room task is, bit for bit: its room and its start and goal."""
    return content_digest(_room_digest(task.room), np.asarray(task.goal_position, dtype=np.float64),
                          np.asarray(task.goal_direction, dtype=np.float64),
                          np.asarray(task.start_root, dtype=np.float64))


def _run_room_tasks(model, tasks, seconds, seed, planning, latent_scale, settle, reach_radius, switch, action_radius,
                    waypoint_radius, lookahead) -> RoomRunResults:
    fps = 30.0
    n_frames = int(round(seconds * fps))
    plans = [goals_along_path(t, planning=planning, switch=switch, action_radius=action_radius,
                              waypoint_radius=waypoint_radius, lookahead=lookahead) for t in tasks]
    action_goal = [len(g) - 1 for g, _ in plans]
    if planning and switch == "demo":
        goals = SteeredGoals.from_paths([g for g, _ in plans], [w for _, w in plans], lookahead)
    elif planning and switch == "path":
        goals = PathGoals.from_paths([g for g, _ in plans], [w for _, w in plans], [t.room for t in tasks],
                                     action_radius)
    else:
        goals = GoalSequence.from_lists([g for g, _ in plans])
    centres, occupancy = room_voxel_cells(tasks, every_object=model.environment_sensor)
    roots = torch.as_tensor(np.stack([t.start_root for t in tasks]), dtype=torch.float32)
    # run_room_tasks caches the room run whole, its motion with it
    out = rollout(model, standing_state(), roots, goals, n_frames, torch.Generator().manual_seed(int(seed)),
                  centres, occupancy, latent_scale=latent_scale, cache=False)
    times, pe, re, reached = measure_goal_runs(out, ["sit"] * len(tasks), [t.goal_position for t in tasks],
                                               [t.goal_direction for t in tasks], settle, reach_radius, fps)
    rotations, positions = rollout_pose(out.states, out.roots)
    joints = positions.numpy()
    body, target, walking, joint = [], [], [], []
    for b, task in enumerate(tasks):
        depths = body_depths(task.room, rotations[b], positions[b])  # the body, every frame of the run
        inside = depths["clutter"] > TOLERANCE
        end = max(int(round(times[b] * fps)) if math.isfinite(times[b]) else n_frames, 1)  # up to the sit
        body.append(inside.mean())
        target.append(np.mean(depths["target"] > TOLERANCE))
        walking.append(inside[:end].mean())
        # the book's first measure: joint centres, up to the sit (or the whole run when it never sat)
        joint.append(penetrating_frames(task.room, joints[b, :end], tolerance=TOLERANCE).mean())
    return RoomRunResults(times, pe, re, reached, np.asarray(body), np.asarray(target), np.asarray(walking),
                          np.asarray(joint), out, [w for _, w in plans], reach_radius, action_goal)
