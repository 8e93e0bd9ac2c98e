"""The small types the pick-and-place demo's pieces pass to each other (§6, Fig. 6): its configuration, a run's
record, the setting every piece reads (body, task, hands, configuration), the stances and the plans.

Named tuples, so a piece's result reads by name (``stance.heading``, ``plan.door``) and still unpacks as before.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ...world.mocap.body_plan import SIDES, PlanBody
from ...world.motion import Motion
from ...world.scenes import Kitchen
from ..planner.interactions import PlannerDataConfig
from ..planner.intp import PlannerConfig
from .environment import EnvironmentConfig
from .goal_library import LibraryConfig
from .navigation import NavigationConfig
from .scheduler import Candidate, SchedulerConfig, Task, TaskPlan

__all__ = ["PickAndPlaceConfig", "PickAndPlace", "DemoSetting", "Bend", "Stance", "OpenStance", "TakeStance", "TableStance",
           "CabinetPlan", "TablePlan", "BodyDistances"]

Bend = tuple  # (h, alpha): the pelvis lowered by h metres and the trunk pitched by alpha radians (``choose_bend``)


@dataclass(frozen=True)
class PickAndPlaceConfig:
    """The demo's constants (defaults: the ``toy`` preset).

    Attributes:
        n_starts: start positions tried, in order, until a walk reaches the stance (ours).
        durations: seconds of each timed phase, ``(reach, grasp, open, lean_in, take_out, release, stand_up,
            place, let_go)`` (ours).
        hold: where the carrying wrist is held while walking, in the pelvis's heading frame: (sideways
            towards the carrying hand, forward, up from the pelvis), metres (ours).
        exit_clearance: after taking the bottle out the body steps back to the nearest floor cell this far from
            every footprint (the open door's included), where the walk to the table starts, metres (ours).
        table_inset: the bottle's centre this far in from the table edge, metres (ours).
        table_gap: the stance's pelvis this far out from the table edge, metres (ours).
        stance_margin: a stance is taken when the body's sample points keep ``body_radius`` plus this from the
            door (at A, over the first half of its swing; at B, opened; on the way, swinging), metres (ours).
        body_radius: radius of the body's sample points, metres (ours; a thin limb).
        bone_samples: points along each bone between its two joints (ours).
        contact_radius: points this near a wrist holding the handle or the bottle (the hand and the wrist end of
            the forearm) may touch what it holds, metres (ours).
        tolerance: penetration of the bottle allowed (it rests on boards), metres; also the placing
            tolerance (ours).
        style: the bend, ``"squat"`` (knees) or ``"stoop"`` (hips) (``world.mocap.standing``).
        hands: which schedule the demo plays: ``"eq24"``, the one Eq. 24 chooses (as the paper; it may hold the
            door across the body), or ``"uncrossed"``, the cheapest feasible co-temporal schedule whose door hand
            holds the opened door on its own side (``scheduler.cheapest_uncrossed``; ours, see the module's
            docstring).
        navigation, environment, library, scheduler: the configurations of the pieces used.
        planner_data, planner: §4's planner that plans the hands' approaches (``hand_paths``): its interactions'
            and its own configuration (chapter 16's; ``planner.interactions.planner_data_config``,
            ``planner.intp.planner_config``).
    """

    n_starts: int = 6
    durations: tuple = (0.9, 0.3, 1.5, 0.9, 1.0, 0.5, 0.9, 1.0, 0.8)
    hold: tuple = (0.16, 0.32, 0.22)
    exit_clearance: float = 0.45
    table_inset: float = 0.16
    table_gap: float = 0.42
    stance_margin: float = 0.01
    body_radius: float = 0.03
    bone_samples: int = 4
    contact_radius: float = 0.12
    tolerance: float = 0.005
    style: str = "squat"
    hands: str = "uncrossed"
    navigation: NavigationConfig = NavigationConfig()
    environment: EnvironmentConfig = EnvironmentConfig()
    library: LibraryConfig = LibraryConfig()
    scheduler: SchedulerConfig = SchedulerConfig()
    planner_data: PlannerDataConfig = PlannerDataConfig()
    planner: PlannerConfig = PlannerConfig()

    def __post_init__(self):
        if isinstance(self.n_starts, bool) or not isinstance(self.n_starts, int) or self.n_starts < 1:
            raise ValueError(f"n_starts: expected a positive int, got {self.n_starts!r}")
        if isinstance(self.bone_samples, bool) or not isinstance(self.bone_samples, int) or self.bone_samples < 0:
            raise ValueError(f"bone_samples: expected a non-negative int, got {self.bone_samples!r}")
        durations = tuple(self.durations)
        if len(durations) != 9 or not all(isinstance(d, (int, float)) and d > 0 for d in durations):
            raise ValueError("durations: expected 9 positive numbers of seconds (reach, grasp, open, lean_in, "
                             f"take_out, release, stand_up, place, let_go), got {self.durations!r}")
        object.__setattr__(self, "durations", tuple(float(d) for d in durations))
        hold = tuple(self.hold)
        if len(hold) != 3 or not all(isinstance(h, (int, float)) for h in hold):
            raise ValueError(f"hold: expected 3 numbers of metres (sideways, forward, up), got {self.hold!r}")
        object.__setattr__(self, "hold", tuple(float(h) for h in hold))
        for name in ("table_inset", "table_gap", "stance_margin", "contact_radius", "tolerance", "exit_clearance"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
                raise ValueError(f"{name}: expected a positive number of metres, got {value!r}")
        if isinstance(self.body_radius, bool) or not isinstance(self.body_radius, (int, float)) \
                or not self.body_radius >= 0:
            raise ValueError(f"body_radius: expected a non-negative number of metres, got {self.body_radius!r}")
        if self.style not in ("squat", "stoop"):
            raise ValueError(f"style: expected 'squat' or 'stoop', got {self.style!r}")
        if self.hands not in ("eq24", "uncrossed"):
            raise ValueError(f"hands: expected 'eq24' or 'uncrossed', got {self.hands!r}")
        for name, kind, factory in (("planner_data", PlannerDataConfig, "planner_data_config"),
                                    ("planner", PlannerConfig, "planner_config")):
            if not isinstance(getattr(self, name), kind):
                raise TypeError(f"{name}: expected a {kind.__name__} ({factory}), got {type(getattr(self, name)).__name__}")


@dataclass(eq=False)
class PickAndPlace:
    """One run of the demo.

    Attributes:
        seed: the kitchen's seed.
        kitchen: the scene as it starts (``demo.cabinet_kitchen``; the bottle is item 0).
        plan: the scheduler's ``TaskPlan`` (§6.3) for the schedule played (``plan.chosen``; ``config.hands``).
        eq24: the schedule Eq. 24 chooses (``scheduler.Candidate``), the same as ``plan.chosen`` unless the
            ``"uncrossed"`` rule replaced it.
        motion: the whole ``Motion`` (30 fps, mean body): local rotations (T, 22, 3, 3), root (T, 3) metres.
        door_angle: (T,) radians, the cabinet door at each frame.
        bottle_pose: (T, 4, 4) the bottle's world pose at each frame.
        phases: ``(name, start, stop)`` frame ranges, in order, covering ``[0, T)``.
        hands: ``{"door": hand, "bottle": hand}`` (``"left"`` / ``"right"``).
        place_at: (3,) where the bottle's grasp point goes down (the scheduler's ``place_at``), metres.
        walks: per walk (to the cabinet, to the table): ``goal`` (2,), ``reached``, ``goal_error`` (metres),
            ``stopped``, ``frames``; the first also ``starts_tried`` (each start with its goal error or error),
            ``start_index``, ``stance`` (how stance A was found) and ``take_stances_tried`` (each stance B tried
            with its clearance and door-hand error, metres).
        checks: ``checks.evaluate``'s dictionary.
        seconds: wall time of the run.
        config: the configuration it ran with.
        hand_paths: the hands' approaches §4's planner planned, by phase (``"reach bottle"``, ``"place"``):
            ``hand_paths.HandPath.as_record`` (the polyline the wrist follows, ``x_s``, each initialisation's
            clearance and fit, the one played, the seconds).
    """

    seed: int
    kitchen: Kitchen
    plan: TaskPlan
    eq24: Candidate
    motion: Motion
    door_angle: np.ndarray
    bottle_pose: np.ndarray
    phases: list
    hands: dict
    place_at: np.ndarray
    walks: list
    checks: dict = field(default_factory=dict)
    seconds: float = 0.0
    config: PickAndPlaceConfig = PickAndPlaceConfig()
    hand_paths: dict = field(default_factory=dict)

    def phase(self, name: str) -> tuple:
        """``(start, stop)`` of the first phase called ``name``."""
        for n, a, b in self.phases:
            if n == name:
                return a, b
        raise ValueError(f"name: expected one of {[n for n, _, _ in self.phases]}, got {name!r}")


@dataclass(frozen=True)
class DemoSetting:
    """What every piece of one run reads: the body, the scheduled task, which hand does what, the configuration.

    Attributes:
        body: the body plan (its bone lengths and shape).
        task: the scheduler's task (the bottle ``target``, the door ``auxiliary``, the opening and the carry point).
        hands: ``{"door": side, "bottle": side}``, each ``"left"`` or ``"right"``.
        config: the demo's :class:`PickAndPlaceConfig`.
        planner: the §4 planner the hands' approaches are planned with (``hand_paths.trained_approach_planner``).
        seed: the run's seed (the planner's latent initialisations).
    """

    body: PlanBody
    task: Task
    hands: dict
    config: PickAndPlaceConfig
    planner: object
    seed: int = 0

    @property
    def door_side(self) -> int:
        """The door hand as a side index (0 left, 1 right)."""
        return SIDES.index(self.hands["door"])

    @property
    def bottle_side(self) -> int:
        """The bottle hand as a side index (0 left, 1 right)."""
        return SIDES.index(self.hands["bottle"])


class Stance(NamedTuple):
    """Where the body stands: the pelvis over ``xy`` (2,) metres, facing ``heading`` radians."""

    xy: np.ndarray
    heading: float


class OpenStance(NamedTuple):
    """Stance A, to take the handle: ``xy`` (2,), ``heading``, the ``bend`` that reaches the closed handle, and
    ``source``, how it was found (the matched keyframe's pelvis, or a shift of it)."""

    xy: np.ndarray
    heading: float
    bend: Bend
    source: str


class TakeStance(NamedTuple):
    """A stance B, to take the bottle out with the door held open: ``xy`` (2,), ``heading``, and ``bends``, the
    bend that reaches the handle and the bottle (B2) and the one that reaches the handle and the carry point
    (B3)."""

    xy: np.ndarray
    heading: float
    bends: tuple


class TableStance(NamedTuple):
    """The stance at the table: ``xy`` (2,), ``heading``, the ``bend`` that reaches ``place_at`` (3,), the
    wrist's target when the bottle stands on ``spot`` (3,)."""

    xy: np.ndarray
    heading: float
    bend: Bend
    spot: np.ndarray
    place_at: np.ndarray


class CabinetPlan(NamedTuple):
    """The plan at the cabinet: the body ``plan``, its ``phases`` ``[(name, frames)]``, the ``door`` angle per
    frame (T,), ``grasp_frame``, the first frame the bottle is held, ``bottle_path`` and ``handle_path``, the
    bottle hand's and the door hand's approaches planned by §4's planner (``hand_paths.HandPath``)."""

    plan: object
    phases: list
    door: np.ndarray
    grasp_frame: int
    bottle_path: object
    handle_path: object


class TablePlan(NamedTuple):
    """The plan at the table: the body ``plan``, its ``phases`` ``[(name, frames)]`` and ``place_path``, the
    bottle hand's approach to the spot planned by §4's planner (``hand_paths.HandPath``)."""

    plan: object
    phases: list
    place_path: object


class BodyDistances(NamedTuple):
    """Per frame, the body's clearance: ``scene`` to the kitchen (the held handle's and bottle's contacts
    excepted), ``bottle`` to the bottle (its holding hand excepted), metres."""

    scene: np.ndarray
    bottle: np.ndarray
