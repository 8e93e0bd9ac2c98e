"""Distance and time-of-arrival fields (CHOICE §4.1, Eqs. 1–6), computed by fast marching.

CHOICE describes the space around a target object with three fields on an object-centric grid
``E_t`` (Eq. 1), ``f(x) = D(x) = (D_t(x), D_o(x), D_toa(x))``:

1. **Target distance** (Eqs. 2–3): ``d(x, M_t)`` solves the Eikonal equation ``‖∇d‖ = 1`` outside
   the target and the obstacles (``∞`` inside them: they are walls) with ``d = 0`` on the target's
   surface; ``D_t = 1 / max(d, ε)``. Around an obstacle the distance is the length of the shortest
   path that goes *around* it (a geodesic), not the straight line.
2. **Obstacle distance** (Eq. 4): ``D_o = 1 / min_i max(d(x, M_Oi), ε)``, the distance to the
   nearest obstacle (fast marching from the obstacles' surfaces, the target a wall).
3. **Time of arrival** (Eqs. 5–6): ``φ`` solves ``‖∇φ‖ = 1 / (‖v(x_n)‖ · PDF(d(x, τ), σ))`` with
   ``φ(x_goal) = 0``, where ``τ`` is a demonstrated wrist trajectory, ``x_n`` the point of ``τ``
   nearest to ``x`` and ``‖v(x_n)‖`` the hand's speed there, the peak of the Gaussian. The front
   moves at the hand's speed along the demonstration and slows down away from it, so ``φ`` is the
   time the hand needs to reach the goal and its descent follows the demonstration.
   ``D_toa = 1 / max(φ, ε)``; inside obstacles ``φ = ∞`` and ``D_toa = 0`` (§4.2's ``x_O``).

Fast marching is scikit-fmm's (``skfmm.distance``, ``skfmm.travel_time``): obstacles are the mask
of a masked ``phi`` (a mask on ``speed`` is ignored), masked or unreachable cells come back masked
and are read as ``∞`` here, and second order falls back to first order where scikit-fmm cannot
use it near obstacles.

Choices the paper does not state, ours:

- **Resolving thin walls.** A cell is blocked when a surface comes within half a cell of its
  centre (``sdf < h``, ``h = spacing / 2``). A shelf board thinner than a cell then still forms a
  wall that the 6-neighbour fast marching cannot leak through, and the front starts on the offset
  surface ``sdf = h``; ``h`` is added back, which is exact in free space (the distance to the level
  set ``{d = h}`` of a distance function is ``d − h``).
- ``ε = 2.5 cm`` for the distances at every scale (the paper's grid spacing), so the fields have the
  same range at toy and paper resolution, and ``ε = 0.1 s`` for the time (about three frames: the last
  stretch into the contact is flat in ``D_toa``).
- ``σ = 5 cm`` for the Gaussian PDF, normalised to peak 1 (the paper sets its peak to the hand's
  speed); a floor of ``10⁻³`` of the peak far from the demonstration, and a hand speed of at least
  10 cm/s (the wrist stops at the contact, where the front would otherwise stall).
- The front starts from a small ball (radius 1.5 cells) around ``x_goal``, whose free cells take
  ``φ = |x − x_goal| / v̄`` with ``v̄`` the demonstration's mean speed inside the ball (the wrist
  slows to a stop at the contact). The target is a wall only where a cell centre lies inside it
  (the wrist ends on its surface; a target widened by half a cell would wall off the approach).

Scaling (paper → toy): 2.5 cm cells in an (80 cm)³ cube (32³, §8.1) → 5 cm cells in the same
cube (16³) at ``toy``; ``small`` and ``paper`` use 2.5 cm.

Grid convention: :class:`FieldGrid` axes are the object-centric frame's x, y, z (yawed about +Z to
align with the surrounding furniture); array index ``[i, j, k]`` runs along local x, y, z
(``indexing="ij"``), so scikit-fmm's ``dx`` is the same spacing on every axis.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np
import skfmm
import torch
from scipy.spatial import cKDTree

from ..._validate import check_finite, check_shape
from ...infra import scaled_config

__all__ = [
    "FieldConfig",
    "FIELD_SCALES",
    "field_config",
    "FieldGrid",
    "object_grid",
    "fast_marching_distance",
    "fast_marching_time",
    "inverse_distance",
    "sdf_union",
    "target_distance",
    "obstacle_distance",
    "demonstration_speed",
    "time_of_arrival",
    "SceneFields",
    "scene_fields",
    "descend",
]


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class FieldConfig:
    """The fields' grid and constants (defaults: the ``toy`` preset).

    Attributes:
        extent: side of the object-centric cube, metres (CHOICE §8.1: 80 cm).
        spacing: grid cell side, metres (CHOICE §8.1: 2.5 cm; toy 5 cm).
        epsilon: ``ε`` of Eqs. 3 and 4, metres (ours).
        time_epsilon: ``ε`` of Eq. 6, seconds (ours).
        sigma: ``σ`` of Eq. 5's Gaussian PDF, metres (ours).
        speed_floor: smallest PDF value far from the demonstration, a fraction of its peak (ours).
        min_hand_speed: smallest ``‖v(x_n)‖`` used in Eq. 5, m/s (ours).
        goal_radius: radius of the ball around the goal the front starts from, in cells (ours).
        order: fast-marching order, 1 or 2 (2 falls back to 1 where scikit-fmm cannot use it).
    """

    extent: float = 0.8
    spacing: float = 0.05
    epsilon: float = 0.025
    time_epsilon: float = 0.1
    sigma: float = 0.05
    speed_floor: float = 1e-3
    min_hand_speed: float = 0.1
    goal_radius: float = 1.5
    order: int = 2

    def __post_init__(self):
        for name in ("extent", "spacing", "epsilon", "time_epsilon", "sigma", "speed_floor", "min_hand_speed", "goal_radius"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0:
                raise ValueError(f"{name}: expected a positive number, got {value!r}")
        if self.spacing * 4 > self.extent:
            raise ValueError(f"spacing: expected at most a quarter of extent ({self.extent} m), got {self.spacing}")
        if self.speed_floor >= 1:
            raise ValueError(f"speed_floor: expected a fraction in (0, 1), got {self.speed_floor}")
        if self.order not in (1, 2):
            raise ValueError(f"order: expected 1 or 2, got {self.order!r}")


# The paper's grid (CHOICE §8.1) at the larger scales.
FIELD_SCALES = {"small": {"spacing": 0.025}, "paper": {"spacing": 0.025}}


def field_config(scale: str = "toy", **overrides) -> FieldConfig:
    """The preset for ``scale``, fields overridable (``field_config("paper", sigma=0.08)``)."""
    return scaled_config(FieldConfig, scale, FIELD_SCALES, overrides, factory="field_config")


# ----------------------------------------------------------------------------- the grid


@dataclass(frozen=True, eq=False)
class FieldGrid:
    """A cubic grid of ``n³`` cells centred on ``centre``, its axes yawed by ``yaw`` about +Z.

    Attributes:
        centre: (3,) metres, world frame (the target object's centre in CHOICE).
        yaw: rotation of the grid's x, y axes about world +Z, radians (aligned with the furniture).
        n: cells per side.
        spacing: cell side, metres.
    """

    centre: np.ndarray
    yaw: float
    n: int
    spacing: float

    def __post_init__(self):
        centre = np.asarray(self.centre, dtype=np.float64)
        check_shape(centre, (3,), "centre")
        check_finite(centre, "centre")
        object.__setattr__(self, "centre", centre)
        if not isinstance(self.n, (int, np.integer)) or isinstance(self.n, bool) or self.n < 2:
            raise ValueError(f"n: expected an int >= 2 cells per side, got {self.n!r}")
        object.__setattr__(self, "n", int(self.n))
        if not self.spacing > 0:
            raise ValueError(f"spacing: expected a positive number of metres, got {self.spacing!r}")
        object.__setattr__(self, "yaw", float(self.yaw))

    @property
    def shape(self) -> tuple:
        return (self.n, self.n, self.n)

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3): grid axes (columns) in the world frame."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    @property
    def half_extent(self) -> float:
        """Half the cube's side, metres (cell centres lie within it by half a cell)."""
        return 0.5 * self.n * self.spacing

    def local_coordinates(self) -> np.ndarray:
        """(n,) metres: cell-centre coordinates along each local axis."""
        return (np.arange(self.n) + 0.5) * self.spacing - self.half_extent

    def to_local(self, points) -> np.ndarray:
        """World points (..., 3) metres → grid-frame points (..., 3) (origin at ``centre``)."""
        points = np.asarray(points, dtype=np.float64)
        check_shape(points, (..., 3), "points")
        return (points - self.centre) @ self.rotation

    def to_world(self, local) -> np.ndarray:
        """Grid-frame points (..., 3) → world points (..., 3) metres."""
        local = np.asarray(local, dtype=np.float64)
        check_shape(local, (..., 3), "local")
        return local @ self.rotation.T + self.centre

    def points(self) -> np.ndarray:
        """(n, n, n, 3) world positions of the cell centres, index ``[i, j, k]`` along local x, y, z."""
        u = self.local_coordinates()
        local = np.stack(np.meshgrid(u, u, u, indexing="ij"), axis=-1)
        return self.to_world(local)

    def contains(self, points) -> np.ndarray:
        """(...) bool: whether world points (..., 3) lie inside the cube."""
        return np.all(np.abs(self.to_local(points)) <= self.half_extent, axis=-1)

    def to_index(self, points) -> np.ndarray:
        """World points (..., 3) → continuous cell indices (..., 3) (cell centres at integers)."""
        return (self.to_local(points) + self.half_extent) / self.spacing - 0.5

    def cell_of(self, points) -> np.ndarray:
        """World points (..., 3) → indices (..., 3) int of the cells that hold them (clipped to the grid)."""
        return np.clip(np.round(self.to_index(points)).astype(np.int64), 0, self.n - 1)

    def sample(self, values, points) -> np.ndarray:
        """Trilinear interpolation of a grid field at world points.

        Args:
            values: (n, n, n) field; ``inf`` where undefined (an interpolation that touches an
                infinite corner returns ``inf``).
            points: (..., 3) metres, clamped to the cell centres' box.
        Returns:
            (...) interpolated values.
        """
        values = np.asarray(values, dtype=np.float64)
        check_shape(values, self.shape, "values")
        idx = np.clip(self.to_index(points), 0.0, self.n - 1.0)
        lo = np.minimum(np.floor(idx).astype(np.int64), self.n - 2)
        t = idx - lo
        out = np.zeros(idx.shape[:-1])
        for corner in range(8):
            bits = [(corner >> a) & 1 for a in range(3)]
            w = np.ones(idx.shape[:-1])
            for a in range(3):
                w = w * (t[..., a] if bits[a] else 1.0 - t[..., a])
            v = values[lo[..., 0] + bits[0], lo[..., 1] + bits[1], lo[..., 2] + bits[2]]
            with np.errstate(invalid="ignore"):
                out = out + np.where(w > 0, w * v, 0.0)
        return out


def object_grid(obj, config: FieldConfig = FieldConfig(), *, yaw: Optional[float] = None, centre=None) -> FieldGrid:
    """The object-centric grid ``E_t`` around ``obj`` (a ``ToyObject``): centred on the centre of its
    canonical box,
    ``config.extent`` wide, yawed like ``yaw`` (default: the object's own heading; pass the
    holding furniture's to align the grid with it, as CHOICE §4.2 does)."""
    if centre is None:  # the centre of its own box, so the grid moves rigidly with the object
        lo, hi = np.asarray(obj.canonical_bounds, dtype=np.float64)
        centre = obj.to_world(0.5 * (lo + hi))
    if yaw is None:
        rot = np.asarray(obj.rotation, dtype=np.float64)
        yaw = float(np.arctan2(rot[1, 0], rot[0, 0]))
    n = int(round(config.extent / config.spacing))
    return FieldGrid(np.asarray(centre, dtype=np.float64), yaw, n, config.spacing)


# ----------------------------------------------------------------------------- fast marching


def _masked_result(result, blocked) -> np.ndarray:
    data = np.asarray(np.ma.getdata(result), dtype=np.float64).copy()
    mask = np.ma.getmaskarray(result) | blocked
    data[mask] = np.inf
    return data


def _check_front(phi, blocked, name: str) -> None:
    if not np.any((phi < 0) & ~blocked):
        raise ValueError(f"{name}: expected the front (phi < 0) to cover at least one free grid cell; "
                         "is the source inside the grid and outside every obstacle?")


def fast_marching_distance(phi, blocked, spacing: float, order: int = 2) -> np.ndarray:
    """Distance (n, n, n) metres from the zero level set of ``phi`` through the free cells (Eq. 2).

    Args:
        phi: (n, n, n) level-set function, negative on the source side of the front (a 2D
            ``(H, W)`` grid works the same way).
        blocked: (n, n, n) bool walls (``‖∇d‖ = ∞``).
        spacing: cell side, metres.
        order: 2, falling back to 1 where scikit-fmm cannot use second order.
    Returns:
        (n, n, n) signed distance (negative on the source side); ``inf`` in walls and in cells
        the front cannot reach.
    """
    phi, blocked = _check_pair(phi, blocked)
    _check_front(phi, blocked, "fast_marching_distance")
    return _march(lambda o: skfmm.distance(np.ma.MaskedArray(phi, blocked), dx=float(spacing), order=o),
                  blocked, order)


def fast_marching_time(phi, speed, blocked, spacing: float, order: int = 2) -> np.ndarray:
    """Arrival time (n, n, n) seconds of a front leaving the zero level set of ``phi`` at ``speed``
    (``‖∇T‖ = 1 / speed``, Eq. 5). Unsigned (time inside the source region counts from its
    boundary too); ``inf`` in walls and unreachable cells.

    Args:
        phi: (n, n, n) level-set function, negative inside the source.
        speed: (n, n, n) positive front speed, m/s.
        blocked: (n, n, n) bool walls.
        spacing: cell side, metres.
    """
    phi, blocked = _check_pair(phi, blocked)
    speed = np.asarray(speed, dtype=np.float64)
    check_shape(speed, phi.shape, "speed")
    if not np.all(np.isfinite(speed[~blocked])) or np.any(speed[~blocked] <= 0):
        raise ValueError("speed: expected finite positive values in every free cell")
    _check_front(phi, blocked, "fast_marching_time")
    safe_speed = np.where(blocked, 1.0, speed)
    return _march(lambda o: skfmm.travel_time(np.ma.MaskedArray(phi, blocked), safe_speed, dx=float(spacing), order=o),
                  blocked, order)


def _check_pair(phi, blocked):
    phi = np.asarray(phi, dtype=np.float64)
    if phi.ndim not in (2, 3):
        raise ValueError(f"phi: expected a 2D or 3D grid (the chapters march on 2D slices too), got shape {phi.shape}")
    if phi.size == 0:
        raise ValueError("phi: expected a non-empty grid")
    blocked = np.asarray(blocked)
    if blocked.dtype != np.bool_:
        raise ValueError(f"blocked: expected a bool array, got dtype {blocked.dtype}")
    check_shape(blocked, phi.shape, "blocked")
    check_finite(phi, "phi")
    return phi, blocked


def _march(run: Callable, blocked, order: int) -> np.ndarray:
    if order not in (1, 2):
        raise ValueError(f"order: expected 1 or 2, got {order!r}")
    if order == 2:
        try:
            out = _masked_result(run(2), blocked)
            if not np.any(np.isnan(out)):
                return out
        except (ValueError, RuntimeError):
            pass  # scikit-fmm cannot always use order 2 next to masked cells: first order below
    return _masked_result(run(1), blocked)


def inverse_distance(d, epsilon: float) -> np.ndarray:
    """``1 / max(d, ε)`` (Eqs. 3, 4, 6); ``0`` where ``d`` is ``inf`` (walls, unreachable cells)."""
    d = np.asarray(d, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return np.where(np.isinf(d), 0.0, 1.0 / np.maximum(d, float(epsilon)))


# ----------------------------------------------------------------------------- the three fields


def sdf_union(things) -> Callable:
    """One signed distance (the minimum) from objects with ``.sdf(points)`` and/or callables
    ``points (..., 3) -> (...)``: numpy points give float64 numpy, torch points a (differentiable)
    tensor; with nothing in ``things`` every point is infinitely far."""
    parts = []
    for k, thing in enumerate(things):
        if hasattr(thing, "sdf"):
            parts.append(thing.sdf)
        elif callable(thing):
            parts.append(thing)
        else:
            raise TypeError(f"obstacles[{k}]: expected an object with .sdf(points) or a callable, got {type(thing).__name__}")

    def sdf(points):
        if isinstance(points, torch.Tensor):
            if not parts:
                return torch.full(points.shape[:-1], float("inf"), dtype=points.dtype, device=points.device)
            return torch.stack([p(points) for p in parts], dim=0).min(dim=0).values
        if not parts:
            return np.full(np.shape(points)[:-1], np.inf)
        return np.min(np.stack([np.asarray(p(points), dtype=np.float64) for p in parts], axis=0), axis=0)

    return sdf


def _grid_sdf(grid: FieldGrid, things) -> np.ndarray:
    """(n, n, n) the union SDF of ``things`` (one object, a callable or a list of them) at the cell centres."""
    things = list(things) if isinstance(things, (list, tuple)) else [things]
    return sdf_union(things)(grid.points().reshape(-1, 3)).reshape(grid.shape)


def target_distance(grid: FieldGrid, target_sdf, obstacle_sdf, order: int = 2) -> np.ndarray:
    """``d(x, M_t)`` of Eq. 2 on the grid, metres: fast marching from the target's surface, the
    obstacles as walls; 0 inside the target, ``inf`` in obstacles and unreachable cells.

    Args:
        grid: the object-centric grid.
        target_sdf: (n, n, n) the target's signed distance at the cell centres, metres.
        obstacle_sdf: (n, n, n) the obstacles' (union) signed distance, metres (``inf``: none).
    """
    h = 0.5 * grid.spacing
    blocked = (np.asarray(obstacle_sdf) < h) & ~(np.asarray(target_sdf) < h)
    d = fast_marching_distance(np.asarray(target_sdf) - h, blocked, grid.spacing, order) + h
    return np.where(np.asarray(target_sdf) < h, np.maximum(np.asarray(target_sdf), 0.0), np.maximum(d, 0.0))


def obstacle_distance(grid: FieldGrid, target_sdf, obstacle_sdf, order: int = 2) -> np.ndarray:
    """``min_i d(x, M_Oi)`` of Eq. 4 on the grid, metres: fast marching from the obstacles'
    surfaces, the target a wall; 0 inside obstacles, ``inf`` inside the target and where no
    obstacle is reachable (or there is none)."""
    obstacle_sdf = np.asarray(obstacle_sdf)
    h = 0.5 * grid.spacing
    inside = obstacle_sdf < h
    if not inside.any():
        return np.full(grid.shape, np.inf)
    blocked = (np.asarray(target_sdf) < h) & ~inside
    d = fast_marching_distance(obstacle_sdf - h, blocked, grid.spacing, order) + h
    return np.where(inside, np.maximum(obstacle_sdf, 0.0), np.maximum(d, 0.0))


def _densify(trajectory, speeds, step):
    """Points along the polyline every ≤ ``step`` metres, with linearly interpolated speeds."""
    pts, vs = [trajectory[:1]], [speeds[:1]]
    for a in range(len(trajectory) - 1):
        seg = trajectory[a + 1] - trajectory[a]
        m = max(1, int(np.ceil(np.linalg.norm(seg) / step)))
        u = (np.arange(1, m + 1) / m)[:, None]
        pts.append(trajectory[a] + u * seg)
        vs.append(speeds[a] + u[:, 0] * (speeds[a + 1] - speeds[a]))
    return np.concatenate(pts), np.concatenate(vs)


def _check_trajectory(trajectory, fps) -> np.ndarray:
    trajectory = np.asarray(trajectory, dtype=np.float64)
    check_shape(trajectory, (None, 3), "trajectory")
    if len(trajectory) < 2:
        raise ValueError(f"trajectory: expected at least 2 frames, got {len(trajectory)}")
    check_finite(trajectory, "trajectory")
    if not fps > 0:
        raise ValueError(f"fps: expected a positive frame rate, got {fps!r}")
    return trajectory


def demonstration_speed(grid: FieldGrid, trajectory, fps: float, config: FieldConfig = FieldConfig()) -> tuple:
    """The front speed of Eq. 5: ``‖v(x_n)‖ · PDF(d(x, τ), σ)`` with the PDF's peak at 1.

    Args:
        grid: the object-centric grid.
        trajectory: (T, 3) demonstrated wrist positions, metres, world frame (any order).
        fps: frames per second of ``trajectory``.
    Returns:
        ``(speed (n, n, n) m/s, distance_to_trajectory (n, n, n) metres)``.
    """
    trajectory = _check_trajectory(trajectory, fps)
    hand_speed = np.linalg.norm(np.gradient(trajectory, axis=0), axis=-1) * float(fps)
    hand_speed = np.maximum(hand_speed, config.min_hand_speed)
    dense, dense_speed = _densify(trajectory, hand_speed, 0.25 * grid.spacing)
    dist, nearest = cKDTree(dense).query(grid.points().reshape(-1, 3))
    pdf = np.maximum(np.exp(-0.5 * (dist / config.sigma) ** 2), config.speed_floor)
    return (dense_speed[nearest] * pdf).reshape(grid.shape), dist.reshape(grid.shape)


def time_of_arrival(grid: FieldGrid, trajectory, fps: float, blocked, config: FieldConfig = FieldConfig(), *,
                    goal=None) -> np.ndarray:
    """``φ`` of Eq. 5, seconds: the hand's time to reach the goal from each cell.

    Args:
        grid: the object-centric grid.
        trajectory: (T, 3) demonstrated wrist positions, metres, ordered so that the LAST frame is
            ``x_goal`` (the first contact when reaching; reverse a leaving segment so that its
            release point comes last).
        fps: frames per second of ``trajectory``.
        blocked: (n, n, n) bool walls (target and obstacles); the goal needs a free cell within
            ``config.goal_radius`` cells.
        goal: (3,) metres, the goal (default ``trajectory[-1]``).
    Returns:
        (n, n, n) seconds; 0 at the goal, ``inf`` in walls and unreachable cells.
    """
    trajectory = _check_trajectory(trajectory, fps)
    goal = trajectory[-1] if goal is None else np.asarray(goal, dtype=np.float64)
    check_shape(goal, (3,), "goal")
    if not grid.contains(goal):
        raise ValueError(f"goal: expected a point inside the grid (centre {grid.centre.round(3).tolist()}, "
                         f"half extent {grid.half_extent} m), got {goal.round(3).tolist()}")
    blocked = np.asarray(blocked)
    if blocked.dtype != np.bool_:
        raise ValueError(f"blocked: expected a bool array, got dtype {blocked.dtype}")
    check_shape(blocked, grid.shape, "blocked")
    speed, _ = demonstration_speed(grid, trajectory, fps, config)
    radius = config.goal_radius * grid.spacing
    to_goal = np.linalg.norm(grid.points() - goal, axis=-1)
    ball = (to_goal < radius) & ~blocked
    if not ball.any():
        raise ValueError(f"goal: expected a free grid cell within {config.goal_radius} cells of the goal "
                         f"{goal.round(3).tolist()}; it is walled in (inside an obstacle?)")
    walls = blocked
    goal_speed = _speed_near_goal(trajectory, goal, radius, fps, config.min_hand_speed)
    t = fast_marching_time(to_goal - radius, speed, walls, grid.spacing, config.order)
    # the front leaves the ball's surface at time radius / v̄; inside the ball, straight to the goal
    return np.where(ball, to_goal / goal_speed, np.where(blocked, np.inf, t + radius / goal_speed))


def _speed_near_goal(trajectory, goal, radius, fps, min_speed) -> float:
    """The demonstration's mean speed inside the goal ball, m/s: path length over time there."""
    inside = np.linalg.norm(trajectory - goal, axis=-1) < radius
    first = len(trajectory) - 1
    while first > 0 and inside[first - 1]:
        first -= 1
    start = max(first - 1, 0)  # include the step that enters the ball
    tail = trajectory[start:]
    length = float(np.linalg.norm(np.diff(tail, axis=0), axis=-1).sum())
    duration = (len(tail) - 1) / float(fps)
    if duration <= 0:
        return float(min_speed)
    return max(length / duration, float(min_speed))


@dataclass
class SceneFields:
    """The three fields of Eq. 1 on one grid, with the raw distances and times behind them.

    Attributes:
        grid: the object-centric grid.
        target_sdf, obstacle_sdf: (n, n, n) signed distances at the cell centres, metres.
        d_target: (n, n, n) ``d(x, M_t)`` metres (Eq. 2), ``inf`` in obstacles/unreachable.
        d_obstacle: (n, n, n) distance to the nearest obstacle, metres, ``inf`` in the target.
        time: (n, n, n) ``φ`` seconds (Eq. 5), or None without a demonstration.
        D_t, D_o: (n, n, n) inverse distances (Eqs. 3–4), 1/metres.
        D_toa: (n, n, n) inverse time of arrival (Eq. 6), 1/seconds, or None.
        config: the constants used.
    """

    grid: FieldGrid
    target_sdf: np.ndarray
    obstacle_sdf: np.ndarray
    d_target: np.ndarray
    d_obstacle: np.ndarray
    time: Optional[np.ndarray]
    D_t: np.ndarray
    D_o: np.ndarray
    D_toa: Optional[np.ndarray]
    config: FieldConfig

    @property
    def blocked(self) -> np.ndarray:
        """(n, n, n) bool: the walls of Eq. 5 (:func:`scene_fields`)."""
        return _arrival_walls(self.grid, self.target_sdf, self.obstacle_sdf)

    @property
    def epsilons(self) -> np.ndarray:
        """(3,) the ``ε`` of ``(D_t, D_o, D_toa)``: each field times its ``ε`` lies in [0, 1]."""
        return np.array([self.config.epsilon, self.config.epsilon, self.config.time_epsilon])

    def stacked(self) -> np.ndarray:
        """(n, n, n, 3) ``(D_t, D_o, D_toa)`` — Eq. 1's ``D(x)`` per cell (needs a demonstration)."""
        if self.D_toa is None:
            raise ValueError("stacked: these fields were computed without a demonstration (no D_toa)")
        return np.stack([self.D_t, self.D_o, self.D_toa], axis=-1)


def _arrival_walls(grid, target_sdf, obstacle_sdf) -> np.ndarray:
    # Obstacles within half a cell are walls (thin boards resolved); the target only where a cell
    # centre is inside it: the wrist ends on its surface, and an inflated target would wall off
    # the last centimetres of every approach.
    return (np.asarray(target_sdf) < 0.0) | (np.asarray(obstacle_sdf) < 0.5 * grid.spacing)


def scene_fields(grid: FieldGrid, target, obstacles: Sequence = (), trajectory=None, fps: float = 30.0,
                 config: FieldConfig = FieldConfig()) -> SceneFields:
    """Eq. 1's three fields around ``target`` among ``obstacles``.

    Args:
        grid: the object-centric grid (:func:`object_grid`).
        target: the target object (anything with ``.sdf(points)``, world frame) or a callable SDF.
        obstacles: objects with ``.sdf`` or callables (furniture, other items, a scene's walls).
        trajectory: (T, 3) demonstrated wrist positions, metres, the goal last; None: no ``D_toa``.
        fps: frames per second of ``trajectory``.
        config: constants (:func:`field_config`).
    """
    target_sdf = _grid_sdf(grid, target)
    if not np.any(target_sdf < 0.5 * grid.spacing):
        raise ValueError("target: expected the target object inside the grid (no cell is within half a cell of it)")
    obstacle_sdf = _grid_sdf(grid, list(obstacles))
    d_t = target_distance(grid, target_sdf, obstacle_sdf, config.order)
    d_o = obstacle_distance(grid, target_sdf, obstacle_sdf, config.order)
    time = None
    if trajectory is not None:
        time = time_of_arrival(grid, trajectory, fps, _arrival_walls(grid, target_sdf, obstacle_sdf), config)
    return SceneFields(
        grid=grid, target_sdf=target_sdf, obstacle_sdf=obstacle_sdf, d_target=d_t, d_obstacle=d_o, time=time,
        D_t=inverse_distance(d_t, config.epsilon), D_o=inverse_distance(d_o, config.epsilon),
        D_toa=None if time is None else inverse_distance(time, config.time_epsilon), config=config,
    )


# ----------------------------------------------------------------------------- following a field


_NEIGHBOURS = np.array([(a, b, c) for a in (-1, 0, 1) for b in (-1, 0, 1) for c in (-1, 0, 1) if (a, b, c) != (0, 0, 0)])
_NEIGHBOUR_LENGTHS = np.linalg.norm(_NEIGHBOURS, axis=1)


def descend(grid: FieldGrid, time, start, *, max_steps: Optional[int] = None) -> np.ndarray:
    """The path down a time-of-arrival field from ``start`` to its source: steepest descent from
    cell to cell over the 26 neighbours (the largest drop of ``φ`` per metre), the direction of
    Eq. 10's velocity on a grid. Fast marching gives every reached cell a neighbour that arrived
    earlier, so the descent ends at the source (the goal's cell) and never enters a wall.

    Args:
        grid: the grid of ``time``.
        time: (n, n, n) ``φ`` seconds (``inf`` in walls and unreachable cells).
        start: (3,) metres, world frame, inside the grid and in a reached cell.
        max_steps: at most this many cells (default ``3 n``).
    Returns:
        (K, 3) world positions: ``start``, then the centres of the cells passed, ending in the
        cell of least ``φ`` around it.
    """
    time = np.asarray(time, dtype=np.float64)
    check_shape(time, grid.shape, "time")
    start = np.asarray(start, dtype=np.float64)
    check_shape(start, (3,), "start")
    if not grid.contains(start):
        raise ValueError(f"start: expected a point inside the grid, got {start.round(3).tolist()}")
    cell = grid.cell_of(start)
    if not np.isfinite(time[tuple(cell)]):
        raise ValueError(f"start: its cell {cell.tolist()} is a wall or unreachable (time = inf)")
    u = grid.local_coordinates()
    path = [start]
    for _ in range(3 * grid.n if max_steps is None else int(max_steps)):
        nb = cell + _NEIGHBOURS
        ok = np.all((nb >= 0) & (nb < grid.n), axis=1)
        drop = np.full(len(nb), -np.inf)
        values = time[nb[ok, 0], nb[ok, 1], nb[ok, 2]]
        drop[ok] = (time[tuple(cell)] - values) / _NEIGHBOUR_LENGTHS[ok]
        best = int(np.argmax(drop))
        if not drop[best] > 0:
            break
        cell = nb[best]
        path.append(grid.to_world(u[cell]))
    return np.stack(path)
