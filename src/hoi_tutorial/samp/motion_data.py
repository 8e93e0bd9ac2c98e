"""MotionNet's training data (SAMP §4.1, Eq. 1): toy mocap clips as states, goals and object voxels.

The paper captures ~100 minutes of one subject: idle, walking and running in every direction, and
sitting and lying down on seven objects after walking up to them from a random start
(Table S.1). Here the toy mocap stands in: clips of the five SAMP actions (idle, walk, run, sit,
lie), each turned into per-frame states ``X_i`` (Eq. 1, reduced: ``world.features.samp_pose_state``)
with the goal the clip is heading for:

- **sit / lie**: the object's sitting (lying) goal the clip ends on, action "sit" ("lie"), during the
  approach walk too, which starts anywhere around the object, 2-4.5 m from its centre
  (``approach_start``), and walks round it where it must, as in the paper's captures ("the subject
  starts from an A-Pose in a random location ... walks towards the object, and performs the action");
  it stops near the spot in front of the seat, not on it (``ARRIVAL``), and the sit-down corrects. Clips end seated or lying (no standing up: at run time a goal is held).
  A share of them (``MotionDataConfig.walk_first_share``; none in the presets) walk to the spot
  where the approach walk ends under a *walk* goal first, facing along the approach, and switch to
  the sitting (lying) goal once the root is within ``WALK_SWITCH_RADIUS`` of it. SAMP's run-time
  planner gives exactly that sequence (§3.3: "walk to the next waypoint ... perform the desired
  action at the final waypoint"), and a model that never saw the goal switch from a walk target to a
  seat in mid-stride follows it poorly; with half of the clips walking first, the open-space sits
  of the MotionNet chapter become fewer. The pipeline chapter trains both and compares them in rooms.
  The paper does not say how its goals were labelled along the captures; this is our choice.
- **walk / run**: the next waypoint of the clip's path, facing along the leg that reaches it, action
  "walk" ("run"): the run-time controller walks waypoint to waypoint the same way (§3.3).
- **idle**: where the clip stands, facing its own facing, action "idle".

**Augmentation** (§4.2: "we augment our data by randomly switching or scaling the object"):
``MotionDataConfig.augmented`` copies of every sit and lie training clip move it onto another
object of its category (:func:`augmented_object`: a new instance, its sizes drawn anew within the
category's ranges, so a switch and a scaling at once) by ``augmentation.augment_clip``, which keeps
the contacts by projection and IK and moves the clip's goal with the seat. The copies follow the
captured clips (``MotionData.clip_augmented``); the test split is never augmented.

The root of every frame is ``(x, y, heading)`` of ``world.features.root_frame``. MotionNet predicts
the next state in its own root frame together with the root's displacement ``(dx, dy, dθ)``
expressed in the previous root frame (the Neural State Machine's root update, Starke et al. 2019,
whose representation SAMP's Eq. 1 follows): SAMP's ``t^p`` and ``t^d`` are relative to the root of
frame ``i − 1`` and carry the same displacement inside the state.

The interaction voxels ``I`` (8×8×8 cells, centre relative to the root, occupancy) are not stored
per frame (2048 numbers a frame): each clip keeps its object's cell centres in the world and their
occupancy, and :func:`voxels_in_root_frame` expresses them in any root frame, in a batch, in torch.
Locomotion clips have no object: their voxels are zeros.

Scaling (paper → toy): ~185K frames of captured motion → a few hundred toy clips (the ``toy``
preset: about 24K frames), one body (the mean toy subject), objects from the toy world's chairs,
armchairs, stools and sofas; the test split uses new object instances and new clips.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
import torch

from .._validate import check_choice, check_shape
from ..infra import load_or_build, scaled_config
from ..world import mocap
from ..world.mocap.sitting import lowest_clearance
from ..world.features import SAMP_ACTIONS, SAMP_STATE_SIZE, root_frame, samp_action_ids, samp_pose_state
from ..world.motion import ACTIONS, Motion
from ..world.objects import ToyObject, make_object
from . import augmentation
from .sensor import sensor_voxels

__all__ = [
    "MOTION_KINDS",
    "OBJECT_CATEGORIES",
    "ROOT_SIZE",
    "WALK_SWITCH_RADIUS",
    "MotionDataConfig",
    "MOTION_DATA_SCALES",
    "motion_data_config",
    "clip_goals",
    "clip_states",
    "lie_facing",
    "root_displacement",
    "apply_root_displacement",
    "as_complex",
    "object_voxel_cells",
    "voxels_in_root_frame",
    "MotionData",
    "APPROACH_DISTANCE",
    "APPROACH_PENETRATION",
    "ARRIVAL",
    "approach_start",
    "approach_clearance",
    "make_clip",
    "augmented_object",
    "motion_data",
]

MOTION_KINDS = SAMP_ACTIONS  # ("idle", "walk", "run", "sit", "lie"), SAMP §4.1
# Objects each interaction is captured with (the toy mocap's sittable and lie-able categories).
OBJECT_CATEGORIES = {"sit": ("chair", "armchair", "stool", "sofa"), "lie": ("sofa",)}
ROOT_SIZE = 3  # (dx, dy, dθ)
WALK_SWITCH_RADIUS = 1.5  # metres: a walk-first clip's goal becomes the seat within this of the standing spot
_SPLITS = ("train", "test")


@dataclass(frozen=True)
class MotionDataConfig:
    """Which toy clips MotionNet learns from (defaults: the ``toy`` preset).

    Attributes:
        clips: ``((kind, count), ...)`` training clips per SAMP action. The toy shares follow
            Table S.1's breakdown (walk 41 %, sit 26 %, idle 18 %, lie 10 %, run 5 % of the minutes)
            loosely: sit and lie clips begin with a walk, so walking is also learned from them.
        test_clips: clips per kind in the test split (new clips, new object instances).
        walk_first_share: the share of sit and lie clips that walk to the end of their approach
            under a walk goal first (see the module docstring; ours, SAMP labels no such goals).
        augmented: copies of every sit and lie training clip on another object of its category
            (§4.2's augmentation, :func:`augmented_object`); 0 (the presets) trains on the captured
            clips alone. The baselines chapter trains with one copy beside the preset and compares.
        seed: seeds every clip and object.
    """

    clips: tuple = (("idle", 10), ("walk", 24), ("run", 8), ("sit", 40), ("lie", 16))
    test_clips: int = 6
    walk_first_share: float = 0.0
    augmented: int = 0
    seed: int = 0

    def __post_init__(self):
        for entry in self.clips:
            if not (isinstance(entry, tuple) and len(entry) == 2 and isinstance(entry[1], int) and entry[1] >= 1):
                raise ValueError(f"clips: expected (kind, positive count) pairs, got {entry!r}")
            check_choice(entry[0], MOTION_KINDS, "clips kind")
        if not isinstance(self.test_clips, int) or self.test_clips < 1:
            raise ValueError(f"test_clips: expected a positive int, got {self.test_clips!r}")
        if not 0.0 <= self.walk_first_share <= 1.0:
            raise ValueError(f"walk_first_share: expected a share in [0, 1], got {self.walk_first_share!r}")
        if not isinstance(self.augmented, int) or isinstance(self.augmented, bool) or self.augmented < 0:
            raise ValueError(f"augmented: expected a count >= 0 (copies per sit and lie clip), got {self.augmented!r}")


MOTION_DATA_SCALES = {
    "small": {"clips": (("idle", 30), ("walk", 70), ("run", 24), ("sit", 120), ("lie", 48))},
    "paper": {"clips": (("idle", 90), ("walk", 210), ("run", 60), ("sit", 360), ("lie", 140)), "test_clips": 20},
}


def motion_data_config(scale: str = "toy", **overrides) -> MotionDataConfig:
    """The preset for ``scale``, fields overridable."""
    return scaled_config(MotionDataConfig, scale, MOTION_DATA_SCALES, overrides, factory="motion_data_config")


# ----------------------------------------------------------------------------- goals and roots


def _forward(heading) -> np.ndarray:
    heading = np.asarray(heading, dtype=np.float64)
    return np.stack([-np.sin(heading), np.cos(heading), np.zeros_like(heading)], axis=-1)


def _waypoint_goals(root_xy: np.ndarray, waypoints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame, the next waypoint of the path and the direction of the leg that reaches it.

    The root is projected onto the path's legs, never going back: while it is nearest to leg
    ``k`` (from waypoint ``k`` to ``k + 1``) the goal is waypoint ``k + 1``.
    """
    legs = np.diff(waypoints, axis=0)
    lengths = np.linalg.norm(legs, axis=1)
    units = legs / np.maximum(lengths, 1e-9)[:, None]
    positions = np.zeros((len(root_xy), 3))
    directions = np.zeros((len(root_xy), 3))
    leg = 0
    for i, p in enumerate(root_xy):
        while leg < len(legs) - 1:
            along = float((p - waypoints[leg]) @ units[leg])
            # past the end of this leg and nearer to the next one: move on
            d_this = np.linalg.norm(p - (waypoints[leg] + np.clip(along, 0, lengths[leg]) * units[leg]))
            along_next = float((p - waypoints[leg + 1]) @ units[leg + 1])
            d_next = np.linalg.norm(p - (waypoints[leg + 1] + np.clip(along_next, 0, lengths[leg + 1]) * units[leg + 1]))
            if along >= lengths[leg] - 1e-6 or d_next < d_this:
                leg += 1
            else:
                break
        positions[i, :2] = waypoints[leg + 1]
        directions[i, :2] = units[leg]
    return positions, directions


def clip_goals(motion: Motion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The goal a toy clip heads for, per frame (see the module docstring).

    Args:
        motion: a clip from :func:`make_clip` (its ``meta["kind"]`` one of ``MOTION_KINDS``).
    Returns:
        ``(positions (T, 3) m, directions (T, 3) unit, actions (T,) int64)``, the actions indices
        into ``SAMP_ACTIONS``. A lying goal's direction is the facing of a body lying on its back
        along it, ``−direction`` of the object's lie goal (the root frame's forward then points to
        the feet; measured on toy clips: within 3° of it). A ``walk_first`` sit or lie clip has a
        walk goal at the end of its approach walk until the root is within ``WALK_SWITCH_RADIUS``.
    """
    kind = motion.meta.get("kind")
    check_choice(kind, MOTION_KINDS, "motion.meta['kind']")
    T = len(motion)
    origin, heading = root_frame(motion.joints)
    origin, heading = origin.double().numpy(), heading.double().numpy()
    actions = np.full(T, SAMP_ACTIONS.index(kind), dtype=np.int64)
    if kind == "idle":
        return np.repeat(origin[:1], T, 0), np.repeat(_forward(heading[:1]), T, 0), actions
    if kind in ("walk", "run"):
        positions, directions = _waypoint_goals(origin[:, :2], np.asarray(motion.meta["waypoints"], dtype=np.float64))
        return positions, directions, actions
    goal = motion.meta["sit_goal" if kind == "sit" else "lie_goal"]
    direction = np.asarray(goal["direction"], dtype=np.float64)
    direction = direction if kind == "sit" else lie_facing(direction)
    positions = np.repeat(np.asarray(goal["position"], dtype=np.float64)[None], T, 0)
    directions = np.repeat(direction[None], T, 0)
    walking = np.flatnonzero(np.asarray(motion.actions) == ACTIONS.index("walk"))  # the approach walk, before the turn
    if motion.meta.get("walk_first") and len(walking):
        spot = origin[walking[-1], :2]  # where the approach walk ends
        leg = spot - origin[0, :2]
        if np.linalg.norm(leg) > 1e-6:
            # the walk goal holds until the root first comes within the radius of the spot
            far = np.logical_and.accumulate(np.linalg.norm(origin[:, :2] - spot, axis=1) >= WALK_SWITCH_RADIUS)
            positions[far] = np.r_[spot, 0.0]
            directions[far] = np.r_[leg / np.linalg.norm(leg), 0.0]
            actions[far] = SAMP_ACTIONS.index("walk")
    return positions, directions, actions


def lie_facing(direction) -> np.ndarray:
    """The root frame's forward of a body lying on its back along a lie goal's ``direction (3,)``:
    ``−direction`` (measured on toy lie clips at the settle frame: within 3°)."""
    return -np.asarray(direction, dtype=np.float64)


def root_displacement(roots: torch.Tensor) -> torch.Tensor:
    """The root update of each frame in the previous root frame.

    Args:
        roots: ``(..., T, 3)`` ``(x, y, heading)`` per frame (metres, radians).
    Returns:
        ``(..., T − 1, 3)``: ``(dx, dy)`` of root ``i`` seen from root ``i − 1``, and
        ``dθ = heading_i − heading_{i−1}`` wrapped to (−π, π].
    """
    prev, cur = roots[..., :-1, :], roots[..., 1:, :]
    d = cur[..., :2] - prev[..., :2]
    c, s = torch.cos(prev[..., 2]), torch.sin(prev[..., 2])
    # rotate by −heading: [c s; −s c] (d)
    local = torch.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], dim=-1)
    dtheta = torch.remainder(cur[..., 2] - prev[..., 2] + math.pi, 2 * math.pi) - math.pi
    return torch.cat([local, dtheta[..., None]], dim=-1)


def apply_root_displacement(root: torch.Tensor, displacement: torch.Tensor) -> torch.Tensor:
    """Inverse of :func:`root_displacement` for one step: ``(..., 3)`` root, ``(..., 3)`` update -> new root.

    The ground-plane step is turned into the world by the root's heading ``h``: with ``x + iy``
    complex, ``xy' = xy + (dx + i dy) e^{ih}``.
    """
    turn = torch.polar(torch.ones_like(root[..., 2]), root[..., 2])  # e^{ih}
    xy = as_complex(root[..., :2]) + as_complex(displacement[..., :2]) * turn
    heading = torch.remainder(root[..., 2:] + displacement[..., 2:] + math.pi, 2 * math.pi) - math.pi
    return torch.cat([torch.view_as_real(xy), heading], dim=-1)


def as_complex(xy: torch.Tensor) -> torch.Tensor:
    """``(..., 2)`` ground vectors as ``(...)`` complex numbers ``x + iy`` (a view where the memory allows)."""
    strides = xy.stride()
    if strides[-1] != 1 or xy.storage_offset() % 2 or any(s % 2 for s in strides[:-1]):
        xy = xy.clone(memory_format=torch.contiguous_format)  # a complex view needs even offsets
    return torch.view_as_complex(xy)


# ----------------------------------------------------------------------------- voxels


def object_voxel_cells(obj: ToyObject, resolution: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """The object's voxel cells in the world: ``(centres (r³, 3) m, occupancy (r³,))``, float32.

    Cells in the order of :meth:`ToyObject.interaction_voxels` flattened, so that
    :func:`voxels_in_root_frame` reproduces it.
    """
    cells = obj.interaction_voxels(np.eye(4), resolution).reshape(-1, 4)
    return cells[:, :3].astype(np.float32), cells[:, 3].astype(np.float32)


def voxels_in_root_frame(centres: torch.Tensor, occupancy: torch.Tensor, roots: torch.Tensor) -> torch.Tensor:
    """SAMP's interaction representation ``I`` in the character's root frame, batched.

    Args:
        centres: ``(B, C, 3)`` world cell centres (or ``(C, 3)``, shared).
        occupancy: ``(B, C)`` (or ``(C,)``).
        roots: ``(B, 3)`` ``(x, y, heading)``.
    Returns:
        ``(B, 4 C)``: per cell ``R(−heading)(centre − (x, y, 0))`` and the occupancy, flattened like
        ``interaction_voxels(...).reshape(-1)`` (2048 numbers for 8×8×8 cells).
    """
    check_shape(roots, (None, 3), "roots")
    B = roots.shape[0]
    if centres.dim() == 2:
        centres, occupancy = centres.expand(B, -1, -1), occupancy.expand(B, -1)
    check_shape(centres, (B, None, 3), "centres")
    check_shape(occupancy, tuple(centres.shape[:2]), "occupancy")
    turn = torch.polar(torch.ones_like(roots[:, 2:]), -roots[:, 2:])  # e^{−ih}, (B, 1)
    local = torch.view_as_real((as_complex(centres[..., :2]) - as_complex(roots[:, None, :2])) * turn)
    return torch.cat([local, centres[..., 2:], occupancy[..., None]], dim=-1).reshape(B, -1)


# ----------------------------------------------------------------------------- clips and the data set


APPROACH_DISTANCE = (2.0, 4.5)  # metres from the object's centre to where a sit or lie clip starts
# Ours: where the approach stops, up to 0.25 m to either side of the standing spot and 20° off the seat's
# facing, the sit-down (lie-down) taking the pelvis from there onto the goal, as a subject's does; a
# toy capture otherwise always stops exactly on the spot, and MotionNet never sees a sit begun off it.
ARRIVAL = (0.25, math.radians(20.0))
APPROACH_PENETRATION = 0.015  # metres: the deepest an approach walk may brush the object (as sitting.py allows)
_APPROACH_TRIES = 8


def approach_start(obj: ToyObject, rng: np.random.Generator) -> np.ndarray:
    """Where a sit or lie clip's approach walk starts: ``(2,)`` metres, in any direction from the
    object's centre (uniform over the circle) and ``APPROACH_DISTANCE`` from it."""
    angle = rng.uniform(-math.pi, math.pi)
    return obj.pose[:2, 3] + rng.uniform(*APPROACH_DISTANCE) * np.array([math.cos(angle), math.sin(angle)])


def approach_clearance(motion: Motion, obj: ToyObject, stride: int = 2) -> float:
    """The smallest signed distance (metres) from ``obj`` to the body over the frames before the
    clip's first sit-down or lie-down (every ``stride``-th frame); negative: the body is inside."""
    names = [ACTIONS[a] for a in motion.actions]
    first = next((k for k, a in enumerate(names) if a in ("sit_down", "sit", "lie_down", "lie")), len(names))
    return lowest_clearance(motion, obj, list(range(0, first, stride)))


def make_clip(kind: str, seed: int, obj: Optional[ToyObject] = None, walk_first_share: float = 0.0):
    """One toy clip of a SAMP action: walks and runs start facing a random direction; sit and lie
    clips end seated or lying (no standing up).

    Args:
        kind: one of ``MOTION_KINDS``.
        seed: int.
        obj: the object for "sit" / "lie" (default: one of ``OBJECT_CATEGORIES[kind]`` from ``seed``).
        walk_first_share: the chance that a sit or lie clip is ``walk_first`` (``meta["walk_first"]``).
    Returns:
        ``(motion, obj)`` with ``obj`` None for locomotion.
    """
    check_choice(kind, MOTION_KINDS, "kind")
    if kind == "idle":
        return mocap.generate_clip(kind, seed=seed), None
    if kind in ("walk", "run"):
        # "walks and runs in different directions" (§4.1), from a standstill facing anywhere: the
        # clip first turns on the spot towards its path (a start facing more than 25° away).
        rng = np.random.default_rng([int(seed), 7])
        waypoints = (mocap.random_path(rng, int(rng.integers(3, 5)), min_length=5.0) if kind == "run"
                     else mocap.random_path(rng))
        start = mocap.standing_pose(position=waypoints[0], heading=float(rng.uniform(-math.pi, math.pi)))
        motion = mocap.walk_path(waypoints, seed=rng, gait=kind, start=start)
        motion.meta = {**motion.meta, "kind": kind, "seed": int(seed)}
        return motion, None
    rng = np.random.default_rng([int(seed), 7])
    if obj is None:
        categories = OBJECT_CATEGORIES[kind]
        obj = make_object(categories[int(rng.integers(len(categories)))], seed=int(rng.integers(2**31)))
    # "The subject starts from an A-Pose in a random location in the MoCap space, walks towards the
    # object" (§4.1): a start anywhere around the object, APPROACH_DISTANCE from its centre. A start
    # whose walk would pass through the object (a subject walks round it) is drawn again.
    for _ in range(_APPROACH_TRIES):
        start = approach_start(obj, rng)
        motion = mocap.generate_clip(kind, seed=int(rng.integers(2**31)), obj=obj, stand_up=False,
                                     start_position=start, arrival=ARRIVAL)
        if approach_clearance(motion, obj) >= -APPROACH_PENETRATION:
            break
    else:
        raise RuntimeError(f"make_clip: no approach to the {obj.category} (seed {seed}) in {_APPROACH_TRIES} starts "
                           f"keeps out of it by {APPROACH_PENETRATION} m")
    motion.meta["walk_first"] = bool(rng.uniform() < walk_first_share)
    return motion, obj


def augmented_object(obj: ToyObject, seed: int, copy: int) -> ToyObject:
    """The object the ``copy``-th augmented copy of a clip made from ``seed`` on ``obj`` moves to:
    another instance of ``obj``'s category, at ``obj``'s pose (§4.2: "randomly switching or scaling
    the object"; the instance's sizes are drawn within ``world.objects.CATEGORY_SIZES``, Supp. F's
    "random object of a similar size")."""
    if not isinstance(copy, int) or copy < 0:
        raise ValueError(f"copy: expected an int >= 0, got {copy!r}")
    draw = int(np.random.default_rng([int(seed), 11, copy]).integers(2**31))
    return make_object(obj.category, seed=draw).with_pose(obj.pose)


def clip_states(motion: Motion) -> tuple[torch.Tensor, torch.Tensor]:
    """A clip from :func:`make_clip` as SAMP states with its goals (:func:`clip_goals`).

    Returns:
        ``(states (T, 437), roots (T, 3))``, float32; roots are ``(x, y, heading)``.
    """
    positions, directions, goal_actions = clip_goals(motion)
    goal_actions = [SAMP_ACTIONS[a] for a in goal_actions]
    _, flat = samp_pose_state(motion, positions, directions, goal_action=goal_actions)
    origin, heading = root_frame(motion.joints)
    return flat.float(), torch.cat([origin[:, :2], heading[:, None]], dim=-1).float()


@dataclass
class MotionData:
    """Frames of toy clips as SAMP states, with their roots, goals and objects.

    Attributes (``N`` frames over ``n_clips`` clips, concatenated clip after clip):
        states: ``(N, 437)`` ``X_i`` (``world.features.SAMP_STATE_LAYOUT``).
        roots: ``(N, 3)`` ``(x, y, heading)`` of each frame's root.
        goal_positions, goal_directions: ``(N, 3)`` the goal of each frame (world, m / unit).
        actions: ``(N,)`` int64 SAMP action of each frame (``SAMP_ACTIONS``).
        goal_actions: ``(N,)`` int64 the action of each frame's goal (``SAMP_ACTIONS``).
        clip_start: ``(n_clips + 1,)`` int64 first frame of each clip (and ``N``).
        clip_kind: ``(n_clips,)`` int64 kind of each clip (index into ``MOTION_KINDS``).
        clip_object: ``(n_clips,)`` int64 row of ``voxel_centres`` / ``voxel_occupancy``, −1 for none.
        voxel_centres: ``(n_objects, 512, 3)`` world cell centres; ``voxel_occupancy (n_objects, 512)``.
        clip_seeds: the seed each clip was made from: ``make_clip(MOTION_KINDS[kind], seed)`` remakes
            its ``Motion`` and object (an augmented copy's: the captured clip it was made from).
        clip_augmented: ``(n_clips,)`` int64 −1 for a captured clip, else which copy
            (:func:`augmented_object`); the copies follow every captured clip.
    """

    states: torch.Tensor
    roots: torch.Tensor
    goal_positions: torch.Tensor
    goal_directions: torch.Tensor
    actions: torch.Tensor
    goal_actions: torch.Tensor
    clip_start: torch.Tensor
    clip_kind: torch.Tensor
    clip_object: torch.Tensor
    voxel_centres: torch.Tensor
    voxel_occupancy: torch.Tensor
    clip_seeds: list
    clip_augmented: torch.Tensor

    def __len__(self) -> int:
        return int(self.states.shape[0])

    @property
    def n_clips(self) -> int:
        return int(self.clip_kind.shape[0])

    def clip_slice(self, clip: int) -> slice:
        return slice(int(self.clip_start[clip]), int(self.clip_start[clip + 1]))

    def frame_clip(self) -> torch.Tensor:
        """``(N,)`` the clip of each frame."""
        if getattr(self, "_frame_clip", None) is None:
            lengths = self.clip_start[1:] - self.clip_start[:-1]
            self._frame_clip = torch.repeat_interleave(torch.arange(self.n_clips), lengths)
        return self._frame_clip

    def kind_frames(self, kind: str) -> torch.Tensor:
        """``(n,)`` indices of every frame of the clips of ``kind`` (one of ``MOTION_KINDS``)."""
        check_choice(kind, MOTION_KINDS, "kind")
        return torch.nonzero(self.clip_kind[self.frame_clip()] == MOTION_KINDS.index(kind))[:, 0]

    def voxels(self, frames: torch.Tensor, roots: Optional[torch.Tensor] = None, sensor: bool = False) -> torch.Tensor:
        """``(B, 2048)`` interaction voxels of ``frames`` (indices) seen from ``roots`` (default theirs), or
        with ``sensor`` what the NSM-like model's environment sensor reads there (``sensor.sensor_voxels``)."""
        roots = self.roots[frames] if roots is None else roots
        objects = self.clip_object[self.frame_clip()[frames]]
        safe = objects.clamp_min(0)
        present = (objects >= 0).to(roots.dtype)[:, None]
        if sensor:  # the sensor grid is always there; it senses nothing in a clip without an object
            return sensor_voxels(self.voxel_centres[safe], self.voxel_occupancy[safe] * present, roots)
        out = voxels_in_root_frame(self.voxel_centres[safe], self.voxel_occupancy[safe], roots)
        return out * present

    def windows(self, length: int, stride: Optional[int] = None) -> torch.Tensor:
        """``(W,)`` first frames of every window of ``length + 1`` frames inside one clip (stride
        ``length // 2`` by default): inputs ``s .. s + length − 1``, targets ``s + 1 .. s + length``."""
        if not isinstance(length, int) or length < 1:
            raise ValueError(f"length: expected a positive int (frames), got {length!r}")
        stride = max(1, length // 2) if stride is None else int(stride)
        starts = []
        for clip in range(self.n_clips):
            a, b = int(self.clip_start[clip]), int(self.clip_start[clip + 1])
            starts.extend(range(a, b - length, stride))
        if not starts:
            raise ValueError(f"length: every clip is shorter than {length + 1} frames")
        return torch.as_tensor(starts, dtype=torch.int64)


def _clip_list(config: MotionDataConfig, split: str) -> list[tuple[str, int]]:
    salt = _SPLITS.index(split)
    out = []
    for kind, count in config.clips:
        count = count if split == "train" else config.test_clips
        k = MOTION_KINDS.index(kind)
        for i in range(count):
            out.append((kind, int(np.random.default_rng([config.seed, salt, k, i]).integers(2**31))))
    return out


def motion_data(config: MotionDataConfig, split: str = "train") -> MotionData:
    """The clips of ``split`` as :class:`MotionData`, built once and then loaded from the cache."""
    check_choice(split, _SPLITS, "split")

    def build():
        states, roots, goal_p, goal_d, goal_a, actions, starts, kinds, objects = [], [], [], [], [], [], [0], [], []
        centres, occupancy, seeds, augmented, copies = [], [], [], [], []

        def add(kind, seed, motion, obj, copy):
            positions, directions, goal_actions = clip_goals(motion)
            flat, root = clip_states(motion)
            states.append(flat)
            roots.append(root)
            goal_p.append(torch.as_tensor(positions, dtype=torch.float32))
            goal_d.append(torch.as_tensor(directions, dtype=torch.float32))
            goal_a.append(torch.as_tensor(goal_actions))
            actions.append(torch.as_tensor(samp_action_ids(motion.actions)))
            starts.append(starts[-1] + len(motion))
            kinds.append(MOTION_KINDS.index(kind))
            seeds.append(seed)
            augmented.append(copy)
            if obj is None:
                objects.append(-1)
            else:
                c, o = object_voxel_cells(obj)
                objects.append(len(centres))
                centres.append(torch.as_tensor(c))
                occupancy.append(torch.as_tensor(o))

        n_copies = config.augmented if split == "train" else 0
        for kind, seed in _clip_list(config, split):
            motion, obj = make_clip(kind, seed, walk_first_share=config.walk_first_share)
            add(kind, seed, motion, obj, -1)
            if obj is not None:
                copies.extend((kind, seed, motion, obj, k) for k in range(n_copies))
        for kind, seed, motion, obj, k in copies:  # §4.2: the same interaction on another object
            new = augmented_object(obj, seed, k)
            add(kind, seed, augmentation.augment_clip(motion, obj, new), new, k)
        if not centres:
            centres, occupancy = [torch.zeros(512, 3)], [torch.zeros(512)]
        return {"states": torch.cat(states), "roots": torch.cat(roots), "goal_positions": torch.cat(goal_p),
                "goal_directions": torch.cat(goal_d), "actions": torch.cat(actions), "goal_actions": torch.cat(goal_a),
                "clip_start": torch.as_tensor(starts, dtype=torch.int64),
                "clip_kind": torch.as_tensor(kinds, dtype=torch.int64),
                "clip_object": torch.as_tensor(objects, dtype=torch.int64),
                "voxel_centres": torch.stack(centres), "voxel_occupancy": torch.stack(occupancy),
                "clip_seeds": seeds, "clip_augmented": torch.as_tensor(augmented, dtype=torch.int64)}

    # the clips come from the toy world (mocap, objects, features) and the augmentation: their source is part of the key
    artifact = load_or_build(f"samp_motion_data_{split}", dataclasses.asdict(config), build, verbose=False)
    data = MotionData(**artifact)
    if data.states.shape[1] != SAMP_STATE_SIZE:
        raise ValueError(f"cached motion data: expected states of {SAMP_STATE_SIZE}, got {data.states.shape[1]}")
    return data
