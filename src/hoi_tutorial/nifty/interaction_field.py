"""NIFTY's object interaction field F_φ (§3.2): where is the valid interaction pose from here?

The field takes a *simplified pose* ``X̃ = {j^p, t^p}`` — the 22 joint positions and the root
translation, 23 points in metres — expressed in the object's own frame, together with the object's
canonical point cloud, and returns an offset ``ΔX̃ = F_φ(X̃)`` such that ``X̃ + ΔX̃`` is a valid
interaction pose (a sitting pose on this chair, a lifting pose at this box). Its squared norm is
the guidance objective ``G(τ) = ‖F_φ(X̃_N)‖²`` on the last frame of a motion (``nifty.guidance``).

Training data comes from the diffusion model's own mistakes (§3.2, "Training"): a ground-truth
interaction motion ``τ^0`` is noised to a random step ``k``, the trained motion model predicts
``τ̂^0``, and the last frame of that prediction ``X̃_N`` is the invalid pose whose target offset is
``Ỹ_N − X̃_N`` (``Ỹ_N`` the ground truth's last frame). The invalid poses are also moved by random
rigid transforms (a yaw about the vertical and a ground-plane shift) to cover poses the model never
makes; the valid pose stays. Loss: L1, ``‖F_φ(X̃_N) − (Ỹ_N − X̃_N)‖₁``.

Architecture (§3.2, Fig. 2 left): an encoder-only transformer (``torch.nn.TransformerEncoder``, as
Appendix B names it) over one token per input pose and one object token from a PointNet over the
canonical point cloud, so one field serves every object of an action.

The variants the supplementary tables ablate are fields of the same class:

- ``output="distance"``: a scalar distance to the manifold instead of the offset (Table 2,
  "Distance OIF"); its objective is the squared distance.
- ``n_frames = m > 1``: the last ``m`` poses in, ``m`` offsets out (Table 6).
- ``frame="human"``: pose and point cloud in the person's canonical frame (the motion's first
  frame) instead of the object's (Table 7, "Local Human").

Scaled down (paper -> toy): 300K iterations at a peak learning rate 5e-5 (one-cycle) -> a couple of
thousand steps at a higher peak; width 512, 8 layers -> 64, 2 layers; 5000 object points -> the
motion model's ``n_points``. The number of noised copies per sequence, the augmentation ranges and
the toy learning rate are ours (NIFTY does not state them).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np
import torch
from torch import nn

from .._validate import as_tensor, check_choice, check_numbers, check_positive_ints, check_shape
from ..infra import (TrainedModel, TrainResult, load_or_build, scaled_config, single_threaded, state_dict_to_cpu,
                     train, trainer_config)
from ..nn.diffusion import classifier_free_x0, q_sample
from ..nn.pointnet import PointNetEncoder
from ..world.features import NIFTY_STATE_LAYOUT, NIFTY_STATE_SIZE
from ..world.motion import FPS
from ..world.skeleton import NUM_JOINTS
from . import motion_model
from .motion_model import InteractionTensors, NiftyMotionModel

__all__ = [
    "POSE_POINTS",
    "FIELD_FRAMES",
    "FIELD_OUTPUTS",
    "InteractionFieldConfig",
    "field_variant",
    "INTERACTION_FIELD_SCALES",
    "interaction_field_config",
    "simplified_pose",
    "object_from_canonical",
    "to_field_frame",
    "FieldTrainingPairs",
    "field_training_pairs",
    "random_rigid_transforms",
    "InteractionField",
    "field_around",
    "train_interaction_field",
    "field_anchor_subset",
    "trained_interaction_field",
]

POSE_POINTS = NUM_JOINTS + 1  # the 22 joints j^p and the root translation t^p
FIELD_FRAMES = ("object", "human")

FIELD_OUTPUTS = ("offset", "distance")


# --------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class InteractionFieldConfig:
    """The interaction field, its training data and its training (defaults: the ``toy`` preset).

    Attributes:
        action: ``"sit"`` or ``"lift"`` (one field per action across objects, as NIFTY).
        frame: ``"object"`` (NIFTY: the object's canonical frame) or ``"human"`` (Table 7's ablation:
            the person's canonical frame, with the point cloud moved into it).
        output: ``"offset"`` (NIFTY: ``ΔX̃``, 23 × 3 numbers per pose) or ``"distance"`` (Table 2's
            ablation: one number per pose, the norm of the offset).
        n_frames: the last poses the field reads (NIFTY: 1; Table 6: 5, 10, 15).
        anchor_fraction: share of the training anchors whose sequences make the field's training
            pairs (NIFTY: all; Table 5: 10, 25, 50 %), a random subset drawn with ``seed``, at least
            one anchor (:func:`field_anchor_subset`).
        width, layers, heads, dropout: the transformer encoder (NIFTY: 512, 8, 4; dropout ours).
        pointnet_hidden: the PointNet's shared layer widths.
        copies_per_sequence: noised copies of each training motion fed through the diffusion model.
        augment_fraction: share of the pairs whose invalid pose gets a random rigid transform.
        augment_yaw_deg: largest yaw of that transform, degrees, about the vertical through the
            frame's origin.
        augment_shift: largest ground-plane shift of that transform, metres, per axis.
        steps, batch_size, lr, lr_schedule, warmup_steps, weight_decay, grad_clip: training
            (NIFTY: 300K steps, AdamW, one-cycle to a peak of 5e-5). With ``"onecycle"`` the shape is
            PyTorch's ``OneCycleLR`` defaults (NIFTY gives only the policy); ``warmup_steps`` 0
            rises for 30 % of the steps (its default ``pct_start``).
        seed: seeds the pairs (noise levels, noise, transforms), the weights and the batches.
    """

    action: str = "sit"
    frame: str = "object"
    output: str = "offset"
    n_frames: int = 1
    anchor_fraction: float = 1.0
    width: int = 64
    layers: int = 2
    heads: int = 4
    dropout: float = 0.0
    pointnet_hidden: tuple = (64, 128)
    copies_per_sequence: int = 8
    augment_fraction: float = 0.5
    augment_yaw_deg: float = 30.0
    augment_shift: float = 0.3
    steps: int = 1500
    batch_size: int = 64
    lr: float = 1e-3
    lr_schedule: str = "onecycle"
    warmup_steps: int = 0
    weight_decay: float = 0.0
    grad_clip: Optional[float] = 1.0
    seed: int = 0

    def __post_init__(self):
        check_choice(self.action, ("sit", "lift"), "action")
        check_choice(self.frame, FIELD_FRAMES, "frame")
        check_choice(self.output, FIELD_OUTPUTS, "output")
        if not 0.0 < float(self.anchor_fraction) <= 1.0:
            raise ValueError(f"anchor_fraction: expected a share in (0, 1], got {self.anchor_fraction!r}")
        check_positive_ints(self, ("n_frames", "width", "layers", "heads", "copies_per_sequence", "steps",
                                   "batch_size"))
        if self.width % self.heads:
            raise ValueError(f"width: expected a multiple of heads={self.heads}, got {self.width}")
        if not 0.0 <= self.augment_fraction <= 1.0:
            raise ValueError(f"augment_fraction: expected a probability in [0, 1], got {self.augment_fraction!r}")
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("dropout",), at_least=0, below=1)
        check_numbers(self, ("augment_yaw_deg", "augment_shift", "weight_decay"), at_least=0)
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)

def field_variant(config: InteractionFieldConfig) -> str:
    """The field's form, as ``guidance.GUIDANCE_ALPHA`` names it: ``"offset"`` (NIFTY),
    ``"distance"`` (Table 2), ``"human frame"`` (Table 7), ``"m frames"`` (Table 6), or the changes
    joined by ``", "``. The share of anchors trained on (Table 5) does not change the form."""
    parts = []
    if config.output == "distance":
        parts.append("distance")
    if config.frame == "human":
        parts.append("human frame")
    if config.n_frames > 1:
        parts.append(f"{config.n_frames} frames")
    return ", ".join(parts) or "offset"


# What the larger scales change (paper: NIFTY §4.1's training, Appendix B's transformer sizes).
INTERACTION_FIELD_SCALES = {
    "small": {"width": 256, "layers": 4, "dropout": 0.1, "pointnet_hidden": (64, 128, 256), "copies_per_sequence": 16,
              "steps": 30000, "lr": 2e-4},
    "paper": {"width": 512, "layers": 8, "dropout": 0.1, "pointnet_hidden": (64, 128, 1024),
              "copies_per_sequence": 16, "steps": 300_000, "batch_size": 32, "lr": 5e-5},
}


def interaction_field_config(action: str, scale: str = "toy", **overrides) -> InteractionFieldConfig:
    """The preset for ``action`` and ``scale`` (``toy``: about a minute on a 2-core CPU), fields
    overridable (``interaction_field_config("sit", "toy", output="distance")``)."""
    check_choice(action, ("sit", "lift"), "action")
    return scaled_config(InteractionFieldConfig, scale, INTERACTION_FIELD_SCALES, overrides,
                         factory="interaction_field_config", fixed={"action": action})


# --------------------------------------------------------------------------- poses and frames


def simplified_pose(states: torch.Tensor, n_frames: int = 1, valid: Optional[torch.Tensor] = None,
                    fps: float = FPS) -> torch.Tensor:
    """``X̃ = {j^p, t^p}`` of the last ``n_frames`` frames of NIFTY states (differentiable), placed where
    the motion recovered from the states is.

    NIFTY recovers a motion's root by integrating ``t^v`` in the ground plane (Appendix B) "so that the
    guidance objective at the last frame will still have a strong effect on earlier frames". The
    simplified pose is read the same way: the root's ground-plane position is the first frame's ``t^p``
    plus the integral of ``t^v`` (as ``world.features.nifty_state_to_pose`` integrates it), its height is
    ``t^p``'s, and the joints ``j^p`` move with the root. For data the two readings agree exactly; for
    a generated motion whose ``t^p`` and integrated ``t^v`` disagree, the field then scores the motion
    that is output, and its gradient reaches the velocities of every earlier frame.

    Args:
        states: ``(B, T, 336)`` un-normalised NIFTY Eq. 1 states (each in its canonical frame).
        n_frames: how many of the last frames.
        valid: optional ``(B, T)`` bool, False on padding frames (a sequence shorter than ``T`` padded
            with its last frame): their velocities are not integrated, so the padding holds still.
        fps: frames per second of the states.
    Returns:
        ``(B, n_frames, 23, 3)`` metres: the 22 joint positions, then the root translation.
    """
    check_shape(states, (None, None, NIFTY_STATE_SIZE), "states")
    if not isinstance(n_frames, int) or not 1 <= n_frames <= states.shape[1]:
        raise ValueError(f"n_frames: expected an int in [1, {states.shape[1]}], got {n_frames!r}")
    velocity = states[..., NIFTY_STATE_LAYOUT["root_velocity"]][..., :2]
    if valid is not None:
        valid = as_tensor(valid, "valid", dtype=torch.bool).to(states.device)
        check_shape(valid, states.shape[:2], "valid")
        velocity = velocity * valid[..., None].to(velocity.dtype)
    first = states[:, :1, NIFTY_STATE_LAYOUT["root_position"]][..., :2]
    step = velocity[:, :-1] / fps
    ground = first + torch.cat([torch.zeros_like(first), torch.cumsum(step, dim=1)], dim=1)  # (B, T, 2)
    last = states[:, -n_frames:]
    joints = last[..., NIFTY_STATE_LAYOUT["joint_positions"]].reshape(*last.shape[:2], NUM_JOINTS, 3)
    root = last[..., NIFTY_STATE_LAYOUT["root_position"]].reshape(*last.shape[:2], 1, 3)
    shift = torch.cat([ground[:, -n_frames:] - root[:, :, 0, :2], torch.zeros_like(root[:, :, 0, :1])], dim=-1)
    return torch.cat([joints, root], dim=2) + shift[:, :, None, :]


def object_from_canonical(object_pose: torch.Tensor) -> torch.Tensor:
    """The ``(B, 4, 4)`` rigid transform from a person's canonical frame to the object's frame.

    Args:
        object_pose: ``(B, 12)`` the top 3×4 of ``person_canonical_from_object`` (the condition's
            ``R_o``, :func:`~hoi_tutorial.nifty.motion_model.interaction_condition`).
    """
    check_shape(object_pose, (None, 12), "object_pose")
    top = object_pose.reshape(-1, 3, 4)
    rotation, translation = top[:, :, :3], top[:, :, 3]
    out = torch.zeros(top.shape[0], 4, 4, dtype=top.dtype, device=top.device)
    out[:, :3, :3] = rotation.transpose(1, 2)
    out[:, :3, 3] = -(rotation.transpose(1, 2) @ translation[..., None])[..., 0]
    out[:, 3, 3] = 1.0
    return out


def _apply(transform: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
    """``(B, 4, 4)`` rigid transforms applied to ``(B, ..., 3)`` points."""
    flat = points.reshape(points.shape[0], -1, 3)
    moved = flat @ transform[:, :3, :3].transpose(1, 2) + transform[:, None, :3, 3]
    return moved.reshape(points.shape)


def to_field_frame(poses: torch.Tensor, points: torch.Tensor, object_pose: torch.Tensor, frame: str):
    """Express simplified poses and the object's points in the field's frame.

    Args:
        poses: ``(B, m, 23, 3)`` metres in each person's canonical frame (:func:`simplified_pose`).
        points: ``(B, P, 3)`` metres, the object's cloud in the object's frame.
        object_pose: ``(B, 12)`` ``R_o`` of each scene.
        frame: ``"object"`` (poses moved to the object's frame, points as they are) or ``"human"``
            (poses as they are, points moved to the person's canonical frame).
    Returns:
        ``(poses, points)`` in that frame, same shapes.
    """
    check_choice(frame, FIELD_FRAMES, "frame")
    check_shape(poses, (None, None, POSE_POINTS, 3), "poses")
    check_shape(points, (poses.shape[0], None, 3), "points")
    check_shape(object_pose, (poses.shape[0], 12), "object_pose")
    to_object = object_from_canonical(object_pose.to(poses))
    if frame == "object":
        return _apply(to_object, poses), points.to(poses)
    return poses, _apply(torch.linalg.inv(to_object), points.to(poses))


def random_rigid_transforms(n: int, max_yaw_deg: float, max_shift: float, generator: torch.Generator) -> torch.Tensor:
    """``(n, 4, 4)`` random rigid transforms: a yaw ``U(±max_yaw_deg)`` about +Z through the origin,
    then a ground-plane shift ``U(±max_shift)`` metres per axis (heights are kept)."""
    yaw = (torch.rand(n, generator=generator, dtype=torch.float64) * 2 - 1) * math.radians(max_yaw_deg)
    shift = (torch.rand(n, 2, generator=generator, dtype=torch.float64) * 2 - 1) * max_shift
    out = torch.eye(4, dtype=torch.float64).repeat(n, 1, 1)
    out[:, 0, 0], out[:, 0, 1] = torch.cos(yaw), -torch.sin(yaw)
    out[:, 1, 0], out[:, 1, 1] = torch.sin(yaw), torch.cos(yaw)
    out[:, :2, 3] = shift
    return out.to(torch.float32)


# --------------------------------------------------------------------------- training pairs


@dataclass
class FieldTrainingPairs:
    """The interaction field's training set (§3.2), in the field's frame.

    Attributes:
        poses: ``(N, m, 23, 3)`` metres, the invalid poses ``X̃`` (the diffusion model's last frames,
            some moved by a random rigid transform).
        targets: ``(N, m, 23, 3)`` metres, the valid poses ``Ỹ`` (the ground truth's last frames).
        points: ``(N, P, 3)`` metres, the object cloud of each pair, in the field's frame.
        sequence: ``(N,)`` int64, the training sequence each pair comes from.
        step: ``(N,)`` int64, the noise level ``k`` the prediction was made from.
        augmented: ``(N,)`` bool, True where a random rigid transform moved the invalid pose.
    """

    poses: torch.Tensor
    targets: torch.Tensor
    points: torch.Tensor
    sequence: torch.Tensor
    step: torch.Tensor
    augmented: torch.Tensor

    @property
    def offsets(self) -> torch.Tensor:
        """``(N, m, 23, 3)`` the training targets of the offset field, ``Ỹ − X̃``."""
        return self.targets - self.poses

    def __len__(self) -> int:
        return int(self.poses.shape[0])


@single_threaded
def field_training_pairs(model: NiftyMotionModel, tensors: InteractionTensors, config: InteractionFieldConfig,
                         device="cpu") -> FieldTrainingPairs:
    """Feed noised ground-truth motions through the trained diffusion model and keep the last frames
    (NIFTY §3.2, "Training").

    For each of ``config.copies_per_sequence`` rounds, every training sequence is noised to a step
    ``k ~ U{0, …, K−1}`` (``q_sample``), the model predicts ``τ̂^0`` with classifier-free guidance
    at the model's scale (the prediction the sampler, and so the guidance, works with), and the
    last ``n_frames`` simplified poses of prediction and ground truth become one pair. A share
    ``augment_fraction`` of the invalid poses is then moved by a random rigid transform in the
    field's frame.

    Args:
        model: the trained motion model of ``config.action``.
        tensors: its training sequences.
        config: the field's configuration (frame, frames, copies, augmentation, seed).
        device: where to run the model.
    Returns:
        :class:`FieldTrainingPairs`.
    """
    if not isinstance(model, NiftyMotionModel):
        raise TypeError(f"model: expected a NiftyMotionModel, got {type(model).__name__}")
    if not isinstance(tensors, InteractionTensors) or len(tensors) == 0:
        raise ValueError("tensors: expected InteractionTensors with at least one training sequence")
    if model.config.action != config.action:
        raise ValueError(f"config.action: {config.action!r}, but the motion model is {model.config.action!r}")
    generator = torch.Generator().manual_seed(config.seed)
    device = torch.device(device)
    was_training = model.training
    model.to(device).eval()
    schedule = model.config.noise_schedule().to(device)
    cond = {name: value.to(device) for name, value in tensors.condition().items()}
    with torch.no_grad():
        encoded = model.encode_condition(cond)
    clean = model.normalise(tensors.states.to(device))
    valid = tensors.valid.to(device)
    truth = simplified_pose(tensors.states.to(device), config.n_frames, valid)
    n = len(tensors)
    poses, targets, sequence, steps = [], [], [], []
    for _ in range(config.copies_per_sequence):
        k = torch.randint(0, schedule.num_steps, (n,), generator=generator)
        noise = torch.randn(clean.shape, generator=generator)
        with torch.no_grad():
            x0_hat = classifier_free_x0(model.denoise, q_sample(schedule, clean, k.to(device), noise.to(device)),
                                        k.to(device), encoded, model.config.guidance_scale)
        poses.append(simplified_pose(model.denormalise(x0_hat), config.n_frames, valid))
        targets.append(truth)
        sequence.append(torch.arange(n))
        steps.append(k)
    model.train(was_training)
    sequence, steps = torch.cat(sequence), torch.cat(steps)
    object_pose, points = tensors.object_pose[sequence].to(device), tensors.points[sequence].to(device)
    poses, points = to_field_frame(torch.cat(poses), points, object_pose, config.frame)
    targets, _ = to_field_frame(torch.cat(targets), points, object_pose, config.frame)
    augmented = torch.rand(len(sequence), generator=generator) < config.augment_fraction
    transforms = random_rigid_transforms(len(sequence), config.augment_yaw_deg, config.augment_shift, generator)
    moved = _apply(transforms.to(poses), poses)
    poses = torch.where(augmented.to(device)[:, None, None, None], moved, poses)
    return FieldTrainingPairs(poses=poses.cpu(), targets=targets.cpu(), points=points.cpu(), sequence=sequence,
                              step=steps, augmented=augmented)


# --------------------------------------------------------------------------- the field


class InteractionField(nn.Module):
    """``F_φ(X̃, P_o)``: an encoder-only transformer over pose tokens and an object token (NIFTY §3.2).

    Each of the ``m`` input poses (23 points × 3, metres) becomes a token by a linear layer plus a
    learned per-frame embedding; the point cloud becomes one token by a PointNet; the transformer
    encoder mixes them; each pose token is read out by a linear layer into its offset (23 × 3) or
    its distance (1).
    """

    def __init__(self, config: InteractionFieldConfig):
        super().__init__()
        self.config = config
        width = config.width
        self.pose_in = nn.Linear(POSE_POINTS * 3, width)
        self.frame_embedding = nn.Parameter(torch.zeros(config.n_frames, width))
        self.point_encoder = PointNetEncoder(width, hidden=tuple(config.pointnet_hidden))
        layer = nn.TransformerEncoderLayer(width, config.heads, dim_feedforward=2 * width, dropout=config.dropout,
                                           activation="gelu", batch_first=True)
        self.encoder = nn.TransformerEncoder(layer, config.layers, enable_nested_tensor=False)
        self.head = nn.Linear(width, POSE_POINTS * 3 if config.output == "offset" else 1)

    def forward(self, poses: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
        """The field at ``poses``.

        Args:
            poses: ``(B, m, 23, 3)`` metres in the field's frame (``m = config.n_frames``).
            points: ``(B, P, 3)`` metres, the object's cloud in the same frame.
        Returns:
            ``(B, m, 23, 3)`` offsets ``ΔX̃`` in metres, or ``(B, m)`` distances in metres.
        """
        check_shape(poses, (None, self.config.n_frames, POSE_POINTS, 3), "poses")
        check_shape(points, (poses.shape[0], None, 3), "points")
        tokens = self.pose_in(poses.flatten(2)) + self.frame_embedding
        tokens = torch.cat([self.point_encoder(points)[:, None], tokens], dim=1)
        out = self.head(self.encoder(tokens)[:, 1:])
        if self.config.output == "offset":
            return out.reshape(poses.shape)
        return out[..., 0]

    def objective(self, poses: torch.Tensor, points: torch.Tensor) -> torch.Tensor:
        """The guidance objective ``G = ‖F_φ(X̃)‖²`` per sample, ``(B,)`` m² (summed over the frames;
        for a distance field, the squared distance)."""
        out = self(poses, points)
        return out.pow(2).flatten(1).sum(dim=1)


@torch.no_grad()
def field_around(field: InteractionField, pose: torch.Tensor, points: torch.Tensor, shifts: torch.Tensor) -> torch.Tensor:
    """The field for one pose moved to several places on the ground (NIFTY Fig. 3).

    Args:
        field: a single-frame field (``n_frames = 1``).
        pose: ``(23, 3)`` metres, a simplified pose in the field's frame.
        points: ``(P, 3)`` metres, the object's cloud in the same frame.
        shifts: ``(S, 2)`` metres, ground-plane translations applied to the pose.
    Returns:
        ``(S, 23, 3)`` the offsets (an offset field) or ``(S,)`` the distances (a distance field).
    """
    if field.config.n_frames != 1:
        raise ValueError(f"field: expected a single-frame field, got n_frames={field.config.n_frames}")
    pose, points, shifts = as_tensor(pose, "pose").float(), as_tensor(points, "points").float(), as_tensor(shifts, "shifts").float()
    check_shape(pose, (POSE_POINTS, 3), "pose")
    check_shape(points, (None, 3), "points")
    check_shape(shifts, (None, 2), "shifts")
    moved = pose.repeat(shifts.shape[0], 1, 1)
    moved[..., :2] += shifts[:, None, :]
    out = field(moved[:, None], points.expand(shifts.shape[0], -1, -1))
    return out[:, 0]


def _field_loss(field: InteractionField, poses, targets, points) -> torch.Tensor:
    """L1 between the field and the offsets (NIFTY §3.2), or its distance and the offsets' norms."""
    predicted = field(poses, points)
    offsets = targets - poses
    if field.config.output == "offset":
        return (predicted - offsets).abs().mean()
    return (predicted - offsets.flatten(2).norm(dim=-1)).abs().mean()


@single_threaded  # one thread wherever it runs: a chapter's kernel and a warm_cache worker train the same field
def train_interaction_field(pairs: FieldTrainingPairs, config: InteractionFieldConfig, device="cpu",
                            progress: bool = False) -> tuple[InteractionField, TrainResult]:
    """Fit the field to the pairs with the L1 loss (NIFTY §3.2) and AdamW with a one-cycle schedule
    (§4.1).

    Returns:
        ``(field in eval mode, TrainResult)``.
    """
    if not isinstance(pairs, FieldTrainingPairs) or len(pairs) == 0:
        raise ValueError("pairs: expected FieldTrainingPairs with at least one pair")
    check_shape(pairs.poses, (None, config.n_frames, POSE_POINTS, 3), "pairs.poses")
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        field = InteractionField(config)

    def sample_batch(step: int, generator: torch.Generator):
        index = torch.randint(0, len(pairs), (config.batch_size,), generator=generator)
        return pairs.poses[index], pairs.targets[index], pairs.points[index]

    def loss_fn(net, batch):
        return _field_loss(net, *batch)

    result = train(field, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return field.eval(), result


@single_threaded
def field_anchor_subset(dataset, config: InteractionFieldConfig) -> list[int]:
    """Indices into ``dataset.anchors`` of the training anchors whose sequences train the field.

    All of ``dataset.training_anchor_index`` for ``anchor_fraction = 1`` (NIFTY); otherwise a random
    ``ceil(anchor_fraction × n)`` of them (at least one), drawn with ``config.seed``, ascending.
    """
    index = list(dataset.training_anchor_index)
    if not index:
        raise ValueError("dataset: expected at least one training sequence")
    if config.anchor_fraction >= 1.0:
        return index
    n = max(1, math.ceil(config.anchor_fraction * len(index)))
    rng = np.random.default_rng([int(config.seed), 5])
    return sorted(int(i) for i in rng.choice(index, size=n, replace=False))


def trained_interaction_field(dataset, model_config, config: InteractionFieldConfig, device="cpu",
                              progress: bool = False) -> TrainedModel:
    """The interaction field for a synthetic dataset and its motion model, built once, then loaded.

    Trains (or loads) the motion model, makes the training pairs with it and fits the field.

    Args:
        dataset: a ``nifty.data.SyntheticDataset`` of ``config.action``.
        model_config: the ``nifty.motion_model.MotionModelConfig`` of the diffusion model.
        config: an :class:`InteractionFieldConfig`.
        device: where to train.
        progress: True always shows training's progress bar; False, where ``infra.progress`` shows one (a notebook).
    Returns:
        a :class:`~hoi_tutorial.infra.TrainedModel` (the field in eval mode on the CPU) whose
        ``details`` hold ``n_pairs`` and ``zero_field_loss``: the training loss of a field that
        always answers 0 (the mean size of the targets), the baseline its losses are read against.
    """
    if config.action != dataset.config.action or model_config.action != config.action:
        raise ValueError(f"config.action: {config.action!r}, but the dataset is {dataset.config.action!r} and the "
                         f"motion model {model_config.action!r}")

    def build():
        trained = motion_model.trained_motion_model(dataset, model_config, device=device, progress=progress)
        used = {id(dataset.anchors[i]) for i in field_anchor_subset(dataset, config)}
        sequences = [s for s in dataset.sequences if id(s.anchor) in used]
        tensors = InteractionTensors.from_sequences(sequences, model_config.max_frames,
                                                    model_config.n_points, model_config.seed)
        pairs = field_training_pairs(trained.model, tensors, config, device=device)
        field, result = train_interaction_field(pairs, config, device=device, progress=progress)
        zero = pairs.offsets.abs().mean() if config.output == "offset" else pairs.offsets.flatten(2).norm(dim=-1).mean()
        return {"state": state_dict_to_cpu(field), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_pairs": len(pairs), "zero_field_loss": float(zero)}

    key = {"data": dataclasses.asdict(dataset.config), "model": dataclasses.asdict(model_config),
           "field": dataclasses.asdict(config)}
    # the motion model's data pipeline, which its imports do not show (motion_model.model_code)
    artifact = load_or_build(f"nifty_{config.action}_interaction_field", key, build, code=motion_model.model_code())
    field = InteractionField(config)
    field.load_state_dict(artifact["state"])
    return TrainedModel(field.eval(), artifact["losses"], artifact["seconds"],
                        {"n_pairs": artifact["n_pairs"], "zero_field_loss": artifact["zero_field_loss"]})
