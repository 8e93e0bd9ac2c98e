"""The planners CHOICE compares with in Table 3 (§8.2.1).

- :func:`minimum_jerk_plan` stands in for cuRobo ({cite}`sundaralingam2023curobo`), "the parallelized
  collision-free minimum-jerk model": the wrist's waypoints between a fixed start and goal minimise the
  squared jerk plus a penalty on coming closer than ``margin`` to an obstacle, read from the scene's
  signed distance (the same geometry the fields are built from). cuRobo optimises a robot's joints
  with a fixed base; here the wrist point itself, at a fixed duration (ours: the straight distance at
  the demonstrations' mean wrist speed). Solved with L-BFGS in torch from the straight line.

The diffusion policy of Chi et al. (the other learned baseline) is still to come.
"""
from __future__ import annotations

from typing import Callable, Optional

import numpy as np
import torch

from .._validate import check_shape

__all__ = ["minimum_jerk_profile", "minimum_jerk_plan"]


def minimum_jerk_profile(n_frames: int) -> np.ndarray:
    """(n,) the minimum-jerk blend ``10s³ − 15s⁴ + 6s⁵`` from 0 to 1 (Flash and Hogan 1985): the jerk-optimal
    free move between two rests."""
    s = np.linspace(0.0, 1.0, int(n_frames))
    return 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5


def minimum_jerk_plan(start, goal, n_frames: int, obstacle_sdf: Optional[Callable] = None, *,
                      margin: float = 0.05, obstacle_weight: float = 1e5, iterations: int = 200) -> np.ndarray:
    """A collision-penalised minimum-jerk wrist path from ``start`` to ``goal`` (the cuRobo stand-in).

    The ends are held at rest (two copies of each end pad the jerk's third differences), the interior
    frames minimise ``Σ ‖Δ³x‖² / J₀ + w · mean(max(0, margin − sdf(x)) / margin)²`` (``J₀`` the free move's
    jerk, so that ``w`` weighs the two in the same units; ours).

    Args:
        start, goal: (3,) metres.
        n_frames: frames including both ends (≥ 3).
        obstacle_sdf: ``points (..., 3) torch → (...)`` signed distance to the obstacles (differentiable);
            None: a free move (the result is then the discrete minimum-jerk path).
        margin: metres the penalty keeps from obstacles.
        obstacle_weight: ``w``.
        iterations: L-BFGS iterations.
    Returns:
        (n_frames, 3) metres.
    """
    start = np.asarray(start, dtype=np.float64)
    goal = np.asarray(goal, dtype=np.float64)
    check_shape(start, (3,), "start")
    check_shape(goal, (3,), "goal")
    n = int(n_frames)
    if n < 3:
        raise ValueError(f"n_frames: expected at least 3 frames, got {n_frames!r}")
    s = torch.as_tensor(minimum_jerk_profile(n)[1:-1, None], dtype=torch.float64)
    a, b = torch.as_tensor(start), torch.as_tensor(goal)
    interior = (a + s * (b - a)).clone().requires_grad_(True)
    optimizer = torch.optim.LBFGS([interior], lr=1.0, max_iter=int(iterations), line_search_fn="strong_wolfe")

    def path():
        return torch.cat([a[None], a[None], a[None], interior, b[None], b[None], b[None]])

    with torch.no_grad():  # the free move's jerk: the scale of the jerk term
        jerk_scale = torch.diff(path(), n=3, dim=0).pow(2).sum().clamp_min(1e-12)

    def objective():
        optimizer.zero_grad()
        loss = torch.diff(path(), n=3, dim=0).pow(2).sum() / jerk_scale
        if obstacle_sdf is not None:
            d = obstacle_sdf(interior)
            loss = loss + obstacle_weight * (torch.clamp(margin - d, min=0.0) / margin).pow(2).mean()
        loss.backward()
        return loss

    optimizer.step(objective)
    return path()[2:-2].detach().numpy()
