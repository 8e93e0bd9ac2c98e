"""SAMP at run time (§3, Fig. 2): MotionNet's decoder stepping a character from goal to goal.

The loop, as the paper runs it:

1. the character's state ``X_{i−1}`` and the object's voxels ``I`` seen from its root;
2. ``Z ~ N(0, σ² I)`` (σ = 1 in §3.1: "sample Z from a standard normal distribution"), and the
   decoder predicts ``Ŷ_i = [X̂_i, root update]``;
3. the root moves by the update; close to the goal the future trajectory samples are pulled
   towards the network's own prediction of them in the goal's frame (:func:`correct_towards_goal`,
   as SAMP's public run-time code does); the goal features of ``X̂_i`` (``t̃^p``, ``t̃^d``, ``g^p``,
   ``g^d``, ``g^a``) are then recomputed from the trajectory and the *current* goal — the goal is
   the controller's input, everything else is the network's (the Neural State Machine's control
   loop, which SAMP's state follows);
4. goals come one after the other (§3.3): "each sub-task requires the character to walk to the
   next waypoint. The final sub-task requires the character to perform the desired action at the
   final waypoint." A goal is passed when the root comes within its radius.

Everything is batched over ``B`` characters, each with its own goals and object.
"""
from __future__ import annotations

import hashlib
import inspect
import pickle
from dataclasses import dataclass
from typing import Optional

import numpy as np
import torch

from .._validate import as_tensor, check_shape
from ..infra import load_or_build, single_threaded
from ..world import mocap
from ..world.features import SAMP_ACTIONS, SAMP_SAMPLE_OFFSETS, SAMP_STATE_LAYOUT, SAMP_STATE_SIZE, samp_pose_state
from ..world.skeleton import NUM_JOINTS
from .core import GoalNetCVAE, MotionModel
from .goal_frame import (CURRENT_SAMPLE, LocalGoal, correct_towards_goal, goal_features, local_goal, recomputed_state,
                         unit, with_goal)
from .motion_data import apply_root_displacement, as_complex, voxels_in_root_frame
from .sensor import sensor_voxels

__all__ = [
    "CURRENT_SAMPLE",
    "content_digest",
    "object_digest",
    "model_digest",
    "current_action",
    "GoalSequence",
    "goal_features",
    "correct_towards_goal",
    "with_goal",
    "standing_state",
    "Rollout",
    "rollout",
]

_NS, _NA = len(SAMP_SAMPLE_OFFSETS), len(SAMP_ACTIONS)


def _rotate(xy: torch.Tensor, angle: torch.Tensor) -> torch.Tensor:
    """Rotate ``(..., 2)`` vectors by ``angle (...)`` about +Z."""
    return torch.view_as_real(as_complex(xy) * torch.polar(torch.ones_like(angle), angle))


@dataclass
class GoalSequence:
    """Goals one after the other, per character (§3.3).

    Attributes:
        positions: ``(B, G, 3)`` world goal positions (m); directions ``(B, G, 3)``.
        actions: ``(B, G)`` int64 index into ``SAMP_ACTIONS`` of the action at each goal.
        radii: ``(B, G)`` a goal is passed when the root is closer than this (m, ground plane); the
            last real goal of a character is never passed.
        counts: ``(B,)`` goals per character (rows beyond are padding).
    """

    positions: torch.Tensor
    directions: torch.Tensor
    actions: torch.Tensor
    radii: torch.Tensor
    counts: torch.Tensor

    @classmethod
    def single(cls, positions, directions, actions) -> "GoalSequence":
        """One goal per character: ``positions (B, 3)``, ``directions (B, 3)``, ``actions`` names or ids."""
        positions = as_tensor(positions, "positions", dtype=torch.float32).reshape(-1, 1, 3)
        B = positions.shape[0]
        directions = as_tensor(directions, "directions", dtype=torch.float32).reshape(B, 1, 3)
        return cls(positions, directions, _action_ids(actions, B)[:, None], torch.zeros(B, 1),
                   torch.ones(B, dtype=torch.int64))

    @classmethod
    def from_lists(cls, goals: list) -> "GoalSequence":
        """From one list per character of ``(position (3,), direction (3,), action, radius)`` tuples."""
        if not goals or any(len(g) == 0 for g in goals):
            raise ValueError("goals: expected a non-empty list of goals for every character")
        B, G = len(goals), max(len(g) for g in goals)
        positions, directions = torch.zeros(B, G, 3), torch.zeros(B, G, 3)
        actions, radii = torch.zeros(B, G, dtype=torch.int64), torch.zeros(B, G)
        for b, seq in enumerate(goals):
            for k in range(G):
                p, d, a, r = seq[min(k, len(seq) - 1)]
                positions[b, k] = torch.as_tensor(np.asarray(p, dtype=np.float32).reshape(3))
                directions[b, k] = torch.as_tensor(np.asarray(d, dtype=np.float32).reshape(3))
                actions[b, k] = int(_action_ids([a], 1)[0])
                radii[b, k] = float(r)
        return cls(positions, directions, actions, radii, torch.as_tensor([len(g) for g in goals]))

    def __post_init__(self):
        check_shape(self.positions, (None, None, 3), "positions")
        B, G = self.positions.shape[:2]
        check_shape(self.directions, (B, G, 3), "directions")
        check_shape(self.actions, (B, G), "actions")
        check_shape(self.radii, (B, G), "radii")
        check_shape(self.counts, (B,), "counts")
        self._rows = torch.arange(B)
        # the goals as the bookkeeping reads them: complex ground positions, unit facings, heights
        self._xy, self._forward = as_complex(self.positions[..., :2]), unit(as_complex(self.directions[..., :2]))
        self._height = self.positions[..., 2:]

    def current(self, index: torch.Tensor):
        """``(position (B, 3), direction (B, 3), action (B,))`` of goal ``index (B,)`` of each character."""
        return self.positions[self._rows, index], self.directions[self._rows, index], self.actions[self._rows, index]

    def seen_from(self, index: torch.Tensor, roots: torch.Tensor) -> LocalGoal:
        """Goal ``index (B,)`` of each character seen from ``roots (B, 3)``."""
        rows = self._rows
        return local_goal(roots, self._xy[rows, index], self._forward[rows, index], self._height[rows, index],
                          self.actions[rows, index])

    def advance(self, index: torch.Tensor, roots: torch.Tensor) -> torch.Tensor:
        """The goal index after the roots ``(B, 3)`` moved: a goal within its radius is passed."""
        offset = roots[:, :2] - self.positions[self._rows, index, :2]
        radius = self.radii[self._rows, index]
        near = offset.square().sum(-1) < radius * radius
        return index + (near & (index < self.counts - 1))


def _action_ids(actions, B: int) -> torch.Tensor:
    if isinstance(actions, torch.Tensor):
        ids = actions.long().reshape(-1)
    else:
        values = [actions] if isinstance(actions, (str, int, np.integer)) else list(actions)
        ids = []
        for a in values:
            if isinstance(a, str):
                if a not in SAMP_ACTIONS:
                    raise ValueError(f"action: expected one of {SAMP_ACTIONS}, got {a!r}")
                ids.append(SAMP_ACTIONS.index(a))
            else:
                ids.append(int(a))
        ids = torch.as_tensor(ids, dtype=torch.int64)
    if ids.numel() == 1:
        ids = ids.expand(B).clone()
    if ids.shape != (B,) or bool(((ids < 0) | (ids >= _NA)).any()):
        raise ValueError(f"actions: expected {B} ids in [0, {_NA}) or names from {SAMP_ACTIONS}")
    return ids


def standing_state(seed: int = 0, frame: int = 30) -> torch.Tensor:
    """``(437,)`` the state of a character standing still (a toy idle clip's frame ``frame``),
    goal features zero: a start for :func:`rollout` (set its root and goal with :func:`with_goal`)."""
    clip = mocap.idle(2.0, seed=seed)
    _, flat = samp_pose_state(clip)
    return flat[min(frame, len(clip) - 1)].float()


@dataclass
class Rollout:
    """What :func:`rollout` produced, frame 0 being the start (``T + 1`` frames).

    Attributes:
        states: ``(B, T + 1, 437)``; roots ``(B, T + 1, 3)`` ``(x, y, heading)`` world;
        goal_index: ``(B, T + 1)`` the goal each frame was heading for;
        actions: ``(B, T + 1)`` the action the state labels its current frame with (``t^a`` at the
            current sample, arg-max: ``SAMP_ACTIONS``).
    """

    states: torch.Tensor
    roots: torch.Tensor
    goal_index: torch.Tensor
    actions: torch.Tensor

    def joints(self) -> torch.Tensor:
        """``(B, T + 1, 22, 3)`` world joint positions (``j^p`` placed at the root)."""
        B, T1 = self.roots.shape[:2]
        local = self.states[..., SAMP_STATE_LAYOUT["joint_positions"]].reshape(B, T1, NUM_JOINTS, 3)
        xy = _rotate(local[..., :2], self.roots[..., None, 2]) + self.roots[..., None, :2]
        return torch.cat([xy, local[..., 2:]], dim=-1)

    def forward(self) -> torch.Tensor:
        """``(B, T + 1, 3)`` the root's forward direction in the world."""
        h = self.roots[..., 2]
        return torch.stack([-torch.sin(h), torch.cos(h), torch.zeros_like(h)], dim=-1)


def current_action(states: torch.Tensor) -> torch.Tensor:
    """``(...)`` arg-max of ``t^a`` at the current sample of ``states (..., 437)``."""
    labels = states[..., SAMP_STATE_LAYOUT["trajectory_actions"]]
    labels = labels.reshape(*labels.shape[:-1], _NS, _NA)[..., CURRENT_SAMPLE, :]
    return labels.argmax(-1)


def content_digest(*items) -> str:
    """sha256 hex of tensors and numpy arrays (dtype, shape and bytes), numbers, strings and ``None``, in order:
    a key for what is computed from them."""
    h = hashlib.sha256()
    for item in items:
        if isinstance(item, np.ndarray):
            item = torch.from_numpy(np.ascontiguousarray(item))
        if isinstance(item, torch.Tensor):
            t = item.detach().to("cpu").contiguous()
            h.update(f"tensor {t.dtype} {tuple(t.shape)};".encode())
            h.update(t.reshape(-1).view(torch.uint8).numpy().tobytes())
        elif item is None or isinstance(item, (bool, int, float, str)):
            h.update(f"{type(item).__name__} {item!r};".encode())
        else:
            raise TypeError(f"cannot digest a {type(item).__name__}")
    return h.hexdigest()


def object_digest(obj) -> str:
    """sha256 hex of everything that makes a toy object what it is: its category, sizes, parts, affordances and
    pose, bit for bit (a key for what is computed from the object alone)."""
    for attr in ("category", "params", "primitives", "annotations", "pose"):
        if not hasattr(obj, attr):
            raise TypeError(f"obj: expected a ToyObject (world.objects.make_object), got {type(obj).__name__}")
    return hashlib.sha256(pickle.dumps((obj.category, obj.params, obj.primitives, obj.annotations,
                                        np.asarray(obj.pose, dtype=np.float64)), protocol=4)).hexdigest()


def model_digest(model) -> str:
    """A ``MotionModel`` as a rollout runs it (or a ``GoalNetCVAE`` as it proposes goals): its class (name and source text), its plain attributes (``latent``,
    ``environment_sensor``, ``training``, …) and every parameter and buffer, bit for bit. The library's models
    live in ``samp.core``, whose code every key of a run holds already (the cache follows imports); the class's
    source counts for a model class of one's own."""
    if not isinstance(model, (MotionModel, GoalNetCVAE)):
        raise TypeError(f"model: expected a samp.core.MotionModel or GoalNetCVAE, got {type(model).__name__}")
    plain = sorted((name, value) for name, value in vars(model).items()
                   if not name.startswith("_") and isinstance(value, (bool, int, float, str)))
    try:
        source = inspect.getsource(type(model))
    except (OSError, TypeError):  # defined where no source is kept (an interactive session)
        source = None
    weights = model.state_dict()
    return content_digest(f"{type(model).__module__}.{type(model).__qualname__}", source, repr(plain),
                          *[item for name in sorted(weights) for item in (name, weights[name])])


def rollout(model: MotionModel, start: torch.Tensor, start_roots: torch.Tensor, goals: GoalSequence,
            n_frames: int, generator: torch.Generator, voxel_centres: Optional[torch.Tensor] = None,
            voxel_occupancy: Optional[torch.Tensor] = None, latent_scale: float = 1.0,
            goal_correction: bool = True, cache: bool = True) -> Rollout:
    """Step ``B`` characters for ``n_frames`` frames with the model's decoder, once (then from the cache).

    Generated motion goes through the artifact cache like a trained model: the key is everything the
    run depends on, bit for bit (the model's class, weights and settings, the start, the goals, the
    object cells, the generator's state, the arguments; the code of this module and what it imports),
    so a cached run is the run this call would make. The generator is left where the run left it.

    Args:
        model: a trained MotionNet (``Z ~ N(0, latent_scale² I)``) or a deterministic baseline.
        start: ``(B, 437)`` or ``(437,)`` start states (their goal features are recomputed).
        start_roots: ``(B, 3)`` world ``(x, y, heading)``.
        goals: the goals, :class:`GoalSequence` with ``B`` rows.
        n_frames: frames to generate (30 a second).
        generator: a CPU ``torch.Generator`` for the latent draws.
        voxel_centres, voxel_occupancy: ``(B, 512, 3)`` and ``(B, 512)`` each character's object in
            the world (``motion_data.object_voxel_cells``), or None for no object (zeros). A model with
            the environment sensor (``model.environment_sensor``) senses them, and takes the cells of
            ``M`` objects, ``(B, 512 M, 3)`` and ``(B, 512 M)``.
        latent_scale: σ of the latent draws.
        goal_correction: near the goal, blend the future trajectory towards its goal-frame
            prediction (:func:`correct_towards_goal`, SAMP's public run-time code).
        cache: ``False`` runs without the cache (and stores nothing); so does a run whose goals are a subclass of
            :class:`GoalSequence` (e.g. ``pipeline.PathGoals``, whose rooms the key would not see).
    Returns:
        :class:`Rollout`.
    """
    if not isinstance(n_frames, int) or isinstance(n_frames, bool) or n_frames < 1:
        raise ValueError(f"n_frames: expected a positive int, got {n_frames!r}")
    if not isinstance(generator, torch.Generator):
        raise TypeError(f"generator: expected a torch.Generator, got {type(generator).__name__}")
    if generator.device.type != "cpu":
        raise ValueError(f"generator: expected a CPU torch.Generator, got one on {generator.device}")
    args = (model, start, start_roots, goals, n_frames, generator, voxel_centres, voxel_occupancy,
            float(latent_scale), bool(goal_correction))
    if not cache or type(goals) is not GoalSequence:  # a subclass (pipeline.PathGoals) holds more than the key sees
        return _rollout(*args)
    inputs = (as_tensor(start, "start"), as_tensor(start_roots, "start_roots"), goals.positions, goals.directions,
              goals.actions, goals.radii, goals.counts,
              None if voxel_centres is None else as_tensor(voxel_centres, "voxel_centres"),
              None if voxel_occupancy is None else as_tensor(voxel_occupancy, "voxel_occupancy"))
    key = {"model": model_digest(model), "device": str(model.x_mean.device), "inputs": content_digest(*inputs),
           "generator": content_digest(generator.get_state()), "n_frames": n_frames,
           "latent_scale": float(latent_scale), "goal_correction": bool(goal_correction)}

    def build():
        out = _rollout(*args)
        return {"states": out.states, "roots": out.roots, "goal_index": out.goal_index, "actions": out.actions,
                "generator_state": generator.get_state()}

    artifact = load_or_build("samp_rollout", key, build, verbose=False)
    generator.set_state(artifact["generator_state"])
    return Rollout(artifact["states"], artifact["roots"], artifact["goal_index"], artifact["actions"])


@torch.no_grad()
@single_threaded
def _rollout(model, start, start_roots, goals, n_frames, generator, voxel_centres, voxel_occupancy, latent_scale,
             goal_correction) -> Rollout:
    roots = as_tensor(start_roots, "start_roots", dtype=torch.float32)
    check_shape(roots, (None, 3), "start_roots")
    B = roots.shape[0]
    x = as_tensor(start, "start", dtype=torch.float32)
    x = x.expand(B, -1).clone() if x.dim() == 1 else x.clone()
    check_shape(x, (B, SAMP_STATE_SIZE), "start")
    if goals.positions.shape[0] != B:
        raise ValueError(f"goals: expected {B} characters, got {goals.positions.shape[0]}")
    device = model.x_mean.device
    index = torch.zeros(B, dtype=torch.int64)
    x = with_goal(x, roots, *goals.current(index))
    states, root_track, goal_track = [x], [roots], [index]
    for _ in range(n_frames):
        if voxel_centres is None:
            voxels = sensor_voxels(None, None, roots) if model.environment_sensor else torch.zeros(B, 2048)
        elif model.environment_sensor:
            voxels = sensor_voxels(voxel_centres, voxel_occupancy, roots)
        else:
            voxels = voxels_in_root_frame(voxel_centres, voxel_occupancy, roots)
        z = None
        if model.latent:
            z = latent_scale * torch.randn(B, model.latent, generator=generator)
        y = model.predict(x.to(device), voxels.to(device), None if z is None else z.to(device)).cpu()
        roots = apply_root_displacement(roots, y[:, SAMP_STATE_SIZE:])
        x = y[:, :SAMP_STATE_SIZE]
        goal = goals.seen_from(index, roots)
        passed = goals.advance(index, roots)
        correct_towards = goal if goal_correction else None  # the goal the step was heading for
        if bool((passed != index).any()):  # a goal was passed: the features are the next one's
            index = passed
            goal = goals.seen_from(index, roots)
        x = recomputed_state(x, goal=goal, correct_towards=correct_towards)
        states.append(x)
        root_track.append(roots)
        goal_track.append(index)
    states = torch.stack(states, dim=1)
    return Rollout(states, torch.stack(root_track, dim=1), torch.stack(goal_track, dim=1), current_action(states))
