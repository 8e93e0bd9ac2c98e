"""Navigation (CHOICE §6.2, Eq. 23): a 2D path to the goal by fast marching, split every 3 m into the
sub-goals that ``locomotion`` follows with matched clips.

The algorithm box's first half, as the paper has it and this module runs it:

1. **The 2D path** (Eq. 23). From the character's position ``p'`` to the goal ``(p_g^root, d_g^root)``
   every floor point ``p`` costs

   ``c(p) = ∞`` in obstacles;  ``angle(p − p_g, d_g)/π + 0.5`` if ``‖p − p_g‖₁ < l``;  ``1`` otherwise,

   with ``l = 0.4 m``: near the goal the cost runs from 0.5 on the side ``d_g`` points to, to 1.5 on the
   opposite side. "The optimal path is computed using fast marching method": a front leaves the goal at
   speed ``1 / c`` (``planner.fields.fast_marching_time``, scikit-fmm), so its arrival time ``T(p)`` is the least
   ``∫ c ds`` from ``p`` to the goal (metres weighted by the unitless cost), and the path descends ``T``
   from ``p'`` (:func:`travel_time`, :func:`plan_path`).
2. **Sub-goals.** "As it will be difficult to find a match for a very long path, the path is split 3m
   from the start position and matched for each segment" (:func:`split_path`).
The paper names the 2D search "breadth-first search" and says the path "is computed using fast marching
method" in the same paragraph; fast marching is the ordered, Dijkstra-like sweep by arrival time that
solves Eq. 23's Eikonal equation, and is what runs here.

Scaling (paper → toy): the CHOICE capture's locomotion → ``n_clips`` toy-mocap walks (32 at ``toy``, about
7300 motions, built in about a second and cached; 128 and 512 walks with keyframes twice as dense at
``small`` and ``paper``, ours: the paper does not say how much locomotion it matches in); the 2D grid is
the scene's (5 cm cells; the paper does not state its resolution); ``l = 0.4 m`` and the 3 m split as
the paper at every scale.

Choices the paper does not state, ours:

- **Obstacles.** Eq. 23's are the floor cells within ``body_radius`` (0.25 m, the toy rooms' walking
  radius) of a footprint or a wall (``scene.inflated_occupancy``); a clip collides when its root comes
  within ``collision_radius`` (0.15 m, about the half-width of the toy body's hips) of one, or leaves the
  grid. The margin between the two lets a matched motion stray from a path that hugs an obstacle. A start
  or goal whose own cell is blocked while a free neighbouring cell's centre lies within a cell of it (a
  toy room's standing spot, exactly ``body_radius`` from a footprint) starts or ends on that cell.
- **The angle** of Eq. 23 is the unsigned angle in [0, π] between ``p − p_g`` and ``d_g``, 0 at
  ``p = p_g``. Read literally, the cheap side is the one ``d_g`` points to: the character arrives walking
  against ``d_g``, as when it walks up to a seat and turns round to sit facing ``d_g``. The text ("approach
  the goal from a direction that is parallel to the orientation of the character at the goal") would also
  fit the other sign; we keep the equation as printed.
- **Reading the path off ``T``.** The front starts on the border of the goal's cell (``T = 0`` in it).
  From the start's cell the path steps to the neighbour of largest drop of ``T`` per metre (8
  neighbours, no diagonal step past a blocked cell: ``planner.fields.descend`` in 2D; fast marching gives every
  reached cell an earlier 4-neighbour, so the descent ends in the goal's cell and never enters an
  obstacle), then is pulled taut: a run of cells is replaced by the straight segment joining its ends
  when that segment touches only free cells and its Eq. 23 cost ``∫ c ds`` is no higher. The cell path
  turns only in 45° steps; the taut one is the geodesic ``−∇T`` traces, to a cell.
- **Sub-goals** lie every ``segment_length`` metres of arc length, the goal last; each is matched with
  the path's direction there (``d_g`` for the goal). The path is read again from the same ``T`` wherever
  a stitched motion ends, and split from there. When no candidate fits, the sub-goal is brought to half
  the distance along the path, down to ``goal_tolerance`` ("difficult to find a match for a very long
  path").

The locomotion that follows the path — the navigation features ``N``, the KD-tree and the stitching — is
``locomotion``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..._validate import check_finite, check_positive_ints, check_shape
from ...infra import scaled_config
from ..planner import fields

__all__ = [
    "FEATURE_PARTS",
    "NavigationConfig",
    "NAVIGATION_SCALES",
    "navigation_config",
    "NavigationGrid",
    "navigation_grid",
    "navigation_cost",
    "cost_map",
    "travel_time",
    "path_cost",
    "NavigationPlan",
    "plan_path",
    "split_path",
    "unit_direction",
    "path_from",
    "direction_at",
]




# The groups of the navigation features N of §6.2, in the paper's order, with their sizes (the
# configuration weighs each group; locomotion builds N).
FEATURE_PARTS = (
    ("goal_direction", 2),  # d_g^root
    ("goal_position", 2),   # p_g^root
    ("left_rotation", 6), ("left_position", 3),     # r^left, p^left
    ("right_rotation", 6), ("right_position", 3),   # r^right, p^right
    ("hip_rotation", 6), ("hip_position", 3),       # r^hip, p^hip
    ("root_velocity", 2),   # v^root
)


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class NavigationConfig:
    """Eq. 23, the split, the matching database and the following (defaults: the ``toy`` preset).

    Attributes:
        near_goal: ``l`` of Eq. 23, metres (CHOICE: 0.4 m), an L1 radius around the goal.
        segment_length: the path is split every this many metres (CHOICE: 3 m).
        body_radius: Eq. 23's obstacles are the footprints and walls inflated by this, metres (ours; the
            toy rooms' walking radius).
        collision_radius: a clip collides when its root comes this near a footprint or wall, metres (ours).
        n_clips: toy-mocap walks in the matching database (ours).
        keyframe_step: frames between the database's keyframes (ours; 1/3 s at 30 fps).
        weights: the nine feature groups' weights, in the order of ``N`` (ours: 1 for ``d_g``, ``p_g`` and
            ``v^root``, 0.1 for the key joints).
        candidates: nearest motions tried before a sub-goal is brought nearer (ours).
        goal_tolerance: the walk ends once the root is this near the goal, metres (ours).
        max_segments: at most this many motions stitched (ours).
        order: fast-marching order, 1 or 2 (2 falls back to 1 where scikit-fmm cannot use it).
        seed: seeds the database's clips.
    """

    near_goal: float = 0.4
    segment_length: float = 3.0
    body_radius: float = 0.25
    collision_radius: float = 0.15
    n_clips: int = 32
    keyframe_step: int = 10
    weights: tuple = (1.0, 1.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 1.0)
    candidates: int = 16
    goal_tolerance: float = 0.3
    max_segments: int = 16
    order: int = 2
    seed: int = 0

    def __post_init__(self):
        for name in ("near_goal", "segment_length", "body_radius", "collision_radius", "goal_tolerance"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0:
                raise ValueError(f"{name}: expected a positive number of metres, got {value!r}")
        if self.collision_radius > self.body_radius:
            raise ValueError(f"collision_radius: expected at most body_radius ({self.body_radius} m), "
                             f"got {self.collision_radius}")
        check_positive_ints(self, ("n_clips", "keyframe_step", "candidates", "max_segments"))
        weights = tuple(self.weights)
        if len(weights) != len(FEATURE_PARTS) or not all(isinstance(w, (int, float)) and w >= 0 for w in weights):
            raise ValueError(f"weights: expected {len(FEATURE_PARTS)} non-negative numbers (one per group of N: "
                             f"{', '.join(n for n, _ in FEATURE_PARTS)}), got {self.weights!r}")
        object.__setattr__(self, "weights", tuple(float(w) for w in weights))
        if self.order not in (1, 2):
            raise ValueError(f"order: expected 1 or 2, got {self.order!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed: expected a non-negative int, got {self.seed!r}")


# Larger databases and keyframes every 1/6 s (ours; the paper does not state the size of its locomotion data).
NAVIGATION_SCALES = {"small": {"n_clips": 128, "keyframe_step": 5}, "paper": {"n_clips": 512, "keyframe_step": 5}}


def navigation_config(scale: str = "toy", **overrides) -> NavigationConfig:
    """The preset for ``scale``, fields overridable (``navigation_config("small", candidates=32)``)."""
    return scaled_config(NavigationConfig, scale, NAVIGATION_SCALES, overrides, factory="navigation_config")


# ----------------------------------------------------------------------------- the 2D grid


_STEPS = np.array([(a, b) for a in (-1, 0, 1) for b in (-1, 0, 1) if (a, b) != (0, 0)])  # 8 neighbours (di, dj)
_STEP_LENGTHS = np.linalg.norm(_STEPS, axis=1)


@dataclass(frozen=True, eq=False)
class NavigationGrid:
    """The floor as square cells, the convention of ``world.scenes``: index ``[i, j]`` is row ``i`` along
    +y and column ``j`` along +x, the cell centre ``((j + 0.5)·cell, (i + 0.5)·cell)``; the grid covers
    ``[0, W·cell] × [0, H·cell]`` metres.

    Attributes:
        blocked: (H, W) bool, Eq. 23's obstacles: where a path may not go (obstacles inflated by the
            body radius).
        cell_size: cell side, metres.
        collision: (H, W) bool, where a matched clip's root may not go (default: ``blocked``; the toy
            scenes' is inflated by the smaller ``collision_radius``).
    """

    blocked: np.ndarray
    cell_size: float
    collision: Optional[np.ndarray] = None

    def __post_init__(self):
        for name in ("blocked", "collision"):
            grid = getattr(self, name)
            if name == "collision" and grid is None:
                object.__setattr__(self, "collision", self.blocked)
                continue
            if not isinstance(grid, np.ndarray) or grid.ndim != 2 or grid.dtype != np.bool_ or grid.size == 0:
                got = f"shape {grid.shape}, dtype {grid.dtype}" if isinstance(grid, np.ndarray) else type(grid).__name__
                raise ValueError(f"{name}: expected a non-empty (H, W) bool numpy array, got {got}")
        if self.collision.shape != self.blocked.shape:
            raise ValueError(f"collision: expected the shape of blocked {self.blocked.shape}, got {self.collision.shape}")
        if not (isinstance(self.cell_size, (int, float)) and self.cell_size > 0):
            raise ValueError(f"cell_size: expected a positive number of metres, got {self.cell_size!r}")
        object.__setattr__(self, "cell_size", float(self.cell_size))

    @property
    def shape(self) -> tuple:
        return tuple(self.blocked.shape)

    @property
    def size(self) -> np.ndarray:
        """(2,) metres: the grid's extent along x and y."""
        return np.array([self.shape[1], self.shape[0]], dtype=np.float64) * self.cell_size

    @property
    def extent(self) -> tuple:
        """(x_min, x_max, y_min, y_max) metres, for ``imshow(..., origin="lower")``."""
        return (0.0, float(self.size[0]), 0.0, float(self.size[1]))

    def centres(self) -> np.ndarray:
        """(H, W, 2) xy metres of the cell centres."""
        i, j = np.meshgrid(np.arange(self.shape[0]), np.arange(self.shape[1]), indexing="ij")
        return (np.stack([j, i], axis=-1) + 0.5) * self.cell_size

    def inside(self, xy) -> np.ndarray:
        """(...) bool: whether floor points xy (..., 2) metres lie on the grid."""
        xy = np.asarray(xy, dtype=np.float64)
        return np.all((xy >= 0.0) & (xy <= self.size), axis=-1)

    def cell_of(self, xy) -> np.ndarray:
        """(..., 2) int ``[i, j]`` of the cells holding xy (..., 2) (clipped to the grid: a point on the
        far edge belongs to the last cell)."""
        xy = np.asarray(xy, dtype=np.float64)
        ij = np.floor(xy[..., ::-1] / self.cell_size).astype(np.int64)
        return np.clip(ij, 0, np.asarray(self.shape) - 1)

    def free(self, xy) -> np.ndarray:
        """(...) bool: on the grid and in a cell free of Eq. 23's obstacles."""
        ij = self.cell_of(xy)
        return self.inside(xy) & ~self.blocked[ij[..., 0], ij[..., 1]]

    def collides(self, xy) -> np.ndarray:
        """(...) bool: off the grid or in a ``collision`` cell (a root there puts the body into an obstacle)."""
        ij = self.cell_of(xy)
        return ~self.inside(xy) | self.collision[ij[..., 0], ij[..., 1]]

    def check_point(self, xy, name: str) -> np.ndarray:
        """``xy`` as a (2,) float array, or a ValueError naming ``name`` when it is off the grid or in an
        obstacle (no free cell of its own or, see :meth:`point_cell`, beside it)."""
        try:
            arr = np.asarray(xy, dtype=np.float64)
        except (TypeError, ValueError):
            arr = None
        extent = f"[0, {self.size[0]:g}] × [0, {self.size[1]:g}] m"
        if arr is None or arr.shape != (2,) or not np.all(np.isfinite(arr)):
            raise ValueError(f"{name}: expected a floor point (x, y) in metres inside the scene {extent}, got {xy!r}")
        if not self.inside(arr):
            raise ValueError(f"{name}: expected a floor point inside the scene {extent}, got [{arr[0]:g}, {arr[1]:g}]")
        self.point_cell(arr, name)
        return arr

    def point_cell(self, xy, name: str = "point") -> tuple:
        """The free cell ``(i, j)`` a point on the grid starts or ends on: its own, or, when only its own is
        blocked (a discretisation effect: a toy room's standing spot is ``body_radius`` from a footprint,
        its cell centre may be nearer), the free one of its 8 neighbours whose centre is nearest, if that
        centre is within one cell of the point. Raises a ValueError naming ``name`` otherwise."""
        xy = np.asarray(xy, dtype=np.float64)
        own = self.cell_of(xy)
        if not self.blocked[tuple(own)]:
            return int(own[0]), int(own[1])
        near = np.clip(own + _STEPS, 0, np.asarray(self.shape) - 1)
        near = near[~self.blocked[near[:, 0], near[:, 1]]]
        gaps = np.linalg.norm((near[:, ::-1] + 0.5) * self.cell_size - xy, axis=1) if len(near) else np.array([np.inf])
        if not gaps.min() <= self.cell_size:
            raise ValueError(f"{name} [{xy[0]:g}, {xy[1]:g}] m lies inside an obstacle (a blocked cell: within the "
                             "body radius of a footprint or a wall)")
        best = near[int(np.argmin(gaps))]
        return int(best[0]), int(best[1])


def navigation_grid(scene, config: NavigationConfig = NavigationConfig()) -> NavigationGrid:
    """The floor of a toy room or kitchen (``world.scenes``): Eq. 23's obstacles are its cells within
    ``config.body_radius`` of a footprint or a wall, the collisions those within ``config.collision_radius``
    (``scene.inflated_occupancy``)."""
    return NavigationGrid(np.asarray(scene.inflated_occupancy(config.body_radius), dtype=bool), float(scene.cell_size),
                          np.asarray(scene.inflated_occupancy(config.collision_radius), dtype=bool))


# ----------------------------------------------------------------------------- Eq. 23 and the 2D path


def unit_direction(direction, name: str) -> np.ndarray:
    d = np.asarray(direction, dtype=np.float64)
    check_shape(d, (2,), name)
    check_finite(d, name)
    norm = float(np.linalg.norm(d))
    if norm < 1e-9:
        raise ValueError(f"{name}: expected a non-zero 2D direction, got {direction!r}")
    return d / norm


def navigation_cost(points, goal, goal_direction, blocked, near_goal: float = 0.4) -> np.ndarray:
    """Eq. 23: the cost ``c(p)`` of floor points.

    Args:
        points: (..., 2) xy metres.
        goal: (2,) ``p_g^root``, metres.
        goal_direction: (2,) ``d_g^root`` (any length > 0).
        blocked: (...) bool, the points in obstacles.
        near_goal: ``l``, metres.
    Returns:
        (...) unitless: ``∞`` in obstacles; ``angle(p − p_g, d_g)/π + 0.5`` where ``‖p − p_g‖₁ < l``
        (the angle in [0, π], 0 at ``p = p_g``); ``1`` elsewhere.
    """
    points = np.asarray(points, dtype=np.float64)
    check_shape(points, (..., 2), "points")
    goal = np.asarray(goal, dtype=np.float64)
    check_shape(goal, (2,), "goal")
    d = unit_direction(goal_direction, "goal_direction")
    blocked = np.asarray(blocked)
    if blocked.dtype != np.bool_ or blocked.shape != points.shape[:-1]:
        raise ValueError(f"blocked: expected a bool array of shape {points.shape[:-1]} (one per point), "
                         f"got dtype {blocked.dtype}, shape {blocked.shape}")
    offset = points - goal
    length = np.linalg.norm(offset, axis=-1)
    cosine = np.where(length > 0, offset @ d / np.maximum(length, 1e-300), 1.0)
    angle = np.arccos(np.clip(cosine, -1.0, 1.0))
    near = np.abs(offset).sum(axis=-1) < near_goal
    return np.where(blocked, np.inf, np.where(near, angle / np.pi + 0.5, 1.0))


def cost_map(grid: NavigationGrid, goal, goal_direction, near_goal: float = 0.4) -> np.ndarray:
    """(H, W) Eq. 23 at the cell centres (``∞`` in blocked cells)."""
    return navigation_cost(grid.centres(), goal, goal_direction, grid.blocked, near_goal)


def _source(grid: NavigationGrid, goal) -> np.ndarray:
    """(H, W) ``phi`` whose zero level set is the border of the goal's cell (negative only in that cell):
    the front's start."""
    centre = (np.asarray(grid.point_cell(goal, "goal"))[::-1] + 0.5) * grid.cell_size
    return np.abs(grid.centres() - centre).max(axis=-1) - 0.5 * grid.cell_size


def travel_time(grid: NavigationGrid, goal, goal_direction, config: NavigationConfig = NavigationConfig()) -> np.ndarray:
    """``T`` (H, W): the least ``∫ c ds`` (Eq. 23's cost × metres) from each cell to the goal, by fast
    marching at speed ``1 / c`` from the border of the goal's cell (``T = 0`` in it); ``∞`` in blocked and
    unreachable cells."""
    goal = grid.check_point(goal, "goal")
    cost = cost_map(grid, goal, goal_direction, config.near_goal)
    phi = _source(grid, goal)
    with np.errstate(divide="ignore"):
        speed = 1.0 / cost
    time = fields.fast_marching_time(phi, speed, grid.blocked, grid.cell_size, config.order)
    return np.where((phi < 0) & ~grid.blocked, 0.0, time)


def _sample_segment(a, b, step: float):
    """Midpoints (n, 2) of ``n`` equal pieces of the segment ``a → b``, each at most ``step`` long, and their length."""
    length = float(np.linalg.norm(b - a))
    n = max(1, int(np.ceil(length / step)))
    u = (np.arange(n) + 0.5) / n
    return a + u[:, None] * (b - a), length / n


def path_cost(path, grid: NavigationGrid, goal, goal_direction, near_goal: float = 0.4) -> float:
    """``∫ c ds`` along a polyline (K, 2) metres (Eq. 23; midpoint rule on pieces of a quarter cell;
    ``inf`` if it crosses a blocked cell or leaves the grid)."""
    path = np.asarray(path, dtype=np.float64)
    check_shape(path, (None, 2), "path")
    total = 0.0
    for a, b in zip(path[:-1], path[1:]):
        mids, ds = _sample_segment(a, b, 0.25 * grid.cell_size)
        blocked = ~grid.free(mids)
        total += float(navigation_cost(mids, goal, goal_direction, blocked, near_goal).sum() * ds)
    return total


def _segment_is_free(grid: NavigationGrid, a, b) -> bool:
    """Whether the segment ``a → b`` (metres) touches only free cells, each cell a closed square: the
    segment's end points, its crossings of the cell borders and the midpoints between them, each in every
    cell that holds it (a point on a border or a corner is in two or four). Exact, and a segment through
    the corner of a blocked cell counts as touching it."""
    ga, gb = np.asarray(a) / grid.cell_size, np.asarray(b) / grid.cell_size
    delta = gb - ga
    ts = [0.0, 1.0]
    for axis in (0, 1):
        if delta[axis] != 0:
            lo, hi = sorted((ga[axis], gb[axis]))
            ts.extend((np.arange(np.ceil(lo), np.floor(hi) + 1) - ga[axis]) / delta[axis])
    ts = np.unique(np.clip(ts, 0.0, 1.0))
    ts = np.concatenate([ts, 0.5 * (ts[:-1] + ts[1:])])
    points = ga + ts[:, None] * delta  # in cells, x then y
    top = np.asarray(grid.shape[::-1]) - 1
    for nudge in ((-1e-9, -1e-9), (-1e-9, 1e-9), (1e-9, -1e-9), (1e-9, 1e-9)):
        xy = np.clip(np.floor(points + nudge).astype(np.int64), 0, top)
        if grid.blocked[xy[:, 1], xy[:, 0]].any():
            return False
    return bool(np.all(grid.inside(np.stack([ga, gb]) * grid.cell_size)))


def _descend(grid: NavigationGrid, time: np.ndarray, cell) -> np.ndarray:
    """Cells (K, 2) from ``cell`` down ``time`` to the goal's cell (``T = 0``): each step to the 8-neighbour
    of largest drop per metre, never diagonally past a blocked cell (``fields.descend`` in 2D)."""
    cell = np.asarray(cell, dtype=np.int64)
    cells = [cell]
    for _ in range(time.size):
        if time[tuple(cell)] == 0.0:
            break
        nb = cell + _STEPS
        ok = np.all((nb >= 0) & (nb < np.asarray(time.shape)), axis=1)
        nbc = np.clip(nb, 0, np.asarray(time.shape) - 1)
        corner = grid.blocked[nbc[:, 0], cell[1]] | grid.blocked[cell[0], nbc[:, 1]]
        ok &= ~((_STEP_LENGTHS > 1) & corner)
        drop = np.where(ok, (time[tuple(cell)] - time[nbc[:, 0], nbc[:, 1]]) / _STEP_LENGTHS, -np.inf)
        best = int(np.argmax(drop))
        if not drop[best] > 0:
            break
        cell = nb[best]
        cells.append(cell)
    return np.stack(cells)


def _pull_taut(points: np.ndarray, grid: NavigationGrid, cost) -> np.ndarray:
    """Greedy string pulling: from each kept point, jump to the farthest later point whose straight
    segment is free and no costlier (``cost(polyline)``) than the path it replaces."""
    legs = np.array([cost(points[a:a + 2]) for a in range(len(points) - 1)])
    cumulative = np.concatenate([[0.0], np.cumsum(legs)])
    keep, k = [0], 0
    while k < len(points) - 1:
        m = k + 1
        while (m + 1 < len(points) and _segment_is_free(grid, points[k], points[m + 1])
               and cost(points[[k, m + 1]]) <= cumulative[m + 1] - cumulative[k] + 1e-9):
            m += 1
        keep.append(m)
        k = m
    return points[keep]


def path_from(grid: NavigationGrid, time: np.ndarray, start, goal, goal_direction, near_goal: float) -> np.ndarray:
    """The taut path (K, 2) from ``start`` to ``goal`` down ``time``."""
    cell = grid.point_cell(start, "start")
    if not np.isfinite(time[cell]):
        raise ValueError(f"start [{start[0]:g}, {start[1]:g}] m cannot reach the goal (no free path; T = inf)")
    cells = _descend(grid, time, cell)
    if time[tuple(cells[-1])] != 0.0:  # cannot happen for a field from travel_time; guards a hand-made one
        raise ValueError("time: its descent from the start stalls before the goal's cell (T = 0 there only)")
    centres = (cells[1:, ::-1] + 0.5) * grid.cell_size
    points = np.concatenate([np.asarray(start, dtype=np.float64)[None], centres, np.asarray(goal, dtype=np.float64)[None]])
    return _pull_taut(points, grid, lambda p: path_cost(p, grid, goal, goal_direction, near_goal))


@dataclass
class NavigationPlan:
    """A 2D path by Eq. 23 and fast marching.

    Attributes:
        path: (K, 2) metres, ``start`` first and the goal last.
        time: (H, W) ``T``, the least ``∫ c ds`` to the goal from each cell (``∞`` in obstacles).
        cost: (H, W) Eq. 23 at the cell centres.
        length: metres along ``path``.
        path_cost: ``∫ c ds`` along ``path``.
        goal, goal_direction: (2,) the goal and its unit direction.
    """

    path: np.ndarray
    time: np.ndarray
    cost: np.ndarray
    length: float
    path_cost: float
    goal: np.ndarray
    goal_direction: np.ndarray


def plan_path(grid: NavigationGrid, start, goal, goal_direction,
              config: NavigationConfig = NavigationConfig()) -> NavigationPlan:
    """The 2D path of CHOICE §6.2 from ``start`` (2,) to ``goal`` (2,) metres, arriving at the goal of
    direction ``goal_direction`` (2,): fast marching on Eq. 23's cost, then the descent of ``T``, pulled taut.

    Raises:
        ValueError: a start or goal off the grid or in an obstacle; a goal the start cannot reach.
    """
    start = grid.check_point(start, "start")
    goal = grid.check_point(goal, "goal")
    direction = unit_direction(goal_direction, "goal_direction")
    time = travel_time(grid, goal, direction, config)
    path = path_from(grid, time, start, goal, direction, config.near_goal)
    return NavigationPlan(path=path, time=time, cost=cost_map(grid, goal, direction, config.near_goal),
                          length=float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()),
                          path_cost=path_cost(path, grid, goal, direction, config.near_goal),
                          goal=goal, goal_direction=direction)


def split_path(path, every: float = 3.0) -> np.ndarray:
    """Sub-goals (M, 2) along a polyline (K, 2) metres: the points ``every``, ``2·every``, ... metres of
    arc length from its start, then its end (CHOICE §6.2: "the path is split 3m from the start position")."""
    path = np.asarray(path, dtype=np.float64)
    check_shape(path, (None, 2), "path")
    if len(path) < 1:
        raise ValueError("path: expected at least one point")
    if not every > 0:
        raise ValueError(f"every: expected a positive number of metres, got {every!r}")
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    marks = np.arange(every, arc[-1], every)
    points = np.stack([np.interp(marks, arc, path[:, 0]), np.interp(marks, arc, path[:, 1])], axis=-1)
    return np.concatenate([points, path[-1:]])


def direction_at(path: np.ndarray, point: np.ndarray) -> np.ndarray:
    """The unit direction (2,) of the polyline's leg nearest ``point``."""
    legs = np.diff(path, axis=0)
    lengths = np.linalg.norm(legs, axis=1)
    legs, starts = legs[lengths > 1e-12], path[:-1][lengths > 1e-12]
    t = np.clip(np.einsum("ij,ij->i", point - starts, legs) / np.einsum("ij,ij->i", legs, legs), 0.0, 1.0)
    nearest = np.argmin(np.linalg.norm(starts + t[:, None] * legs - point, axis=1))
    return legs[nearest] / np.linalg.norm(legs[nearest])
