"""Table 4's runs (CHOICE §8.3.1): the controller's goal-phase sources on unseen reach-and-grasp scenes, each goal
matched by §6.1 against the goal library — keyframes of other clips — and never taken from the clip under test.

The algorithm box, as this module runs it (``B`` scenes):

1. **Scenes** (:func:`reach_scene`): a held-out reach-and-grasp clip (``world.mocap`` with the seed
   ``10 000 + seed``, never trained on) gives what a user's click gives — the item on its support, its grasp
   point, the working hand — and a start, the character at the clip's first frame. The recorded motion itself
   is measured in the ``"Dataset"`` row and nowhere else.
2. **Matching** (§6.1, :func:`matched_goals`): the scene's hand goal (the distance field around the item; ``c`` =
   the grasp height, the hand, grasp, approach) queries a goal library of "all the goal keyframes in the training
   set" (:func:`reach_library`: the grasp of each of the controller's training reaches, in ``goal_library``'s
   KD-trees); the nearest keyframe's clip gives
   - the goal window ``G^keyJ``: its root, hip and wrists over the 2 s window at its grasp, carried into the scene
     as ``goal_library.match_goal`` carries a keyframe — into the new goal's frame, then shifted so that the working
     wrist lies on the grasp point (the root kept on the ground);
   - the matched goal phase: that clip's PAE phase ``[S, A, F]`` at its grasp, precomputed (§5.2: "the
     corresponding phase of each frames can be precomputed by the PAE"), due at that clip's grasp frame counted
     from the rollout's start (``KeyJointGoal.due``): the rollouts carry it to each frame by
     ``controller.kalman.goal_phase_at``, as training does.
3. **The approach** (§4, :func:`planned_approach_goal`): the working wrist's samples up to the keyframe are
   replaced by the implicit planner's plan (chapter 16's, ``intp.plan_trajectory``) from the window's first
   sample to the grasp point among the scene's obstacles — CHOICE's ``τ_plan``.
   **Rows** (:func:`table4_runs`): each drives all scenes in one batch from its start for ``anchor + after``
   frames (``anchor`` the held-out clip's grasp frame, so that every row is measured over the recording's span):
   ``"w/o goal phase"``, ``"w/ matched goal"``, ``"w/ predicted goal"`` and ``"w/ KF goal"`` are
   ``controller.runtime.rollout``'s four goal-phase sources on the planned goal; ``"w/ KF + cuRobo"`` is the
   Kalman one with the approach the straight minimum-jerk path between the same two ends instead
   (:func:`straight_approach_goal`). Every row bounds its goal phase by the same ``A_max``, the largest amplitude
   of the controller's training frames (``controller.runtime.phase_filter_config``).
4. **Measures** (``controller.measures``): unsmoothness, sliding, the Fréchet distance of 2 s pose windows
   against the controller's training clips, the working wrist's RMS curvature on its approach.

Ours, where CHOICE does not say or where the toy differs:

- The nearest keyframe (``k = 1``) gives the window, the phase and the time to the keyframe (its clip's grasp frame:
  the toy reaches start standing, as the scenes do).
- **The plan on the window**: the planned path (with its walk from the wrist to ``x_s``) is laid on the window's
  seven approach samples evenly by frame, so the window keeps the matched clip's timing; the rotations stay the
  matched clip's (CHOICE transfers the prior's orientations onto the plan, Eq. 12). Where the planner finds no
  path, the scene keeps the matched approach (``"planned"`` says where).
- The library is the controller's training reaches (walk up, reach, grasp), not ``goal_library.goal_keyframes``'
  clips, which reach from where they stand: a goal window holding no walk is one the toy controller never saw
  in training, and with it the wrists stopped about 0.8 m from their grasps (median, seed 1).
- A held-out clip's grasp point and hand are the scene's (``meta["grasp_point"]``, ``["hand"]``).
"""
from __future__ import annotations

import dataclasses
import time
from typing import NamedTuple, Optional

import numpy as np
import torch

from ... import metrics
from ...infra import load_or_build
from ...world import mocap
from ...world.motion import FPS, Motion
from ...world.objects import object_from_description
from ..controller import network, phase, runtime
from ..controller.features import WINDOW, WINDOW_OFFSETS, WRIST_JOINTS, key_joint_transforms, phase_state
from ..controller.measures import motion_measures, pose_window_features
from ..planner import baselines, fields, interactions, intp
from ..planner.interactions import condition_vector
from . import environment as env
from . import goal_library
from .environment import HANDS, EnvironmentConfig, floor_sdf, goal_frame
from .goal_library import GoalLibrary
from .hand_paths import ApproachPlanner, trained_approach_planner

__all__ = ["TABLE4_ROWS", "ReachScene", "reach_scene", "KeyframeWindow", "reach_library", "MatchedGoals",
           "matched_goals", "reach_goals", "planned_approach_goal", "straight_approach_goal", "table4_runs",
           "scene_goal"]

TABLE4_ROWS = ("w/ KF + cuRobo", "w/o goal phase", "w/ matched goal", "w/ predicted goal", "w/ KF goal")
_ROW_VARIANT = {"w/ KF + cuRobo": "kalman", "w/o goal phase": "none", "w/ matched goal": "matched",
                "w/ predicted goal": "predicted", "w/ KF goal": "kalman"}
_CENTRE = WINDOW // 2


class ReachScene(NamedTuple):
    """What a user's click on an item gives (no motion).

    Attributes:
        item: the ``ToyObject`` as placed. support: the table or shelf it stands on.
        grasp_point: (3,) metres, where the wrist goes. hand: ``"left"`` or ``"right"``.
    """

    item: object
    support: object
    grasp_point: np.ndarray
    hand: str


def reach_scene(clip: Motion) -> ReachScene:
    """The scene of a ``world.mocap`` reach-and-grasp clip, read from its ``meta`` only (the item, its support, the
    grasp point and the hand), never from its frames."""
    if not isinstance(clip, Motion):
        raise ValueError(f"clip: expected a world.motion.Motion, got {type(clip).__name__}")
    missing = [k for k in ("object", "support", "grasp_point", "hand") if k not in clip.meta]
    if missing or clip.meta["support"] is None:
        raise ValueError(f"clip: expected a reach-and-grasp clip with meta object, support, grasp_point and hand; "
                         f"missing {missing or ['support']}")
    return ReachScene(object_from_description(clip.meta["object"]), object_from_description(clip.meta["support"]),
                      np.asarray(clip.meta["grasp_point"], dtype=np.float64), str(clip.meta["hand"]))


class KeyframeWindow(NamedTuple):
    """A library keyframe's goal window, precomputed (one per library clip).

    Attributes:
        positions: (13, 4, 3) the root, hip, left and right wrist over the 2 s window at the first contact, in the
            clip's world (metres). rotations: (13, 4, 3, 3) theirs.
        phase: (C, 3) the clip's PAE phase ``[S, A, F]`` at the contact.
        frame: (4, 4) ``world_from_goal`` of the clip's goal (``environment.goal_frame`` of its grid).
        seed: the clip's seed (its ``meta["seed"]``).
        anchor: the contact's frame in the clip (its ``meta["anchor_frame"]``): the frames from the clip's start to it.
    """

    positions: np.ndarray
    rotations: np.ndarray
    phase: np.ndarray
    frame: np.ndarray
    seed: int
    anchor: int


def _hand_goal(scene: ReachScene, config: EnvironmentConfig) -> env.HandGoal:
    """The scene's §6.1 hand goal (``environment.object_goal``: the grid around the item, yawed like its support;
    the environment the support and the floor; the contact the grasp point)."""
    return env.object_goal(scene.item, scene.support, scene.item.category, [scene.support, floor_sdf], config,
                           contact=scene.grasp_point)


@torch.no_grad()
def reach_library(clips, env_model: env.EnvironmentAutoencoder, phase_model: phase.PhaseAutoencoder,
                  config: EnvironmentConfig = EnvironmentConfig()) -> tuple[GoalLibrary, list]:
    """The goal library of reach-and-grasp ``clips`` (CHOICE's: "all the goal keyframes in the training set"), one
    keyframe per clip at its grasp, and each keyframe's :class:`KeyframeWindow` — its key joints
    (``controller.features.key_joint_transforms``) over the window ``anchor + 5k`` (k = −6..6, clamped to the clip)
    and its phase from ``phase_model``.

    Returns:
        ``(library, windows)``: a ``goal_library.GoalLibrary`` (row ``i`` is clip ``i``) and ``len(clips)`` windows.
    """
    rows, windows = [], []
    for clip in clips:
        goal = _hand_goal(reach_scene(clip), config)
        rows.append(goal_library.keyframe_row(clip, "item", goal.grid, goal.environment, config, "grasp"))
        anchor = int(clip.meta["anchor_frame"])
        positions, rotations = key_joint_transforms(clip)
        frames = (anchor + WINDOW_OFFSETS).clamp(0, len(clip) - 1)
        state = phase.clip_phase(phase_model, clip).state()[anchor]
        windows.append(KeyframeWindow(positions[frames].double().numpy(), rotations[frames].double().numpy(),
                                      state.double().numpy(), goal_frame(goal.grid), int(clip.meta["seed"]), anchor))
    return goal_library.build_goal_library(env_model, rows), windows


class MatchedGoals(NamedTuple):
    """The goals of ``B`` scenes and where they came from.

    Attributes:
        goal: ``controller.runtime.KeyJointGoal`` (positions (B, 13, 4, 3), rotations, phase (B, C, 3), hand).
        rows: (B,) the matched library rows. distances: (B,) their §6.1 feature distances.
        seeds: (B,) the matched clips' seeds.
    """

    goal: runtime.KeyJointGoal
    rows: np.ndarray
    distances: np.ndarray
    seeds: np.ndarray


@torch.no_grad()
def matched_goals(scenes, library: GoalLibrary, model: env.EnvironmentAutoencoder, windows,
                  config: EnvironmentConfig = EnvironmentConfig()) -> MatchedGoals:
    """The goal of each scene by §6.1 matching: the nearest grasp keyframe for the scene's hand
    (``goal_library.match_goal``, k = 1), its window, phase and time from its clip's start (the goal's ``due``)
    from ``windows`` (:func:`reach_library`'s).

    The window is carried into the scene like ``match_goal``'s keyframe: from the matched clip's goal frame into
    the scene's, then shifted so that the working wrist at the contact lies on the grasp point; the root's height
    is set to 0 (it is the pelvis's projection on the ground).
    """
    scenes = list(scenes)
    if not scenes or not all(isinstance(s, ReachScene) for s in scenes):
        raise ValueError("scenes: expected a non-empty sequence of ReachScene (reach_scene of a clip)")
    if len(windows) != len(library):
        raise ValueError(f"windows: expected one window per library row ({len(library)}), got {len(windows)}")
    rows = []
    for s in scenes:
        goal = _hand_goal(s, config)
        match, = goal_library.match_goal(library, model, goal, s.hand, 1, config, "grasp")
        window = windows[match.index]
        move = goal_frame(goal.grid) @ np.linalg.inv(window.frame)  # the clip's world -> the scene
        positions = window.positions @ move[:3, :3].T + move[:3, 3]
        rotations = move[:3, :3] @ window.rotations
        k = 2 + HANDS.index(s.hand)
        positions = positions + (s.grasp_point - positions[_CENTRE, k])
        positions[:, 0, 2] = 0.0
        rows.append((positions, rotations, window.phase, HANDS.index(s.hand), match.index, match.distance, window.seed,
                     window.anchor))
    positions, rotations, states, hands, indices, distances, seeds, anchors = zip(*rows)
    goal = runtime.KeyJointGoal(torch.as_tensor(np.stack(positions), dtype=torch.float32),
                                torch.as_tensor(np.stack(rotations), dtype=torch.float32),
                                torch.as_tensor(np.stack(states), dtype=torch.float32), torch.as_tensor(hands),
                                torch.as_tensor(anchors))
    return MatchedGoals(goal, np.array(indices), np.array(distances), np.array(seeds))


def reach_goals(model: network.ControllerNet, controller_config: network.ControllerConfig, clips,
                environment: Optional[EnvironmentConfig] = None) -> MatchedGoals:
    """:func:`matched_goals` of the scenes of reach-and-grasp ``clips`` in the library of the controller's training
    reaches (:func:`reach_library` under ``model``'s PAE), with the trained §6.1 autoencoder of ``environment``
    (``environment.trained_environment_autoencoder``; None: the ``toy`` preset)."""
    environment = env.environment_config("toy") if environment is None else environment
    env_model = env.trained_environment_autoencoder(environment).model
    train = mocap.generate_dataset(controller_config.clips, seed=controller_config.seed, kinds=controller_config.kinds)
    library, windows = reach_library([c for c in train if c.meta.get("kind") == "reach_grasp"], env_model,
                                     model.phase_model, environment)
    return matched_goals([reach_scene(c) for c in clips], library, env_model, windows, environment)


def planned_approach_goal(goal: runtime.KeyJointGoal, scenes, planner: ApproachPlanner, *, seed: int = 0):
    """The goal with the working wrist's approach (the window's samples up to the keyframe) replaced by §4's plan
    (``intp.plan_trajectory``: the matched prior, the latent fit of Eq. 9, ``x_s`` of Eq. 11, Eq. 10's descent)
    from the window's first sample to the scene's grasp point, among the scene's obstacles (the support).

    The plan (walked from the wrist to ``x_s`` first, ``intp.WristPlan.from_wrist``) is laid on the window's
    samples by its frame index: sample ``j`` of ``0..6`` takes the plan's frame ``j / 6`` of the way along (ours:
    the window keeps the matched clip's timing, the plan gives the way); rotations stay the matched clip's.

    Returns:
        ``(goal, plans)``: a new ``controller.runtime.KeyJointGoal`` and the ``intp.WristPlan`` of each scene (None
        where the planner found no path: that scene keeps the matched approach).
    """
    scenes = list(scenes)
    if len(scenes) != goal.positions.shape[0]:
        raise ValueError(f"scenes: expected one per goal ({goal.positions.shape[0]}), got {len(scenes)}")
    positions = goal.positions.clone()
    generator = torch.Generator().manual_seed(int(seed))
    plans = []
    for b, scene in enumerate(scenes):
        k = 2 + int(goal.hand[b])
        grid = fields.object_grid(scene.item, planner.field, yaw=env.object_yaw(scene.support))
        scene_fields = fields.scene_fields(grid, scene.item, [scene.support], None, FPS, planner.field)
        condition = condition_vector(float(scene.grasp_point[2]), scene.hand, "grasp", "approach")
        wrist = positions[b, 0, k].double().numpy()
        try:
            plan = intp.plan_trajectory(planner.model, planner.config, planner.dataset, scene_fields, condition,
                                        wrist, scene.grasp_point, generator=generator)
        except ValueError:  # no path found (the latent fit gave no finite time of arrival): the matched approach
            plans.append(None)
            continue
        path = plan.from_wrist(wrist, FPS)  # (K, 3), the wrist first, the contact last
        index = np.round(np.linspace(0.0, 1.0, _CENTRE + 1) * (len(path) - 1)).astype(int)
        positions[b, :_CENTRE + 1, k] = torch.as_tensor(path[index], dtype=positions.dtype)
        plans.append(plan)
    return goal._replace(positions=positions), plans


def straight_approach_goal(goal, hand):
    """The goal with the working wrist's approach (the window's samples before the keyframe) replaced by the
    minimum-jerk path between the same two ends (``planner.baselines.minimum_jerk_plan`` without obstacles: the
    cuRobo stand-in's straight move; rotations kept).

    Args:
        goal: ``controller.runtime.KeyJointGoal`` (positions (B, 13, 4, 3)).
        hand: (B,) 0 left, 1 right.
    Returns:
        a new ``controller.runtime.KeyJointGoal``.
    """
    positions = goal.positions.clone()
    for b in range(positions.shape[0]):
        k = 2 + int(hand[b])
        path = baselines.minimum_jerk_plan(positions[b, 0, k].double().numpy(),
                                           positions[b, _CENTRE, k].double().numpy(), _CENTRE + 1)
        positions[b, :_CENTRE + 1, k] = torch.as_tensor(path, dtype=positions.dtype)
    return goal._replace(positions=positions)


def scene_goal(table: dict, scene: int) -> runtime.KeyJointGoal:
    """The goal :func:`table4_runs` gave its held-out scene ``scene`` (the keyframe matched by §6.1, the working
    wrist's approach planned by §4), as a batch of one: what the Table 4 rows (but the cuRobo one) ran toward."""
    n = len(table["anchors"])
    if isinstance(scene, bool) or not isinstance(scene, (int, np.integer)) or not 0 <= scene < n:
        raise ValueError(f"scene: expected an index into the {n} scenes, got {scene!r}")
    return runtime.KeyJointGoal(**{name: None if value is None else value[scene:scene + 1]
                                   for name, value in table["goal"].items()})


class _Joints:
    """A bare ``(joints, fps)`` motion for ``controller.measures.motion_measures``."""

    def __init__(self, joints, fps):
        self.joints, self.fps = joints, fps


def table4_runs(controller_config: network.ControllerConfig, *, clips: int = 12, after: int = 15, seed: int = 0,
                environment: Optional[EnvironmentConfig] = None,
                planner_data: Optional[interactions.PlannerDataConfig] = None,
                planner_config: Optional[intp.PlannerConfig] = None) -> dict:
    """Table 4's rows on ``clips`` unseen reach-and-grasp scenes (the module's algorithm box), run once and then
    loaded from the cache.

    Args:
        controller_config: the trained controller's (``network.trained_controller``).
        after: frames after each held-out clip's grasp frame. seed: the held-out clips are ``world.mocap``'s with
            the seed ``10 000 + seed``.
        environment: the §6.1 autoencoder's configuration (None: the ``toy`` preset).
        planner_data, planner_config: §4's planner (:func:`trained_approach_planner`; None: the ``toy`` presets
            seeded like the controller).
    Measures (``controller.measures.motion_measures``, each scene cut at its own ``anchor + after``; the working
    wrist's RMS curvature over frames ``[0, anchor]``): means over scenes (sliding over those with a planted foot,
    ``"planted clips"``); the Fréchet distance pools every scene's 2 s windows of a row against those of the
    controller's training clips (the ``"Dataset"`` row's: the held-out clips' own, a floor). ``reach`` is the
    working wrist's closest approach to the grasp point (metres).

    Returns:
        ``{"rows": {row: {"Unsmth.", "Slid.", "FD", "EE RMSC", "planted clips", "per clip" {measure: (clips,)},
        "reach" (clips,), "joints" [(T_i, 22, 3)], and but for the Dataset row the rollout's "fed goal phase" and
        "network goal phase" (steps, clips, C, 3) ``[S, A, F]`` (what each step fed the network, and its ``P̂_g``),
        "deviation" (steps, clips) ``c`` of Eq. 22}}, "hands" (clips,), "anchors" (clips,), "matched rows",
        "matched seeds", "match distances", "test seeds" (clips,), "goal phase" (clips, C, 3) the matched one,
        "goal" the rows' planned goal (``controller.runtime.KeyJointGoal``'s fields; :func:`scene_goal`),
        "amplitude max", "planned" (clips,) bool (the planner found a path), "planning seconds", "seconds" (per
        row, the rollout's wall time), "steps"}``.
    """
    if isinstance(clips, bool) or not isinstance(clips, int) or clips < 1:
        raise ValueError(f"clips: expected a positive int, got {clips!r}")
    if isinstance(after, bool) or not isinstance(after, int) or after < 0:
        raise ValueError(f"after: expected an int >= 0 (frames after the grasp), got {after!r}")
    environment = env.environment_config("toy") if environment is None else environment
    if planner_data is None:
        planner_data = interactions.planner_data_config("toy", seed=controller_config.seed)
    if planner_config is None:
        planner_config = intp.planner_config("toy", seed=controller_config.seed)

    def build():
        model = network.trained_controller(controller_config).model
        test = mocap.generate_dataset(clips, seed=10_000 + int(seed), kinds=("reach_grasp",))
        matched = reach_goals(model, controller_config, test, environment)
        planner = trained_approach_planner(planner_data, planner_config)
        clock = time.perf_counter()
        goal, plans = planned_approach_goal(matched.goal, [reach_scene(c) for c in test], planner, seed=int(seed))
        planning_seconds = time.perf_counter() - clock
        train = mocap.generate_dataset(controller_config.clips, seed=controller_config.seed,
                                       kinds=controller_config.kinds)  # the controller's training clips
        anchors = np.array([int(c.meta["anchor_frame"]) for c in test])
        ends = np.minimum(anchors + after, [len(c) - 1 for c in test])
        hands = goal.hand.numpy()
        reference = np.concatenate([pose_window_features(c) for c in train])
        state = runtime.toward_goal(runtime.initial_state(model, test), goal)  # the start: each clip's first frame
        frames = int(ends.max())
        first = torch.stack([c.joints[0].float() for c in test])  # (B, 22, 3) frame 0, the start
        target = goal.positions[torch.arange(len(test)), _CENTRE, 2 + goal.hand].double().numpy()  # the grasp points
        rows, seconds = {}, {}

        def measure(motions):
            per = [motion_measures(m, None, [(0, int(a) + 1)], ("left", "right")[h])
                   for m, a, h in zip(motions, anchors, hands)]
            out = {k: float(np.nanmean([p[k] for p in per])) for k in ("Unsmth.", "Slid.", "EE RMSC")}
            out["per clip"] = {k: np.array([p[k] for p in per]) for k in ("Unsmth.", "Slid.", "EE RMSC")}
            out["planted clips"] = int(np.sum(np.isfinite([p["Slid."] for p in per])))
            out["FD"] = float(metrics.frechet_distance(np.concatenate([pose_window_features(m) for m in motions]),
                                                       reference))
            return out

        for row in TABLE4_ROWS:
            g = straight_approach_goal(matched.goal, hands) if row == "w/ KF + cuRobo" else goal
            clock = time.perf_counter()
            run = runtime.rollout(model, state, g, frames, _ROW_VARIANT[row], controller_config.blend_radius)
            seconds[row] = time.perf_counter() - clock
            # frame 0 is the start; step i gives frame i + 1
            joints = torch.cat([first[None], run.joints], dim=0).double().numpy()  # (frames + 1, B, 22, 3)
            motions = [_Joints(joints[:e + 1, b], FPS) for b, e in enumerate(ends)]
            rows[row] = measure(motions)
            rows[row]["reach"] = np.array([np.linalg.norm(joints[:e + 1, b, WRIST_JOINTS[h]] - target[b], axis=-1).min()
                                           for b, (e, h) in enumerate(zip(ends, hands))])
            rows[row]["joints"] = [m.joints for m in motions]
            rows[row]["fed goal phase"] = phase_state(run.goal_phase).double().numpy()
            rows[row]["network goal phase"] = run.predicted_goal_phase.double().numpy()
            rows[row]["deviation"] = run.deviation.double().numpy()
        dataset = [_Joints(c.joints[:e + 1].double().numpy(), FPS) for c, e in zip(test, ends)]
        rows["Dataset"] = measure(dataset)
        rows["Dataset"]["reach"] = np.array([np.linalg.norm(c.joints[:e + 1, WRIST_JOINTS[h]].double().numpy() - t,
                                                            axis=-1).min()
                                             for c, e, h, t in zip(test, ends, hands, target)])
        rows["Dataset"]["joints"] = [m.joints for m in dataset]
        return {"rows": rows, "hands": hands, "anchors": anchors, "matched rows": matched.rows,
                "matched seeds": matched.seeds, "match distances": matched.distances,
                "test seeds": np.array([int(c.meta["seed"]) for c in test]), "goal phase": goal.phase.double().numpy(),
                "goal": goal._asdict(),
                "amplitude max": float(model.phase_amplitude_max), "planned": np.array([p is not None for p in plans]),
                "planning seconds": planning_seconds, "seconds": seconds, "steps": frames}

    key = {"controller": dataclasses.asdict(controller_config), "clips": clips, "after": after, "seed": int(seed),
           "environment": dataclasses.asdict(environment), "planner data": dataclasses.asdict(planner_data),
           "planner": dataclasses.asdict(planner_config)}
    return load_or_build("choice_table4", key, build)
