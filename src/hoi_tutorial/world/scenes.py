"""Procedural scenes: cluttered rooms (SAMP navigation and sitting) and kitchens (CHOICE pick-and-place).

A scene covers the rectangle ``[0, size_x] × [0, size_y]`` of the floor (z = 0), closed by four
walls. Navigation uses a 2D grid of square cells of ``cell_size`` metres: array index
``[i, j]`` is row ``i`` along +y and column ``j`` along +x, the cell centre being
``((j + 0.5)·cell, (i + 0.5)·cell)``; ``plt.imshow(grid, origin="lower", extent=scene.extent)``
draws it the right way up. A cell is blocked when its centre lies in the footprint (vertical
projection) of an object part that reaches into the body's height band ``FOOTPRINT_BAND``;
footprints are not inflated (use ``inflated_occupancy(radius)`` for a body of that radius).
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np
import torch

from .._validate import check_choice, check_shape
from .objects import (
    GRASPABLE,
    SITTABLE,
    ToyObject,
    as_rng,
    make_object,
    object_from_description,
)
from .primitives import box, union_sdf

__all__ = [
    "FOOTPRINT_BAND",
    "WALL_THICKNESS",
    "WALL_HEIGHT",
    "CLUTTER_CATEGORIES",
    "Room",
    "Kitchen",
    "make_room",
    "make_kitchen",
    "room_layout",
    "room_from_layout",
]

FOOTPRINT_BAND = (0.05, 1.8)  # heights (m) a standing body occupies; parts wholly outside do not block
WALL_THICKNESS = 0.1
WALL_HEIGHT = 2.5
CLUTTER_CATEGORIES = ("table", "box", "stool", "sofa", "chair", "armchair")


def _wall_primitives(size):
    lx, ly = size
    t, h = WALL_THICKNESS, WALL_HEIGHT
    return [
        box((-t / 2, ly / 2, h / 2), (t / 2, ly / 2 + t, h / 2), name="wall"),
        box((lx + t / 2, ly / 2, h / 2), (t / 2, ly / 2 + t, h / 2), name="wall"),
        box((lx / 2, -t / 2, h / 2), (lx / 2 + t, t / 2, h / 2), name="wall"),
        box((lx / 2, ly + t / 2, h / 2), (lx / 2 + t, t / 2, h / 2), name="wall"),
    ]


def _objects_footprint_distance(objects, xy) -> np.ndarray:
    """Horizontal distance (N,) metres from ``xy`` (N, 2) to the union of the objects' footprints."""
    out = np.full(len(xy), np.inf)
    for obj in objects:
        for part in obj.footprints(FOOTPRINT_BAND):
            out = np.minimum(out, part.distance(xy))
    return out


class _GridScene:
    """Shared 2D-grid and distance logic; subclasses provide ``size``, ``cell_size`` and ``objects``."""

    def _init_grid(self, footprint_grid=None):
        self.size = np.asarray(self.size, dtype=np.float64).reshape(2)
        if np.any(self.size <= 0) or self.cell_size <= 0:
            raise ValueError(f"size, cell_size: expected positive values, got {self.size.tolist()}, {self.cell_size}")
        self.shape = tuple(int(np.ceil(s / self.cell_size - 1e-9)) for s in self.size[::-1])  # (H, W)
        centres = self.grid_to_world(np.stack(np.meshgrid(*map(np.arange, self.shape), indexing="ij"), -1))
        flat = centres.reshape(-1, 2)
        if footprint_grid is None:
            footprint_grid = _objects_footprint_distance(self.objects, flat).reshape(self.shape)
        self._footprint_grid = footprint_grid
        self._clearance_grid = np.minimum(self._footprint_grid, self._wall_distance(flat).reshape(self.shape))
        self._walls = _wall_primitives(self.size)

    # ------------------------------------------------------------------ grid geometry

    @property
    def extent(self) -> tuple:
        """(x_min, x_max, y_min, y_max) metres of the grid, for ``imshow(..., origin="lower")``."""
        return (0.0, self.shape[1] * self.cell_size, 0.0, self.shape[0] * self.cell_size)

    def grid_to_world(self, ij) -> np.ndarray:
        """Cell indices (..., 2) ``[i (row, y), j (column, x)]`` → cell-centre xy (..., 2) metres."""
        ij = np.asarray(ij)
        check_shape(ij, (..., 2), "ij")
        return (ij[..., ::-1].astype(np.float64) + 0.5) * self.cell_size

    def world_to_grid(self, xy) -> np.ndarray:
        """Floor points xy (..., 2) metres → indices (..., 2) int ``[i, j]`` of their cells (unclipped)."""
        xy = np.asarray(xy, dtype=np.float64)
        check_shape(xy, (..., 2), "xy")
        return np.floor(xy[..., ::-1] / self.cell_size).astype(np.int64)

    def in_grid(self, ij) -> np.ndarray:
        """Whether indices (..., 2) lie inside the grid: (...) bool."""
        ij = np.asarray(ij)
        return (ij[..., 0] >= 0) & (ij[..., 0] < self.shape[0]) & (ij[..., 1] >= 0) & (ij[..., 1] < self.shape[1])

    # ------------------------------------------------------------------ distances

    def _wall_distance(self, xy) -> np.ndarray:
        xy = np.asarray(xy, dtype=np.float64)
        d = np.minimum.reduce([xy[..., 0], self.size[0] - xy[..., 0], xy[..., 1], self.size[1] - xy[..., 1]])
        return np.clip(d, 0.0, None)

    def footprint_distance(self, xy) -> np.ndarray:
        """Horizontal distance (...) metres from xy (..., 2) to the nearest object footprint (0 inside one)."""
        xy = np.asarray(xy, dtype=np.float64)
        check_shape(xy, (..., 2), "xy")
        return _objects_footprint_distance(self.objects, xy.reshape(-1, 2)).reshape(xy.shape[:-1])

    def obstacle_distance(self, xy) -> np.ndarray:
        """Horizontal clearance (...) metres of xy (..., 2): distance to the nearest footprint or wall (0 when blocked)."""
        return np.minimum(self.footprint_distance(xy), self._wall_distance(xy))

    def is_free(self, xy) -> np.ndarray:
        """Whether floor points xy (..., 2) metres are inside the room and outside every footprint: (...) bool."""
        return self.obstacle_distance(xy) > 0.0

    @property
    def occupancy(self) -> np.ndarray:
        """(H, W) bool, True where the cell centre lies in an object's footprint (no inflation)."""
        return self._footprint_grid <= 0.0

    @property
    def clearance(self) -> np.ndarray:
        """(H, W) metres: horizontal distance from each cell centre to the nearest footprint or wall."""
        return self._clearance_grid.copy()

    def inflated_occupancy(self, radius: float) -> np.ndarray:
        """(H, W) bool: cells whose centre is closer than ``radius`` metres to a footprint or a wall
        (where a disc-shaped body of that radius cannot stand)."""
        return self._clearance_grid < radius

    def sdf(self, points):
        """Signed distance (...) metres to everything in the scene (objects and walls; not the floor).

        Args:
            points: (..., 3) metres, world frame; torch (differentiable) or numpy.
        """
        check_shape(points, (..., 3), "points")
        parts = [obj.sdf(points) for obj in self.objects] + [union_sdf(points, self._walls)]
        if isinstance(points, torch.Tensor):
            return torch.stack(parts, dim=-1).min(dim=-1).values
        return np.min(np.stack(parts, axis=-1), axis=-1)

    # ------------------------------------------------------------------ connectivity

    def free_component(self, xy, radius: float) -> np.ndarray:
        """(H, W) bool: the cells a body of ``radius`` metres reaches from the free cell nearest to xy (2,).

        Breadth-first search over 4-connected cells of ``~inflated_occupancy(radius)``.
        """
        free = ~self.inflated_occupancy(radius)
        if not free.any():
            return free
        start = self.world_to_grid(np.asarray(xy, dtype=np.float64))
        if not (self.in_grid(start) and free[tuple(start)]):
            cells = np.argwhere(free)
            start = cells[np.argmin(np.linalg.norm(self.grid_to_world(cells) - np.asarray(xy), axis=1))]
        return _bfs(free, tuple(int(v) for v in start))

    def _sample_in_mask(self, mask, n, rng, clearance):
        # a point anywhere in a cell is within cell/√2 of its centre; clearance is 1-Lipschitz
        margin = self.cell_size / np.sqrt(2.0)
        cells = np.argwhere(mask & (self._clearance_grid >= clearance + margin))
        if len(cells) == 0:
            raise ValueError(f"start_positions: no free cell with clearance {clearance} m in the reachable area")
        pick = cells[rng.choice(len(cells), size=n, replace=len(cells) < n)]
        jitter = rng.uniform(-0.5, 0.5, size=(n, 2)) * self.cell_size
        return self.grid_to_world(pick) + jitter

    # ------------------------------------------------------------------ drawing

    def _draw(self, ax, highlight=()):
        ax.imshow(self.occupancy, origin="lower", extent=self.extent, cmap="Greys", alpha=0.35, interpolation="nearest")
        for k, obj in enumerate(self.objects):
            colour = "tab:red" if k in highlight else "tab:blue"
            lo, hi = obj.bounds
            ax.add_patch(_rectangle(lo, hi, colour))
            ax.text((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, obj.category, ha="center", va="center", fontsize=7)
        ax.set_xlim(0, self.size[0])
        ax.set_ylim(0, self.size[1])
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        return ax


def _rectangle(lo, hi, colour):
    from matplotlib.patches import Rectangle

    return Rectangle((lo[0], lo[1]), hi[0] - lo[0], hi[1] - lo[1], fill=False, edgecolor=colour, linewidth=1.0)


def _bfs(free: np.ndarray, start: tuple) -> np.ndarray:
    """Cells of ``free`` (H, W) 4-connected to ``start`` (i, j)."""
    seen = np.zeros_like(free, dtype=bool)
    if not free[start]:
        return seen
    seen[start] = True
    queue = deque([start])
    H, W = free.shape
    while queue:
        i, j = queue.popleft()
        for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            a, b = i + di, j + dj
            if 0 <= a < H and 0 <= b < W and free[a, b] and not seen[a, b]:
                seen[a, b] = True
                queue.append((a, b))
    return seen


# ----------------------------------------------------------------------------- rooms


@dataclass(eq=False)
class Room(_GridScene):
    """A rectangular room with a target object and clutter (SAMP §3.3 navigation, §4 sitting).

    Attributes:
        size: (2,) metres, the floor is ``[0, size[0]] × [0, size[1]]``.
        objects: placed ``ToyObject``s (world poses set).
        target_index: index of the object to interact with.
        cell_size: grid cell side, metres.
        body_radius: radius (m) of the disc a walking body needs (default clearance).
    """

    size: np.ndarray
    objects: list
    target_index: int = 0
    cell_size: float = 0.05
    body_radius: float = 0.25

    def __post_init__(self):
        if not 0 <= self.target_index < len(self.objects):
            raise ValueError(f"target_index: expected an index into {len(self.objects)} objects, got {self.target_index}")
        self._init_grid()

    @property
    def target(self) -> ToyObject:
        """The object to interact with."""
        return self.objects[self.target_index]

    def standing_point(self, position, direction, radius: float | None = None,
                       max_distance: float = 1.2) -> np.ndarray:
        """Where a body of ``radius`` can stand in front of a goal on furniture: (2,) xy metres.

        Walks from ``position`` along the ground-plane part of ``direction`` (half a cell at a time,
        0.3 m to ``max_distance``) to the first point whose clearance is at least ``radius``.

        Args:
            position: (3,) or (2,) metres, world frame (a sit goal's pelvis, say).
            direction: (3,) or (2,) the goal's forward direction.
            radius: body radius in metres (default ``body_radius``).
        Raises:
            ValueError: a direction with no ground-plane part, or no standing spot along it.
        """
        radius = self.body_radius if radius is None else radius
        start = np.asarray(position, dtype=np.float64).reshape(-1)[:2]
        heading = np.asarray(direction, dtype=np.float64).reshape(-1)[:2]
        if start.shape != (2,) or heading.shape != (2,) or not np.all(np.isfinite(np.r_[start, heading])):
            raise ValueError(f"position, direction: expected finite (3,) or (2,) vectors, got {position!r}, {direction!r}")
        norm = float(np.linalg.norm(heading))
        if norm < 1e-6:
            raise ValueError(f"direction: expected a direction with a ground-plane part, got {direction!r}")
        steps = np.arange(0.3, max_distance + 1e-9, self.cell_size / 2)
        candidates = start + steps[:, None] * heading / norm
        # outside the room the wall distance is 0, so no candidate there passes
        ok = np.flatnonzero(self.obstacle_distance(candidates) >= radius)
        if len(ok) == 0:
            raise ValueError(f"standing_point: no standing spot with clearance {radius:g} m within {max_distance:g} m "
                             f"in front of the goal at [{start[0]:.2f}, {start[1]:.2f}] m")
        return candidates[ok[0]]

    def approach_point(self, goal_index: int = 0, radius: float | None = None) -> np.ndarray:
        """Where a body of ``radius`` can stand in front of the target's sit goal ``goal_index``:
        (2,) xy metres (:meth:`standing_point`). Raises ``ValueError`` when there is none.
        """
        radius = self.body_radius if radius is None else radius
        positions, directions = self.target.sit_goals
        if not 0 <= goal_index < len(positions):
            raise ValueError(f"goal_index: expected an index into {len(positions)} sit goals, got {goal_index}")
        try:
            return self.standing_point(positions[goal_index], directions[goal_index], radius)
        except ValueError:
            raise ValueError(f"approach_point: sit goal {goal_index} has no standing spot with clearance {radius} m") \
                from None

    def reachable_mask(self, radius: float | None = None, goal_index: int = 0) -> np.ndarray:
        """(H, W) bool: cells from which a body of ``radius`` walks to the target's approach point."""
        radius = self.body_radius if radius is None else radius
        return self.free_component(self.approach_point(goal_index, radius), radius)

    def reachable_fraction(self, radius: float | None = None, goal_index: int = 0) -> float:
        """Share of the free cells (for a body of ``radius``) that reach the target's approach point."""
        radius = self.body_radius if radius is None else radius
        free = ~self.inflated_occupancy(radius)
        return float(self.reachable_mask(radius, goal_index).sum() / max(free.sum(), 1))

    def start_positions(self, n: int, seed=0, clearance: float | None = None) -> np.ndarray:
        """``n`` start points (n, 2) xy metres, at least ``clearance`` from footprints and walls, from
        which the target's approach point is reachable by a body of radius ``clearance``."""
        clearance = self.body_radius if clearance is None else float(clearance)
        return self._sample_in_mask(self.reachable_mask(clearance), int(n), as_rng(seed), clearance)

    def top_down(self, ax=None):
        """Draw occupancy, object boxes and the target's sit goals (matplotlib axes, created if None)."""
        import matplotlib.pyplot as plt

        ax = ax if ax is not None else plt.gca()
        self._draw(ax, highlight=(self.target_index,))
        positions, directions = self.target.sit_goals
        ax.quiver(positions[:, 0], positions[:, 1], directions[:, 0], directions[:, 1], color="tab:red", scale=12)
        return ax


_TRUNCATION = 0.6  # metres: footprint distances beyond this are stored as inf while placing


def _place(obj, rng, scene_size, d_old, centres, cell, gap, *, region=None, wall_margin=0.05, tries=40, yaw=None, xy=None):
    """Rejection-sample a pose for ``obj`` whose footprint keeps ``gap`` metres from ``d_old``.

    ``d_old`` (H·W,) is the distance from the cell centres to the footprints already placed
    (inf beyond ``_TRUNCATION`` from an object's bounding box).
    Since footprint distances are 1-Lipschitz, ``min(d_new + d_old) >= gap + cell·√2`` over the
    cell centres guarantees a true separation of at least ``gap``.
    Returns the placed object and its distance map, or (None, None).
    """
    threshold = gap + cell * np.sqrt(2.0)
    if threshold > _TRUNCATION:
        raise ValueError(f"gap: expected at most {_TRUNCATION - cell * np.sqrt(2.0):.2f} m, got {gap}")
    region = region if region is not None else (np.zeros(2), np.asarray(scene_size))
    for _ in range(tries):
        pose_xy = xy() if callable(xy) else rng.uniform(region[0], region[1])
        pose_yaw = yaw() if callable(yaw) else rng.uniform(-np.pi, np.pi)
        cand = obj.placed(pose_xy[0], pose_xy[1], pose_yaw)
        lo, hi = cand.bounds
        if np.any(lo[:2] < wall_margin) or np.any(hi[:2] > np.asarray(scene_size) - wall_margin):
            continue
        # cells farther than _TRUNCATION from the bounding box cannot fail a test with a smaller
        # threshold, so their distance is left at inf (the truncated map stays exact for the tests)
        near = np.all((centres >= lo[:2] - _TRUNCATION) & (centres <= hi[:2] + _TRUNCATION), axis=1)
        d_new = np.full(len(centres), np.inf)
        d_new[near] = _objects_footprint_distance([cand], centres[near])
        if np.min(d_new[near] + d_old[near], initial=np.inf) >= threshold:
            return cand, d_new
    return None, None


def _grid_centres(size, cell):
    H, W = (int(np.ceil(s / cell - 1e-9)) for s in np.asarray(size)[::-1])
    i, j = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    return np.stack([(j + 0.5) * cell, (i + 0.5) * cell], axis=-1).reshape(-1, 2)


def room_layout(room: Room) -> dict:
    """What ``room`` is, as the artifact cache stores it (``infra.load_or_build``): its size, grid settings, every
    object's category, sizes and pose, and its footprint distance grid as computed (the slow part of making a room).
    :func:`room_from_layout` gives the room back."""
    if not isinstance(room, Room):
        raise TypeError(f"room: expected a Room, got {type(room).__name__}")
    return {"size": np.asarray(room.size, dtype=np.float64), "target_index": int(room.target_index),
            "cell_size": float(room.cell_size), "body_radius": float(room.body_radius),
            "objects": [{"category": o.category, "params": dict(o.params), "pose": np.asarray(o.pose)}
                        for o in room.objects],
            "footprint_grid": np.asarray(room._footprint_grid)}


def room_from_layout(layout: dict) -> Room:
    """The :class:`Room` of :func:`room_layout`: its objects rebuilt from their sizes and poses
    (``objects.object_from_description``) and the footprint grid it stored, the same room bit for bit."""
    names = ("size", "target_index", "cell_size", "body_radius", "objects", "footprint_grid")
    if not isinstance(layout, dict) or set(layout) != set(names):
        raise ValueError(f"layout: expected a dict with the keys {list(names)} (room_layout), got "
                         f"{sorted(layout) if isinstance(layout, dict) else type(layout).__name__}")
    room = Room.__new__(Room)
    room.size, room.target_index = layout["size"], int(layout["target_index"])
    room.cell_size, room.body_radius = float(layout["cell_size"]), float(layout["body_radius"])
    room.objects = [object_from_description(o) for o in layout["objects"]]
    if not 0 <= room.target_index < len(room.objects):
        raise ValueError(f"layout['target_index']: expected an index into {len(room.objects)} objects, "
                         f"got {room.target_index}")
    grid = np.asarray(layout["footprint_grid"], dtype=np.float64)
    shape = tuple(int(np.ceil(s / room.cell_size - 1e-9)) for s in np.asarray(room.size, dtype=np.float64)[::-1])
    check_shape(grid, shape, "layout['footprint_grid']")
    room._init_grid(grid)
    return room


def make_room(
    seed=0,
    *,
    size=(6.0, 6.0),
    n_clutter: int = 6,
    target_category: str = "chair",
    cell_size: float = 0.05,
    body_radius: float = 0.25,
    gap: float = 0.05,
    max_attempts: int = 50,
) -> Room:
    """A room with a sittable target object and clutter, deterministic for a seed.

    The target is placed in the middle part of the room, then ``n_clutter`` objects from
    ``CLUTTER_CATEGORIES`` by rejection sampling of non-overlapping footprints (at least ``gap``
    metres apart; an object that finds no place after 40 tries is left out). A layout is kept
    when the target's first sit goal is reachable (breadth-first search on the grid inflated
    by ``body_radius``) from at least half of the free cells; otherwise it is redrawn.

    Args:
        seed: int or ``numpy.random.Generator``.
        size: (2,) room size in metres.
        target_category: one of ``SITTABLE``.
    """
    check_choice(target_category, SITTABLE, "target_category")
    rng = as_rng(seed)
    size = np.asarray(size, dtype=np.float64)
    centres = _grid_centres(size, cell_size)
    for _ in range(max_attempts):
        d_old = np.full(len(centres), np.inf)
        target, d_new = _place(make_object(target_category, rng), rng, size, d_old, centres, cell_size, gap,
                               region=(0.3 * size, 0.7 * size))
        if target is None:
            continue
        objects, d_old = [target], np.minimum(d_old, d_new)
        for _ in range(n_clutter):
            category = str(rng.choice(CLUTTER_CATEGORIES))
            obj, d_new = _place(make_object(category, rng), rng, size, d_old, centres, cell_size, gap)
            if obj is not None:
                objects.append(obj)
                d_old = np.minimum(d_old, d_new)
        room = Room(size, objects, 0, cell_size, body_radius)
        try:
            if room.reachable_fraction() >= 0.5:
                return room
        except ValueError:  # no standing spot in front of the seat
            continue
    raise RuntimeError(f"make_room: no layout with a reachable target after {max_attempts} attempts; use fewer clutter objects or a larger room")


# ----------------------------------------------------------------------------- kitchens


@dataclass(eq=False)
class Kitchen(_GridScene):
    """A kitchen for pick-and-place (CHOICE): containers, small items in and on them, floor obstacles.

    Attributes:
        size: (2,) metres.
        furniture: placed ``[shelf, cabinet, drawer, table]`` (in that order).
        items: placed small objects (bottles, mugs, teapots).
        holders: for each item, the index into ``furniture`` of what holds it.
        obstacles: placed boxes on the floor.
        cell_size: grid cell side, metres.
    """

    size: np.ndarray
    furniture: list
    items: list
    holders: list
    obstacles: list = field(default_factory=list)
    cell_size: float = 0.05

    def __post_init__(self):
        if len(self.holders) != len(self.items):
            raise ValueError(f"holders: expected one holder per item ({len(self.items)}), got {len(self.holders)}")
        self._init_grid()

    @property
    def objects(self) -> list:
        """Everything in the scene: furniture, then obstacles, then items."""
        return list(self.furniture) + list(self.obstacles) + list(self.items)

    def furniture_of(self, category: str) -> ToyObject:
        """The piece of furniture of a category (``"shelf"``, ``"cabinet"``, ``"drawer"``, ``"table"``)."""
        names = [f.category for f in self.furniture]
        check_choice(category, names, "category")
        return self.furniture[names.index(category)]

    def holder_of(self, item_index: int) -> ToyObject:
        """The furniture that holds item ``item_index``."""
        return self.furniture[self.holders[item_index]]

    def obstacles_near(self, point, radius: float, exclude=()) -> list:
        """Objects whose surface is within ``radius`` metres of ``point`` (3,), nearest first.

        Args:
            point: (3,) metres, world frame.
            exclude: objects to leave out (e.g. the item being grasped), compared by identity.
        Returns:
            list of ``(ToyObject, distance)`` pairs, distance in metres (negative inside).
        """
        point = np.asarray(point, dtype=np.float64)
        check_shape(point, (3,), "point")
        skip = {id(o) for o in exclude}
        found = [(o, float(o.sdf(point))) for o in self.objects if id(o) not in skip]
        return sorted([f for f in found if f[1] < radius], key=lambda f: f[1])

    def start_positions(self, n: int, seed=0, clearance: float = 0.25) -> np.ndarray:
        """``n`` points (n, 2) xy metres in the largest free area, at least ``clearance`` from obstacles."""
        free = ~self.inflated_occupancy(clearance)
        if not free.any():
            raise ValueError(f"start_positions: no free cell with clearance {clearance} m")
        from scipy import ndimage

        labels, count = ndimage.label(free)
        largest = np.argmax(np.bincount(labels.ravel())[1:]) + 1
        return self._sample_in_mask(labels == largest, int(n), as_rng(seed), clearance)

    def top_down(self, ax=None):
        """Draw occupancy and object boxes, items in red (matplotlib axes, created if None)."""
        import matplotlib.pyplot as plt

        ax = ax if ax is not None else plt.gca()
        n_fixed = len(self.furniture) + len(self.obstacles)
        return self._draw(ax, highlight=tuple(range(n_fixed, n_fixed + len(self.items))))


def _item_radius(item: ToyObject) -> float:
    lo, hi = item.canonical_bounds
    return float(np.max(np.linalg.norm(np.array([[lo[0], lo[1]], [lo[0], hi[1]], [hi[0], lo[1]], [hi[0], hi[1]]]), axis=1)))


def make_kitchen(
    seed=0,
    *,
    size=(5.0, 5.0),
    n_items: int = 4,
    door_angle: float | None = None,
    drawer_open: float | None = None,
    n_obstacles: int | None = None,
    cell_size: float = 0.05,
) -> Kitchen:
    """A kitchen: a shelf, a cabinet with a door, a drawer unit against the walls, a table, items, obstacles.

    The shelf stands against the +y wall, the cabinet against the +x wall and the drawer unit
    against the −x wall, each facing the room; the table stands in the middle. Each item
    (bottle, mug or teapot) is put on a support surface (a shelf board, the cabinet's floor or
    board, the drawer's tray, the table top) that is tall enough for it, not overlapping the
    items already there. 1–3 boxes stand on the floor as obstacles.

    Args:
        seed: int or ``numpy.random.Generator``.
        door_angle: cabinet door opening (rad); None draws it in [0, 1.8].
        drawer_open: top drawer pulled out (m); None draws it in [0, 0.3].
    """
    rng = as_rng(seed)
    size = np.asarray(size, dtype=np.float64)
    lx, ly = size
    door_angle = float(rng.uniform(0.0, 1.8)) if door_angle is None else float(door_angle)
    drawer_open = float(rng.uniform(0.0, 0.3)) if drawer_open is None else float(drawer_open)
    n_obstacles = int(rng.integers(1, 4)) if n_obstacles is None else int(n_obstacles)
    centres = _grid_centres(size, cell_size)
    gap = 0.05

    for _ in range(50):
        shelf = make_object("shelf", rng)
        cabinet = make_object("cabinet", rng, door_angle=door_angle)
        drawer = make_object("drawer", rng, drawer_open=drawer_open)
        table = make_object("table", rng)
        d_old = np.full(len(centres), np.inf)
        placed = []
        # against a wall: the back of the carcass 2 cm from the wall, the front towards the room
        specs = [
            (shelf, np.pi, lambda o=shelf: np.array([rng.uniform(0.8, lx - 0.8), ly - o.params["depth"] / 2 - 0.02])),
            (cabinet, np.pi / 2, lambda o=cabinet: np.array([lx - o.params["depth"] / 2 - 0.02, rng.uniform(0.8, ly - 1.2)])),
            (drawer, -np.pi / 2, lambda o=drawer: np.array([o.params["depth"] / 2 + 0.02, rng.uniform(0.8, ly - 1.2)])),
            (table, None, lambda: rng.uniform(0.35 * size, 0.65 * size)),
        ]
        for obj, yaw, where in specs:
            yaw_fn = (lambda y=yaw: y) if yaw is not None else (lambda: float(rng.choice([0.0, np.pi / 2])))
            obj_placed, d_new = _place(obj, rng, size, d_old, centres, cell_size, gap, wall_margin=0.0, yaw=yaw_fn, xy=where)
            if obj_placed is None:
                break
            placed.append(obj_placed)
            d_old = np.minimum(d_old, d_new)
        if len(placed) < 4:
            continue
        obstacles = []
        for _ in range(n_obstacles):
            obj, d_new = _place(make_object("box", rng), rng, size, d_old, centres, cell_size, 0.3)
            if obj is not None:
                obstacles.append(obj)
                d_old = np.minimum(d_old, d_new)
        items, holders = _place_items(placed, n_items, rng)
        if len(items) == n_items:
            return Kitchen(size, placed, items, holders, obstacles, cell_size)
    raise RuntimeError(f"make_kitchen: could not place {n_items} items; ask for fewer")


def _place_items(furniture, n_items, rng):
    """Put ``n_items`` random small objects on the furniture's support surfaces without overlaps."""
    occupied = {}  # (holder, support) -> list of (xy, radius)
    items, holders = [], []
    for _ in range(n_items):
        item = make_object(str(rng.choice(GRASPABLE)), rng)
        height, radius = item.canonical_bounds[1, 2], _item_radius(item)
        options = [
            (h, s)
            for h, holder in enumerate(furniture)
            for s, row in enumerate(holder.support_surfaces)
            if row[5] >= height + 0.02 and row[2] - row[1] > 2 * radius + 0.02 and row[4] - row[3] > 2 * radius + 0.02
        ]
        for _ in range(30):
            if not options:
                break
            h, s = options[rng.integers(len(options))]
            z, x0, x1, y0, y1, _ = furniture[h].support_surfaces[s]
            xy = np.array([rng.uniform(x0 + radius + 0.01, x1 - radius - 0.01), rng.uniform(y0 + radius + 0.01, y1 - radius - 0.01)])
            others = occupied.setdefault((h, s), [])
            if all(np.linalg.norm(xy - o) >= radius + r + 0.01 for o, r in others):
                others.append((xy, radius))
                local = np.eye(4)
                yaw = rng.uniform(-np.pi, np.pi)
                local[:3, :3] = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
                local[:3, 3] = (xy[0], xy[1], z)
                items.append(item.with_pose(furniture[h].pose @ local))
                holders.append(h)
                break
    return items, holders
