"""The goal library and K-nearest goal matching (CHOICE §6.1), on ``environment``'s features.

1. **The goal library** (:func:`goal_keyframes`, :class:`GoalLibrary`): "the flattened latent code z
   together with the hand manipulation state c ... as the matching feature vector from all the goal
   keyframes in the training set ... in a KD tree structure". Our keyframes are the first contacts of
   toy-mocap clips (reach an item on a shelf or a table; take the handle of a cabinet door or a drawer),
   each with ``f = {z; c}`` and its three key joints (both wrists, the pelvis) in the goal's frame.
2. **Matching** (:meth:`GoalLibrary.query`, :func:`match_goal`): "we encode the environment around the
   target object o to form its matching feature with the manipulation state c: f = {z_o; c} and match
   K-nearest neighbors in the KD tree"; the matches' key joints are carried into the scene.

The choices the paper does not state (exact labels as keys, keyframes into the scene, the library's clips) are
listed in ``environment``'s docstring.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch
from scipy.spatial import cKDTree

from ..._validate import check_choice, check_positive_ints, check_shape
from ...infra import load_or_build, scaled_config
from ...world.mocap.grasping import reach_grasp
from ...world.mocap.handles import open_door, open_drawer
from ...world.objects import GRASPABLE, make_object, object_from_description
from ..planner import fields
from ..planner.fields import FieldGrid
from ..planner.interactions import condition_vector
from .environment import (GOAL_KINDS, HANDLED_CATEGORY, HANDS, EnvironmentAutoencoder, EnvironmentConfig, HandGoal,
                          KeyPose, encode, environment_field, floor_sdf, goal_frame, object_yaw)

__all__ = ["LibraryConfig", "LIBRARY_SCALES", "library_config", "keyframe_row", "goal_keyframes", "GoalLibrary",
           "build_goal_library", "Match", "match_goal"]


@dataclass(frozen=True)
class LibraryConfig:
    """The goal keyframes matched against (defaults: the ``toy`` preset).

    Attributes:
        n_clips: clips of each kind — reach and grasp an item, open a cabinet door, open a drawer — the hands
            alternating; every grasp also enters as a place (CHOICE: the goal keyframes of 150 sequences).
        seed: seeds the clips.
    """

    n_clips: int = 12
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("n_clips",))


LIBRARY_SCALES = {"small": {"n_clips": 48}, "paper": {"n_clips": 300}}


def library_config(scale: str = "toy", **overrides) -> LibraryConfig:
    """The preset for ``scale``, fields overridable."""
    return scaled_config(LibraryConfig, scale, LIBRARY_SCALES, overrides, factory="library_config")


def keyframe_row(motion, kind: str, grid: FieldGrid, environment, config: EnvironmentConfig,
                 action: str = "grasp") -> dict:
    """One library row of a clip whose first contact is ``meta["anchor_frame"]``: the goal's field (``grid`` around
    the goal, ``environment`` the things around it), ``c`` and the key joints at the first contact and at the end
    (:func:`goal_keyframes`'s row)."""
    hand, anchor = motion.meta["hand"], int(motion.meta["anchor_frame"])
    to_goal = np.linalg.inv(goal_frame(grid))
    contact = KeyPose.from_motion(motion, anchor).transformed(to_goal)
    end = KeyPose.from_motion(motion, len(motion) - 1).transformed(to_goal)
    height = float(motion.joint(f"{hand}_wrist")[anchor, 2])
    return {"kind": kind, "condition": condition_vector(height, hand, action, "approach"),
            "field": environment_field(grid, environment, config),
            "contact_rotations": contact.rotations, "contact_positions": contact.positions,
            "end_rotations": end.rotations, "end_positions": end.positions,
            "clip": motion.meta["kind"], "seed": int(motion.meta["seed"])}


def goal_keyframes(config: EnvironmentConfig, library: LibraryConfig) -> list[dict]:
    """The library's goal keyframes, built once from toy-mocap clips, then loaded from the cache.

    Per clip index ``i`` (hand ``HANDS[i % 2]``): a reach-and-grasp of a bottle, mug or teapot on a table or
    a shelf board (as a grasp and as a place), the opening of a cabinet door and of a drawer. A row holds
    ``kind``, ``condition`` (4,), ``field`` (n, n, n), the key joints at the first contact
    (``contact_rotations`` (3, 3, 3), ``contact_positions`` (3, 3)) and at the clip's end (``end_*``), in
    the goal's frame (:func:`goal_frame`), and the clip's ``clip`` kind and ``seed``.
    """
    def build():
        rows = []
        for i in range(library.n_clips):
            rng = np.random.default_rng([library.seed, i])
            hand, seed = HANDS[i % 2], int(rng.integers(2 ** 31))
            item = make_object(GRASPABLE[i % len(GRASPABLE)], rng)
            motion = reach_grasp(item, hand=hand, seed=seed, pick_up=True, approach=False)
            target = object_from_description(motion.meta["object"])
            support = object_from_description(motion.meta["support"])
            grid = fields.object_grid(target, config.field, yaw=object_yaw(support))
            for action in ("grasp", "place"):
                rows.append(keyframe_row(motion, "item", grid, [support, floor_sdf], config, action))
            for kind, clip in (("door", open_door), ("drawer", open_drawer)):
                furniture = make_object(HANDLED_CATEGORY[kind], rng, **{"door_angle" if kind == "door" else "drawer_open": 0.0})
                motion = clip(furniture, hand=hand, seed=seed, approach=False)
                grid = fields.object_grid(furniture, config.field, centre=furniture.handle_point)
                rows.append(keyframe_row(motion, kind, grid, [furniture, floor_sdf], config))
        return rows

    key = {"field": dataclasses.asdict(config.field), "truncation": config.truncation,
           "library": dataclasses.asdict(library)}
    return load_or_build("choice_goal_keyframes", key, build, verbose=False)


def _label(kind: str, condition) -> tuple:
    """The exact-match key of a keyframe: its kind and ``c``'s three labels."""
    return (kind, *(int(round(float(v))) for v in np.asarray(condition)[1:]))


@dataclass
class GoalLibrary:
    """The goal keyframes with their matching features ``f = {z; c}`` in KD trees (§6.1).

    Attributes:
        latents: (N, latent) ``z`` of each keyframe's environment.
        conditions: (N, 4) ``c``.
        kinds: (N,) ``"item"``, ``"door"`` or ``"drawer"``.
        contact, end: N :class:`KeyPose` each, in the goal's frame: at the first contact, at the clip's end.
        scales: (latent + 1,) what ``[z, h]`` is divided by (``s_z`` repeated, then ``s_h``).
        trees: ``{label: (indices (M,), cKDTree)}``, one tree per kind and labels of ``c``.
    """

    latents: np.ndarray
    conditions: np.ndarray
    kinds: tuple
    contact: list
    end: list
    scales: np.ndarray
    trees: dict

    def __len__(self) -> int:
        return len(self.kinds)

    def features(self, latents, heights) -> np.ndarray:
        """(..., latent + 1) the continuous part of ``f``: ``[z / s_z, h / s_h]``."""
        latents, heights = np.asarray(latents, dtype=np.float64), np.asarray(heights, dtype=np.float64)
        return np.concatenate([latents, heights[..., None]], axis=-1) / self.scales

    def query(self, latent, condition, kind: str, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The ``k`` nearest keyframes to ``f = {z; c}`` among those of the same kind and labels.

        Args:
            latent: (latent,) ``z`` of the new goal. condition: (4,) ``c``. kind: one of ``GOAL_KINDS``.
        Returns:
            ``(distances (k',), indices (k',))``, nearest first, ``k' = min(k, keyframes with the labels)``.
        """
        check_choice(kind, GOAL_KINDS, "kind")
        if not isinstance(k, (int, np.integer)) or isinstance(k, bool) or k < 1:
            raise ValueError(f"k: expected a positive int, got {k!r}")
        latent, condition = np.asarray(latent, dtype=np.float64), np.asarray(condition, dtype=np.float64)
        check_shape(latent, (self.latents.shape[1],), "latent")
        check_shape(condition, (4,), "condition")
        label = _label(kind, condition)
        if label not in self.trees:
            raise ValueError(f"condition: no goal keyframe with kind, hand, action, segment {label}; "
                             f"the library has {sorted(self.trees)}")
        indices, tree = self.trees[label]
        distances, found = tree.query(self.features(latent, condition[0]), k=min(k, len(indices)))
        return np.atleast_1d(distances), indices[np.atleast_1d(found)]


@torch.no_grad()
def build_goal_library(model: EnvironmentAutoencoder, rows: list[dict]) -> GoalLibrary:
    """Encode the rows' fields and put their features in one cKDTree per label (:func:`goal_keyframes`'s rows)."""
    if not rows:
        raise ValueError("rows: expected at least one goal keyframe")
    latents = encode(model, np.stack([r["field"] for r in rows]))
    conditions = np.stack([np.asarray(r["condition"], dtype=np.float64) for r in rows])
    spread = lambda x: float(np.std(x)) or 1.0  # noqa: E731 (a constant feature divides by 1)
    scales = np.concatenate([np.full(latents.shape[1], spread(latents)), [spread(conditions[:, 0])]])
    kinds = tuple(str(r["kind"]) for r in rows)
    library = GoalLibrary(latents, conditions, kinds,
                          [KeyPose(r["contact_rotations"], r["contact_positions"]) for r in rows],
                          [KeyPose(r["end_rotations"], r["end_positions"]) for r in rows], scales, {})
    labels = [_label(kind, c) for kind, c in zip(kinds, conditions)]
    features = library.features(latents, conditions[:, 0])
    for label in sorted(set(labels)):
        indices = np.flatnonzero([lab == label for lab in labels])
        library.trees[label] = (indices, cKDTree(features[indices]))
    return library


@dataclass(frozen=True, eq=False)
class Match:
    """A matched goal keyframe carried into the scene: ``M(H, o)`` of §6.3.

    Attributes:
        index: the library row. distance: its feature distance (§6.1).
        contact: the key joints at the first contact, world frame, the acting wrist on the goal's contact.
        end: the key joints at the clip's end (item lifted, door or drawer opened), moved with ``contact``.
    """

    index: int
    distance: float
    contact: KeyPose
    end: KeyPose


def match_goal(library: GoalLibrary, model: EnvironmentAutoencoder, goal: HandGoal, hand: str, k: int,
               config: EnvironmentConfig = EnvironmentConfig(), action: str = "grasp") -> list[Match]:
    """``M(H, o)``: the ``k`` nearest goal keyframes of ``goal`` for ``hand``, in the scene (world frame).

    The new goal's ``z`` (:func:`encode` of ``goal.field``) and ``c`` (its height, ``hand``, ``action``, the
    approach) query the library; each match's key joints are put in the goal's frame and shifted so that
    the ``hand`` wrist lies on ``goal.contact``.
    """
    z = encode(model, goal.field(config)[None])[0]
    distances, indices = library.query(z, goal.condition(hand, action), goal.kind, k)
    frame = goal_frame(goal.grid)
    out = []
    for distance, i in zip(distances, indices):
        contact = library.contact[i].transformed(frame)
        shift = goal.contact - contact.hand(hand)
        out.append(Match(int(i), float(distance), contact.translated(shift),
                         library.end[i].transformed(frame).translated(shift)))
    return out
