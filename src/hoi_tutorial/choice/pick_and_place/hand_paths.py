"""The demo's hands planned by CHOICE's own planner (§4.2, Eqs. 9–12; §6, Fig. 2): the neural implicit trajectory
planner of ``choice.planner.intp``, trained on the toy interactions, plans a wrist's approach in the demo's own
scene.

The algorithm box, as this module runs it (:func:`planned_approach`):

1. **The scene's fields** (Eqs. 1–4, ``planner.fields.scene_fields``): the object-centric grid around the target
   (the bottle on its board; the bottle where it will stand on the table), yawed like the furniture that holds
   it, with the scene's other things as obstacles (the cabinet with its door open, the other furniture, the other
   items).
2. **Plan** (``intp.plan_trajectory``): match a prior, fit the latent code to the known fields (Eq. 9) from the
   planner's initialisations and keep the best fit (as CHOICE), start at ``x_s`` (Eq. 11), integrate down ``φ̂``
   (Eq. 10) and land on the contact; the wrist goes straight from where it is to ``x_s`` first
   (``WristPlan.from_wrist``: CHOICE leaves that stretch to the controller). The path's least distance to the
   obstacles is recorded.
3. **Time** (ours, in ``motion_pieces``): the hand moves along the planned path in the phase's frames, minimum-jerk
   in arc length (``motion_pieces.along_path``), as the demo's other hand paths; the planner's own pace (``v̄`` a
   frame) sets the shape, not the duration.

The minimum-jerk planner (``planner.baselines.minimum_jerk_plan``, CHOICE's cuRobo stand-in) is a baseline of
Table 3 only; no hand of the demo follows it.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import torch

from ..._validate import check_shape
from ..planner import fields, interactions, intp

__all__ = ["ApproachPlanner", "trained_approach_planner", "HandPath", "planned_approach", "path_clearance"]


class ApproachPlanner(NamedTuple):
    """§4's implicit planner as §6's scenes use it (the demo's hands, Table 4's re-planned approaches): the trained
    auto-decoder, its configuration, the interactions it was trained on (the priors of Eqs. 11–12 are matched among
    them) and the field configuration of its grids."""

    model: intp.AutoDecoder
    config: intp.PlannerConfig
    dataset: interactions.InteractionSet
    field: fields.FieldConfig


def trained_approach_planner(data_config: interactions.PlannerDataConfig,
                             config: intp.PlannerConfig) -> ApproachPlanner:
    """The planner of chapter 16 (``intp.trained_planner`` through the artifact cache: trained once, then loaded)
    with its training interactions."""
    return ApproachPlanner(intp.trained_planner(data_config, config).model, config,
                           interactions.interaction_set(data_config, "train"), data_config.field)


@dataclass
class HandPath:
    """A hand's planned approach, world metres.

    Attributes:
        path: (K, 3) the planned polyline in time order, from the wrist to the contact (``WristPlan.from_wrist``).
        start: (3,) ``x_s`` of Eq. 11.
        clearance: the path's least distance to the obstacles, metres.
        fit_loss: (inits,) each initialisation's final Eq. 9 loss (the least one's code is played).
        prior_index: the matched training interaction.
        seconds: the planning time (the fit and the best code's integration).
    """

    path: np.ndarray
    start: np.ndarray
    clearance: float
    fit_loss: np.ndarray
    prior_index: int
    seconds: float

    def as_record(self) -> dict:
        """Plain numbers for the artifact cache and the chapter's tables."""
        return {"path": self.path.tolist(), "start": self.start.tolist(), "clearance": float(self.clearance),
                "fit_loss": self.fit_loss.tolist(), "prior_index": int(self.prior_index),
                "seconds": float(self.seconds)}


def path_clearance(path, obstacles) -> float:
    """The least signed distance (metres) of the points ``path`` (K, 3) to ``obstacles`` (things with ``.sdf``)."""
    return float(np.min(np.asarray(fields.sdf_union(list(obstacles))(np.asarray(path, dtype=np.float64)))))


def planned_approach(planner: ApproachPlanner, target, obstacles, wrist, contact, hand: str, action: str, *,
                     grid_yaw: float, seed: int = 0) -> HandPath:
    """Plan the wrist's approach to ``contact`` on ``target`` among ``obstacles`` (the algorithm box above).

    Args:
        planner: :func:`trained_approach_planner`.
        target: the object the hand goes to (a ``ToyObject``; for a place, the item where it will stand).
        obstacles: the scene's other things (objects with ``.sdf``).
        wrist: (3,) the wrist where the approach starts, metres. contact: (3,) the grasp or release point.
        hand: ``"left"`` or ``"right"``. action: ``"grasp"`` or ``"place"`` (``c`` of §4.2, with the contact's
            height and the segment ``"approach"``).
        grid_yaw: radians, the yaw of the holding furniture (CHOICE §4.2 aligns the grid with it).
        seed: seeds the latent initialisations.
    Returns:
        :class:`HandPath`.
    Raises:
        ValueError: a contact outside the grid or inside an obstacle (``intp.plan_each_init``).
    """
    if not isinstance(planner, ApproachPlanner):
        raise ValueError("planner: expected an ApproachPlanner (trained_approach_planner), got "
                         f"{type(planner).__name__}")
    wrist, contact = (np.asarray(v, dtype=np.float64) for v in (wrist, contact))
    check_shape(wrist, (3,), "wrist")
    check_shape(contact, (3,), "contact")
    obstacles = list(obstacles)
    grid = fields.object_grid(target, planner.field, yaw=float(grid_yaw))
    scene = fields.scene_fields(grid, target, obstacles, config=planner.field)
    condition = interactions.condition_vector(float(contact[2]), hand, action, "approach")
    clock = time.perf_counter()
    plan = intp.plan_trajectory(planner.model, planner.config, planner.dataset, scene, condition, wrist, contact,
                                generator=torch.Generator().manual_seed(int(seed)))
    path = plan.from_wrist(wrist)
    return HandPath(path, plan.start, path_clearance(path, obstacles), np.asarray(plan.fit.final, dtype=np.float64),
                    plan.prior_index, time.perf_counter() - clock)
