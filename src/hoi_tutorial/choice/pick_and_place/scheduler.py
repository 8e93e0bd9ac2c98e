"""The bimanual task scheduler (CHOICE §6.3, Eq. 24, Fig. 6).

"Humans use both hands to achieve pick-and-place tasks efficiently ... e.g. using one hand to open the door
of the cabinet while taking out an object". The algorithm box, as this module runs it:

1. **Target and auxiliary objects** (:func:`detect_task`): the user picks the target item ``o_g``; the
   auxiliary object ``o_d`` is what stands in its way out, found "by ray-casting" and decided by "whether
   the target object can be taken outside the cabinet without collision" — here the item's surface swept
   along its ways out of its holder (lifted, then out of the front or straight up) against every other
   object's signed distance. A hit holder with a door or drawer that frees the way when opened makes the
   door or drawer ``o_d``; a hit item is an obstacle to move (Fig. 7).
2. **Matching** (§6.1, ``goal_library.match_goal``): the K nearest goal keyframes ``M(H, o)`` for each free
   hand ``H ∈ {l, r}`` and each object — "4 pairs of hand-object interaction matches" with both hands free.
3. **Scheduling** (:func:`evaluate_schedules`, Eq. 24): "if only one hand is free, the opening and grasping
   tasks are allocated sequentially to the free hand; if two hands are free, the total goal costs are
   computed for all potential schedules" — sequential with the left hand, with the right, co-temporal with
   one hand on each object — over all ``K × K`` combinations of matched keyframes:
   ``C = Σ_k Dev(M_k(H_{i_d}, o_d), p_k^key) + w Dev(M_k(H_{i_d}, o_d), M_k(H_{i_g}, o_g))``, ``w = 2``,
   ``k`` the three key joints, ``p^key`` the current pose and ``Dev`` the deviation of two 6D configurations
   of Eq. 22 (``controller.kalman.bidirectional_deviation``: ``α √2 θ + β ‖Δt‖``, ``α = 1/π``, ``β`` one over the body
   width). The cheapest feasible schedule is chosen.
4. **The state machine** (:func:`keyframes`, Fig. 6): a walk to the first matched keyframe's root, then for
   each object the states of its hand — reach → grasp → open (door, drawer) or carry (item) → place →
   release. A sequential schedule runs the auxiliary object's states to the end before the target's; a
   co-temporal one keeps the auxiliary hand holding (the door open, the obstacle out of the way) while the
   other hand takes the target out, and lets go (or puts the obstacle back) before the target is placed.
   The keyframes are plain data for a controller (the controller of §5 is not built here).

Choices the paper does not state, ours:

- Eq. 24's second term reads ``M_k(H_{i_d}, o_g)`` in our copy; we read ``H_{i_g}`` (the target keyframe
  of the hand that takes the target; otherwise ``i_g`` would appear nowhere).
- **Co-temporal keyframes.** The matched keyframes are single-handed; in a co-temporal schedule the target
  keyframe keeps the auxiliary hand where the auxiliary keyframe put it (it holds the door), in Eq. 24 and in
  the keyframes; the schedule is feasible only when the held point (the opened handle, the held obstacle)
  and the target's contact lie within the arm span (shoulder to shoulder plus both arms, mean toy body).
- With no auxiliary object Eq. 24 keeps its first term with the target in ``o_d``'s place; the hand is chosen
  by it.
- **Ways out**: lifted by ``lift``, then along the holder's front (+Y) or up, in steps of ``step`` until the
  item has left the holder's box (an open door included); a part closer than ``step / 2`` to a swept point is
  hit (a surface crossed between two steps comes that close at one of them). At most one auxiliary object
  (the way that needs the fewest; more raise an error); a door or drawer is opened to the smallest of
  ``open_steps`` even openings up to its full travel that frees the way; a drawer's items move with it.
- **Where the hands go**: the walk ends at the first matched keyframe's pelvis (the root goal §6.2 navigates
  to); ``p^key`` is the caller's. An item is carried until it has left the carcass (the door closed) along
  its way; an obstacle is held there, beside the target's way by both items' radii and a step, and in a
  co-temporal schedule put back where it stood once the target is out; a sequential schedule first puts it
  down on its own board at the nearest spot along the board that is free and off the target's way. A
  matched keyframe is moved so that its wrist is on the step's position (§6.3: keyframes are "adjusted to
  the runtime scene by IK").

Scaling (paper → toy): none: ``w = 2`` as the paper; ``K`` (unstated) is 3 for a toy library of six keyframes
per hand, kind and action.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

from ..._validate import check_choice, check_positive_ints, check_shape
from ...infra import scaled_config
from ...world.mocap.body_plan import UP
from ...world.objects import CATEGORY_SIZES
from ...world.scenes import Kitchen
from ...world.skeleton import joint_index, rest_joint_positions
from ..controller import kalman
from .environment import (HANDS, EnvironmentConfig, HandGoal, KeyPose, check_in_scene, handle_goal, item_goal,
                          object_goal, room_sdf)
from .goal_library import GoalLibrary, Match, match_goal

__all__ = [
    "ACTIONS",
    "SchedulerConfig",
    "SCHEDULER_SCALES",
    "scheduler_config",
    "deviation",
    "schedule_cost",
    "arm_span",
    "held_on_its_side",
    "cheapest_uncrossed",
    "Task",
    "detect_task",
    "Schedule",
    "candidate_schedules",
    "Candidate",
    "evaluate_schedules",
    "choose_schedule",
    "library_matcher",
    "Keyframe",
    "keyframes",
    "TaskPlan",
    "plan_task",
]

ACTIONS = ("walk", "reach", "grasp", "open", "carry", "place", "release")
_STATE = {"cabinet": "door_angle", "drawer": "drawer_open"}  # the parameter a door or drawer opens by


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class SchedulerConfig:
    """The scheduler's constants (the same at every scale).

    Attributes:
        weight: ``w`` of Eq. 24 (CHOICE: 2).
        k: matched keyframes per hand and object, ``K`` of §6.1 (ours).
        lift: how far an item is lifted before it slides out, metres (ours).
        step: the sweep's step, metres; a part within ``step / 2`` of a swept point is hit (ours).
        surface_samples: surface points of an item swept (ours).
        open_steps: even openings tried up to a door's or drawer's full travel (ours).
    """

    weight: float = 2.0
    k: int = 3
    lift: float = 0.01
    step: float = 0.01
    surface_samples: int = 96
    open_steps: int = 8

    def __post_init__(self):
        check_positive_ints(self, ("k", "surface_samples", "open_steps"))
        if not self.weight >= 0:
            raise ValueError(f"weight: expected w of Eq. 24 >= 0, got {self.weight!r}")
        for name in ("lift", "step"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: expected a positive number of metres, got {getattr(self, name)!r}")


SCHEDULER_SCALES: dict = {}  # nothing to scale: w is the paper's


def scheduler_config(scale: str = "toy", **overrides) -> SchedulerConfig:
    """The preset for ``scale`` (the same for all), fields overridable."""
    return scaled_config(SchedulerConfig, scale, SCHEDULER_SCALES, overrides, factory="scheduler_config")


# ----------------------------------------------------------------------------- Eq. 24


def deviation(a: KeyPose, b: KeyPose) -> float:
    """``Σ_k Dev(a_k, b_k)`` over the three key joints: Eq. 22's deviation of 6D configurations,
    ``α √2 θ_k + β ‖t_a − t_b‖`` with ``α = 1/π``, ``β = 1 / body width`` (``controller.kalman.PhaseFilterConfig``)."""
    return float(kalman.bidirectional_deviation(a.rotations, a.positions, b.rotations, b.positions,
                                                kalman.PhaseFilterConfig()))


def schedule_cost(current: KeyPose, auxiliary: KeyPose, target: KeyPose, weight: float = 2.0) -> float:
    """Eq. 24 for one combination: ``Dev(M(H_{i_d}, o_d), p^key) + w Dev(M(H_{i_d}, o_d), M(H_{i_g}, o_g))``.

    Args:
        current: ``p^key``, the key joints now.
        auxiliary: the matched keyframe of the auxiliary object's hand.
        target: the matched keyframe of the target's hand (in a co-temporal schedule, with the auxiliary
            hand where ``auxiliary`` holds it).
    """
    return deviation(auxiliary, current) + weight * deviation(auxiliary, target)


@functools.lru_cache(maxsize=1)
def arm_span() -> float:
    """Metres from wrist to wrist with both arms stretched sideways: the mean toy body's shoulder width
    plus both arms (the farthest two contacts held at once can be apart)."""
    joints = rest_joint_positions().numpy()
    length = lambda a, b: float(np.linalg.norm(joints[joint_index(a)] - joints[joint_index(b)]))  # noqa: E731
    return (length("left_shoulder", "right_shoulder") + length("left_shoulder", "left_wrist")
            + length("right_shoulder", "right_wrist"))


# ----------------------------------------------------------------------------- detecting o_g and o_d


def _ways(holder) -> list[np.ndarray]:
    """The unit directions an item leaves its holder by: out of the front (+Y), straight up."""
    front = holder.rotation[:, 1] * np.array([1.0, 1.0, 0.0])
    return [front / np.linalg.norm(front), UP]


def _carcass(holder):
    """The holder with its door or drawer closed."""
    return holder.with_params(**{_STATE[holder.category]: 0.0}) if holder.category in _STATE else holder


def _travel(points, box, way, config: SchedulerConfig) -> float:
    """How far points (P, 3) move along ``way`` until all have left ``box`` (2, 3), plus a step, metres."""
    corners = np.array([[x, y, z] for x in box[:, 0] for y in box[:, 1] for z in box[:, 2]])
    return float(np.max(corners @ way) - np.min(points @ way)) + config.step


def _sweep(item, holder, way, config: SchedulerConfig) -> np.ndarray:
    """(S, P, 3) the item's surface points lifted by ``lift``, then moved along ``way`` in steps of ``step``
    until every point has left the holder's box (an open door included)."""
    points = item.surface_points(config.surface_samples, seed=0) + config.lift * UP
    s = np.arange(0.0, _travel(points, holder.bounds, way, config) + config.step, config.step)
    return points[None] + s[:, None, None] * way


def _carry_point(contact, item, holder, way, config: SchedulerConfig) -> np.ndarray:
    """(3,) where ``contact`` on the item is once the item, lifted, has left the holder's carcass along ``way``."""
    points = item.surface_points(config.surface_samples, seed=0) + config.lift * UP
    return np.asarray(contact) + config.lift * UP + _travel(points, _carcass(holder).bounds, way, config) * way


def _scene(kitchen: Kitchen, holder, opening: Optional[float] = None) -> list[tuple]:
    """``(original, now)`` for every object of the kitchen, with ``holder``'s door or drawer opened to
    ``opening`` (None: as it is); a drawer's items move with the drawer."""
    if opening is None:
        return [(o, o) for o in kitchen.objects]
    state = _STATE[holder.category]
    opened = holder.with_params(**{state: float(opening)})
    shift = (float(opening) - holder.params[state]) * holder.rotation[:, 1] if holder.category == "drawer" else 0.0
    riders = [kitchen.items[i] for i, h in enumerate(kitchen.holders) if kitchen.furniture[h] is holder]
    out = []
    for o in kitchen.objects:
        if o is holder:
            o_now = opened
        elif any(o is r for r in riders) and holder.category == "drawer":
            pose = o.pose.copy()
            pose[:3, 3] += shift
            o_now = o.with_pose(pose)
        else:
            o_now = o
        out.append((o, o_now))
    return out


def _now(scene, obj):
    return next(now for original, now in scene if original is obj)


def _blockers(scene, item, holder, way, config: SchedulerConfig) -> tuple[list, np.ndarray]:
    """The objects (as they are in the kitchen) in the way of ``item`` leaving ``holder`` along ``way`` in
    ``scene`` (:func:`_scene`), and the sweep."""
    swept = _sweep(_now(scene, item), _now(scene, holder), way, config)
    flat = swept.reshape(-1, 3)
    hit = [o for o, now in scene if o is not item and np.min(now.sdf(flat)) < 0.5 * config.step]
    return hit, swept


@dataclass(frozen=True, eq=False)
class Task:
    """What §6.3's first step finds for one target.

    Attributes:
        kitchen: the scene as it is.
        index: the target's item index.
        target: ``o_g`` as it is grasped: in the scene with the door or drawer opened and the obstacle gone.
        auxiliary: ``o_d``: the door or drawer handle, or the obstacle item; None when the way is free.
        way: (3,) unit direction the target leaves its holder by.
        carry: (3,) where the target's contact is at the end of its way out, metres.
        hold: (3,) where the auxiliary hand holds ``o_d`` while the target comes out (the opened handle, the
            obstacle beside the way), or None.
        opening: the door angle (rad) or drawer travel (m) opened to, or None.
        aside: (3,) where a sequential schedule puts an obstacle down (its contact there), or None when its
            board has no free spot.
    """

    kitchen: Kitchen
    index: int
    target: HandGoal
    auxiliary: Optional[HandGoal]
    way: np.ndarray
    carry: np.ndarray
    hold: Optional[np.ndarray] = None
    opening: Optional[float] = None
    aside: Optional[np.ndarray] = None


def detect_task(kitchen: Kitchen, index: int, config: SchedulerConfig = SchedulerConfig(),
                env_config: EnvironmentConfig = EnvironmentConfig()) -> Task:
    """The target item ``index`` of ``kitchen`` and the auxiliary object in its way (step 1 of §6.3).

    Raises:
        ValueError: an index that is no item's; no way out even with the door or drawer open and the items
        moved; a way that needs more than one auxiliary object.
    """
    goal = item_goal(kitchen, index, env_config)  # checks the index
    item, holder = goal.obj, kitchen.holder_of(index)
    as_is = _scene(kitchen, holder)
    options = []  # (number of auxiliary objects, way, opening or None, obstacle items)
    for way in _ways(holder):
        hit, _ = _blockers(as_is, item, holder, way, config)
        opening = None
        if any(o is holder for o in hit) and holder.category in _STATE:  # does opening it free the way?
            full = CATEGORY_SIZES[holder.category][_STATE[holder.category]].high
            hit_open, _ = _blockers(_scene(kitchen, holder, full), item, holder, way, config)
            if not any(o is holder for o in hit_open):
                hit, opening = hit_open, full
        if any(not any(o is i for i in kitchen.items) for o in hit):
            continue  # a part of the furniture in the way
        options.append((len(hit) + (opening is not None), way, opening, hit))
    if not options:
        raise ValueError(f"index: the {goal.name} cannot be taken out of its {holder.category} without a collision, "
                         "even with its door or drawer open and the other items moved")
    count, way, opening, obstacles = min(options, key=lambda o: o[0])
    if count > 1:
        names = (["its door or drawer"] if opening is not None else []) + [o.category for o in obstacles]
        raise ValueError(f"index: taking out the {goal.name} needs {count} auxiliary objects ({', '.join(names)}); "
                         "the scheduler plans one")
    if opening is not None:
        return _opening_task(kitchen, index, goal, holder, way, opening, config, env_config)
    if obstacles:
        return _obstacle_task(kitchen, index, goal, holder, way, obstacles[0], config, env_config)
    return Task(kitchen, index, goal, None, way, _carry_point(goal.contact, item, holder, way, config))


def _goal_in(kitchen: Kitchen, scene, goal: HandGoal, holder, env_config, without=()) -> HandGoal:
    """``goal`` (an item) as it is in ``scene``, the objects ``without`` gone from around it."""
    item = _now(scene, goal.obj)
    around = [now for o, now in scene if o is not goal.obj and not any(o is w for w in without)]
    return object_goal(item, _now(scene, holder), goal.name, around + [room_sdf(kitchen.size)], env_config)


def _opening_task(kitchen, index, goal, holder, way, full, config, env_config) -> Task:
    """The task with the holder's door or drawer as ``o_d``, opened to the smallest opening that frees the way."""
    current = holder.params[_STATE[holder.category]]
    for value in np.linspace(current, full, config.open_steps + 1)[1:]:
        scene = _scene(kitchen, holder, value)
        hit, swept = _blockers(scene, goal.obj, holder, way, config)
        if not hit:
            break
    target = _goal_in(kitchen, scene, goal, holder, env_config)
    auxiliary = handle_goal(kitchen, "door" if holder.category == "cabinet" else "drawer", env_config)
    carry = _carry_point(target.contact, target.obj, holder, way, config)
    return Task(kitchen, index, target, auxiliary, way, carry, hold=_now(scene, holder).handle_point,
                opening=float(value))


def _radius(obj) -> float:
    """Half the largest horizontal extent of an object's canonical box, metres."""
    lo, hi = obj.canonical_bounds
    return 0.5 * float(np.max(hi[:2] - lo[:2]))


def _obstacle_task(kitchen, index, goal, holder, way, obstacle, config, env_config) -> Task:
    """The task with an item in front of the target as ``o_d``: held beside the way, or put aside."""
    auxiliary = item_goal(kitchen, next(i for i, o in enumerate(kitchen.items) if o is obstacle), env_config)
    as_is = _scene(kitchen, holder)
    if _blockers(as_is, obstacle, holder, way, config)[0]:
        raise ValueError(f"index: the {auxiliary.name} in front of the {goal.name} cannot be taken out either")
    side = holder.rotation[:, 0]
    apart = (obstacle.translation - goal.obj.translation) @ side
    clear_of_way = max(_radius(obstacle) + _radius(goal.obj) + config.step - abs(apart), 0.0)
    beside = clear_of_way * (1.0 if apart >= 0 else -1.0) * side
    target = _goal_in(kitchen, as_is, goal, holder, env_config, without=(obstacle,))
    others = [o for o in kitchen.objects if o is not obstacle and o is not goal.obj]
    _, target_swept = _blockers(as_is, goal.obj, holder, way, config)
    aside = _aside_spot(obstacle, holder, others, target_swept, config)
    return Task(kitchen, index, target, auxiliary, way, _carry_point(target.contact, goal.obj, holder, way, config),
                hold=_carry_point(auxiliary.contact, obstacle, holder, way, config) + beside,
                aside=None if aside is None else auxiliary.contact + aside)


def _aside_spot(obstacle, holder, others, target_swept, config) -> Optional[np.ndarray]:
    """The shortest move (3,) along the obstacle's board that puts it where it touches nothing (lifted by
    ``lift``, as the sweep) and is off the target's way; None if the board has no such spot."""
    side = holder.rotation[:, 0]
    base = holder.to_canonical(obstacle.translation[None])[0]
    rows = holder.support_surfaces
    _, x0, x1 = rows[int(np.argmin(np.abs(rows[:, 0] - base[2])))][:3]
    r = _radius(obstacle)
    steps = np.arange(config.step, x1 - x0, config.step)
    for offset in sorted(np.concatenate([steps, -steps]), key=abs):
        if not x0 + r <= base[0] + offset <= x1 - r:
            continue
        pose = obstacle.pose.copy()
        pose[:3, 3] += offset * side
        moved = obstacle.with_pose(pose)
        points = moved.surface_points(config.surface_samples, seed=0) + config.lift * UP
        clear = all(np.min(o.sdf(points)) >= 0.5 * config.step for o in others)
        if clear and np.min(moved.sdf(target_swept.reshape(-1, 3))) >= 0.5 * config.step:
            return offset * side
    return None


# ----------------------------------------------------------------------------- schedules (Eq. 24)


@dataclass(frozen=True)
class Schedule:
    """Which hand takes the auxiliary object (None: there is none) and which the target."""

    auxiliary_hand: Optional[str]
    target_hand: str

    @property
    def cotemporal(self) -> bool:
        return self.auxiliary_hand is not None and self.auxiliary_hand != self.target_hand

    @property
    def name(self) -> str:
        if self.auxiliary_hand is None:
            return f"{self.target_hand} hand"
        if self.cotemporal:
            return f"co-temporal ({self.auxiliary_hand}: auxiliary, {self.target_hand}: target)"
        return f"sequential ({self.target_hand} hand)"


def _free_hands(busy) -> list[str]:
    busy = tuple(busy)
    for hand in busy:
        check_choice(hand, HANDS, "busy")
    free = [h for h in HANDS if h not in busy]
    if not free:
        raise ValueError(f"busy: both hands hold something ({list(busy)}); a free hand is needed to take the target")
    return free


def candidate_schedules(busy: Sequence[str] = (), auxiliary: bool = True) -> list[Schedule]:
    """The schedules §6.3 weighs: sequential with each free hand, and with both free the two co-temporal
    ones (one hand on each object); without an auxiliary object, each free hand alone.

    Args:
        busy: the hands that hold something (``"left"``, ``"right"``).
        auxiliary: whether there is an auxiliary object.
    """
    free = _free_hands(busy)
    if not auxiliary:
        return [Schedule(None, h) for h in free]
    out = [Schedule(h, h) for h in free]
    if len(free) == 2:
        out += [Schedule(d, g) for d in free for g in free if d != g]
    return out


@dataclass(frozen=True, eq=False)
class Candidate:
    """One schedule's best combination of matched keyframes.

    Attributes:
        schedule: the hands.
        cost: Eq. 24's minimum over the ``K × K`` combinations (``inf`` when infeasible).
        auxiliary: the matched keyframe of ``o_d`` (None without one).
        target: the matched keyframe of ``o_g`` (as matched: Eq. 24 and the keyframes put a co-temporal
            schedule's auxiliary hand where ``auxiliary`` holds it).
        feasible: False when a co-temporal schedule's two contacts lie beyond the arm span, or a sequential
            one has nowhere to put an obstacle down.
    """

    schedule: Schedule
    cost: float
    auxiliary: Optional[Match]
    target: Match
    feasible: bool = True


Matcher = Callable[[HandGoal, str], Sequence[Match]]


def evaluate_schedules(task: Task, current: KeyPose, matcher: Matcher, config: SchedulerConfig = SchedulerConfig(),
                       busy: Sequence[str] = ()) -> list[Candidate]:
    """Eq. 24 for every candidate schedule (:func:`candidate_schedules`), each at its best combination.

    Args:
        task: from :func:`detect_task`.
        current: ``p^key``, the key joints now.
        matcher: ``matcher(goal, hand) -> [Match, ...]``, the K matched keyframes ``M(H, o)`` in the scene
            (:func:`library_matcher`).
        busy: the hands that hold something.
    """
    schedules = candidate_schedules(busy, task.auxiliary is not None)
    hands = [h for h in HANDS if any(s.target_hand == h for s in schedules)]
    target = {h: list(matcher(task.target, h)) for h in hands}
    auxiliary = {h: list(matcher(task.auxiliary, h)) for h in hands} if task.auxiliary is not None else {}
    for name, matches in (("target", target), ("auxiliary", auxiliary)):
        if any(len(m) == 0 for m in matches.values()):
            raise ValueError(f"matcher: expected at least one matched keyframe for the {name} per hand")
    out = []
    for schedule in schedules:
        if schedule.auxiliary_hand is None:
            costs = [(deviation(g.contact, current), None, g) for g in target[schedule.target_hand]]
        else:
            costs = []
            for a in auxiliary[schedule.auxiliary_hand]:
                for g in target[schedule.target_hand]:
                    pose = g.contact
                    if schedule.cotemporal:  # the auxiliary hand stays where its keyframe holds o_d
                        pose = pose.with_joint(HANDS.index(schedule.auxiliary_hand), a.contact)
                    costs.append((schedule_cost(current, a.contact, pose, config.weight), a, g))
        cost, a, g = min(costs, key=lambda c: c[0])
        feasible = _feasible(task, schedule)
        out.append(Candidate(schedule, cost if feasible else float("inf"), a, g, feasible))
    return out


def held_on_its_side(task: Task, auxiliary_hand: str) -> bool:
    """Whether ``auxiliary_hand`` holds ``o_d`` on its own side of the target, so that the arms do not cross:
    seen from in front of the holder (facing its back), the held point ``task.hold`` is not on the other hand's
    side of the target's contact (a tie counts as either side)."""
    check_choice(auxiliary_hand, HANDS, "auxiliary_hand")
    if task.hold is None:
        raise ValueError("task: expected a task with an auxiliary object held (task.hold), got none")
    right = -task.kitchen.holder_of(task.index).rotation[:, 0]  # the viewer's right: the holder faces +Y
    lateral = float((np.asarray(task.hold) - task.target.contact) @ right)
    return lateral >= 0.0 if auxiliary_hand == "right" else lateral <= 0.0


def _feasible(task: Task, schedule: Schedule) -> bool:
    """Co-temporal: the held point and the target's contact within the arm span; sequential with an obstacle:
    a free spot to put it down."""
    if schedule.cotemporal:
        return bool(np.linalg.norm(task.hold - task.target.contact) <= arm_span())
    if schedule.auxiliary_hand is not None and task.auxiliary.kind == "item":
        return task.aside is not None
    return True


def _cheapest(candidates: list[Candidate]) -> Candidate:
    feasible = [c for c in candidates if c.feasible]
    if not feasible:
        raise ValueError(f"schedule: none of {[c.schedule.name for c in candidates]} is feasible (the contacts are "
                         "beyond the arm span, or an obstacle has nowhere to go); free a hand or clear the board")
    return min(feasible, key=lambda c: c.cost)


def cheapest_uncrossed(task: Task, candidates: Sequence[Candidate]) -> Candidate:
    """The cheapest feasible candidate once the co-temporal schedules that hold ``o_d`` across the body
    (:func:`held_on_its_side` False) are left out: what Eq. 24 would choose if it knew where the held point is
    (ours, to show what the crossing costs; :func:`choose_schedule` is the paper's choice)."""
    kept = [c for c in candidates if not (c.schedule.cotemporal and not held_on_its_side(task, c.schedule.auxiliary_hand))]
    return _cheapest(kept)


def choose_schedule(task: Task, current: KeyPose, matcher: Matcher, config: SchedulerConfig = SchedulerConfig(),
                    busy: Sequence[str] = ()) -> Candidate:
    """The cheapest feasible schedule by Eq. 24 (:func:`evaluate_schedules`)."""
    return _cheapest(evaluate_schedules(task, current, matcher, config, busy))


def library_matcher(library: GoalLibrary, model, config: SchedulerConfig = SchedulerConfig(),
                    env_config: EnvironmentConfig = EnvironmentConfig()) -> Matcher:
    """``M(H, o)`` by §6.1's matching: ``matcher(goal, hand)`` is ``goal_library.match_goal``'s ``config.k``
    matches (``model`` the trained ``environment.EnvironmentAutoencoder``)."""
    def matcher(goal: HandGoal, hand: str) -> list[Match]:
        return match_goal(library, model, goal, hand, config.k, env_config)
    return matcher


# ----------------------------------------------------------------------------- the state machine (Fig. 6)


@dataclass(frozen=True, eq=False)
class Keyframe:
    """One goal for the controller.

    Attributes:
        action: one of ``ACTIONS`` (walk, reach, grasp, open, carry, place, release).
        hand: ``"left"`` or ``"right"``; None for the walk.
        object: the object's name (``"cabinet door"``, ``"bottle 2"``).
        position: (3,) metres, world frame: the wrist's goal (the pelvis's for the walk).
        pose: the matched key joints at this goal (world frame), or None.
    """

    action: str
    hand: Optional[str]
    object: str
    position: np.ndarray
    pose: Optional[KeyPose] = None

    def __post_init__(self):
        check_choice(self.action, ACTIONS, "action")
        if self.action == "walk":
            if self.hand is not None:
                raise ValueError(f"hand: expected None for the walk (the root moves), got {self.hand!r}")
        else:
            check_choice(self.hand, HANDS, "hand")
        position = np.asarray(self.position, dtype=np.float64)
        check_shape(position, (3,), "position")
        object.__setattr__(self, "position", position)


def _states(goal: HandGoal, role: str, place: bool) -> tuple:
    """Fig. 6's states of one hand on one object, in order."""
    if goal.kind in ("door", "drawer"):
        return ("reach", "grasp", "open", "release")
    if role == "auxiliary":  # an obstacle: out of the way, then down
        return ("reach", "grasp", "carry", "place", "release")
    return ("reach", "grasp", "carry") + (("place", "release") if place else ())


def _on(pose: Optional[KeyPose], hand: str, position) -> Optional[KeyPose]:
    """``pose`` moved so that the ``hand`` wrist is on ``position``."""
    return None if pose is None else pose.translated(np.asarray(position) - pose.hand(hand))


def _object_keyframes(goal, hand, match, states, positions) -> list[Keyframe]:
    poses = {"reach": match.contact, "grasp": match.contact, "open": match.end, "carry": match.end,
             "place": match.contact}
    return [Keyframe(s, hand, goal.name, positions[s], _on(poses.get(s), hand, positions[s])) for s in states]


def keyframes(task: Task, candidate: Candidate, place_at=None) -> list[Keyframe]:
    """Fig. 6's state machine: the chosen schedule as an ordered list of keyframes.

    Args:
        task: from :func:`detect_task`.
        candidate: the schedule and its matched keyframes (:func:`choose_schedule`).
        place_at: (3,) metres, where the target's contact goes down, or None to keep it in the hand.
    Returns:
        the walk to the first matched keyframe's pelvis, then the hands' states: a sequential schedule does
        the auxiliary object to the end first; a co-temporal one holds it (door open, obstacle aside) while
        the other hand takes the target out, then lets go (or puts the obstacle back) before the target is
        placed.
    """
    schedule = candidate.schedule
    if place_at is not None:
        place_at = check_in_scene(task.kitchen, place_at, "place_at")
    target_positions = {"reach": task.target.contact, "grasp": task.target.contact, "carry": task.carry,
                        "place": place_at, "release": place_at}
    target = _object_keyframes(task.target, schedule.target_hand, candidate.target,
                               _states(task.target, "target", place_at is not None), target_positions)
    if task.auxiliary is None:
        steps = target
    else:
        aux = task.auxiliary
        down = aux.contact if schedule.cotemporal else task.aside  # the obstacle back in place, or aside
        if aux.kind == "item" and down is None:
            raise ValueError(f"task: no free spot on the board for the {aux.name}; a sequential schedule "
                             "must put it down before taking the target")
        positions = {"reach": aux.contact, "grasp": aux.contact, "open": task.hold, "carry": task.hold,
                     "place": down, "release": task.hold if aux.kind != "item" else down}
        auxiliary = _object_keyframes(aux, schedule.auxiliary_hand, candidate.auxiliary,
                                      _states(aux, "auxiliary", True), positions)
        if schedule.cotemporal:  # the auxiliary hand holds (its pose in the target's keyframes) until the target is out
            holding = next(i for i, k in enumerate(auxiliary) if k.action in ("open", "carry")) + 1
            held, k = auxiliary[holding - 1].pose, HANDS.index(schedule.auxiliary_hand)
            target = [dataclasses.replace(f, pose=f.pose.with_joint(k, held)) if f.pose is not None else f
                      for f in target]
            out = next(i for i, k in enumerate(target) if k.action == "carry") + 1  # the target is out
            steps = auxiliary[:holding] + target[:out] + auxiliary[holding:] + target[out:]
        else:
            steps = auxiliary + target
    first = steps[0]
    walk = Keyframe("walk", None, first.object, first.pose.pelvis, first.pose)
    return [walk] + steps


@dataclass
class TaskPlan:
    """The scheduler's output for one target: what it found, weighed and chose, and the keyframes."""

    task: Task
    candidates: list
    chosen: Candidate
    keyframes: list


def plan_task(kitchen: Kitchen, index: int, current: KeyPose, matcher: Matcher,
              config: SchedulerConfig = SchedulerConfig(), env_config: EnvironmentConfig = EnvironmentConfig(), *,
              busy: Sequence[str] = (), place_at=None, schedule: Optional[Schedule] = None) -> TaskPlan:
    """§6.3 end to end: detect ``o_g`` and ``o_d``, weigh the schedules by Eq. 24, run Fig. 6's state machine.

    Args:
        kitchen, index: the scene and the target item.
        current: ``p^key``.
        matcher: ``M(H, o)`` (:func:`library_matcher`).
        busy: hands that hold something.
        place_at: (3,) where the target goes down (None: it stays in the hand).
        schedule: force this schedule instead of the cheapest (it must be a candidate).
    """
    task = detect_task(kitchen, index, config, env_config)
    candidates = evaluate_schedules(task, current, matcher, config, busy)
    if schedule is None:
        chosen = _cheapest(candidates)
    else:
        chosen = next((c for c in candidates if c.schedule == schedule), None)
        if chosen is None:
            raise ValueError(f"schedule: expected one of {[c.schedule.name for c in candidates]}, got {schedule.name}")
    return TaskPlan(task, candidates, chosen, keyframes(task, chosen, place_at))
