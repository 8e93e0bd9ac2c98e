"""Ground paths for locomotion: a centripetal Catmull-Rom curve through waypoints resampled by
arc length (:func:`path_from_waypoints`), and the speed profiles that say how far along a path
the root is at each time (smooth starts and stops, slower in tight bends).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..._validate import check_finite, check_shape
from ..motion import FPS

__all__ = ["GroundPath", "path_from_waypoints", "speed_profile", "path_speed_profile"]


@dataclass
class GroundPath:
    """A smooth ground path sampled by arc length (every ~1 cm)."""

    arc: np.ndarray       # (N,) metres
    points: np.ndarray    # (N, 2) metres
    heading: np.ndarray   # (N,) radians, unwrapped

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    def at(self, s):
        """Position ``(..., 2)`` and heading ``(...)`` at arc length(s) ``s``."""
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        xy = np.stack([np.interp(s, self.arc, self.points[:, 0]), np.interp(s, self.arc, self.points[:, 1])], -1)
        return xy, np.interp(s, self.arc, self.heading)


def path_from_waypoints(waypoints, spacing: float = 0.01) -> GroundPath:
    """Centripetal Catmull-Rom curve through ``waypoints (K, 2)`` metres, resampled by arc length.

    Returns an object with ``arc (N,)``, ``points (N, 2)``, ``heading (N,)`` (radians, heading 0
    faces +Y) and ``at(s)`` giving position and heading at arc length ``s``.
    """
    pts = np.asarray(waypoints, dtype=np.float64)
    check_shape(pts, (None, 2), "waypoints")
    check_finite(pts, "waypoints")
    if len(pts) < 2:
        raise ValueError(f"waypoints: expected at least 2 points, got {len(pts)}")
    keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-6])
    pts = pts[keep]
    if len(pts) < 2:
        raise ValueError("waypoints: expected at least two distinct points")
    ext = np.concatenate([2 * pts[:1] - pts[1:2], pts, 2 * pts[-1:] - pts[-2:-1]])
    dense = [pts[:1]]
    for i in range(1, len(ext) - 2):
        p0, p1, p2, p3 = ext[i - 1], ext[i], ext[i + 1], ext[i + 2]
        # Centripetal knots (alpha = 1/2) avoid cusps and self-intersections inside a segment.
        t0 = 0.0
        t1 = t0 + max(np.linalg.norm(p1 - p0), 1e-6) ** 0.5
        t2 = t1 + max(np.linalg.norm(p2 - p1), 1e-6) ** 0.5
        t3 = t2 + max(np.linalg.norm(p3 - p2), 1e-6) ** 0.5
        n = max(8, int(np.linalg.norm(p2 - p1) / 0.004))
        t = np.linspace(t1, t2, n + 1)[1:, None]
        a1 = (t1 - t) / (t1 - t0) * p0 + (t - t0) / (t1 - t0) * p1
        a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2
        a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3
        b1 = (t2 - t) / (t2 - t0) * a1 + (t - t0) / (t2 - t0) * a2
        b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3
        dense.append((t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2)
    dense = np.concatenate(dense)
    seg = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    arc_dense = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(2, int(math.ceil(arc_dense[-1] / spacing)) + 1)
    arc = np.linspace(0.0, arc_dense[-1], n)
    points = np.stack([np.interp(arc, arc_dense, dense[:, 0]), np.interp(arc, arc_dense, dense[:, 1])], -1)
    tangent = np.gradient(points, axis=0)
    heading = np.unwrap(np.arctan2(-tangent[:, 0], tangent[:, 1]))
    return GroundPath(arc=arc, points=points, heading=heading)


# --------------------------------------------------------------------------- speed along a path

def speed_profile(length: float, cruise: float, ramp_per_speed: float):
    """Arc length ``s(t)`` with smooth acceleration and deceleration; returns (s_of_t, stop_time, cruise)."""
    ramp_per_speed = max(ramp_per_speed, 1e-3)
    # Distance of both ramps is cruise * ramp / 2 each (smoothstep has mean 1/2).
    if cruise * cruise * ramp_per_speed > length:
        cruise = math.sqrt(length / ramp_per_speed)
    ramp = cruise * ramp_per_speed
    cruise_time = (length - cruise * ramp) / cruise
    stop = 2 * ramp + cruise_time

    def s_of_t(t):
        t = np.asarray(t, dtype=np.float64)
        x = np.clip(t / ramp, 0, 1)
        accel = cruise * ramp * (x**3 - 0.5 * x**4)
        y = np.clip((stop - t) / ramp, 0, 1)
        decel = length - cruise * ramp * (y**3 - 0.5 * y**4)
        mid = cruise * ramp * 0.5 + cruise * (t - ramp)
        return np.where(t < ramp, accel, np.where(t > stop - ramp, decel, mid)).clip(0, length)

    return s_of_t, stop, cruise


def path_speed_profile(path: GroundPath, cruise: float, accel: float, lateral_accel: float, min_speed: float):
    """Arc length ``s(t)`` along a curved path: slower in tight bends, smooth starts and stops.

    The speed limit at arc length ``s`` is ``min(cruise, sqrt(lateral_accel / curvature))`` (never
    below ``min_speed``); a forward and a backward pass cap the acceleration at ``accel`` m/s², and
    a Gaussian blur of the speed over time removes the remaining kinks (the distance is rescaled
    so the walk still ends exactly at the path's end).

    Returns ``(s_of_t, stop_time, speed_of_t)``.
    """
    ds = float(np.mean(np.diff(path.arc))) if len(path.arc) > 1 else path.length
    curvature = np.abs(np.gradient(path.heading, path.arc)) if len(path.arc) > 2 else np.zeros_like(path.arc)
    curvature = gaussian_filter1d(curvature, max(1.0, 0.15 / max(ds, 1e-6)), mode="nearest")
    limit = np.clip(np.sqrt(lateral_accel / np.maximum(curvature, 1e-9)), min_speed, cruise)
    v = limit.copy()
    v[0] = v[-1] = 0.0
    steps = np.diff(path.arc)
    for i in range(1, len(v)):
        v[i] = min(v[i], math.sqrt(v[i - 1] ** 2 + 2 * accel * steps[i - 1]))
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2 * accel * steps[i]))
    dt = 2.0 * steps / np.maximum(v[1:] + v[:-1], 1e-9)
    t_of_s = np.concatenate([[0.0], np.cumsum(dt)])
    fine = 1.0 / (10 * FPS)
    sigma = 0.12
    pad = 4 * sigma
    t_grid = np.arange(-pad, t_of_s[-1] + pad + fine, fine)
    s_grid = np.interp(t_grid, t_of_s, path.arc)
    speed = gaussian_filter1d(np.gradient(s_grid, fine), sigma / fine, mode="constant")
    s_smooth = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * fine)])
    start = int(np.searchsorted(s_smooth, 1e-5 * path.length))
    end = int(np.searchsorted(s_smooth, s_smooth[-1] * (1 - 1e-5)))
    scale = path.length / max(s_smooth[end] - s_smooth[start], 1e-12)
    t_grid = t_grid[start:end + 1] - t_grid[start]
    s_smooth = (s_smooth[start:end + 1] - s_smooth[start]) * scale
    speed = speed[start:end + 1] * scale
    stop = float(t_grid[-1])

    def s_of_t(t):
        return np.interp(np.asarray(t, dtype=np.float64), t_grid, s_smooth)

    def speed_of_t(t):
        return np.interp(np.asarray(t, dtype=np.float64), t_grid, speed, left=0.0, right=0.0)

    return s_of_t, stop, speed_of_t
