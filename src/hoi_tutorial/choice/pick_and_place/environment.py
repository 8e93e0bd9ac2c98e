"""Environment features of a hand goal (CHOICE §6.1).

CHOICE matches every hand goal — an item to grasp, a spot to place it, the handle of a door or a drawer —
to the goal keyframes of its capture, which give the scheduler (§6.3), the trajectory planner and the
controller a motion prior. The algorithm box, as this module runs it:

1. **The environment around a goal** (:func:`environment_field`): "a distance field of the environment
   pivoted at the object center obtained by fast marching" — on the object-centric grid of
   ``planner.fields.object_grid`` (a cube around the goal, yawed like the furniture) the distance of every cell to
   the nearest surface of the environment, by fast marching from those surfaces (``planner.fields.obstacle_distance``).
2. **The autoencoder** (:class:`EnvironmentAutoencoder`): "3 layers of convolution + max-pooling followed by
   3 layers of deconvolution + upscaling"; the flattened code ``z ∈ R¹⁶`` is the environment feature.
   Trained with the mean squared error on the goals of toy kitchens (:func:`training_grids`).
3. **The goal library and matching** are in ``goal_library``.

Choices the paper does not state, ours:

- **The grid** is the planner's (``planner.fields.object_grid``; CHOICE §8.1: 2.5 cm cells in an (80 cm)³ cube);
  for a handle it is centred on the handle. The cells per side must divide by 8 (three poolings).
- **The environment** of a goal is everything but the goal's own item — the furniture, the other items, the
  room's walls and floor; for a door or drawer the furniture itself with its handle. Without the item the
  feature is the same for grasping it and for placing it there (``c`` tells them apart). Distances are
  truncated at ``truncation`` (half the cube) and divided by it: the input lies in [0, 1].
- **The code**: a linear layer on the flattened last pooling gives ``z`` (a 16-number bottleneck would need
  a 16-cell pooling), a linear layer maps it back; each decoder layer upscales (nearest, ×2) and then
  convolves (a stride-1 transposed convolution), so the last layer works at full resolution; ReLU between
  layers, a linear output.
- **Exact labels.** ``c``'s labels (hand, grasp/place, approach/leave) and the goal's kind (item, door,
  drawer: Table 2's key-joint actions) are keys: one KD tree per label combination over the continuous part
  ``[z / s_z, h / s_h]`` (``h`` the goal height of ``c``; ``s_z``, ``s_h`` the library's standard deviations).
  One tree over ``{z; c}`` with the labels weighted above the rest's spread finds the same neighbours; the
  split keeps that true for any query.
- **Keyframes into the scene**: a match's key joints are put in the new goal's frame and shifted so that
  the acting wrist is on the new contact (§6.3: keyframes "adjusted to the runtime scene by IK").
- **The library** is made of clips without the approach walk (their first contact is the keyframe); a pick
  also enters as a place, the same pose with the action label set (as ``planner.interactions``); hands alternate. A
  clip's scene has no room: its environment is the support (or the furniture) and the floor.

Scaling (paper → toy): 2.5 cm cells → 5 cm (16³); CHOICE's capture (150 sequences of about 3 minutes) →
``n_kitchens`` procedural kitchens for the autoencoder and ``n_clips`` clips of each kind for the library.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from ..._validate import check_choice, check_finite, check_numbers, check_positive_ints, check_shape
from ...infra import (TrainedModel, check_scale, load_or_build, scaled_config, single_threaded, state_dict_to_cpu,
                     train, trainer_config)
from ...world.kinematics import forward_kinematics
from ...world.mocap.poses import standing_pose
from ...world.scenes import WALL_HEIGHT, Kitchen, make_kitchen
from ...world.skeleton import bone_offsets, joint_index
from ..planner import fields
from ..planner.fields import FieldConfig, FieldGrid, field_config
from ..planner.interactions import condition_vector

__all__ = [
    "KEYFRAME_JOINTS",
    "HANDS",
    "GOAL_KINDS",
    "HANDLED_CATEGORY",
    "EnvironmentConfig",
    "ENVIRONMENT_SCALES",
    "environment_config",
    "KeyPose",
    "goal_frame",
    "floor_sdf",
    "room_sdf",
    "environment_field",
    "HandGoal",
    "check_in_scene",
    "object_yaw",
    "front_grasp_point",
    "object_goal",
    "item_goal",
    "handle_goal",
    "kitchen_goals",
    "training_grids",
    "EnvironmentAutoencoder",
    "build_environment_autoencoder",
    "train_environment_autoencoder",
    "trained_environment_autoencoder",
    "encode",
    "reconstruction_errors",
]

KEYFRAME_JOINTS = ("left_wrist", "right_wrist", "pelvis")  # CHOICE's three key joints: both hands and the hip
HANDS = ("left", "right")  # a hand's index into KEYFRAME_JOINTS
GOAL_KINDS = ("item", "door", "drawer")
HANDLED_CATEGORY = {"door": "cabinet", "drawer": "drawer"}  # goal kind -> furniture category


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class EnvironmentConfig:
    """The environment feature: its grid, autoencoder and training data (defaults: the ``toy`` preset).

    Attributes:
        field: the grid (``fields.field_config`` of the same scale): ``extent`` and ``spacing``.
        truncation: distances above this (m) count as this; the input is ``min(d, truncation) / truncation``.
        n_kitchens: procedural kitchens whose goals (every item, the door's and the drawer's handles) train
            the autoencoder.
        channels: the three encoder convolutions' channels; the decoder mirrors them (ours).
        latent: size of ``z`` (CHOICE: 16).
        steps, batch_size, lr, lr_schedule, optimizer: training (ours).
        seed: seeds the kitchens, the weights and the batches.
    """

    field: FieldConfig = FieldConfig()
    truncation: float = 0.4
    n_kitchens: int = 24
    channels: tuple = (8, 16, 32)
    latent: int = 16
    steps: int = 600
    batch_size: int = 16
    lr: float = 2e-3
    lr_schedule: str = "cosine"
    optimizer: str = "adam"
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("n_kitchens", "latent", "steps", "batch_size"))
        if not isinstance(self.field, FieldConfig):
            raise TypeError(f"field: expected a FieldConfig (fields.field_config), got {type(self.field).__name__}")
        if self.cells % 8:
            raise ValueError(f"field: expected extent / spacing divisible by 8 (three poolings), got {self.cells} cells")
        if len(self.channels) != 3 or not all(isinstance(c, int) and c > 0 for c in self.channels):
            raise ValueError(f"channels: expected three positive ints (CHOICE's three layers), got {self.channels!r}")
        check_numbers(self, ("truncation", "lr"), above=0)

    @property
    def cells(self) -> int:
        """Cells per side of the grid."""
        return int(round(self.field.extent / self.field.spacing))


# The larger scales: more kitchens, wider layers, longer training (CHOICE states none of these); the paper's
# grid spacing (2.5 cm, 32³) comes with field_config.
ENVIRONMENT_SCALES = {
    "small": {"n_kitchens": 100, "channels": (16, 32, 64), "steps": 3000},
    "paper": {"n_kitchens": 400, "channels": (32, 64, 128), "steps": 20000, "batch_size": 32},
}


def environment_config(scale: str = "toy", **overrides) -> EnvironmentConfig:
    """The preset for ``scale`` (its ``field`` is ``fields.field_config(scale)``), fields overridable."""
    check_scale(scale, "environment_config: scale")
    return scaled_config(EnvironmentConfig, scale, ENVIRONMENT_SCALES, overrides, factory="environment_config",
                         fixed={"field": field_config(scale)})


# ----------------------------------------------------------------------------- key joints


@dataclass(frozen=True, eq=False)
class KeyPose:
    """The 6D configurations of the three key joints (§6.3's ``p^key`` and ``M_k``), in some frame.

    Attributes:
        rotations: (3, 3, 3) the global rotations of ``KEYFRAME_JOINTS`` (left wrist, right wrist, pelvis).
        positions: (3, 3) their positions, metres.
    """

    rotations: np.ndarray
    positions: np.ndarray

    def __post_init__(self):
        rotations = np.array(self.rotations, dtype=np.float64)
        positions = np.array(self.positions, dtype=np.float64)
        check_shape(rotations, (len(KEYFRAME_JOINTS), 3, 3), "rotations")
        check_shape(positions, (len(KEYFRAME_JOINTS), 3), "positions")
        check_finite(rotations, "rotations")
        check_finite(positions, "positions")
        object.__setattr__(self, "rotations", rotations)
        object.__setattr__(self, "positions", positions)

    @classmethod
    def from_motion(cls, motion, frame: int) -> "KeyPose":
        """The key joints of ``motion`` (a ``world.motion.Motion``) at ``frame``, world frame."""
        idx = [joint_index(j) for j in KEYFRAME_JOINTS]
        return cls(_orthonormal(motion.global_rotations[frame, idx].double().numpy()),
                   motion.joints[frame, idx].double().numpy())

    @classmethod
    def standing(cls, position, heading: float, betas=None) -> "KeyPose":
        """The relaxed standing pose (``world.mocap.poses.standing_pose``, arms hanging) with the pelvis over
        ``position`` (2,) metres, facing ``heading`` (radians, 0 faces +Y)."""
        local, root = standing_pose(betas, position=tuple(np.asarray(position, dtype=float)[:2]), heading=heading)
        rotations, positions = forward_kinematics(local, root, bone_offsets(betas))
        idx = [joint_index(j) for j in KEYFRAME_JOINTS]
        return cls(_orthonormal(rotations[idx].double().numpy()), positions[idx].double().numpy())

    def hand(self, hand: str) -> np.ndarray:
        """(3,) the wrist position of ``hand`` ("left" or "right")."""
        check_choice(hand, HANDS, "hand")
        return self.positions[HANDS.index(hand)]

    @property
    def pelvis(self) -> np.ndarray:
        """(3,) the pelvis position."""
        return self.positions[KEYFRAME_JOINTS.index("pelvis")]

    def transformed(self, transform) -> "KeyPose":
        """``transform`` (4, 4) applied to every joint (e.g. ``world_from_goal`` to a goal-frame pose)."""
        transform = np.asarray(transform, dtype=np.float64)
        check_shape(transform, (4, 4), "transform")
        R, t = transform[:3, :3], transform[:3, 3]
        return KeyPose(R @ self.rotations, self.positions @ R.T + t)

    def translated(self, offset) -> "KeyPose":
        """Every joint moved by ``offset`` (3,) metres."""
        return KeyPose(self.rotations, self.positions + np.asarray(offset, dtype=np.float64))

    def with_joint(self, k: int, other: "KeyPose") -> "KeyPose":
        """This pose with key joint ``k`` taken from ``other``."""
        rotations, positions = self.rotations.copy(), self.positions.copy()
        rotations[k], positions[k] = other.rotations[k], other.positions[k]
        return KeyPose(rotations, positions)


def _orthonormal(rotations: np.ndarray) -> np.ndarray:
    """The nearest rotations (..., 3, 3) to float32 forward kinematics' (``U Vᵀ`` of the SVD)."""
    u, _, vt = np.linalg.svd(rotations)
    return u @ vt


def goal_frame(grid: FieldGrid) -> np.ndarray:
    """(4, 4) ``world_from_goal``: the grid's axes and centre (the frame the library's key joints live in)."""
    frame = np.eye(4)
    frame[:3, :3], frame[:3, 3] = grid.rotation, grid.centre
    return frame


# ----------------------------------------------------------------------------- the environment field


def floor_sdf(points) -> np.ndarray:
    """Signed distance (...) metres to the floor ``z = 0`` (negative below it)."""
    return np.asarray(points, dtype=np.float64)[..., 2]


def room_sdf(size, floor: bool = True):
    """The signed distance to a room's walls and floor seen from inside, a callable ``points (..., 3) -> (...)``:
    ``min(x, X − x, y, Y − y, z)`` for the floor ``[0, X] × [0, Y]`` (negative outside the room); the walls
    alone (no ``z``) when ``floor`` is False."""
    size = np.asarray(size, dtype=np.float64).reshape(2)

    def sdf(points):
        p = np.asarray(points, dtype=np.float64)
        sides = [p[..., 0], size[0] - p[..., 0], p[..., 1], size[1] - p[..., 1]]
        return np.minimum.reduce(sides + [p[..., 2]] if floor else sides)

    return sdf


def environment_field(grid: FieldGrid, environment, config: EnvironmentConfig = EnvironmentConfig()) -> np.ndarray:
    """§6.1's input: the fast-marching distance to the environment, truncated and scaled to [0, 1].

    Args:
        grid: the object-centric grid around the goal.
        environment: objects with ``.sdf`` and SDF callables (``fields.sdf_union``'s ``things``).
    Returns:
        (n, n, n) float32 ``min(d, truncation) / truncation``: 0 inside the environment, 1 where nothing is
        within ``truncation`` (or within the grid).
    """
    sdf = fields.sdf_union(list(environment))(grid.points().reshape(-1, 3)).reshape(grid.shape)
    nothing = np.full(grid.shape, np.inf)  # no target: the goal's own object is left out, nothing is a wall
    d = fields.obstacle_distance(grid, nothing, sdf, config.field.order)
    return (np.minimum(d, config.truncation) / config.truncation).astype(np.float32)


@dataclass(frozen=True, eq=False)
class HandGoal:
    """A hand goal in a scene and what surrounds it: what §6.1 matches.

    Attributes:
        kind: ``"item"``, ``"door"`` or ``"drawer"`` (``GOAL_KINDS``).
        name: the object's name in keyframes and messages (``"bottle 2"``, ``"cabinet door"``).
        contact: (3,) metres, world frame: where the wrist goes (a grasp point, a handle).
        grid: the object-centric grid (centred on the item's box or on the handle, yawed like the furniture).
        environment: objects and SDF callables around it (everything but the item itself).
        obj: the item, or the cabinet / drawer unit.
    """

    kind: str
    name: str
    contact: np.ndarray
    grid: FieldGrid
    environment: tuple
    obj: object

    def __post_init__(self):
        check_choice(self.kind, GOAL_KINDS, "kind")
        contact = np.asarray(self.contact, dtype=np.float64)
        check_shape(contact, (3,), "contact")
        check_finite(contact, "contact")
        object.__setattr__(self, "contact", contact)
        object.__setattr__(self, "environment", tuple(self.environment))

    def field(self, config: EnvironmentConfig = EnvironmentConfig()) -> np.ndarray:
        """(n, n, n) float32 :func:`environment_field` around the goal."""
        return environment_field(self.grid, self.environment, config)

    def condition(self, hand: str, action: str = "grasp") -> np.ndarray:
        """(4,) ``c`` of §4.2 for this goal: its height, the hand, the action, the approach."""
        return condition_vector(float(self.contact[2]), hand, action, "approach")


def check_in_scene(kitchen: Kitchen, point, name: str) -> np.ndarray:
    """``point`` (3,) as float64 when it lies in the kitchen (floor rectangle, below the walls' top), else
    ``ValueError`` naming ``name`` and the room's bounds."""
    point = np.asarray(point, dtype=np.float64)
    check_shape(point, (3,), name)
    check_finite(point, name)
    lo, hi = np.zeros(3), np.array([kitchen.size[0], kitchen.size[1], WALL_HEIGHT])
    if np.any(point < lo) or np.any(point > hi):
        raise ValueError(f"{name}: expected a point inside the scene [0, {hi[0]:g}] × [0, {hi[1]:g}] × "
                         f"[0, {hi[2]:g}] m, got {np.round(point, 3).tolist()}")
    return point


def object_yaw(obj) -> float:
    return float(np.arctan2(obj.rotation[1, 0], obj.rotation[0, 0]))


def front_grasp_point(item, front) -> np.ndarray:
    """(3,) the item's annotated grasp point that faces ``front`` (3,) most (the side a person reaches)."""
    points = np.asarray(item.grasp_points)
    centre = item.to_world(item.canonical_bounds.mean(axis=0))
    return points[int(np.argmax((points - centre) @ np.asarray(front, dtype=np.float64)))]


def object_goal(item, holder, name: str, environment, config: EnvironmentConfig = EnvironmentConfig(), *,
                contact=None) -> HandGoal:
    """The goal of grasping ``item`` (a ``ToyObject``) held by ``holder`` among ``environment`` (the things
    around it, not the item): its grid yawed like the holder, its contact the grasp point facing the
    holder's front unless ``contact`` (3,) is given."""
    contact = front_grasp_point(item, holder.rotation[:, 1]) if contact is None else contact
    grid = fields.object_grid(item, config.field, yaw=object_yaw(holder))
    return HandGoal("item", name, contact, grid, environment, item)


def item_goal(kitchen: Kitchen, index: int, config: EnvironmentConfig = EnvironmentConfig(), *,
              contact=None) -> HandGoal:
    """The goal of grasping item ``index`` of ``kitchen`` (:func:`object_goal`; the environment: every other
    object, the walls and the floor)."""
    if not isinstance(index, (int, np.integer)) or isinstance(index, bool) or not 0 <= index < len(kitchen.items):
        raise ValueError(f"index: expected an item index in [0, {len(kitchen.items)}), got {index!r}")
    item = kitchen.items[index]
    environment = [o for o in kitchen.objects if o is not item] + [room_sdf(kitchen.size)]
    goal = object_goal(item, kitchen.holder_of(index), f"{item.category} {index}", environment, config,
                       contact=contact)
    check_in_scene(kitchen, goal.contact, "contact")
    return goal


def handle_goal(kitchen: Kitchen, kind: str, config: EnvironmentConfig = EnvironmentConfig()) -> HandGoal:
    """The goal of taking the handle of the cabinet door (``kind="door"``) or the drawer (``"drawer"``)."""
    check_choice(kind, tuple(HANDLED_CATEGORY), "kind")
    furniture = kitchen.furniture_of(HANDLED_CATEGORY[kind])
    handle = check_in_scene(kitchen, furniture.handle_point, "handle")
    grid = fields.object_grid(furniture, config.field, yaw=object_yaw(furniture), centre=handle)
    name = "cabinet door" if kind == "door" else "drawer"
    return HandGoal(kind, name, handle, grid, list(kitchen.objects) + [room_sdf(kitchen.size)], furniture)


def kitchen_goals(kitchen: Kitchen, config: EnvironmentConfig = EnvironmentConfig()) -> list[HandGoal]:
    """Every goal of a kitchen: its items, then the door's and the drawer's handles."""
    return [item_goal(kitchen, i, config) for i in range(len(kitchen.items))] + \
        [handle_goal(kitchen, kind, config) for kind in HANDLED_CATEGORY]


def training_grids(config: EnvironmentConfig) -> torch.Tensor:
    """(N, n, n, n) float32: the environment fields of every goal of ``config.n_kitchens`` toy kitchens
    (``make_kitchen`` with doors and drawers in random states), built once, then loaded from the cache."""
    def build():
        grids = []
        for k in range(config.n_kitchens):
            kitchen = make_kitchen(np.random.default_rng([config.seed, k]))
            grids += [goal.field(config) for goal in kitchen_goals(kitchen, config)]
        return torch.as_tensor(np.stack(grids))

    key = {"field": dataclasses.asdict(config.field), "truncation": config.truncation,
           "n_kitchens": config.n_kitchens, "seed": config.seed}
    return load_or_build("choice_environment_grids", key, build, verbose=False)


# ----------------------------------------------------------------------------- the autoencoder


class EnvironmentAutoencoder(nn.Module):
    """§6.1's 3D CNN: three convolution + max-pooling layers, a linear code ``z``, three upscaling +
    deconvolution layers.

    Shapes: grids (B, n, n, n) in [0, 1] → codes (B, latent) → reconstructions (B, n, n, n).
    """

    def __init__(self, cells: int, channels: tuple, latent: int):
        super().__init__()
        c1, c2, c3 = channels
        m = cells // 8
        self.cells, self.latent = cells, latent
        self.encoder = nn.Sequential(
            nn.Conv3d(1, c1, 3, padding=1), nn.ReLU(), nn.MaxPool3d(2),
            nn.Conv3d(c1, c2, 3, padding=1), nn.ReLU(), nn.MaxPool3d(2),
            nn.Conv3d(c2, c3, 3, padding=1), nn.ReLU(), nn.MaxPool3d(2),
            nn.Flatten(), nn.Linear(c3 * m ** 3, latent))
        self.decoder = nn.Sequential(
            nn.Linear(latent, c3 * m ** 3), nn.ReLU(), nn.Unflatten(1, (c3, m, m, m)),
            nn.Upsample(scale_factor=2), nn.ConvTranspose3d(c3, c2, 3, padding=1), nn.ReLU(),
            nn.Upsample(scale_factor=2), nn.ConvTranspose3d(c2, c1, 3, padding=1), nn.ReLU(),
            nn.Upsample(scale_factor=2), nn.ConvTranspose3d(c1, 1, 3, padding=1))

    def encode(self, grids: torch.Tensor) -> torch.Tensor:
        """(B, n, n, n) → (B, latent) ``z``."""
        check_shape(grids, (None, self.cells, self.cells, self.cells), "grids")
        return self.encoder(grids[:, None])

    def decode(self, z: torch.Tensor) -> torch.Tensor:
        """(B, latent) → (B, n, n, n)."""
        return self.decoder(z)[:, 0]

    def forward(self, grids: torch.Tensor) -> torch.Tensor:
        return self.decode(self.encode(grids))


def build_environment_autoencoder(config: EnvironmentConfig) -> EnvironmentAutoencoder:
    """A fresh autoencoder, its weights seeded by ``config.seed`` (the global RNG untouched)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return EnvironmentAutoencoder(config.cells, tuple(config.channels), config.latent)


@single_threaded
def train_environment_autoencoder(grids: torch.Tensor, config: EnvironmentConfig, device="cpu",
                                  progress: bool = False):
    """Minimise the mean squared reconstruction error over ``grids`` (N, n, n, n).

    Returns:
        ``(EnvironmentAutoencoder in eval mode, TrainResult)``.
    """
    grids = torch.as_tensor(grids, dtype=torch.float32)
    check_shape(grids, (None, config.cells, config.cells, config.cells), "grids")
    if len(grids) == 0:
        raise ValueError("grids: expected at least one training grid")
    model = build_environment_autoencoder(config)

    def sample_batch(step, generator):
        return grids[torch.randint(0, len(grids), (config.batch_size,), generator=generator)]

    def loss_fn(net, batch):
        return (net(batch) - batch).pow(2).mean()

    result = train(model, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return model.cpu().eval(), result


@torch.no_grad()
def encode(model: EnvironmentAutoencoder, grids) -> np.ndarray:
    """(B, latent) float64 ``z`` of grids (B, n, n, n)."""
    return model.encode(torch.as_tensor(np.asarray(grids), dtype=torch.float32)).double().numpy()


@torch.no_grad()
def reconstruction_errors(model: EnvironmentAutoencoder, grids) -> np.ndarray:
    """(B,) the mean squared error of each grid's reconstruction."""
    grids = torch.as_tensor(np.asarray(grids), dtype=torch.float32)
    return (model(grids) - grids).pow(2).mean(dim=(1, 2, 3)).double().numpy()


def trained_environment_autoencoder(config: EnvironmentConfig, device="cpu", progress: bool = False) -> TrainedModel:
    """The autoencoder trained on :func:`training_grids` once, then loaded from the cache.

    ``details``: ``n_grids``; ``reconstruction``, the mean squared error over the training grids; and
    ``mean_grid``, the same error of the training set's mean grid (the baseline a code must beat).
    """
    def build():
        grids = training_grids(config)
        model, result = train_environment_autoencoder(grids, config, device=device, progress=progress)
        baseline = (grids - grids.mean(dim=0)).pow(2).mean().item()
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_grids": len(grids),
                "reconstruction": float(reconstruction_errors(model, grids).mean()), "mean_grid": baseline}

    artifact = load_or_build("choice_environment_autoencoder", dataclasses.asdict(config), build)
    model = build_environment_autoencoder(config)
    model.load_state_dict(artifact["state"])
    details = {k: artifact[k] for k in ("n_grids", "reconstruction", "mean_grid")}
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"], details)
