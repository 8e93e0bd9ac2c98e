"""SAMP's whole pipeline in a cluttered room (Fig. 2, §3.3): a goal on the target, A*, MotionNet.

The algorithm box, as :func:`run_room_tasks` runs it:

1. **Goal**: a sitting goal on the room's target object (the object's own, or one GoalNet proposed,
   see ``goalnet.sample_goals``).
2. **Path planning** (§3.3): A* from the character's start to the spot in front of the goal
   (``Room.standing_point``), on the room's grid inflated by the body radius; the waypoints are
   where the path turns (``planning.plan_path``).
3. **Sub-tasks**: "each sub-task requires the character to walk to the next waypoint. The final
   sub-task requires the character to perform the desired action at the final waypoint." The
   waypoints become walk goals passed within ``waypoint_radius``; once the character is within
   ``action_radius`` of the standing spot, the goal becomes the sitting goal (the training clips walk
   up to a seat with its goal from 2-4.5 m).
4. **MotionNet** steps the character (``runtime.rollout``) with the target's voxels.

Without path planning (SAMP's §5.2 ablation) the sitting goal is the only goal from the start.

**Penetration** (§5.2, "the percentage of frames where a penetration happens"): a frame counts when
a joint of the body is inside a piece of furniture other than the target or a wall (signed distance
below ``-tolerance``); the target is where the character sits, so contact with it is the task.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional, Sequence

import numpy as np
import torch

from .._validate import check_choice
from ..world.primitives import union_sdf
from .core import MotionModel
from .evaluation import measure_goal_runs
from .motion_data import object_voxel_cells
from .planning import plan_path
from .runtime import GoalSequence, Rollout, rollout, standing_state

__all__ = ["RoomTask", "room_tasks", "goals_along_path", "RoomRunResults", "penetrating_frames", "run_room_tasks"]


@dataclass
class RoomTask:
    """One run in a room: where the character starts and which goal on the target it is given.

    Attributes:
        room: a ``world.scenes.Room``.
        goal_position, goal_direction: ``(3,)`` a sitting goal on ``room.target`` (world).
        start_root: ``(3,)`` ``(x, y, heading)``.
    """

    room: object
    goal_position: np.ndarray
    goal_direction: np.ndarray
    start_root: np.ndarray


def room_tasks(rooms: Sequence, seed: int = 0, min_distance: float = 2.0) -> list[RoomTask]:
    """One task per room: the target's first sitting goal that has a standing spot in front of it,
    and a start drawn among the room's free cells that reach it, at least ``min_distance`` metres
    from the goal, facing anywhere.

    Raises:
        ValueError: a room whose target has no sitting goal with a standing spot, or no start far
            enough from it.
    """
    tasks = []
    for k, room in enumerate(rooms):
        rng = np.random.default_rng([int(seed), 4411, k])
        positions, directions = room.target.sit_goals
        for position, direction in zip(positions, directions):
            try:
                room.standing_point(position, direction)
            except ValueError:
                continue
            break
        else:
            raise ValueError(f"rooms[{k}]: the target {room.target.category} has no sitting goal with a standing spot")
        starts = room.start_positions(64, seed=rng)
        far = starts[np.linalg.norm(starts - np.asarray(position)[:2], axis=1) >= min_distance]
        if len(far) == 0:
            raise ValueError(f"rooms[{k}]: no start {min_distance} m or more from the goal among 64 drawn")
        start = far[0]
        tasks.append(RoomTask(room, np.asarray(position, dtype=np.float64), np.asarray(direction, dtype=np.float64),
                              np.array([start[0], start[1], rng.uniform(-math.pi, math.pi)])))
    return tasks


def goals_along_path(task: RoomTask, action: str = "sit", planning: bool = True, waypoint_radius: float = 0.5,
                     action_radius: float = 1.5) -> tuple[list, Optional[np.ndarray]]:
    """The goal list of one run (``runtime.GoalSequence.from_lists`` rows) and its waypoints.

    Returns:
        ``(goals, waypoints)``: goals as ``(position, direction, action, radius)``; waypoints ``(M, 2)``
        of the A* path (None without planning).
    """
    check_choice(action, ("sit",), "action")
    final = (task.goal_position, task.goal_direction, action, 0.0)
    if not planning:
        return [final], None
    spot = task.room.standing_point(task.goal_position, task.goal_direction)
    path = plan_path(task.room, task.start_root[:2], spot)
    goals = []
    points = path.waypoints
    for k in range(1, len(points)):
        leg = points[k] - points[k - 1]
        norm = float(np.linalg.norm(leg))
        direction = np.r_[leg / norm, 0.0] if norm > 1e-9 else np.r_[task.goal_direction[:2], 0.0]
        last = k == len(points) - 1
        goals.append((np.r_[points[k], 0.0], direction, "walk", action_radius if last else waypoint_radius))
    goals.append(final)
    return goals, points


def penetrating_frames(room, joints: np.ndarray, tolerance: float = 0.02) -> np.ndarray:
    """``(T,)`` bool: frames where a joint of ``joints (T, 22, 3)`` is more than ``tolerance`` metres
    inside a wall or an object other than the room's target."""
    points = np.asarray(joints, dtype=np.float64)
    others = [obj.sdf(points) for i, obj in enumerate(room.objects) if i != room.target_index]
    walls = union_sdf(points, room._walls)
    distance = np.min(np.stack(others + [walls], axis=-1), axis=-1) if others else walls
    return (distance < -tolerance).any(axis=-1)


@dataclass
class RoomRunResults:
    """What :func:`run_room_tasks` measured, one entry per task.

    Attributes:
        execution_time: seconds until the character's own label turned to "sit" (``inf`` if never).
        position_error, rotation_error: PE (cm) and RE (degrees) 1.5 s later (``inf`` if never).
        reached: sat within the limit with PE below ``reach_radius``.
        penetration: ``(n_tasks,)`` share of each run's frames with a penetration (until it sat,
            or the whole run).
        rollout: the motion; waypoints: each run's A* waypoints (None without planning).
    """

    execution_time: np.ndarray
    position_error: np.ndarray
    rotation_error: np.ndarray
    reached: np.ndarray
    penetration: np.ndarray
    rollout: Rollout = field(repr=False)
    waypoints: list = field(repr=False, default_factory=list)
    reach_radius: float = 0.3

    @property
    def penetration_percent(self) -> float:
        """Frames with a penetration over all runs' frames, percent."""
        return float(100.0 * np.mean(self.penetration))


def run_room_tasks(model: MotionModel, tasks: Sequence[RoomTask], seconds: float = 30.0, seed: int = 0,
                   planning: bool = True, latent_scale: float = 1.0, settle: float = 1.5,
                   reach_radius: float = 0.3) -> RoomRunResults:
    """Run the tasks as one batch, with or without path planning, and measure them (module docstring)."""
    if not tasks:
        raise ValueError("tasks: expected at least one RoomTask")
    fps = 30.0
    n_frames = int(round(seconds * fps))
    plans = [goals_along_path(t, planning=planning) for t in tasks]
    goals = GoalSequence.from_lists([g for g, _ in plans])
    cells = [object_voxel_cells(t.room.target) for t in tasks]
    centres = torch.as_tensor(np.stack([c for c, _ in cells]))
    occupancy = torch.as_tensor(np.stack([o for _, o in cells]))
    roots = torch.as_tensor(np.stack([t.start_root for t in tasks]), dtype=torch.float32)
    out = rollout(model, standing_state(), roots, goals, n_frames, torch.Generator().manual_seed(int(seed)),
                  centres, occupancy, latent_scale=latent_scale)
    times, pe, re, reached = measure_goal_runs(out, ["sit"] * len(tasks), [t.goal_position for t in tasks],
                                               [t.goal_direction for t in tasks], settle, reach_radius, fps)
    joints = out.joints().double().numpy()
    pen = []
    for b, task in enumerate(tasks):
        # penetration while navigating: up to the sit (or the whole run when it never sat)
        end = int(round(times[b] * fps)) if math.isfinite(times[b]) else n_frames
        pen.append(penetrating_frames(task.room, joints[b, :max(end, 1)]).mean())
    return RoomRunResults(times, pe, re, reached, np.asarray(pen), out, [w for _, w in plans], reach_radius)
