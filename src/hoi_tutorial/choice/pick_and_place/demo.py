"""The pick-and-place demo of CHOICE (§6, Fig. 6) in a toy kitchen: walk to the cabinet, open its door with one
hand, take the bottle out with the other, carry it to the table and put it down.

The algorithm box, as this module runs it (:func:`pick_and_place`):

1. **The scene** (:func:`cabinet_kitchen`): kitchen ``seed`` of ``world.scenes.make_kitchen`` with the
   cabinet door closed, the items it held taken out, and a bottle (item 0) on the cabinet's top board.
2. **The schedule** (§6.3, Eq. 24, ``scheduler.plan_task``): the bottle is ``o_g``; the closed door
   is found in its way (``o_d``) and opened just enough (``task.opening``, radians); the four schedules are
   weighed by Eq. 24 with the goal keyframes matched by §6.1 (``environment`` and ``goal_library``, the trained
   environment autoencoder and goal library) and ``p^key`` the standing pose at the first start, facing the
   cabinet; the demo plays a co-temporal one (``config.hands``, below). Fig. 6's state machine gives the
   keyframes: walk → reach, grasp, open (door hand) → reach, grasp, carry (bottle hand) → release (door) →
   place, release (bottle).
3. **Stances** (``stances``, with step 6's stance at the table). A, to take the handle:
   the walk keyframe's pelvis (§6.3's root goal), facing the cabinet, moved in 5 cm steps if needed. B, to hold
   the opened door and take the bottle: positions and headings in front of the cabinet from which a bend
   (pelvis drop and pitch) reaches both hand goals with the body clear of the opened cabinet; the first eight
   found are tried, most clearance first, until the motion at the cabinet (step 5) is free of collisions with
   the door hand on its handle.
4. **The walk** (§6.2, Eq. 23, ``navigation.navigation_grid`` and ``locomotion.follow_path``):
   from ``kitchen.start_positions`` (in order) to A; a matched motion whose elbows, wrists, knees, ankles or
   feet come within ``body_radius`` of the scene is passed over (ours: the matching checks the root on its grid); a walk that
   ends farther than ``goal_tolerance`` is a miss and the next start is tried (every try is recorded in
   ``walks``); the pose then settles onto A.
5. **At the cabinet** (Fig. 6's states as wrist paths; steps 4–7 are in ``motion_pieces``): the door hand reaches
   the handle along the path §4's planner plans among the kitchen's things with the door closed (the handle a ball
   around its grasp point, ``hand_paths.grip_target``) and pulls it on
   its circle about the hinge to ``task.opening`` (minimum-jerk in time); the body turns to face the handle
   while the door's edge passes, then steps (``world.mocap.standing.step_feet``) behind the door to B; the
   other hand, waiting in front of the belly, reaches the bottle's grasp point along the path §4's planner
   plans in this kitchen (``hand_paths.planned_approach``: the fields around the bottle with the opened cabinet
   as an obstacle, Eqs. 9–11), grasps, and takes the bottle out along its way (grasp point → lifted →
   ``task.carry``); the door hand lets go (the door stays open); the body stands up and steps back to a free
   floor cell while the bottle is brought out and up in front of it.
6. **Carry** (§6.2 again): the walk to a stance at the table edge nearest the cabinet, on the floor grid of
   the kitchen with the door open, the carrying arm held by IK at ``hold`` in the body's heading frame.
7. **Place and release** (Fig. 6): the bottle is lowered onto a free spot of the table top along the path §4's
   planner plans to it (the bottle where it will stand as the target; the scheduler's ``place_at`` is where its
   grasp point goes), then the hand draws back and hangs.
8. **Checks** (:func:`evaluate`, from ``checks``): the door's opening against the
   scheduler's, the bottle out of the cabinet's box and standing on the table, the clearance of body and
   bottle against the scene with the cabinet rebuilt at every frame's door angle, the door hand's distance
   from the handle, and the arms against each other (crossed wrists, arm-to-arm clearance).

Choices that are ours (the paper does not state them, or we simplify):

- **The body is not driven by the §5.1 controller.** The arms are posed by two-bone IK
  (``world.kinematics.solve_limb_ik``, through ``world.mocap.body_plan.plan_to_motion``) on the scheduled
  keyframes and the wrist paths (the planner's three approaches; ours for the way out, the hold and the door's
  swing, which the handle's circle fixes);
  the trunk bends (``world.mocap.standing.choose_bend``) so that the shoulders reach; the feet are planted
  except for the steps at the cabinet (A → B, B → the walk's start) and the walks. The mixture-of-experts controller of §5.1 (``choice.controller``) is evaluated
  separately (Table 4) and plays no part here; nor does §6.2's phase-driven interaction motion.
  :func:`controller_at_cabinet` rolls the toy controller out toward the demo's handle keyframe to show why, and
  ``controller_reaches`` measures how far IK would have to close each of the demo's three contacts after it.
- **The matched keyframes** give the schedule, the hands and the walk goal; their poses are not imitated
  (the stances and bends above replace them).
- **The hands** (``config.hands``). Eq. 24 prices single-handed matched keyframes: it sees where each hand grasps,
  not where the opened door takes the handle. In the toy kitchens its co-temporal choice gives the door to the
  hand nearer the closed handle, and the swing then carries the handle across the body to the bottle's other side
  (``scheduler.held_on_its_side`` False): the door hand crosses the midline and the arms touch. By default
  (``"uncrossed"``) the demo plays the cheapest co-temporal schedule that holds the door on its hand's side
  (``scheduler.cheapest_uncrossed``; the paper's scheduler matches keyframes recorded with both hands at work,
  where such a hold would find no match); ``"eq24"`` plays Eq. 24's choice. ``eq24`` in the result is Eq. 24's
  choice either way. The checks report crossed arms and self-contact (``arms_crossed``, ``self_contact``);
  ``collision`` is against the scene.
- **Settling**: the matched walk ends within ``goal_tolerance`` of its goal, not on it; the pose is blended
  into the standing pose on the stance (the feet slide over that gap).
- **The bottle** moves rigidly with the grasping wrist's position and the body's heading and is kept upright
  (a hand that turns its wrist to hold it so); it is lifted by the scheduler's ``lift`` and slid out along
  its way.
- **Collision measure**: the body's sample points against the scene, with the contacts of the hands exempt
  (``checks``, where it is described).

Scaling (paper → toy): none of the demo's own constants scale; the models it uses (the environment
autoencoder, the goal library, the locomotion database) follow their own presets.
"""
from __future__ import annotations

import dataclasses
import functools
import sys
import time

import numpy as np
import torch

from ...infra import check_scale, load_or_build, scaled_config
from ...world.kinematics import forward_kinematics
from ...world.mocap.body_plan import SIDES, PlanBody, check_betas, plan_to_motion
from ...world.mocap.motion_math import forward_xyz, heading_of
from ...world.mocap.poses import standing_pose
from ...world.motion import FPS, Motion
from ...world.objects import make_object
from ...world.scenes import Kitchen, make_kitchen
from ...world.skeleton import joint_index
from ..controller import features, network, runtime
from ..planner.interactions import planner_data_config
from ..planner.intp import planner_config
from . import environment as env
from . import goal_library, locomotion, navigation, scheduler
from .checks import body_distances, body_points, evaluate, handle_at
from .environment import EnvironmentConfig, KeyPose
from .goal_library import LibraryConfig
from .hand_paths import trained_approach_planner
from .motion_pieces import (attach_bottle, exit_point, hold_arm, last_pose, pelvis_yaw, plan_at_cabinet,
                                    plan_at_table, settle, walk)
from .navigation import NavigationConfig
from .demo_types import DemoSetting, PickAndPlace, PickAndPlaceConfig, Stance
from .stances import item_radius, open_stance, table_stance, take_stance
from .scheduler import SchedulerConfig

__all__ = [
    "PickAndPlaceConfig",  # from demo_types, re-exported
    "PICK_AND_PLACE_SCALES",
    "pick_and_place_config",
    "cabinet_kitchen",
    "cabinet_schedule",
    "schedule_survey",
    "PickAndPlace",  # from demo_types, re-exported
    "pick_and_place",
    "cached_pick_and_place",
    "controller_at_cabinet",
    "cached_controller_measure",
    "cached_controller_at_cabinet",
    "body_points",  # from checks, re-exported
    "evaluate",  # from checks, re-exported
]


# ----------------------------------------------------------------------------- configuration (the class is in demo_types)


PICK_AND_PLACE_SCALES: dict = {}  # nothing of the demo's own scales; its pieces follow their presets


def pick_and_place_config(scale: str = "toy", **overrides) -> PickAndPlaceConfig:
    """The preset for ``scale`` (its navigation, environment, library, scheduler and planner configurations those of
    the same scale), fields overridable."""
    check_scale(scale, "pick_and_place_config: scale")
    fixed = {"navigation": navigation.navigation_config(scale), "environment": env.environment_config(scale),
             "library": goal_library.library_config(scale), "scheduler": scheduler.scheduler_config(scale),
             "planner_data": planner_data_config(scale), "planner": planner_config(scale)}
    fixed = {k: v for k, v in fixed.items() if k not in overrides}
    return scaled_config(PickAndPlaceConfig, scale, PICK_AND_PLACE_SCALES, overrides,
                         factory="pick_and_place_config", fixed=fixed)


def _check_seed(seed) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected a non-negative int, got {seed!r}")
    return int(seed)


# ----------------------------------------------------------------------------- the scene


# What the demo's artifacts are keyed by besides their builders' imports: the whole CHOICE package (the kitchens,
# the body, the motion data, the trained models and their training all shape the run).
_DEMO_CODE = (sys.modules[__package__.rpartition(".")[0]],)
_BOTTLE_DRAWS = 32
_FRONT = 0.95  # how far to the front of its board the bottle stands (0: at the back, 1: at the front)


def cabinet_kitchen(seed: int) -> Kitchen:
    """Kitchen ``seed`` with the cabinet door closed and one bottle (item 0) inside the cabinet.

    The kitchen's items the cabinet held are left out. The bottle is the first of
    ``make_object("bottle", numpy.random.default_rng([seed, k]))``, ``k = 0, 1, ...`` (at most 32 draws), that
    fits on the cabinet's top board (2 cm to spare below the carcass; else the draw that fits highest); it
    stands there centred sideways, 95 % of the way to the front of the range its centre can take (the top
    board and the front are in reach of a toy body). Deterministic for ``seed``.

    Raises:
        ValueError: ``seed`` is not a non-negative int, or the bottle fits on no board of the cabinet.
    """
    seed = _check_seed(seed)
    base = make_kitchen(seed, door_angle=0.0)
    cabinet = base.furniture_of("cabinet")
    h = base.furniture.index(cabinet)
    top = max(cabinet.support_surfaces[:, 0])
    choice = None
    for k in range(_BOTTLE_DRAWS):  # the first of the seed's bottles that fits on the cabinet's top board
        bottle = make_object("bottle", np.random.default_rng([seed, k]))
        height, r = float(bottle.canonical_bounds[1, 2]), item_radius(bottle) + 0.005
        rows = [row for row in cabinet.support_surfaces
                if row[5] >= height + 0.02 and row[2] - row[1] > 2 * r and row[4] - row[3] > 2 * r]
        if rows and (choice is None or max(row[0] for row in rows) > max(row[0] for row in choice[2])):
            choice = (bottle, r, rows)
        if rows and max(row[0] for row in rows) >= top:
            break
    if choice is None:
        raise ValueError(f"seed: no bottle of seed {seed} fits on a board of the cabinet")
    bottle, r, rows = choice
    z, x0, x1, y0, y1, _ = max(rows, key=lambda row: row[0])
    local = np.eye(4)
    local[:3, 3] = (0.5 * (x0 + x1), y0 + r + _FRONT * (y1 - y0 - 2 * r), z)
    bottle = bottle.with_pose(cabinet.pose @ local)
    keep = [i for i, holder in enumerate(base.holders) if holder != h]
    return Kitchen(base.size, base.furniture, [bottle] + [base.items[i] for i in keep],
                   [h] + [base.holders[i] for i in keep], base.obstacles, base.cell_size)


# ----------------------------------------------------------------------------- the models


@functools.lru_cache(maxsize=4)
def _matcher(environment: EnvironmentConfig, library: LibraryConfig, config: SchedulerConfig):
    """``M(H, o)`` of §6.1: the trained environment autoencoder (artifact cache) and the goal library."""
    model = env.trained_environment_autoencoder(environment).model
    rows = goal_library.goal_keyframes(environment, library)
    return scheduler.library_matcher(goal_library.build_goal_library(model, rows), model, config, environment)


@functools.lru_cache(maxsize=4)
def _database(config: NavigationConfig):
    return locomotion.motion_database(config)


# ----------------------------------------------------------------------------- the demo


_HOLD_TOLERANCE = 0.02  # metres the door hand may be off the handle for a stance B to be taken at once


def cabinet_schedule(seed: int, config: PickAndPlaceConfig = PickAndPlaceConfig()) -> scheduler.TaskPlan:
    """Step 2 of the demo alone: §6.3 (``scheduler.plan_task``) for the bottle of :func:`cabinet_kitchen` ``seed``,
    ``p^key`` the standing pose at the kitchen's first start position, facing the cabinet."""
    seed = _check_seed(seed)
    if not isinstance(config, PickAndPlaceConfig):
        raise ValueError(f"config: expected a PickAndPlaceConfig (pick_and_place_config), got {type(config).__name__}")
    kitchen = cabinet_kitchen(seed)
    matcher = _matcher(config.environment, config.library, config.scheduler)
    start = kitchen.start_positions(config.n_starts, seed=seed)[0]
    current = KeyPose.standing(start, heading_of(kitchen.furniture_of("cabinet").translation[:2] - start))
    return scheduler.plan_task(kitchen, 0, current, matcher, config.scheduler, config.environment)


def schedule_survey(n_kitchens: int = 20, config: PickAndPlaceConfig = PickAndPlaceConfig()) -> list[dict]:
    """Eq. 24 in the demo kitchens ``0 .. n_kitchens - 1`` (:func:`cabinet_schedule`), built once, then loaded.

    Returns one dictionary per kitchen: ``kitchen``; ``eq24``, the name of the schedule Eq. 24 chooses, and
    ``cotemporal``; ``across``, whether that is a co-temporal schedule holding the door across the body
    (``scheduler.held_on_its_side`` False); ``uncrossed``, the name of ``scheduler.cheapest_uncrossed``'s
    choice, and ``uncrossed_cotemporal``; ``costs``, Eq. 24's cost per schedule name (inf: not feasible).
    """
    if isinstance(n_kitchens, bool) or not isinstance(n_kitchens, int) or n_kitchens < 1:
        raise ValueError(f"n_kitchens: expected a positive int, got {n_kitchens!r}")
    if not isinstance(config, PickAndPlaceConfig):
        raise ValueError(f"config: expected a PickAndPlaceConfig (pick_and_place_config), got {type(config).__name__}")

    def build():
        rows = []
        for k in range(n_kitchens):
            plan = cabinet_schedule(k, config)
            chosen = plan.chosen.schedule
            uncrossed = scheduler.cheapest_uncrossed(plan.task, plan.candidates).schedule
            rows.append({"kitchen": k, "eq24": chosen.name, "cotemporal": chosen.cotemporal,
                         "across": bool(chosen.cotemporal
                                        and not scheduler.held_on_its_side(plan.task, chosen.auxiliary_hand)),
                         "uncrossed": uncrossed.name, "uncrossed_cotemporal": uncrossed.cotemporal,
                         "costs": {c.schedule.name: float(c.cost) for c in plan.candidates}})
        return rows

    key = {"n_kitchens": n_kitchens, "config": dataclasses.asdict(config)}
    return load_or_build("choice_schedule_survey", key, build)


def pick_and_place(seed: int, config: PickAndPlaceConfig = PickAndPlaceConfig()) -> PickAndPlace:
    """Walk to the cabinet, open its door with one hand, take the bottle out with the other, carry it to the
    table and put it down (the algorithm box above). Deterministic for ``seed``.

    Args:
        seed: the kitchen (:func:`cabinet_kitchen`), a non-negative int.
        config: :func:`pick_and_place_config`.
    Returns:
        :class:`PickAndPlace` with its :func:`evaluate` checks.
    Raises:
        ValueError: a bad seed or configuration; a kitchen with no stance or no table spot.
    """
    t0 = time.perf_counter()
    first = cabinet_schedule(seed, config)  # §6.3: the schedule (checks the seed and the configuration)
    seed = _check_seed(seed)
    kitchen = first.task.kitchen
    body = PlanBody(check_betas(None))
    rng = np.random.default_rng(seed)
    database = _database(config.navigation)
    grid = navigation.navigation_grid(kitchen, config.navigation)
    cabinet = kitchen.furniture_of("cabinet")
    front = cabinet.rotation[:, 1]
    starts = kitchen.start_positions(config.n_starts, seed=seed)
    task, chosen = first.task, first.chosen
    if task.auxiliary is None or task.auxiliary.kind != "door":
        raise ValueError("kitchen: expected the closed cabinet door in the bottle's way")
    if config.hands == "uncrossed":  # ours: the door held on its hand's side (the module's docstring)
        chosen = scheduler.cheapest_uncrossed(task, [c for c in first.candidates if c.schedule.cotemporal])
    hands = {"door": chosen.schedule.auxiliary_hand, "bottle": chosen.schedule.target_hand}
    if hands["door"] == hands["bottle"]:
        # one hand does both (sequential): the demo is the co-temporal case of the paper; say so
        raise ValueError(f"schedule: expected a co-temporal schedule, Eq. 24 chose {chosen.schedule.name}")
    planner = trained_approach_planner(config.planner_data, config.planner)  # §4's planner plans the hands
    setting = DemoSetting(body, task, hands, config, planner, seed)
    g = setting.bottle_side
    walk_goal = scheduler.keyframes(task, chosen)[0].position[:2]  # the first matched keyframe's pelvis
    stance_xy, heading, bend1, stance_source = open_stance(setting, cabinet, walk_goal, grid, rng)
    takes = take_stance(setting, cabinet, Stance(stance_xy, heading), rng)

    # §6.2: the walk to the stance, from the starts in turn until one arrives
    walk1, tried = None, []
    for k, start in enumerate(starts):
        try:
            nav = walk(grid, database, start, stance_xy, front[:2], None, kitchen=kitchen, config=config)
        except ValueError as error:
            tried.append({"start": start.tolist(), "error": str(error)})
            continue
        tried.append({"start": start.tolist(), "reached": bool(nav.reached), "goal_error": float(nav.goal_error)})
        if walk1 is None or nav.goal_error < walk1[1].goal_error:
            walk1 = (k, nav)
        if nav.reached:
            break
    if walk1 is None:
        raise ValueError(f"kitchen: no start position has a walk to the cabinet ({tried})")
    k1, nav1 = walk1

    # the hands at the cabinet: the stances B in turn until the motion there is free of collisions
    open_kitchen = Kitchen(kitchen.size, [cabinet.with_params(door_angle=float(task.opening)) if f is cabinet else f
                                          for f in kitchen.furniture], kitchen.items[1:], kitchen.holders[1:],
                           kitchen.obstacles, kitchen.cell_size)
    grid2 = navigation.navigation_grid(open_kitchen, config.navigation)
    bottle = kitchen.items[0]
    best, take_tried = None, []
    for i, (xy_b, psi_b, (bend2, bend3)) in enumerate(takes):
        exit_b = exit_point(open_kitchen, grid2, xy_b, config.exit_clearance)
        built = plan_at_cabinet(setting, Stance(stance_xy, heading), Stance(xy_b, psi_b), exit_b, (bend1, bend2, bend3),
                                np.random.default_rng([seed, i]))
        motion_b = plan_to_motion(built.plan, body)
        glob_b, joints_b = forward_kinematics(motion_b.local_rotations.double(), motion_b.root_position.double())
        yaws_b = np.unwrap(np.array([pelvis_yaw(r) for r in glob_b[:, 0].numpy()]))
        pose_b = attach_bottle(bottle, joints_b[:, joint_index(f"{hands['bottle']}_wrist")].numpy(), yaws_b,
                               built.grasp_frame, len(motion_b) - 1)
        d_b, db_b = body_distances(kitchen, motion_b, built.door, pose_b, hands=hands, contact=task.target.contact,
                                   config=config)
        score = min(float(d_b.min()), float(db_b.min())) - config.body_radius
        phase_starts = np.cumsum([0] + [n for _, n in built.phases])
        names_b = [name for name, _ in built.phases]
        held = slice(int(phase_starts[names_b.index("grasp handle")]), int(phase_starts[names_b.index("release door")]))
        wrist_b = joints_b[held, joint_index(f"{hands['door']}_wrist")].numpy()
        error = float(np.max(np.linalg.norm(wrist_b - handle_at(cabinet, built.door[held]), axis=-1)))
        take_tried.append({"stance": np.asarray(xy_b).tolist(), "heading": psi_b, "clearance": score,
                           "door_hand_error": error})
        rank = min(score, 0.0) - max(error - _HOLD_TOLERANCE, 0.0)
        if best is None or rank > best[0]:
            best = (rank, xy_b, psi_b, exit_b, built, motion_b)
        if score >= 0.0 and error <= _HOLD_TOLERANCE:
            break
    _, take_xy, take_heading, exit_xy, (cab_plan, cab_phases, cab_door, grasp_frame, bottle_path, handle_path), \
        cab_motion = best

    # the table: its stance and the spot, then Fig. 6's keyframes with the place
    contact_offset = task.target.contact - bottle.translation
    table_xy, table_heading, table_bend, spot, place_at = table_stance(setting, kitchen, grid2,
                                                                       Stance(take_xy, take_heading), contact_offset, rng)
    keyframes = scheduler.keyframes(task, chosen, place_at)
    plan = scheduler.TaskPlan(task, first.candidates, chosen, keyframes)

    # the pieces of motion
    pieces, phases = [], []

    def add(name, motion):
        start = sum(len(p) for p in pieces)
        pieces.append(motion)
        phases.append((name, start, start + len(motion)))

    if nav1.motion is None:  # the start is already within the tolerance: one standing frame facing the stance
        towards = np.asarray(stance_xy) - nav1.root[-1, :2]
        local, root = standing_pose(body.betas, position=tuple(nav1.root[-1, :2]), heading=heading_of(towards))
        nav1.motion = Motion(local[None].float(), root[None].float(), betas=body.betas)
    add("walk to cabinet", nav1.motion)
    add("settle at cabinet", settle(last_pose(nav1.motion), (stance_xy, heading), body))
    offset = sum(len(p) for p in pieces)
    pieces.append(cab_motion)
    at = offset
    for name, n in cab_phases:
        phases.append((name, at, at + n))
        at += n
    nav2 = walk(grid2, database, exit_xy, table_xy, -_forward2(table_heading), take_heading, kitchen=open_kitchen,
                config=config)
    carried = [nav2.motion.slice(1, len(nav2.motion))] if nav2.motion is not None and len(nav2.motion) > 1 else []
    last = last_pose(carried[0]) if carried else last_pose(cab_motion)
    settle2 = settle(last, (table_xy, table_heading), body)
    if carried:
        add("walk to table", hold_arm(carried[0], g, config.hold))
    add("settle at table", hold_arm(settle2, g, config.hold))
    table_plan, table_phases, place_path = plan_at_table(setting, Stance(table_xy, table_heading), table_bend, spot,
                                                         place_at)
    offset = sum(len(p) for p in pieces)
    pieces.append(plan_to_motion(table_plan, body))
    at = offset
    for name, n in table_phases:
        phases.append((name, at, at + n))
        at += n
    motion = Motion.concatenate([Motion(p.local_rotations.float(), p.root_position.float(), betas=body.betas)
                                 for p in pieces])
    T = len(motion)
    door = np.zeros(T)
    cab_start = dict((n, a) for n, a, _ in phases)["reach handle"]
    door[cab_start:cab_start + len(cab_door)] = cab_door
    door[cab_start + len(cab_door):] = cab_door[-1]
    glob, joints = forward_kinematics(motion.local_rotations.double(), motion.root_position.double())
    wrists = joints[:, joint_index(f"{hands['bottle']}_wrist")].numpy()
    yaws = np.unwrap(np.array([pelvis_yaw(r) for r in glob[:, 0].numpy()]))
    place_end = dict((n, b) for n, _, b in phases)["place"] - 1
    bottle_pose = attach_bottle(bottle, wrists, yaws, cab_start + grasp_frame, place_end)
    walks = [{"to": "cabinet", "starts_tried": tried, "start_index": k1, "goal": np.asarray(stance_xy).tolist(),
              "reached": bool(nav1.reached), "goal_error": float(nav1.goal_error), "stopped": nav1.stopped,
              "frames": len(nav1.motion), "stance": stance_source, "take_stances_tried": take_tried},
             {"to": "table", "start_index": None, "goal": np.asarray(table_xy).tolist(), "reached": bool(nav2.reached),
              "goal_error": float(nav2.goal_error), "stopped": nav2.stopped,
              "frames": len(carried[0]) if carried else 0}]
    result = PickAndPlace(seed, kitchen, plan, first.chosen, motion, door, bottle_pose, phases, hands, np.asarray(place_at),
                          walks, config=config, hand_paths={"reach handle": handle_path.as_record(),
                                                            "reach bottle": bottle_path.as_record(),
                                                            "place": place_path.as_record()})
    result.checks = evaluate(result)
    result.checks["walks_reached"] = bool(nav1.reached and nav2.reached)
    result.seconds = time.perf_counter() - t0
    return result


def _index_of(candidate, candidates) -> int:
    for i, c in enumerate(candidates):
        if c is candidate:
            return i
    raise ValueError("candidate: expected one of the plan's candidates")


def cached_pick_and_place(seed: int, config: PickAndPlaceConfig = PickAndPlaceConfig()) -> PickAndPlace:
    """:func:`pick_and_place` through the artifact cache: run once per seed and configuration, then loaded.

    What is stored is what the run computed: the motion, the door angles, the bottle's poses, the phases, the
    hands, ``place_at``, the walks, the checks, the run's wall time and which candidates were played and chosen by
    Eq. 24. The kitchen and the schedule's candidates are rebuilt by :func:`cabinet_schedule` (deterministic for the
    seed; the first step of :func:`pick_and_place`) and the keyframes by ``scheduler.keyframes``. The artifact's key
    holds the source of the whole of ``choice``, ``world``, ``nn`` and ``infra``: a change in any runs the demo again.
    """
    seed = _check_seed(seed)
    if not isinstance(config, PickAndPlaceConfig):
        raise ValueError(f"config: expected a PickAndPlaceConfig (pick_and_place_config), got {type(config).__name__}")

    def build():
        run = pick_and_place(seed, config)
        motion = run.motion
        if motion.actions is not None or motion.contacts is not None:
            raise RuntimeError("pick_and_place: expected a motion without action or contact labels")
        return {"local_rotations": motion.local_rotations, "root_position": motion.root_position,
                "betas": motion.betas, "fps": float(motion.fps), "door_angle": run.door_angle,
                "bottle_pose": run.bottle_pose, "phases": [list(p) for p in run.phases], "hands": dict(run.hands),
                "place_at": run.place_at, "walks": run.walks, "checks": run.checks, "seconds": float(run.seconds),
                "chosen": _index_of(run.plan.chosen, run.plan.candidates),
                "eq24": _index_of(run.eq24, run.plan.candidates), "hand_paths": run.hand_paths}

    # the kitchens, the body, the motion data, the trained models and their training: all of it shapes the run
    stored = load_or_build("choice_pick_and_place", {"seed": seed, "config": dataclasses.asdict(config)}, build,
                           code=_DEMO_CODE)
    first = cabinet_schedule(seed, config)
    chosen = first.candidates[stored["chosen"]]
    place_at = np.asarray(stored["place_at"])
    plan = scheduler.TaskPlan(first.task, first.candidates, chosen, scheduler.keyframes(first.task, chosen, place_at))
    motion = Motion(stored["local_rotations"], stored["root_position"], betas=stored["betas"], fps=stored["fps"])
    return PickAndPlace(seed, first.task.kitchen, plan, first.candidates[stored["eq24"]], motion,
                        np.asarray(stored["door_angle"]), np.asarray(stored["bottle_pose"]),
                        [tuple(p) for p in stored["phases"]], dict(stored["hands"]), place_at, stored["walks"],
                        checks=stored["checks"], seconds=stored["seconds"], config=config,
                        hand_paths=stored["hand_paths"])


def controller_at_cabinet(run: PickAndPlace, model, frames: int = 60, lead: float = 1.0) -> dict:
    """The §5.1 controller given the demo's first hand keyframe, to see whether it could drive the demo's body.

    The goal is the door hand's grasp of the handle (the first frame of ``"grasp handle"``): the four key joints
    of the demo's IK-posed motion over the 13-sample window there (``features.key_joint_transforms``), the PAE
    phase there as the matched goal phase, due at the demo's grasp, the door hand working. Each goal-phase source (``features.VARIANTS``)
    is rolled out for ``frames`` frames from two starts:

    - ``"standing"``: the pose where the demo's reach begins (stance A, after the walk and the settle), the
      future root trajectory held in place;
    - ``"walking"``: the walk ``lead`` seconds before it ends, the future root trajectory on the straight line to
      the goal's root (``runtime.toward_goal``, as Table 4's runs start).

    The state at a start sees only the motion up to it (the PAE's window is clamped there).

    Args:
        run: a :class:`PickAndPlace`.
        model: a trained ``network.ControllerNet`` (``network.trained_controller(...).model``).
        frames: frames rolled out from each start, a positive int.
        lead: seconds before the walk's end for the ``"walking"`` start, positive.
    Returns:
        ``{"pelvis_height", "wrist_height"`` (the goal keyframe's, metres), ``"starts": {start: {"frame",
        "distance"`` (the door wrist from the handle at the start, m), ``"closest": {variant: m}`` (the door
        wrist's closest approach to the handle), ``"root_error": {variant: m}`` (the root's distance from the goal's
        root after the last frame)``}}}``.
    """
    if not isinstance(run, PickAndPlace):
        raise ValueError(f"run: expected a PickAndPlace (pick_and_place), got {type(run).__name__}")
    if not isinstance(model, network.ControllerNet):
        raise ValueError(f"model: expected a network.ControllerNet, got {type(model).__name__}")
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise ValueError(f"frames: expected a positive int, got {frames!r}")
    if isinstance(lead, bool) or not isinstance(lead, (int, float)) or not lead > 0:
        raise ValueError(f"lead: expected a positive number of seconds, got {lead!r}")
    side = SIDES.index(run.hands["door"])
    motion = run.motion
    g = run.phase("grasp handle")[0]
    # the demo's grasp of the handle as a reach's keyframe (runtime.clip_goal reads it from the clip's meta)
    goal = runtime.clip_goal(model, [dataclasses.replace(motion, meta={"anchor_frame": g, "hand": run.hands["door"]})])
    centre = goal.positions[0, features.WINDOW // 2]  # (4, 3): root, hip, left wrist, right wrist
    handle = centre[2 + side].numpy()
    wrist = joint_index(f"{SIDES[side]}_wrist")
    walk_end = run.phase("walk to cabinet")[1]
    starts = {"standing": (run.phase("reach handle")[0], False),
              "walking": (max(walk_end - int(round(lead * FPS)), 1), True)}
    states = []
    for frame, walking in starts.values():
        state = runtime.initial_state(model, [motion.slice(0, frame + 1)], frame=frame)
        states.append(runtime.toward_goal(state, goal) if walking else state)
    state = runtime.ControllerState(*(torch.cat(parts) for parts in zip(*states)))  # both starts in one batch
    goals = runtime.KeyJointGoal(*(part.expand(len(states), *part.shape[1:]) for part in goal))
    goals = goals._replace(due=torch.tensor([g - frame for frame, _ in starts.values()]))  # the grasp from each start
    closest, root_error = {}, {}
    for variant in features.VARIANTS:
        rolled = runtime.rollout(model, state, goals, frames, variant)
        closest[variant] = np.min(np.linalg.norm(rolled.wrist[:, :, side].numpy() - handle, axis=-1), axis=0)
        root_error[variant] = np.linalg.norm(rolled.origin[-1, :, :2].numpy() - centre[0, :2].numpy(), axis=-1)
    out = {"pelvis_height": float(centre[1, 2]), "wrist_height": float(handle[2]), "starts": {}}
    for k, (name, (frame, _)) in enumerate(starts.items()):
        out["starts"][name] = {"frame": int(frame),
                               "distance": float(np.linalg.norm(motion.joints[frame, wrist].numpy() - handle)),
                               "closest": {v: float(closest[v][k]) for v in features.VARIANTS},
                               "root_error": {v: float(root_error[v][k]) for v in features.VARIANTS}}
    return out


def cached_controller_measure(name: str, measure, seed: int, config: PickAndPlaceConfig,
                              controller: network.ControllerConfig, **arguments):
    """``measure(run, model, **arguments)`` through the artifact cache (``name``), for the demo of ``seed`` and
    ``config`` (:func:`cached_pick_and_place`) and the controller trained with ``controller``
    (``network.trained_controller``): rolled out once, then loaded (the chapter opened again, or from a pretrained
    pack, runs none of its rollouts). The rollouts run on the CPU; ``measure`` checks its own arguments."""
    seed = _check_seed(seed)
    if not isinstance(config, PickAndPlaceConfig):
        raise ValueError(f"config: expected a PickAndPlaceConfig (pick_and_place_config), got {type(config).__name__}")
    if not isinstance(controller, network.ControllerConfig):
        raise ValueError(f"controller: expected a network.ControllerConfig (network.controller_config), got "
                         f"{type(controller).__name__}")

    def build():
        return measure(cached_pick_and_place(seed, config), network.trained_controller(controller).model, **arguments)

    # as the demo's artifact: the kitchens, the body, the motion data and the trained models all shape the rollouts
    key = {"seed": seed, "config": dataclasses.asdict(config), "controller": dataclasses.asdict(controller),
           **arguments}
    return load_or_build(name, key, build, code=_DEMO_CODE)


def cached_controller_at_cabinet(seed: int, config: PickAndPlaceConfig, controller: network.ControllerConfig,
                                 frames: int = 60, lead: float = 1.0) -> dict:
    """:func:`controller_at_cabinet` through the artifact cache (:func:`cached_controller_measure`), for the demo
    of ``seed`` and ``config`` and the controller trained with ``controller``."""
    return cached_controller_measure("choice_controller_at_cabinet", controller_at_cabinet, seed, config, controller,
                                     frames=frames, lead=lead)


def _forward2(heading: float) -> np.ndarray:
    return forward_xyz(heading)[:2]
