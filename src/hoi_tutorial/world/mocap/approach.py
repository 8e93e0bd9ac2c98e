"""How an interaction clip gets to its object and away again: how far objects reach along a
line (measured through their SDF), the waypoints of an approach walk that keeps clear of the
obstacles (with a grid search as the last resort), the walk itself, a short walk away, and the
joining of approach, interaction and walk-away into one clip.
"""
from __future__ import annotations

import heapq
import math
from typing import Optional

import numpy as np
import torch

from ..motion import Motion
from .body_plan import UP, PlanBody
from .gait import walk_path
from .motion_math import forward_xyz, rot_z
from .paths import path_from_waypoints
from .poses import standing_pose

__all__ = ["extents_along", "extent_along", "near_extent", "approach_waypoints", "walk_to_spot", "walk_away",
           "join_clips"]


# --------------------------------------------------------------------------- geometry queries

def extents_along(obstacles, origin_xy, direction, z_values, max_dist=2.0, step=0.01, margin=0.0):
    """Per height in ``z_values``: the largest ``t`` in [0, max_dist] with ``origin + t * direction``
    (at that height) inside an obstacle, 0 when none; numpy ``(len(z_values),)`` metres."""
    t = np.arange(0.0, max_dist + 1e-9, step)
    xy = origin_xy[None, :2] + t[:, None] * direction[None, :2]
    pts = np.concatenate([np.concatenate([xy, np.full((len(t), 1), z)], 1) for z in z_values])
    inside = np.zeros(len(pts), dtype=bool)
    for obj in obstacles:
        inside |= obj.sdf(pts) < margin
    inside = inside.reshape(len(z_values), len(t))
    return np.array([float(t[row].max()) if row.any() else 0.0 for row in inside])


def extent_along(obstacles, origin_xy, direction, z_values, max_dist=2.0, step=0.01, margin=0.0):
    """Largest ``t`` in [0, max_dist] with a point ``origin + t * direction`` at some height inside an obstacle."""
    return float(extents_along(obstacles, origin_xy, direction, z_values, max_dist, step, margin).max())


def near_extent(obstacles, point, towards, half_width: float, top: float) -> float:
    """How far the obstacles reach from ``point`` towards the person (``towards (3,)``), metres.

    Measured on a swath ``2 * half_width`` wide around ``point`` and every 3 cm of height up to
    ``top``, so thin parts (a seat board, chair legs, a table top) are not missed.
    """
    side = np.cross(UP, towards)
    heights = tuple(np.arange(0.02, top + 0.03, 0.03))
    return max(extent_along(obstacles, point + lateral * side, towards, heights, max_dist=1.5, step=0.02)
               for lateral in np.linspace(-half_width, half_width, 5))


def _path_clear(waypoints, obstacles, skip_end: float, trust_end: float, clearance: float = 0.36,
                end_clearance: float = 0.17) -> bool:
    """Whether the walking path through ``waypoints`` keeps clear of every obstacle.

    The path must keep ``clearance`` metres from the obstacles, easing to ``end_clearance`` over
    its last ``skip_end`` metres (where it comes alongside the object); its last ``trust_end``
    metres are not checked (the standing spot was chosen clear of the object).
    """
    path = path_from_waypoints(np.asarray(waypoints, dtype=np.float64))
    s = np.arange(0.0, max(path.length - trust_end, 0.0), 0.05)
    if len(s) == 0:
        return True
    xy, _ = path.at(s)
    ease = np.clip((path.length - skip_end - s) / 0.6, 0.0, 1.0)
    need = end_clearance + (clearance - end_clearance) * ease
    heights = (0.1, 0.5, 0.9, 1.3)
    pts = np.concatenate([np.concatenate([xy, np.full((len(xy), 1), z)], 1) for z in heights])
    need = np.tile(need, len(heights))
    return all(np.all(obj.sdf(pts) >= need) for obj in obstacles)


# --------------------------------------------------------------------------- approach

def approach_waypoints(spot_xy, out_dir, rng, obstacles, start_position, centre_xy, sideways: bool,
                       lane: float = 0.0):
    """Waypoints from a start at least 1.5 m from ``centre_xy`` to the standing spot ``spot_xy``.

    ``out_dir (3,)`` points from the spot away from the object: starts are drawn within ±75° of
    it. The walker arrives along ``-out_dir`` (facing the object), or, when ``sideways``, straight
    from the start's side (a sitter then turns less to face away from the seat), along a lane
    ``lane`` metres farther out than the spot that the last half metre leaves for the spot (the
    turning steps of a sitter come in a little closer than a walking body may pass). A path that
    passes within 0.32 m of an obstacle gets a detour corner beside the object.
    """
    if start_position is not None:
        start = np.asarray(start_position, dtype=np.float64).reshape(-1)
        if start.shape != (2,) or not np.all(np.isfinite(start)):
            raise ValueError(f"start_position: expected 2 finite numbers (metres), got {start_position!r}")
        candidates = [start]
    else:
        candidates = []
        for _ in range(16):
            direction = rot_z(rng.uniform(-1.3, 1.3))[:2, :2] @ out_dir[:2]
            candidates.append(centre_xy + direction * rng.uniform(1.6, 2.1))

    def pre_points(start):
        if not sideways:
            return [spot_xy + 0.5 * out_dir[:2]]
        # Along the object's front, from the start's side first: the final turn then swings the
        # toes away from the object, never into it. Where a straight lane is blocked (armrests),
        # the last metre comes in at a slant from a little farther out.
        to_start = start - spot_xy
        side = 1.0 if out_dir[0] * to_start[1] - out_dir[1] * to_start[0] >= 0 else -1.0
        return [spot_xy + across * (rot_z(sign * np.pi / 2)[:2, :2] @ out_dir[:2]) + (lane + out) * out_dir[:2]
                for sign in (side, -side) for across, out in ((0.5, 0.0), (0.55, 0.25))]

    # Coming straight in, the last steps end on the spot that was checked for the walking body;
    # turning steps that leave the lane are checked by the caller.
    trust_end = (0.3 if lane > 0.0 else 0.05) if sideways else 0.35
    for start in candidates:
        for pre in pre_points(start):
            way = [start, pre, spot_xy]
            if _path_clear(way, obstacles, skip_end=0.55, trust_end=trust_end):
                return np.stack(way)
        side = 1.0 if (out_dir[0] * (start - spot_xy)[1] - out_dir[1] * (start - spot_xy)[0]) >= 0 else -1.0
        lateral = rot_z(side * np.pi / 2)[:2, :2] @ out_dir[:2]
        reach = extent_along(obstacles, centre_xy, np.append(lateral, 0.0), (0.1, 0.5, 0.9)) + 0.6
        corner = centre_xy + lateral * reach + out_dir[:2] * 0.6
        way = [start, corner, spot_xy + 0.5 * out_dir[:2], spot_xy]
        if _path_clear(way, obstacles, skip_end=0.55, trust_end=0.35):
            return np.stack(way)
    # No simple path (a start boxed in by an L-sofa, say): route around on a grid.
    for start in candidates:
        for pre in pre_points(start):
            outside = pre + 0.3 * out_dir[:2]
            route = _grid_route(start, outside, obstacles)
            if route is not None:
                return np.stack([start] + route + [outside, pre, spot_xy])
    start = candidates[0]
    return np.stack([start, pre_points(start)[0], spot_xy])


def _grid_route(start, goal, obstacles, clearance: float = 0.3, cell: float = 0.1):
    """Intermediate waypoints (a list of ``(2,)``) of a shortest 8-connected grid path from ``start``
    to ``goal`` that keeps ``clearance`` metres from the obstacles, or None when there is none."""
    lo = np.minimum(start, goal) - 2.5
    shape = tuple(np.ceil((np.maximum(start, goal) + 2.5 - lo) / cell).astype(int) + 1)
    ix, iy = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    xy = lo + cell * np.stack([ix, iy], -1).reshape(-1, 2)
    pts = np.concatenate([np.concatenate([xy, np.full((len(xy), 1), z)], 1) for z in (0.1, 0.5, 0.9, 1.3)])
    free = np.ones(len(pts), dtype=bool)
    for obj in obstacles:
        free &= obj.sdf(pts) >= clearance
    free = free.reshape(4, *shape).all(0)
    a = tuple(np.round((start - lo) / cell).astype(int))
    b = tuple(np.round((goal - lo) / cell).astype(int))
    if not (free[a] and free[b]):
        return None
    cost = {a: 0.0}
    parent = {}
    queue = [(0.0, a)]
    steps = [(dx, dy, math.hypot(dx, dy)) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    while queue:
        c, node = heapq.heappop(queue)
        if node == b:
            break
        if c > cost[node]:
            continue
        for dx, dy, length in steps:
            nxt = (node[0] + dx, node[1] + dy)
            if not (0 <= nxt[0] < shape[0] and 0 <= nxt[1] < shape[1]) or not free[nxt]:
                continue
            if c + length < cost.get(nxt, np.inf):
                cost[nxt] = c + length
                parent[nxt] = node
                heapq.heappush(queue, (c + length, nxt))
    if b not in parent:
        return None
    cells = [b]
    while cells[-1] != a:
        cells.append(parent[cells[-1]])
    path = lo + cell * np.array(cells[::-1], dtype=np.float64)
    # Keep every ~0.5 m of the grid path between the ends as waypoints.
    return [p for p in path[5:-5:5]]


def walk_to_spot(body: PlanBody, rng, spot_xy, heading, out_dir, obstacles, start_position, centre_xy, approach: bool,
                 sideways: bool = False):
    """The walk to the standing spot (a ``Motion``, or ``None`` without approach) and its last pose (numpy)."""
    if not approach:
        local, root = standing_pose(body.betas, position=spot_xy, heading=heading)
        return None, (local.double().numpy(), root.double().numpy())
    waypoints = approach_waypoints(spot_xy, out_dir, rng, obstacles, start_position, centre_xy, sideways)
    walk = walk_path(waypoints, betas=body.betas, seed=rng, end_heading=heading, settle=False)
    return walk, (walk.local_rotations[-1].double().numpy(), walk.root_position[-1].double().numpy())


def walk_away(body: PlanBody, rng, last_local, last_root, heading, distance):
    """A short walk of ``distance`` metres from the last pose, roughly straight ahead."""
    angle = rng.uniform(-0.3, 0.3)
    direction = forward_xyz(heading + angle)[:2]
    waypoints = np.stack([last_root[:2], last_root[:2] + distance * direction])
    return walk_path(waypoints, betas=body.betas, seed=rng, start=(torch.as_tensor(last_local),
                                                                   torch.as_tensor(last_root)), settle=False)


def join_clips(approach_motion, interaction: Motion, after: Optional[Motion], meta: dict):
    """Concatenate approach (without its last frame, which the interaction reproduces), interaction, after.

    Returns the motion and the index of the interaction's first frame.
    """
    parts = []
    first = 0
    if approach_motion is not None:
        parts.append(approach_motion.slice(0, len(approach_motion) - 1))
        first = len(approach_motion) - 1
    parts.append(interaction)
    if after is not None and len(after) > 1:
        parts.append(after.slice(1, len(after)))
    motion = Motion.concatenate(parts) if len(parts) > 1 else parts[0]
    motion.meta = dict(meta)
    return motion, first
