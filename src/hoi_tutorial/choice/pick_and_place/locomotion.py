"""Navigation matching (CHOICE §6.2): the 2D path of ``navigation`` followed by stitching toy-mocap
locomotion clips matched on the navigation features ``N`` with a KD-tree.

The algorithm box's second half, as the paper has it and this module runs it:

1. **The database.** For every motion between two keyframes of the locomotion data,
   ``N = {d_g^root, p_g^root, r^left, p^left, r^right, p^right, r^hip, p^hip, v^root}`` (2 + 2 + 6 + 3 +
   6 + 3 + 6 + 3 + 2 = 33 numbers): the root's 2D direction and position at the motion's end, the key
   joints' 6D orientations and positions and the root's 2D velocity, all relative to the root frame at
   the motion's beginning; a ``scipy.spatial.cKDTree`` over them (:class:`MotionDatabase`, :func:`match`).
2. **Following.** With the character's current pose and the next sub-goal as the query, "a motion that
   has least deviation and has no collision with the surrounding obstacles is selected": the nearest
   motions are tried in order and the first that does not collide is stitched on, its first root frame
   placed on the character's (:func:`select_window`). Repeat from where it ended until the root is within
   ``goal_tolerance`` of the goal (:func:`follow_path`).

Choices the paper does not state, ours (the path's are in ``navigation``):

- **The clips and their keyframes.** The toy walks (:func:`locomotion_clips`) start standing facing
  anywhere and stop facing anywhere, so the motions start, turn and stop as well as walk. They have no
  keyframes: ours are every ``keyframe_step`` frames, and a motion runs from a keyframe to any later one,
  up to the first beyond ``segment_length`` of walking (a 3 m sub-goal is within reach of its ends).
- **Feature frames.** ``d_g, p_g`` at the motion's last frame; the key joints (left wrist, right wrist,
  pelvis: §6.3's left hand, right hand and hip) and ``v^root`` at its first frame, which is what a query's
  current pose ``p'`` supplies. Rotations are 6D (``rotations.matrix_to_rotation_6d``), the root frame
  ``features.root_frame`` (pelvis on the ground, facing from the hips), ``v^root`` a backward difference
  (a forward one at a clip's first frame; zero for the standing start).
- **The distance** is Euclidean, each group of ``N`` divided by its mean standard deviation over the
  database and multiplied by ``√weight``, as motion matching does; the weights are 1 for ``d_g``,
  ``p_g`` and ``v^root`` and 0.1 for the six key-joint groups. Measured with :func:`follow_path` in the
  toy rooms ``make_room(0)`` to ``make_room(29)`` (from ``room.start_positions(1, seed)`` to the chair's
  ``approach_point(0)``, ``d_g`` its sit direction): with all weights 1 the key joints, six groups of
  nine, outvote where the motion goes and 7 walks of 30 end within 0.3 m of the goal (median 0.65 m);
  with 0.1, 20 of 30 (24 within 0.5 m, median 0.18 m; none collides). The rest stop short ("no match"),
  mostly walking past a goal the toy walks cannot step back to.
- **Selection.** The ``candidates`` (16) nearest motions are tried in order; each is cut at its frame
  nearest the sub-goal, and skipped when it collides (its root on the grid's obstacle cells; with a caller's
  ``clear``, its elbows, wrists, knees, ankles or feet in the scene) or when it ends neither within ``goal_tolerance`` of
  the goal nor lower on ``T`` than it starts (it would not bring the character nearer). No blending at
  the seams: the root is continuous on the ground by construction, the pose is the database's.
- ``goal_tolerance`` 0.3 m (window ends lie 0.3–0.5 m apart at walking speed), at most ``max_segments``
  (16) motions, and a start heading along the path unless given.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np
import torch
from scipy.spatial import cKDTree

from ..._validate import check_finite, check_shape
from ...infra import load_or_build, single_threaded
from ...world import mocap
from ...world.features import feature_layout, root_frame
from ...world.motion import FPS, Motion
from ...world.mocap import standing_pose
from ...world.rotations import matrix_to_rotation_6d, rotation_about_z
from ...world.skeleton import joint_index
from .environment import KEYFRAME_JOINTS
from .navigation import (FEATURE_PARTS, NavigationConfig, NavigationGrid, NavigationPlan, direction_at, path_from, plan_path,
                         split_path, unit_direction)

__all__ = [
    "LIMB_JOINTS",
    "FEATURE_LAYOUT",
    "FEATURE_SIZE",
    "frame_features",
    "query_features",
    "MotionDatabase",
    "locomotion_clips",
    "build_database",
    "motion_database",
    "match",
    "window_collides",
    "placed_limb_points",
    "select_window",
    "MatchedSegment",
    "Navigation",
    "follow_path",
]

# The navigation features N of §6.2, in the paper's order.
# the joints that swing beyond the root's clearance, checked against the scene with a caller's ``clear``
LIMB_JOINTS = ("left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_knee", "right_knee", "left_ankle",
               "right_ankle", "left_foot", "right_foot")
FEATURE_LAYOUT, FEATURE_SIZE = feature_layout(FEATURE_PARTS)
_POSE_SIZE = FEATURE_SIZE - 4  # the part of N a pose carries (after d_g, p_g)


# ----------------------------------------------------------------------------- the navigation features N


def _to_root(vectors, heading) -> np.ndarray:
    """2D world vectors (..., 2) → the root frame of ``heading`` (...) radians (forward is +y)."""
    c, s = np.cos(heading), np.sin(heading)
    x, y = vectors[..., 0], vectors[..., 1]
    return np.stack([c * x + s * y, -s * x + c * y], axis=-1)


def _forward(heading) -> np.ndarray:
    """(..., 2) the unit ground direction a body of ``heading`` faces (0 faces +y)."""
    heading = np.asarray(heading, dtype=np.float64)
    return np.stack([-np.sin(heading), np.cos(heading)], axis=-1)


def frame_features(local_rotations, root_position, betas=None, fps: float = FPS):
    """Every frame's root frame and the pose part of ``N`` (its key joints and root velocity).

    Args:
        local_rotations: (T, 22, 3, 3) local joint rotations.
        root_position: (T, 3) pelvis positions, metres.
        betas: (10,) body shape or None (the mean body).
        fps: frames per second.
    Returns:
        ``(origin (T, 2) metres, heading (T,) radians, pose (T, 29))``; ``pose`` is ``[r^left, p^left,
        r^right, p^right, r^hip, p^hip, v^root]`` in the frame's own root frame (rotations 6D, positions
        metres, velocity m/s by a backward difference, forward at frame 0, zero for one frame).
    """
    motion = Motion(torch.as_tensor(local_rotations, dtype=torch.float64), torch.as_tensor(root_position, dtype=torch.float64),
                    torch.zeros(10, dtype=torch.float64) if betas is None else torch.as_tensor(betas, dtype=torch.float64),
                    fps=fps)
    joints, rotations = motion.joints, motion.global_rotations
    origin3, heading = root_frame(joints)
    inverse = rotation_about_z(-heading)  # (T, 3, 3): world → root frame
    parts = []
    for name in KEYFRAME_JOINTS:
        j = joint_index(name)
        parts.append(matrix_to_rotation_6d(inverse @ rotations[:, j]))
        parts.append((inverse @ (joints[:, j] - origin3)[..., None])[..., 0])
    origin, heading = origin3[:, :2].numpy(), heading.numpy()
    velocity = np.zeros_like(origin)
    if len(origin) > 1:
        velocity[1:] = np.diff(origin, axis=0) * fps
        velocity[0] = velocity[1]
    pose = np.concatenate([p.numpy() for p in parts] + [_to_root(velocity, heading)], axis=-1)
    return origin, heading, pose


def query_features(pose, origin, heading, subgoal, subgoal_direction) -> np.ndarray:
    """``N`` (33,) of a query: the sub-goal's direction and position in the current root frame, then the
    current pose part (29,) (:func:`frame_features`).

    Args:
        pose: (29,) the current pose's part of ``N``.
        origin: (2,) metres, heading: radians — the current root frame.
        subgoal: (2,) metres; subgoal_direction: (2,) the direction to arrive in.
    """
    pose = np.asarray(pose, dtype=np.float64)
    check_shape(pose, (_POSE_SIZE,), "pose")
    d = _to_root(unit_direction(subgoal_direction, "subgoal_direction"), heading)
    p = _to_root(np.asarray(subgoal, dtype=np.float64) - np.asarray(origin, dtype=np.float64), heading)
    return np.concatenate([d, p, pose])


# ----------------------------------------------------------------------------- the matching database


def _group_scales(features: np.ndarray, weights) -> np.ndarray:
    """(33,) multipliers: each group's ``√weight`` over its mean standard deviation (1 where it has none)."""
    std = features.std(axis=0)
    out = np.ones(FEATURE_SIZE)
    for (name, _), weight in zip(FEATURE_PARTS, weights):
        part = FEATURE_LAYOUT[name]
        spread = float(std[part].mean())
        out[part] = np.sqrt(weight) / (spread if spread > 1e-9 else 1.0)
    return out


class MotionDatabase:
    """Motions between keyframes of toy-mocap walks, their features ``N`` and a ``cKDTree`` over them.

    Attributes:
        local_rotations: (F, 22, 3, 3) float32, every clip's frames one after another.
        root_position: (F, 3) float32 metres.
        clip_offsets: (C + 1,) int, clip ``c`` holds frames ``clip_offsets[c] : clip_offsets[c + 1]``.
        origin: (F, 2) metres, heading: (F,) radians — each frame's root frame.
        pose: (F, 29) each frame's pose part of ``N``.
        limb_points: (F, 10, 3) metres, world frame of the clips: elbows, wrists, knees, ankles and feet
            (``LIMB_JOINTS``), which swing beyond the root's clearance (:func:`select_window`'s ``clear``).
        windows: (W, 3) int ``[clip, first frame, last frame]`` (frames indexed into ``F``).
        features: (W, 33) ``N`` of each motion.
        scales: (33,) the distance's multipliers; tree: ``cKDTree`` over ``features · scales``.
    """

    def __init__(self, arrays: dict, weights=NavigationConfig().weights):
        for name in ("local_rotations", "root_position", "clip_offsets", "origin", "heading", "pose", "limb_points",
                     "windows", "features"):
            setattr(self, name, np.asarray(arrays[name]))
        check_shape(self.features, (None, FEATURE_SIZE), "features")
        self.scales = _group_scales(self.features, weights)
        self.tree = cKDTree(self.features * self.scales)

    def __len__(self) -> int:
        return len(self.windows)

    def scaled(self, features) -> np.ndarray:
        """Features (..., 33) in the tree's space (multiplied by ``scales``)."""
        return np.asarray(features, dtype=np.float64) * self.scales


def _candidate_windows(origin: np.ndarray, offsets: np.ndarray, step: int, reach: float) -> np.ndarray:
    """(W, 3) ``[clip, first, last]``: keyframe to later keyframe, up to the first whose root walked ``reach``."""
    out = []
    for c in range(len(offsets) - 1):
        keys = np.arange(offsets[c], offsets[c + 1], step)
        walked = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(origin[offsets[c]:offsets[c + 1]], axis=0), axis=1))])
        for a, s in enumerate(keys):
            for e in keys[a + 1:]:
                out.append((c, s, e))
                if walked[e - offsets[c]] - walked[s - offsets[c]] > reach:
                    break
    return np.asarray(out, dtype=np.int64).reshape(-1, 3)


def _window_features(origin, heading, pose, windows) -> np.ndarray:
    s, e = windows[:, 1], windows[:, 2]
    d = _to_root(_forward(heading[e]), heading[s])
    p = _to_root(origin[e] - origin[s], heading[s])
    return np.concatenate([d, p, pose[s]], axis=-1)


def locomotion_clips(config: NavigationConfig = NavigationConfig()) -> list:
    """The database's ``config.n_clips`` toy walks (``Motion``, mean body, 30 fps): each through
    ``mocap.random_path`` waypoints, from standing facing anywhere (turning on the spot first when more
    than 25° off the path) to standing facing anywhere (turning in the last steps, or on the spot in every
    other clip), so that the motions start, stop and turn as well as walk."""
    root = np.random.SeedSequence([config.seed, zlib.crc32(b"choice.navigation")])
    clips = []
    for k, child in enumerate(root.spawn(config.n_clips)):
        rng = np.random.default_rng(child)
        waypoints = mocap.random_path(rng)
        start = standing_pose(position=waypoints[0], heading=float(rng.uniform(-np.pi, np.pi)))
        clips.append(mocap.generate_clip("walk", seed=rng, waypoints=waypoints, start=start,
                                         end_heading=float(rng.uniform(-np.pi, np.pi)), end_turn=("steps", "spot")[k % 2]))
    return clips


@single_threaded
def build_database(config: NavigationConfig = NavigationConfig()) -> dict:
    """The database's arrays (:class:`MotionDatabase`) from :func:`locomotion_clips`."""
    clips = locomotion_clips(config)
    origins, headings, poses = zip(*(frame_features(c.local_rotations, c.root_position, c.betas, c.fps) for c in clips))
    offsets = np.concatenate([[0], np.cumsum([len(c) for c in clips])]).astype(np.int64)
    origin, heading, pose = np.concatenate(origins), np.concatenate(headings), np.concatenate(poses)
    windows = _candidate_windows(origin, offsets, config.keyframe_step, config.segment_length)
    limbs = [c.joints[:, [joint_index(n) for n in LIMB_JOINTS]] for c in clips]
    return {
        "local_rotations": torch.cat([c.local_rotations for c in clips]).float().numpy(),
        "root_position": torch.cat([c.root_position for c in clips]).float().numpy(),
        "clip_offsets": offsets, "origin": origin, "heading": heading, "pose": pose, "windows": windows,
        "limb_points": torch.cat(limbs).float().numpy(),
        "features": _window_features(origin, heading, pose, windows),
    }


def motion_database(config: NavigationConfig = NavigationConfig()) -> MotionDatabase:
    """The matching database for ``config``, built once (:func:`build_database`) and then loaded from the
    artifact cache."""
    key = {"n_clips": config.n_clips, "keyframe_step": config.keyframe_step,
           "segment_length": config.segment_length, "seed": config.seed, "fps": FPS}
    arrays = load_or_build("choice_navigation_database", key, lambda: build_database(config))
    return MotionDatabase(arrays, config.weights)


def match(database: MotionDatabase, query, k: int = 1):
    """The ``k`` nearest motions to ``query`` (..., 33) by the KD-tree.

    Returns:
        ``(distances (..., k), indices (..., k))`` into ``database.windows``, nearest first (the
        distance in the scaled feature space).
    """
    query = np.asarray(query, dtype=np.float64)
    if query.ndim == 0 or query.shape[-1] != FEATURE_SIZE:
        raise ValueError(f"query: expected navigation features N of shape (..., {FEATURE_SIZE}) "
                         f"({', '.join(f'{n} {s}' for n, s in FEATURE_PARTS)}), got {query.shape}")
    check_finite(query, "query")
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k: expected a positive int, got {k!r}")
    distances, indices = database.tree.query(database.scaled(query), k=[i + 1 for i in range(min(int(k), len(database)))])
    return distances, indices


def _placed_roots(database: MotionDatabase, window: int, origin, heading) -> np.ndarray:
    """The motion's root xy (n, 2) metres, placed so that its first frame's root frame is ``(origin, heading)``."""
    _, s, e = database.windows[window]
    local = _to_root(database.origin[s:e + 1] - database.origin[s], database.heading[s])
    c, si = np.cos(heading), np.sin(heading)
    world = np.stack([c * local[:, 0] - si * local[:, 1], si * local[:, 0] + c * local[:, 1]], axis=-1)
    return world + np.asarray(origin, dtype=np.float64)


def placed_limb_points(database: MotionDatabase, window: int, origin, heading) -> np.ndarray:
    """The motion's limb joints (n, 10, 3) metres (``LIMB_JOINTS``), placed as :func:`_placed_roots` places its
    root."""
    _, s, e = database.windows[window]
    points = np.asarray(database.limb_points[s:e + 1], dtype=np.float64)
    local = _to_root(points[..., :2] - database.origin[s], database.heading[s])
    c, si = np.cos(heading), np.sin(heading)
    world = np.stack([c * local[..., 0] - si * local[..., 1], si * local[..., 0] + c * local[..., 1]], axis=-1)
    return np.concatenate([world + np.asarray(origin, dtype=np.float64), points[..., 2:]], axis=-1)


def window_collides(database: MotionDatabase, grid: NavigationGrid, window: int, origin, heading) -> bool:
    """Whether motion ``window``, started at the root frame ``(origin (2,), heading)``, puts its root in a
    ``grid.collision`` cell or off the grid at any frame."""
    return bool(np.any(grid.collides(_placed_roots(database, window, origin, heading))))


def select_window(database: MotionDatabase, grid: NavigationGrid, query, origin, heading, *, candidates: int = 16,
                  keep: Optional[Callable] = None, cut_at=None, clear: Optional[Callable] = None):
    """The nearest of the ``candidates`` nearest motions to ``query`` (33,) that does not collide when started
    at the root frame ``(origin (2,), heading)``, and whose end (2,) metres passes ``keep(end)`` when given:
    CHOICE §6.2's "least deviation and no collision". With ``cut_at`` (2,) metres, each motion is cut at
    its frame nearest that point (after its first) before it is checked. The root is checked on the grid;
    with ``clear`` given, the limbs too: ``clear(points (n, 10, 3) metres) -> bool``, False for a motion whose
    elbows, wrists, knees, ankles or feet enter the scene (:func:`placed_limb_points`).

    Returns:
        ``(window, last, distance, rejected)``: the index (None when every candidate fails), its last frame
        (into the database's frames), its feature distance, and the tuple of the nearer motions rejected,
        nearest first.
    """
    distances, indices = match(database, query, candidates)
    rejected = []
    for distance, window in zip(np.atleast_1d(distances), np.atleast_1d(indices)):
        window = int(window)
        roots = _placed_roots(database, window, origin, heading)
        if cut_at is not None:
            roots = roots[:2 + int(np.argmin(np.linalg.norm(roots[1:] - np.asarray(cut_at), axis=1)))]
        if np.any(grid.collides(roots)) or (keep is not None and not keep(roots[-1])) or (
                clear is not None and not clear(placed_limb_points(database, window, origin, heading)[:len(roots)])):
            rejected.append(window)
            continue
        return window, int(database.windows[window, 1]) + len(roots) - 1, float(distance), tuple(rejected)
    return None, None, float("inf"), tuple(rejected)


# ----------------------------------------------------------------------------- following the path


@dataclass
class MatchedSegment:
    """One stitched motion.

    Attributes:
        window: index into ``database.windows``; clip: its clip.
        first, last: the clip-local frames used (``last`` is where it was cut).
        distance: its feature distance to the query.
        subgoal: (2,) metres, the sub-goal it was matched to.
        rejected: the nearer motions skipped (colliding, or not bringing the character nearer).
        frames: its frames in :attr:`Navigation.root` (a slice).
    """

    window: int
    clip: int
    first: int
    last: int
    distance: float
    subgoal: np.ndarray
    rejected: tuple
    frames: slice


@dataclass
class Navigation:
    """The walk :func:`follow_path` stitched.

    Attributes:
        plan: the 2D path from the start (:class:`NavigationPlan`).
        segments: the matched motions, in order.
        motion: the stitched ``Motion`` (30 fps, mean body), None when nothing was matched.
        root: (T, 3) pelvis positions, metres; heading: (T,) radians (0 faces +y).
        reached: whether the root ended within ``goal_tolerance`` of the goal.
        goal_error: metres from the last root position (on the ground) to the goal.
        stopped: why the walk ended: ``"reached"``, ``"no match"`` (every candidate failed, down to the
            shortest sub-goal) or ``"max_segments"``.
    """

    plan: NavigationPlan
    segments: list
    motion: Optional[Motion]
    root: np.ndarray
    heading: np.ndarray
    reached: bool
    goal_error: float
    stopped: str


def _rotate(xy, yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([c * xy[0] - s * xy[1], s * xy[0] + c * xy[1]])


def _match_next(grid, database, plan, path, origin, heading, pose, config, clear=None):
    """The next motion from the root frame ``(origin, heading)`` with ``pose``: its sub-goal ``segment_length``
    along ``path``, brought to half the distance while no candidate fits. Returns ``select_window``'s
    answer and the sub-goal."""
    here = plan.time[grid.point_cell(origin)]

    def nearer(end):  # within the tolerance of the goal, or lower on T than the start
        return np.linalg.norm(end - plan.goal) <= config.goal_tolerance or plan.time[tuple(grid.cell_of(end))] < here

    every = config.segment_length
    while True:
        subgoal = split_path(path, every)[0]
        arriving = plan.goal_direction if np.allclose(subgoal, plan.goal) else direction_at(path, subgoal)
        query = query_features(pose, origin, heading, subgoal, arriving)
        found = select_window(database, grid, query, origin, heading, candidates=config.candidates, keep=nearer,
                              cut_at=subgoal, clear=clear)
        if found[0] is not None or every / 2 < config.goal_tolerance:
            return found, subgoal
        every /= 2


def follow_path(grid: NavigationGrid, database: MotionDatabase, start, goal, goal_direction, *,
                start_heading: Optional[float] = None, config: NavigationConfig = NavigationConfig(),
                clear: Optional[Callable] = None) -> Navigation:
    """Walk from ``start`` to ``goal`` (2,) metres, arriving to face ``goal_direction`` (2,), by matching and
    stitching motions (CHOICE §6.2).

    The character starts standing (``standing_pose``, mean body) at ``start`` facing ``start_heading``
    (radians, 0 faces +y; default: along the path). Each round reads the path from the root down the plan's
    ``T``, takes its first sub-goal (:func:`split_path`), queries ``N`` with the current pose and stitches
    the nearest motion that fits (:func:`select_window`), its first root frame on the character's. It stops
    when the root is within ``config.goal_tolerance`` of the goal, when nothing fits, or after
    ``config.max_segments`` motions. ``clear`` (optional) also rejects motions whose limbs enter the scene
    (:func:`select_window`).

    Raises:
        ValueError: as :func:`plan_path`.
    """
    plan = plan_path(grid, start, goal, goal_direction, config)
    if start_heading is None:
        first_leg = plan.path[1] - plan.path[0] if len(plan.path) > 1 else plan.goal_direction
        start_heading = float(np.arctan2(-first_leg[0], first_leg[1]))
    local, root = standing_pose(position=tuple(plan.path[0]), heading=float(start_heading))
    origin, heading, pose = plan.path[0].copy(), float(start_heading), frame_features(local[None], root[None])[2][0]
    segments, parts, headings, n_frames, stopped = [], [], [], 0, "max_segments"
    for _ in range(config.max_segments):
        if np.linalg.norm(origin - plan.goal) <= config.goal_tolerance:
            stopped = "reached"
            break
        path = path_from(grid, plan.time, origin, plan.goal, plan.goal_direction, config.near_goal)
        (window, e, distance, rejected), subgoal = _match_next(grid, database, plan, path, origin, heading, pose, config,
                                                               clear)
        if window is None:
            stopped = "no match"
            break
        clip, s = (int(v) for v in database.windows[window, :2])
        yaw = heading - float(database.heading[s])
        skip = 1 if parts else 0  # the first frame repeats the previous motion's last
        piece = Motion(torch.as_tensor(database.local_rotations[s:e + 1]), torch.as_tensor(database.root_position[s:e + 1]))
        translation = np.r_[origin - _rotate(database.origin[s], yaw), 0.0]
        parts.append(piece.transformed(yaw, translation).slice(skip, e - s + 1))
        headings.append(database.heading[s + skip:e + 1] + yaw)
        offset = int(database.clip_offsets[clip])
        segments.append(MatchedSegment(window, clip, s - offset, e - offset, distance, subgoal, rejected,
                                       slice(n_frames, n_frames + len(parts[-1]))))
        n_frames += len(parts[-1])
        origin = parts[-1].root_position[-1, :2].double().numpy()
        heading, pose = float(database.heading[e]) + yaw, database.pose[e]
    if np.linalg.norm(origin - plan.goal) <= config.goal_tolerance:
        stopped = "reached"
    motion = Motion.concatenate(parts) if parts else None
    root_out = motion.root_position.double().numpy() if parts else root.double().numpy()[None]
    heading_out = np.angle(np.exp(1j * np.concatenate(headings))) if parts else np.array([float(start_heading)])
    error = float(np.linalg.norm(root_out[-1, :2] - plan.goal))
    return Navigation(plan=plan, segments=segments, motion=motion, root=root_out, heading=heading_out,
                      reached=error <= config.goal_tolerance, goal_error=error, stopped=stopped)
