"""Path planning for SAMP (§3.3 "Path Planning", Appendix E "Path Planning Formulation").

SAMP computes an obstacle-free path from the character's start to the goal with A* and splits it
into waypoints ``w_0, w_1, …`` "that define the locations where the path changes direction"; the
character walks to each waypoint in turn and performs the action at the last one (§3.3).
Appendix E runs A* on Unity's navigation mesh: the walkable area computed from the character's
cylinder collider and the scene, stored as convex polygons; the path's corners are the waypoints.

At toy scale the walkable area is the room's grid inflated by the body radius
(``room.inflated_occupancy(radius)``: the cylinder collider seen from above is a disc):

- :func:`astar`: A* on the grid, 8-connected without cutting blocked corners (octile heuristic) or
  4-connected (Manhattan), optimal;
- :func:`turning_points`: the cells where the grid path changes direction (§3.3's waypoints, literally);
- :func:`line_of_sight` and :func:`shortcut_waypoints`: greedy string pulling, which removes the
  staircase corners a grid path has and a navigation mesh's corner path does not (it stands in for
  the funnel step of Unity's navmesh, Appendix E footnote: docs.unity3d.com/Manual/nav-InnerWorkings.html);
- :func:`plan_path`: start and goal in metres → :class:`PlannedPath` (cells, points, waypoints);
- :func:`simplify_waypoints`: the waypoints as a navigation mesh's corner path has them: no leg shorter than
  the radius a walk goal is passed within, no turn under ``MIN_TURN_DEG`` (where the straight walk is free);
- :func:`draw_path`: the room from above with the path and its waypoints.

Grid convention (``hoi_tutorial.world.scenes``): cell ``(i, j)`` is row ``i`` along +y, column ``j``
along +x. This module imports numpy and scipy.ndimage (matplotlib inside :func:`draw_path`, networkx inside
:func:`networkx_grid_graph`).
"""
from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
from scipy import ndimage

__all__ = [
    "astar",
    "path_cost",
    "turning_points",
    "line_of_sight",
    "shortcut_waypoints",
    "PlannedPath",
    "grid_distance",
    "networkx_grid_graph",
    "approach_point",
    "check_room_point",
    "plan_path",
    "MIN_TURN_DEG",
    "straight_walk_is_free",
    "simplify_waypoints",
    "reaches",
    "nearest_walkable_point",
    "draw_path",
]

SQRT2 = math.sqrt(2.0)
# The smallest change of direction kept as a waypoint by simplify_waypoints, degrees (ours; SAMP's waypoints are the
# corners of Unity's navmesh path, whose polygons are larger than a grid's cells and leave no such wiggles).
MIN_TURN_DEG = 20.0


# ----------------------------------------------------------------------------- checks


def _check_blocked(blocked) -> np.ndarray:
    if not isinstance(blocked, np.ndarray) or blocked.ndim != 2 or blocked.dtype != np.bool_:
        got = (f"shape {tuple(blocked.shape)}, dtype {blocked.dtype}" if isinstance(blocked, np.ndarray)
               else type(blocked).__name__)
        raise ValueError(f"blocked: expected an (H, W) bool numpy array, got {got}")
    return blocked


def _check_cell(cell, shape, name: str) -> tuple:
    arr = np.asarray(cell)
    if arr.shape != (2,) or not (np.issubdtype(arr.dtype, np.integer)
                                 or (np.issubdtype(arr.dtype, np.floating) and np.all(arr == np.round(arr)))):
        raise ValueError(f"{name}: expected a cell (i, j) of two ints, got {cell!r}")
    i, j = int(arr[0]), int(arr[1])
    if not (0 <= i < shape[0] and 0 <= j < shape[1]):
        raise ValueError(f"{name}: cell ({i}, {j}) is outside the grid of shape {tuple(shape)}")
    return i, j


# ----------------------------------------------------------------------------- A*


def astar(blocked: np.ndarray, start, goal, *, diagonal: bool = True) -> list:
    """Shortest obstacle-free path on a grid with A* (SAMP §3.3; Hart, Nilsson and Raphael 1968).

    8-connected when ``diagonal``: a step costs 1 along an axis and √2 diagonally, and a diagonal
    step is allowed only when both cells beside it are free, so the path never cuts a blocked
    corner; the heuristic is the octile distance. 4-connected otherwise, Manhattan heuristic. Both
    heuristics are admissible and consistent, so the path is optimal and a cell is expanded at
    most once. Ties on ``f = g + h`` go to the smaller ``h`` (nearer the goal), then the smaller
    flat index: the result is deterministic.

    Args:
        blocked: (H, W) bool, True where the body cannot stand.
        start, goal: cells ``(i, j)``, ints.
        diagonal: 8-connected (True) or 4-connected (False).
    Returns:
        The cells ``[(i, j), …]`` from ``start`` to ``goal`` inclusive (Python ints).
    Raises:
        ValueError: bad ``blocked``; start or goal outside the grid or blocked; goal unreachable.
    """
    blocked = _check_blocked(blocked)
    H, W = blocked.shape
    si, sj = _check_cell(start, (H, W), "start")
    gi, gj = _check_cell(goal, (H, W), "goal")
    if blocked[si, sj]:
        raise ValueError(f"start ({si}, {sj}) lies inside an obstacle (blocked cell)")
    if blocked[gi, gj]:
        raise ValueError(f"goal ({gi}, {gj}) lies inside an obstacle (blocked cell)")

    # Flat indices into the grid padded by one blocked cell on each side: no bounds checks.
    Wp = W + 2
    padded = np.ones((H + 2, Wp), dtype=np.uint8)
    padded[1:-1, 1:-1] = blocked
    wall = bytearray(padded.tobytes())
    rows, cols = np.divmod(np.arange(padded.size), Wp)
    dx, dy = np.abs(cols - (gj + 1)), np.abs(rows - (gi + 1))
    if diagonal:
        h = (np.maximum(dx, dy) + (SQRT2 - 1.0) * np.minimum(dx, dy)).tolist()
    else:
        h = (dx + dy).astype(np.float64).tolist()
    # (offset, cost, side cell 1, side cell 2); side offsets 0 for axis moves (never checked)
    moves = [(1, 1.0, 0, 0), (-1, 1.0, 0, 0), (Wp, 1.0, 0, 0), (-Wp, 1.0, 0, 0)]
    if diagonal:
        moves += [(di * Wp + dj, SQRT2, di * Wp, dj) for di in (1, -1) for dj in (1, -1)]

    n = len(wall)
    g = [math.inf] * n
    parent = [-1] * n
    closed = bytearray(n)
    s, t = (si + 1) * Wp + sj + 1, (gi + 1) * Wp + gj + 1
    g[s] = 0.0
    heap = [(h[s], h[s], s)]
    pop, push = heapq.heappop, heapq.heappush
    while heap:
        _, _, u = pop(heap)
        if closed[u]:
            continue
        if u == t:
            break
        closed[u] = 1
        gu = g[u]
        for off, cost, side1, side2 in moves:
            v = u + off
            if wall[v] or closed[v]:
                continue
            if side1 and (wall[u + side1] or wall[u + side2]):
                continue
            nv = gu + cost
            if nv < g[v]:
                g[v] = nv
                parent[v] = u
                hv = h[v]
                push(heap, (nv + hv, hv, v))
    else:
        raise ValueError(f"goal ({gi}, {gj}) is unreachable from start ({si}, {sj}) "
                         f"({'8' if diagonal else '4'}-connected free cells)")
    path = []
    u = t
    while u != -1:
        r, c = divmod(u, Wp)
        path.append((r - 1, c - 1))
        u = parent[u]
    return path[::-1]


def path_cost(cells) -> float:
    """Length of a cell path in cells: the sum of its step lengths (1 along an axis, √2 diagonally).

    Args:
        cells: (N, 2) cells ``(i, j)``, N ≥ 1.
    """
    arr = np.asarray(cells, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) == 0:
        raise ValueError(f"cells: expected shape (N, 2) with N >= 1, got {arr.shape}")
    return float(np.linalg.norm(np.diff(arr, axis=0), axis=1).sum())


def turning_points(cells) -> list:
    """The waypoints of SAMP §3.3, "the locations where the path changes direction".

    Args:
        cells: (N, 2) cells of a path (e.g. from :func:`astar`).
    Returns:
        ``[(i, j), …]``: the start, every cell where the step direction changes, and the end
        (just the start when N = 1).
    """
    arr = np.asarray(cells, dtype=np.int64)
    if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) == 0:
        raise ValueError(f"cells: expected shape (N, 2) with N >= 1, got {arr.shape}")
    if len(arr) == 1:
        return [tuple(int(v) for v in arr[0])]
    steps = np.diff(arr, axis=0)
    turns = np.flatnonzero(np.any(steps[1:] != steps[:-1], axis=1)) + 1
    keep = np.concatenate([[0], turns, [len(arr) - 1]])
    return [tuple(int(v) for v in arr[k]) for k in keep]


# ----------------------------------------------------------------------------- string pulling


def line_of_sight(blocked: np.ndarray, a, b) -> bool:
    """Whether the segment between the centres of cells ``a`` and ``b`` touches only free cells.

    Supercover traversal (every cell the segment passes through, Amanatides–Woo style, exact in
    integers): where the segment passes exactly through a cell corner, both cells beside the
    corner are checked, the same no-corner-cutting rule as :func:`astar`'s diagonal steps. So two
    consecutive cells of an A* path always see each other.

    Args:
        blocked: (H, W) bool.
        a, b: cells ``(i, j)`` inside the grid.
    """
    blocked = _check_blocked(blocked)
    i, j = _check_cell(a, blocked.shape, "a")
    bi, bj = _check_cell(b, blocked.shape, "b")
    ny, nx = abs(bi - i), abs(bj - j)
    si, sj = (1 if bi > i else -1), (1 if bj > j else -1)
    if blocked[i, j]:
        return False
    ix = iy = 0
    while ix < nx or iy < ny:
        # compare the parameters (ix + ½)/nx and (iy + ½)/ny of the next column and row crossings
        decision = (1 + 2 * ix) * ny - (1 + 2 * iy) * nx
        if decision == 0:  # through a corner: both side cells are touched
            if blocked[i + si, j] or blocked[i, j + sj]:
                return False
            i, j, ix, iy = i + si, j + sj, ix + 1, iy + 1
        elif decision < 0:
            j, ix = j + sj, ix + 1
        else:
            i, iy = i + si, iy + 1
        if blocked[i, j]:
            return False
    return True


def shortcut_waypoints(blocked: np.ndarray, cells) -> list:
    """Greedy string pulling of a grid path: the corner path a navigation mesh would give.

    From the current waypoint, walk along the later path cells while they stay in
    :func:`line_of_sight` and jump to the last one seen before the first that is hidden; repeat
    until the goal. Unity's navmesh (SAMP Appendix E) pulls its polygon path taut with a funnel
    step; on a grid this greedy pass removes the staircase corners A* leaves. The result never
    is longer than the grid path (triangle inequality), and each leg is obstacle-free at cell
    resolution.

    Args:
        blocked: (H, W) bool.
        cells: (N, 2) path cells, consecutive cells in line of sight (e.g. from :func:`astar`).
    Returns:
        ``[(i, j), …]`` waypoints, a subset of ``cells`` that starts and ends with theirs.
    """
    pts = [tuple(int(v) for v in c) for c in np.asarray(cells, dtype=np.int64).reshape(-1, 2)]
    if not pts:
        raise ValueError("cells: expected a path of at least one cell, got none")
    out, k = [pts[0]], 0
    while k < len(pts) - 1:
        m = k + 1
        while m + 1 < len(pts) and line_of_sight(blocked, pts[k], pts[m + 1]):
            m += 1
        out.append(pts[m])
        k = m
    return out


# ----------------------------------------------------------------------------- rooms


@dataclass
class PlannedPath:
    """A planned walk through a room (SAMP §3.3).

    Attributes:
        cells: (N, 2) int, the A* cells ``(i, j)`` from the start's cell to the goal's (see :func:`plan_path`).
        points: (N, 2) metres, those cells' centres (xy).
        waypoints: (M, 2) metres, after shortcutting: the first is the start point itself, the
            last the goal point itself, those between are cell centres where the path turns.
        length: metres, the length of the waypoint polyline.
        grid_cost: metres, the A* cost (:func:`path_cost`) × the cell size.
        radius: metres, the body radius the occupancy was inflated by.
    """

    cells: np.ndarray
    points: np.ndarray
    waypoints: np.ndarray
    length: float
    grid_cost: float
    radius: float


def check_room_point(room, xy, name: str) -> np.ndarray:
    """``xy`` as a ``(2,)`` float array, or a ValueError naming ``name`` when it is not a finite floor
    point inside ``room`` (``[0, size_x] × [0, size_y]`` metres)."""
    lx, ly = (float(v) for v in np.asarray(room.size).reshape(2))
    extent = f"[0, {lx}] × [0, {ly}] m"
    try:
        arr = np.asarray(xy, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a floor point (x, y) in metres inside the room {extent}, got {xy!r}") from None
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected a floor point (x, y) in metres inside the room {extent}, got {xy!r}")
    if not (0.0 <= arr[0] <= lx and 0.0 <= arr[1] <= ly):
        raise ValueError(f"{name}: expected a floor point inside the room {extent}, "
                         f"got [{arr[0]:g}, {arr[1]:g}]")
    return arr


def _point_cell(room, blocked, xy, name: str, radius: float) -> tuple:
    """The free cell a point starts or ends on: its own, or (when only its centre is too close to an
    obstacle, a discretisation effect) the free neighbouring cell whose centre is nearest."""
    clearance = float(np.asarray(room.obstacle_distance(xy)))
    if clearance < radius:
        hint = (" (a goal on furniture, e.g. a seat, is inside the inflated footprint: plan to "
                "room.approach_point(goal_index) instead)" if name == "goal" else "")
        raise ValueError(f"{name} [{xy[0]:g}, {xy[1]:g}] m lies inside an obstacle inflated by the body radius "
                         f"{radius:g} m (clearance {clearance:.3f} m){hint}")
    top = np.asarray(blocked.shape) - 1
    ij = np.clip(room.world_to_grid(xy), 0, top)  # a point on the far wall maps to the last cell
    near = np.clip(ij + np.stack(np.meshgrid([0, -1, 1], [0, -1, 1], indexing="ij"), -1).reshape(-1, 2), 0, top)
    near = near[~blocked[near[:, 0], near[:, 1]]]
    if len(near) == 0:
        raise ValueError(f"{name} [{xy[0]:g}, {xy[1]:g}] m has no free grid cell around it for the body radius "
                         f"{radius:g} m (clearance {clearance:.3f} m; use a finer cell_size)")
    best = near[np.argmin(np.linalg.norm(room.grid_to_world(near) - xy, axis=1))]
    return int(best[0]), int(best[1])


def grid_distance(u, v, *, diagonal: bool = True) -> float:
    """The A* heuristic between cells ``u`` and ``v``: octile distance (8-connected) or Manhattan."""
    dx, dy = abs(u[0] - v[0]), abs(u[1] - v[1])
    if not diagonal:
        return float(dx + dy)
    return max(dx, dy) + (SQRT2 - 1.0) * min(dx, dy)


def networkx_grid_graph(blocked: np.ndarray, *, diagonal: bool = True):
    """The graph :func:`astar` searches, as a ``networkx.Graph``, to cross-check it against
    ``networkx.astar_path`` (tests, ``scripts/bench_astar.py``, the chapter).

    Nodes are the free cells ``(i, j)``; edges join 4-neighbours (weight 1) and, when ``diagonal``,
    diagonal neighbours whose two side cells are free (weight √2). networkx is imported here only.
    """
    import networkx as nx

    blocked = _check_blocked(blocked)
    H, W = blocked.shape
    graph = nx.Graph()
    free = [(i, j) for i in range(H) for j in range(W) if not blocked[i, j]]
    graph.add_nodes_from(free)
    steps = ((0, 1), (1, 0), (1, 1), (1, -1)) if diagonal else ((0, 1), (1, 0))
    for i, j in free:
        for di, dj in steps:
            a, b = i + di, j + dj
            if not (0 <= a < H and 0 <= b < W) or blocked[a, b]:
                continue
            if di and dj and (blocked[i + di, j] or blocked[i, j + dj]):
                continue
            graph.add_edge((i, j), (a, b), weight=SQRT2 if di and dj else 1.0)
    return graph


def approach_point(room, goal_position, goal_direction, *, radius: Optional[float] = None,
                   max_distance: float = 1.2) -> np.ndarray:
    """Where a body of ``radius`` can stand in front of a goal on furniture: (2,) xy metres.

    A sitting goal (GoalNet's, or an object's labelled one) lies on the seat, inside the inflated
    footprint; SAMP's last sub-task walks to the final waypoint and performs the action there
    (§3.3). The waypoint is the room's :meth:`~hoi_tutorial.world.scenes.Room.standing_point`: the
    first point along the goal's forward direction, 0.3 m to ``max_distance``, whose clearance is at
    least ``radius`` (default ``room.body_radius``).

    Raises:
        ValueError: a direction with no ground-plane part, or no standing spot along it.
    """
    return room.standing_point(goal_position, goal_direction, radius, max_distance)


def reaches(room, starts, goal, *, radius: Optional[float] = None) -> np.ndarray:
    """``(n,)`` bool: which of ``starts (n, 2)`` (xy metres) :func:`plan_path` can join to ``goal``.

    One labelling of the free cells as :func:`astar` connects them (``scipy.ndimage.label``, 4-connected: a
    diagonal step needs both side cells free) answers for every start;
    a start or goal inside an inflated obstacle or outside the room reaches nothing.
    """
    radius = float(room.body_radius if radius is None else radius)
    blocked = np.asarray(room.inflated_occupancy(radius), dtype=bool)
    # astar steps diagonally only when both cells beside the step are free, so two cells it can join are joined
    # along the axes too: its regions are the 4-connected ones (ndimage's default structure). Two regions that
    # touch only at a corner are apart.
    components, _ = ndimage.label(~blocked)

    def cell_of(xy, name):
        try:
            return _point_cell(room, blocked, check_room_point(room, xy, name), name, radius)
        except ValueError:
            return None

    goal_cell = cell_of(goal, "goal")
    out = np.zeros(len(starts), dtype=bool)
    if goal_cell is None:
        return out
    for i, xy in enumerate(np.asarray(starts, dtype=np.float64).reshape(-1, 2)):
        cell = cell_of(xy, "start")
        out[i] = cell is not None and components[cell] == components[goal_cell]
    return out


def nearest_walkable_point(room, xy, start, *, radius: Optional[float] = None, max_distance: float = 1.0) -> np.ndarray:
    """The walkable point nearest ``xy`` that a walk from ``start`` can reach: (2,) xy metres, a cell centre.

    SAMP's demo plans its path to the sitting goal itself, on the seat (``PathPlanningUtility.ComputePath``):
    Unity's ``NavMesh.SamplePosition(goal, 1.0)`` moves the goal to the nearest point of the navigation mesh
    within 1 m. Here the mesh is the free cells of ``room.inflated_occupancy(radius)``, and only the region
    :func:`plan_path` can join to ``start`` counts (a pocket the walk cannot enter is no answer).

    Args:
        room: a :class:`~hoi_tutorial.world.scenes.Room`.
        xy: (2,) the point to move onto the walkable area (e.g. a seat's goal), inside the room.
        start: (2,) where the walk starts (walkable).
        radius: body radius, metres (default ``room.body_radius``).
        max_distance: metres; farther cells do not count (the demo's 1 m).
    Raises:
        ValueError: ``start`` not walkable, or no reachable walkable cell within ``max_distance`` of ``xy``.
    """
    radius = float(room.body_radius if radius is None else radius)
    xy = check_room_point(room, xy, "xy")
    start = check_room_point(room, start, "start")
    if not (math.isfinite(float(max_distance)) and float(max_distance) > 0.0):
        raise ValueError(f"max_distance: expected a positive number of metres, got {max_distance!r}")
    blocked = np.asarray(room.inflated_occupancy(radius), dtype=bool)
    _point_cell(room, blocked, start, "start", radius)  # a start inside an obstacle is an error
    cells = np.argwhere(room.free_component(start, radius))  # astar's regions: 4-connected free cells
    centres = room.grid_to_world(cells).reshape(-1, 2)
    gaps = np.linalg.norm(centres - xy, axis=1)
    best = int(np.argmin(gaps))
    if gaps[best] > float(max_distance):
        raise ValueError(f"xy [{xy[0]:g}, {xy[1]:g}] m: no walkable point reachable from start [{start[0]:g}, "
                         f"{start[1]:g}] m within {float(max_distance):g} m (nearest {gaps[best]:.2f} m)")
    return centres[best]


def plan_path(room, start, goal, *, radius: Optional[float] = None, shortcut: bool = True) -> PlannedPath:
    """Plan SAMP's obstacle-free walk from ``start`` to ``goal`` in a room (§3.3, Appendix E).

    The walkable area is the room's grid without the cells closer than ``radius`` to a footprint
    or a wall (``room.inflated_occupancy``; Appendix E computes the navigation mesh from the
    character's cylinder collider). A point is inside an obstacle when its own clearance
    (``room.obstacle_distance``) is below ``radius``; otherwise it maps to its cell, or, when only
    that cell's centre is too close (within half a cell of the limit), to the nearest free
    neighbouring cell. :func:`astar` (8-connected) joins the two cells, and :func:`shortcut_waypoints` (or, with ``shortcut=False``, :func:`turning_points`)
    gives the waypoints; the start and goal points replace their cells' centres at the two ends.

    A goal on furniture (a seat) lies inside the inflated footprint: plan to
    ``room.approach_point(goal_index)`` and let the action take the last step.

    Args:
        room: a :class:`~hoi_tutorial.world.scenes.Room` (anything with ``size``, ``cell_size``,
            ``body_radius``, ``inflated_occupancy``, ``obstacle_distance``, ``world_to_grid``,
            ``grid_to_world``).
        start, goal: (2,) xy metres inside the room.
        radius: body radius in metres (default ``room.body_radius``).
        shortcut: string-pull the waypoints (True) or keep every turn of the grid path (False).
    Returns:
        A :class:`PlannedPath`.
    Raises:
        ValueError: a point outside the room or inside an (inflated) obstacle; goal unreachable.
    """
    radius = float(room.body_radius if radius is None else radius)
    if not (math.isfinite(radius) and radius >= 0.0):
        raise ValueError(f"radius: expected a non-negative number of metres, got {radius}")
    start = check_room_point(room, start, "start")
    goal = check_room_point(room, goal, "goal")
    blocked = np.asarray(room.inflated_occupancy(radius), dtype=bool)
    cells = {name: _point_cell(room, blocked, xy, name, radius) for name, xy in (("start", start), ("goal", goal))}
    try:
        path = astar(blocked, cells["start"], cells["goal"], diagonal=True)
    except ValueError as exc:
        raise ValueError(f"goal [{goal[0]:g}, {goal[1]:g}] m is unreachable from start [{start[0]:g}, {start[1]:g}] m "
                         f"for a body of radius {radius:g} m ({exc})") from None
    turns = shortcut_waypoints(blocked, path) if shortcut else turning_points(path)
    waypoints = room.grid_to_world(np.asarray(turns, dtype=np.int64)).reshape(-1, 2)
    waypoints[0], waypoints[-1] = start, goal
    if len(waypoints) == 1:  # start and goal in one cell
        waypoints = np.stack([start, goal])
    cells_arr = np.asarray(path, dtype=np.int64).reshape(-1, 2)
    return PlannedPath(
        cells=cells_arr,
        points=room.grid_to_world(cells_arr),
        waypoints=waypoints,
        length=float(np.linalg.norm(np.diff(waypoints, axis=0), axis=1).sum()),
        grid_cost=path_cost(path) * float(room.cell_size),
        radius=radius,
    )


def straight_walk_is_free(room, a, b, *, blocked: Optional[np.ndarray] = None, radius: Optional[float] = None) -> bool:
    """Whether a body of ``radius`` (default ``room.body_radius``) can walk straight from ``a`` to ``b`` (xy
    metres): both points have its clearance and :func:`line_of_sight` joins their cells on the inflated grid
    (``blocked``, computed when not given)."""
    radius = float(room.body_radius if radius is None else radius)
    if blocked is None:
        blocked = np.asarray(room.inflated_occupancy(radius), dtype=bool)
    try:
        ca = _point_cell(room, blocked, np.asarray(a, dtype=np.float64), "a", radius)
        cb = _point_cell(room, blocked, np.asarray(b, dtype=np.float64), "b", radius)
    except ValueError:
        return False
    return line_of_sight(blocked, ca, cb)


def simplify_waypoints(room, waypoints, *, min_leg: float = 0.5, min_turn_deg: float = MIN_TURN_DEG,
                       radius: Optional[float] = None) -> np.ndarray:
    """The waypoints of a planned path as a navigation mesh's corner path would give them (SAMP Appendix E).

    String pulling on a grid (:func:`shortcut_waypoints`) leaves the rounded corners of the inflated obstacles
    as runs of corners a few cells apart (in the toy rooms the median leg was 0.3 m, most legs shorter than the
    0.5 m within which a walk goal is passed); a navmesh, whose obstacles are polygons, turns once at such a
    corner. Repeatedly, the first interior waypoint with a leg beside it shorter than ``min_leg`` or a turn under
    ``min_turn_deg``:

    1. is dropped when the straight walk between its neighbours is free (:func:`line_of_sight` on the grid
       inflated by the body radius); else,
    2. with the next waypoint, when the leg between them is short, is replaced by the one corner where the
       lines of the legs before and after them meet, when that corner has the body's clearance and both new
       legs are free; else it stays.

    Every step removes a waypoint, so it ends; the first and last waypoints stay.

    Args:
        room: the :class:`~hoi_tutorial.world.scenes.Room` the path was planned in.
        waypoints: ``(M, 2)`` metres, e.g. :attr:`PlannedPath.waypoints`.
        min_leg: metres, the shortest leg kept where the walk allows it: the radius a walk goal is passed within.
        min_turn_deg: the smallest turn kept, degrees.
        radius: the body radius the grid is inflated by (default ``room.body_radius``).
    Returns:
        ``(M', 2)`` metres, ``M' <= M``, the same first and last waypoint.
    """
    points = np.asarray(waypoints, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2 or not np.all(np.isfinite(points)):
        raise ValueError(f"waypoints: expected (M, 2) finite metres with M >= 2, got shape {points.shape}")
    if not (min_leg >= 0 and 0 <= min_turn_deg <= 180):
        raise ValueError(f"min_leg, min_turn_deg: expected >= 0 metres and 0-180 degrees, got {min_leg}, {min_turn_deg}")
    radius = float(room.body_radius if radius is None else radius)
    blocked = np.asarray(room.inflated_occupancy(radius), dtype=bool)

    def free_walk(a, b):
        return straight_walk_is_free(room, a, b, blocked=blocked, radius=radius)

    def turn_deg(a, p, b):
        u, v = p - a, b - p
        cosine = float(u @ v) / max(float(np.linalg.norm(u) * np.linalg.norm(v)), 1e-12)
        return math.degrees(math.acos(min(1.0, max(-1.0, cosine))))

    def corner(a, p, q, b):  # where the line a→p meets the line q→b, or None
        d1, d2 = p - a, b - q
        det = d1[0] * (-d2[1]) + d2[0] * d1[1]
        if abs(det) < 1e-9:
            return None
        t = ((q - a)[0] * (-d2[1]) + d2[0] * (q - a)[1]) / det
        x = a + t * d1
        return x if t > 0 and np.linalg.norm(x - p) <= 2 * min_leg else None

    pts = [p for p in points]
    while True:
        for k in range(1, len(pts) - 1):
            a, p, b = pts[k - 1], pts[k], pts[k + 1]
            short_next = np.linalg.norm(b - p) < min_leg
            if not (np.linalg.norm(p - a) < min_leg or short_next or turn_deg(a, p, b) < min_turn_deg):
                continue
            if free_walk(a, b):
                del pts[k]
                break
            if short_next and k + 2 < len(pts):
                x = corner(a, p, b, pts[k + 2])
                if x is not None and free_walk(a, x) and free_walk(x, pts[k + 2]):
                    pts[k:k + 2] = [x]
                    break
        else:
            return np.stack(pts)


def draw_path(room, path: PlannedPath, ax=None):
    """Draw the room from above (``room.top_down``), the A* cells (thin line) and the waypoints
    (markers on a thick line). Returns the matplotlib axes (created if None)."""
    import matplotlib.pyplot as plt

    ax = ax if ax is not None else plt.gca()
    room.top_down(ax)
    ax.plot(path.points[:, 0], path.points[:, 1], "-", color="0.4", linewidth=0.8, label="A* cells")
    ax.plot(path.waypoints[:, 0], path.waypoints[:, 1], "o-", color="tab:green", linewidth=2.0,
            markersize=5, label="waypoints")
    ax.plot(*path.waypoints[0], "s", color="tab:blue", markersize=7, label="start")
    ax.plot(*path.waypoints[-1], "*", color="tab:red", markersize=10, label="goal")
    ax.legend(loc="upper right", fontsize=7)
    return ax
