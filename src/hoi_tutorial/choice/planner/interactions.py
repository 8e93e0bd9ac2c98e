"""The planner's training interactions (CHOICE §4.2 "Training", §7, §8.1): toy-mocap reaches in
cluttered shelves and on tables, each turned into the three fields of Eq. 1 on its object grid.

CHOICE trains its auto-decoder on 5546 captured interactions, "each composed of a pick-and-place motion
and the local environment geometry represented by position/field-feature pairs uniformly sampled in a
resolution of 2.5 cm within a (80 cm)³ cubic region around the target object" (§8.1). Here:

1. A **clip**: ``world.mocap.reach_grasp`` puts a small item (bottle, mug or teapot) on a shelf board or
   a table top, walks a character there, reaches with one hand and picks the item up (its ``support`` is
   drawn by the clip). Up to ``clutter`` further items are put on the same surface, away from the
   demonstrated wrist path (they are obstacles the demonstration happens to avoid, as the bottles of
   CHOICE's Fig. 10(d)).
2. Its **segments** (§4.2's condition label "approaching or leaving"): the approach (from the start of the
   reach to the first contact) and the leave (from the lift's start to the end, the item in hand).
3. Each segment's **fields** on the object-centric grid (``fields.scene_fields``: target = the item,
   obstacles = the support and the other items), the time of arrival counted to the contact (a leave is
   reversed so its contact comes last).
4. Its **condition** ``c ∈ R⁴`` (§4.2): the goal's height (m), the hand (0 left, 1 right), grasp or place
   (0, 1), approach or leave (0, 1).

The toy mocap has no placing clip: with ``place=True`` every pick also enters the data played backwards
as a place — the approach of a place is the pick's leave reversed and vice versa — with the same fields
and the action label set to 1 (ours). The scaling (paper → toy): 5546 interactions → ``n_clips`` clips
(4 interactions each with places).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch

from ..._validate import check_positive_ints
from ...infra import check_scale, load_or_build, scaled_config
from ...world.mocap.body_plan import describe_object
from ...world.mocap.grasping import reach_grasp
from ...world.objects import GRASPABLE, make_object, object_from_description
from ...world.skeleton import joint_index
from . import fields
from .fields import FieldConfig, field_config

__all__ = [
    "CONDITION_NAMES",
    "PlannerDataConfig",
    "PLANNER_DATA_SCALES",
    "planner_data_config",
    "Interaction",
    "InteractionSet",
    "condition_vector",
    "make_clip_scene",
    "clip_interactions",
    "interaction_set",
]

CONDITION_NAMES = ("goal height (m)", "hand (0 left, 1 right)", "action (0 grasp, 1 place)",
                   "segment (0 approach, 1 leave)")
_SPLITS = ("train", "test")


@dataclass(frozen=True)
class PlannerDataConfig:
    """The planner's interactions (defaults: the ``toy`` preset).

    Attributes:
        n_clips: pick-up clips per split (``"train"``; the test split has ``n_test_clips``).
        n_test_clips: clips of the unseen test interactions.
        items: categories of the picked item.
        clutter: at most this many further items on the target's support surface.
        clearance: the clutter keeps this far (m) from the demonstrated wrist path (ours).
        place: add every pick played backwards as a place (ours; the toy mocap has no placing clip).
        field: the grids and field constants (``fields.field_config`` of the same scale).
        seed: seeds the clips and the clutter.
    """

    n_clips: int = 24
    n_test_clips: int = 18
    items: tuple = GRASPABLE
    clutter: int = 2
    clearance: float = 0.06
    place: bool = True
    field: FieldConfig = FieldConfig()
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("n_clips", "n_test_clips"))
        if not isinstance(self.clutter, int) or isinstance(self.clutter, bool) or self.clutter < 0:
            raise ValueError(f"clutter: expected an int >= 0, got {self.clutter!r}")
        for item in self.items:
            if item not in GRASPABLE:
                raise ValueError(f"items: expected categories among {list(GRASPABLE)}, got {item!r}")
        if not isinstance(self.field, FieldConfig):
            raise TypeError(f"field: expected a FieldConfig (fields.field_config), got {type(self.field).__name__}")


# CHOICE §8.1: 5546 interactions (about 1400 pick clips with places) at 2.5 cm.
PLANNER_DATA_SCALES = {"small": {"n_clips": 200, "n_test_clips": 40}, "paper": {"n_clips": 1400, "n_test_clips": 168}}


def planner_data_config(scale: str = "toy", **overrides) -> PlannerDataConfig:
    """The preset for ``scale`` (its ``field`` is ``fields.field_config(scale)``), fields overridable."""
    check_scale(scale, "planner_data_config: scale")
    return scaled_config(PlannerDataConfig, scale, PLANNER_DATA_SCALES, overrides, factory="planner_data_config",
                         fixed={"field": field_config(scale)})


def condition_vector(goal_height: float, hand: str, action: str, segment: str) -> np.ndarray:
    """``c ∈ R⁴`` of §4.2: ``[goal height (m), hand, grasp/place, approach/leave]`` as float32."""
    labels = {"hand": ("left", "right"), "action": ("grasp", "place"), "segment": ("approach", "leave")}
    values = {"hand": hand, "action": action, "segment": segment}
    for name, allowed in labels.items():
        if values[name] not in allowed:
            raise ValueError(f"{name}: expected one of {list(allowed)}, got {values[name]!r}")
    return np.array([float(goal_height)] + [float(labels[n].index(values[n])) for n in ("hand", "action", "segment")],
                    dtype=np.float32)


@dataclass
class Interaction:
    """One interaction: a scene, a demonstrated wrist segment, its fields and its condition.

    Attributes:
        fields: (n, n, n, 3) float32 ``(D_t, D_o, D_toa)`` (Eq. 1) on ``grid``.
        condition: (4,) float32, ``c`` of §4.2 (:func:`condition_vector`).
        grid: the object-centric grid.
        wrist: (T, 3) metres, world frame, the wrist positions ordered so the contact is LAST.
        wrist_rotations: (T, 3, 3) the wrist's global rotations in the same order.
        target: the item (a ``ToyObject`` description dict: category, params, pose).
        obstacles: descriptions of the support and the clutter.
        support: ``"shelf"`` or ``"table"``.
        clip_seed: the seed of the clip.
    """

    fields: np.ndarray
    condition: np.ndarray
    grid: fields.FieldGrid
    wrist: np.ndarray
    wrist_rotations: np.ndarray
    target: dict
    obstacles: list
    support: str
    clip_seed: int

    def target_object(self):
        return object_from_description(self.target)

    def obstacle_objects(self) -> list:
        return [object_from_description(d) for d in self.obstacles]

    @property
    def local_wrist(self) -> np.ndarray:
        """(T, 3) the wrist positions in the grid frame (origin at the grid centre)."""
        return self.grid.to_local(self.wrist)


def _support_row(support, item) -> np.ndarray:
    """The support-surface row ``(z, x0, x1, y0, y1, clearance)`` (support frame) the item stands on."""
    base = support.to_canonical(item.translation[None])[0]
    rows = support.support_surfaces
    return rows[int(np.argmin(np.abs(rows[:, 0] - base[2])))]


def make_clip_scene(clip_seed: int, config: PlannerDataConfig):
    """One pick-up clip and its scene: ``(motion, target, support, clutter list)``.

    The item's category is drawn from ``config.items``; the clutter items stand on the item's support
    surface, not overlapping the item or each other, at least ``config.clearance`` from the wrist
    path of the whole clip.
    """
    rng = np.random.default_rng([config.seed, int(clip_seed)])
    item = make_object(str(rng.choice(config.items)), rng)
    motion = reach_grasp(item, seed=int(clip_seed), pick_up=True)
    target = object_from_description(motion.meta["object"])
    support = object_from_description(motion.meta["support"])
    wrist = np.asarray(motion.joint(f"{motion.meta['hand']}_wrist"), dtype=np.float64)
    z, x0, x1, y0, y1, _ = _support_row(support, target)
    placed = [target]
    clutter = []
    for _ in range(int(rng.integers(0, config.clutter + 1))):
        other = make_object(str(rng.choice(config.items)), rng)
        radius = float(np.max(np.abs(other.canonical_bounds[:, :2])))
        for _ in range(30):
            xy = rng.uniform([x0 + radius, y0 + radius], [x1 - radius, y1 - radius]) if x1 - x0 > 2 * radius and y1 - y0 > 2 * radius else None
            if xy is None:
                break
            local = np.eye(4)
            yaw = rng.uniform(-np.pi, np.pi)
            local[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
            local[:3, 3] = (xy[0], xy[1], z)
            candidate = other.with_pose(support.pose @ local)
            far_from_items = all(np.min(np.asarray(o.sdf(candidate.surface_points(64, seed=0)))) > 0.02 for o in placed)
            if far_from_items and np.min(np.asarray(candidate.sdf(wrist))) > config.clearance:
                placed.append(candidate)
                clutter.append(candidate)
                break
    return motion, target, support, clutter


def _leave_start(motion) -> int:
    """First frame of the leave: the last frame before the item moves with the hand."""
    poses = np.asarray(motion.meta["object_poses"])
    anchor = int(motion.meta["anchor_frame"])
    moved = np.linalg.norm(poses[:, :3, 3] - poses[anchor, :3, 3], axis=1) > 1e-3
    later = np.flatnonzero(moved[anchor:])
    return anchor + int(later[0]) - 1 if len(later) else len(poses) - 1


def clip_interactions(clip_seed: int, config: PlannerDataConfig) -> list[Interaction]:
    """The interactions of one clip: the approach and the leave of the pick, and with
    ``config.place`` the same two played backwards as a place."""
    motion, target, support, clutter = make_clip_scene(clip_seed, config)
    hand = motion.meta["hand"]
    joint = f"{hand}_wrist"
    positions = np.asarray(motion.joint(joint), dtype=np.float64)
    rotations = np.asarray(motion.global_rotations[:, joint_index(joint)], dtype=np.float64)
    start, anchor = int(motion.meta["interaction_start"]), int(motion.meta["anchor_frame"])
    leave = _leave_start(motion)
    segments = {  # wrist frames with the contact last
        "approach": np.arange(max(start - 15, 0), anchor + 1),
        "leave": np.arange(len(positions) - 1, leave - 1, -1),
    }
    grid = fields.object_grid(target, config.field, yaw=float(np.arctan2(support.rotation[1, 0], support.rotation[0, 0])))
    obstacles = [support] + clutter
    out = []
    for segment, frames in segments.items():
        traj = positions[frames]
        scene = fields.scene_fields(grid, target, obstacles, traj, motion.fps, config.field)
        stacked = scene.stacked().astype(np.float32)
        goal_height = float(traj[-1, 2])
        actions = [("grasp", segment)]
        if config.place:  # a pick played backwards: its approach is a place's leave and vice versa
            actions.append(("place", "leave" if segment == "approach" else "approach"))
        for action, seg in actions:
            out.append(Interaction(
                fields=stacked, condition=condition_vector(goal_height, hand, action, seg), grid=grid,
                wrist=traj, wrist_rotations=rotations[frames], target=describe_object(target),
                obstacles=[describe_object(o) for o in obstacles], support=support.category, clip_seed=int(clip_seed)))
    return out


@dataclass
class InteractionSet:
    """The interactions of a split, with their fields stacked for training.

    Attributes:
        interactions: the :class:`Interaction` list.
        fields: (N, n, n, n, 3) float32 tensor, one row per interaction.
        conditions: (N, 4) float32 tensor.
        points: (n, n, n, 3) float32 tensor, the cell centres in the grid frame (the same for all).
        epsilons: (3,) the ``ε`` of ``(D_t, D_o, D_toa)`` (Eqs. 3, 4, 6): each field times its own lies in [0, 1].
    """

    interactions: list
    fields: torch.Tensor
    conditions: torch.Tensor
    points: torch.Tensor
    epsilons: tuple

    def __len__(self) -> int:
        return len(self.interactions)


def _clip_seeds(config: PlannerDataConfig, split: str) -> list[int]:
    count = config.n_clips if split == "train" else config.n_test_clips
    base = 0 if split == "train" else 1_000_000
    return [base + 1000 * config.seed + k for k in range(count)]


def interaction_set(config: PlannerDataConfig, split: str = "train") -> InteractionSet:
    """The interactions of ``split`` (``"train"`` or ``"test"``: other clips, other scenes), built
    once and then loaded from the cache."""
    if split not in _SPLITS:
        raise ValueError(f"split: expected one of {list(_SPLITS)}, got {split!r}")

    def build():
        rows = []
        for seed in _clip_seeds(config, split):
            for inter in clip_interactions(seed, config):
                row = {
                    "fields": inter.fields, "condition": inter.condition, "wrist": inter.wrist,
                    "wrist_rotations": inter.wrist_rotations, "target": inter.target, "obstacles": inter.obstacles,
                    "support": inter.support, "clip_seed": inter.clip_seed,
                    "grid": {"centre": inter.grid.centre, "yaw": inter.grid.yaw, "n": inter.grid.n,
                             "spacing": inter.grid.spacing}}
                rows.append(row)
        return rows

    key = dataclasses.asdict(config)
    key["split"] = split
    rows = load_or_build("choice_interactions", key, build, verbose=False)
    interactions = []
    for row in rows:
        g = row["grid"]
        grid = fields.FieldGrid(np.asarray(g["centre"]), float(g["yaw"]), int(g["n"]), float(g["spacing"]))
        interactions.append(Interaction(
            fields=np.asarray(row["fields"]), condition=np.asarray(row["condition"]), grid=grid,
            wrist=np.asarray(row["wrist"]), wrist_rotations=np.asarray(row["wrist_rotations"]),
            target=row["target"], obstacles=list(row["obstacles"]), support=str(row["support"]),
            clip_seed=int(row["clip_seed"])))
    first = interactions[0].grid
    points = first.to_local(first.points())
    return InteractionSet(
        interactions=interactions,
        fields=torch.as_tensor(np.stack([i.fields for i in interactions])),
        conditions=torch.as_tensor(np.stack([i.condition for i in interactions])),
        points=torch.as_tensor(points, dtype=torch.float32), epsilons=(config.field.epsilon, config.field.epsilon, config.field.time_epsilon))
