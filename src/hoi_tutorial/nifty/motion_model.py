"""NIFTY's object-conditioned motion diffusion model (§3.1, Appendix B).

A motion ``τ = {X_1 … X_N}`` is a sequence of NIFTY Eq. 1 pose states (336 numbers per frame,
:func:`~hoi_tutorial.world.features.nifty_pose_state`), all in the canonical frame of its first
pose. The model ``M_θ(τ^k, k, C)`` predicts the clean motion x̂0 from a noisy one (NIFTY Eq. 2–3,
x0-parameterisation, L2 loss, k uniform) given the interaction condition
``C = {P_o, R_o, b, X_0}``:

- ``P_o``: the object's point cloud in its own canonical frame, encoded by a PointNet;
- ``R_o``: the object's rigid pose relative to the person (4×4 ``person_canonical_from_object``,
  its top 3×4 = 12 numbers), encoded by a three-layer MLP;
- ``b``: the body shape (10 numbers) and ``X_0``: the first frame's pose state, each projected by
  a Linear layer;

each condition becoming one token of a :class:`~hoi_tutorial.nn.transformer.TransformerDenoiser`
(per-frame tokens, a step token, learned null tokens). The whole condition is dropped jointly for
10 % of training samples so that sampling can use classifier-free guidance with scale ``s``
(MDM's 2.5), and an objective on x̂0 can be added with reconstruction guidance (NIFTY Eq. 4).
Sampled states become motions by integrating the root velocity in the ground plane and taking
the height from ``t^p`` (Appendix B, :func:`~hoi_tutorial.world.features.motion_from_nifty_state`).

Training sequences shorter than ``max_frames`` are padded with their last (interaction) frame,
as Appendix B does, and the loss covers the padding too; longer ones keep their last
``max_frames`` frames so that they still end in their anchor. States are standardised per
feature with statistics over the valid frames, stored in the model.

Scaling (paper -> toy): 150 -> 121 frames (a depth-4 tree of 1-second nodes plus the anchor);
width 512 -> 64; 8 -> 2 layers (4 heads at every scale); dropout 0.1 -> 0 (on a CPU it costs
almost half of each step); K = 1000 -> 100 diffusion steps; 5000 -> 256 object points;
600K iterations of batch 32 at lr 1e-4 -> 1000 iterations of batch 16 at lr 2e-3 (cosine
decay), under a minute on one CPU thread. ``small`` sits in between.
"""
from __future__ import annotations

import dataclasses
import importlib
import math
import sys
from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np
import torch
from torch import nn

from .._validate import as_tensor, check_choice, check_numbers, check_positive_ints, check_shape
from .. import metrics
from ..infra import TrainedModel, TrainResult, load_or_build, single_threaded, state_dict_to_cpu, trainer_config
from ..infra.presets import scaled_config
from ..nn.mlp import MLP
from ..nn.diffusion import (NoiseSchedule, SamplingRecord, classifier_free_x0, cosine_schedule, sample,
                            sample_with_record, train_denoiser)
from ..nn.pointnet import PointNetEncoder
from ..nn.transformer import TransformerDenoiser
from ..world.features import (NIFTY_STATE_SIZE, canonical_transform, motion_from_nifty_state, nifty_pose_state,
                              root_frame)
from ..world.motion import Motion
from ..world.rotations import rotation_about_z
from ..world.skeleton import NUM_BETAS, NUM_JOINTS

__all__ = [
    "CONDITION_KEYS",
    "OBJECT_POSE_SIZE",
    "MotionModelConfig",
    "MOTION_MODEL_SCALES",
    "motion_model_config",
    "canonical_from_world_matrix",
    "interaction_condition",
    "InteractionTensors",
    "NiftyMotionModel",
    "build_motion_model",
    "train_motion_model",
    "trained_motion_model",
    "model_code",
    "sample_motions",
    "sample_motions_with_record",
    "states_to_motions",
    "final_pelvis_distance",
    "anchor_skeleton_distance",
]

# The raw condition C = {P_o, R_o, b, X_0}, as the model's ``cond`` dict takes it.
CONDITION_KEYS = ("points", "object_pose", "betas", "start_pose")
OBJECT_POSE_SIZE = 12  # the top 3×4 of person_canonical_from_object
_STD_FLOOR = 1e-2  # features (nearly) constant in the data are scaled by at most 1/_STD_FLOOR


# --------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class MotionModelConfig:
    """The motion diffusion model and its training (see the module docstring for the scaling).

    The defaults are the ``toy`` preset; :func:`motion_model_config` gives every scale.

    Attributes:
        action: ``"sit"`` or ``"lift"`` (NIFTY trains one model per action).
        max_frames: frames per motion (NIFTY: 150); shorter sequences are padded with their last frame.
        width: token size of the transformer (NIFTY: 512).
        layers: transformer encoder layers (NIFTY: 8).
        heads: attention heads (NIFTY: 4).
        dropout: dropout inside the transformer (MDM: 0.1).
        n_points: points of the object cloud ``P_o`` (NIFTY: 5000).
        pointnet_hidden: widths of the PointNet's shared per-point layers.
        diffusion_steps: K (NIFTY: 1000; the toy preset's 50 is a scale-down, like its width and steps).
        p_uncond: probability of dropping the whole condition in training (NIFTY: 0.1).
        guidance_scale: classifier-free guidance scale ``s`` at sampling (MDM: 2.5).
        steps: optimiser steps (NIFTY: 600K).
        batch_size: sequences per step (NIFTY: 32).
        lr: AdamW learning rate (NIFTY: 1e-4).
        lr_schedule: ``"constant"`` or ``"cosine"`` (after ``warmup_steps`` of linear warm-up).
        warmup_steps: linear warm-up steps.
        grad_clip: gradient-norm clip, or ``None``.
        seed: seeds the initial weights, the batches, the noise and the object point sampling.
    """

    action: str = "sit"
    max_frames: int = 121
    width: int = 64
    layers: int = 2
    heads: int = 4
    dropout: float = 0.0
    n_points: int = 256
    pointnet_hidden: tuple = (64, 128)
    diffusion_steps: int = 50
    p_uncond: float = 0.1
    guidance_scale: float = 2.5
    steps: int = 1000
    batch_size: int = 16
    lr: float = 2e-3
    lr_schedule: str = "cosine"
    warmup_steps: int = 100
    grad_clip: Optional[float] = 1.0
    seed: int = 0

    def __post_init__(self):
        check_choice(self.action, ("sit", "lift"), "action")
        check_choice(self.lr_schedule, ("constant", "cosine"), "lr_schedule")
        check_positive_ints(self, ("max_frames", "width", "layers", "heads", "n_points", "diffusion_steps", "steps",
                                   "batch_size"))
        if self.width % self.heads:
            raise ValueError(f"width: expected a multiple of heads={self.heads}, got {self.width}")
        if not 0.0 <= self.p_uncond <= 1.0:
            raise ValueError(f"p_uncond: expected a probability in [0, 1], got {self.p_uncond!r}")
        if self.diffusion_steps < 2:
            raise ValueError(f"diffusion_steps: expected at least 2, got {self.diffusion_steps}")
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("dropout",), at_least=0, below=1)
        check_numbers(self, ("guidance_scale",))
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)

    def noise_schedule(self) -> NoiseSchedule:
        """The cosine schedule with ``diffusion_steps`` steps (MDM's and NIFTY's)."""
        return cosine_schedule(self.diffusion_steps)


# What the larger scales change from the defaults (the toy preset); ``paper`` is NIFTY's Appendix B.
MOTION_MODEL_SCALES = {
    "small": {"max_frames": 151, "width": 256, "layers": 4, "dropout": 0.1, "n_points": 1024,
              "pointnet_hidden": (64, 128, 256), "diffusion_steps": 1000, "steps": 30000, "batch_size": 32,
              "lr": 2e-4, "warmup_steps": 500},
    "paper": {"max_frames": 150, "width": 512, "layers": 8, "dropout": 0.1, "n_points": 5000,
              "pointnet_hidden": (64, 128, 1024), "diffusion_steps": 1000, "steps": 600_000, "batch_size": 32,
              "lr": 1e-4, "lr_schedule": "constant", "warmup_steps": 0, "grad_clip": None},
}


def motion_model_config(action: str, scale: str = "toy", **overrides) -> MotionModelConfig:
    """The preset for ``action`` and ``scale``: ``toy`` (≤ 1 min on a 2-core CPU), ``small``,
    ``paper`` (NIFTY's sizes).

    Fields can be overridden by keyword (``motion_model_config("sit", "toy", steps=200)``).
    """
    check_choice(action, ("sit", "lift"), "action")
    return scaled_config(MotionModelConfig, scale, MOTION_MODEL_SCALES, overrides,
                         factory="motion_model_config", fixed={"action": action})


# --------------------------------------------------------------------------- tensorisation


def canonical_from_world_matrix(motion: Motion, frame: int = 0) -> np.ndarray:
    """The 4×4 rigid transform taking world points into the canonical frame of ``frame`` (NIFTY §3.1).

    It is :func:`~hoi_tutorial.world.features.canonical_transform` as a matrix: a yaw about +Z
    through the world origin, then a ground-plane translation.

    Args:
        motion: a ``Motion``.
        frame: the frame that becomes canonical.
    Returns:
        ``(4, 4)`` float64 ``canonical_from_world``.
    """
    yaw, translation = canonical_transform(motion, frame)
    out = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    out[:2, :2] = [[c, -s], [s, c]]
    out[:3, 3] = translation.detach().cpu().double().numpy()
    return out


def _inverse_rigid(matrix: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = matrix[:3, :3].T
    out[:3, 3] = -matrix[:3, :3].T @ matrix[:3, 3]
    return out


def interaction_condition(motion: Motion, obj, n_points: int, seed=0, points=None) -> dict:
    """The condition ``C = {P_o, R_o, b, X_0}`` of NIFTY §3.1 for a person starting as ``motion`` does.

    Only the first frame matters (velocities in ``X_0`` come from the frames after it, zero for a
    one-frame motion).

    Args:
        motion: a ``Motion`` (world frame) whose first frame is the start pose.
        obj: a placed object with ``pose`` ``(4, 4)`` world_from_object and
            ``point_cloud(n, seed)`` (canonical frame), e.g. ``world.objects.ToyObject``.
        n_points: size of ``P_o`` (NIFTY: 5000).
        seed: seed of the point sampling (int or ``numpy.random.Generator``).
        points: ``(n_points, 3)`` metres, an object-frame cloud of ``obj`` already sampled (then
            ``seed`` is unused).
    Returns:
        dict of float32 tensors: ``points (n_points, 3)`` metres, object frame;
        ``object_pose (12,)`` the top 3×4 of ``person_canonical_from_object`` (rotation entries,
        translation in metres); ``betas (10,)``; ``start_pose (336,)`` the first frame's Eq. 1
        state (canonical frame); and ``world_from_canonical (4, 4)`` to place generated motions.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
    canonical_from_world = canonical_from_world_matrix(motion, 0)
    relative = canonical_from_world @ np.asarray(obj.pose, dtype=np.float64)
    if points is None:
        points = obj.point_cloud(int(n_points), seed=seed)
    points = np.asarray(points, dtype=np.float64)
    check_shape(points, (int(n_points), 3), "points")
    start = nifty_pose_state(motion.slice(0, min(len(motion), 2)))[0]
    return {
        "points": torch.as_tensor(points, dtype=torch.float32),
        "object_pose": torch.as_tensor(relative[:3, :4].reshape(-1), dtype=torch.float32),
        "betas": motion.betas.detach().to(torch.float32).cpu(),
        "start_pose": start.detach().to(torch.float32).cpu(),
        "world_from_canonical": torch.as_tensor(_inverse_rigid(canonical_from_world), dtype=torch.float32),
    }


@dataclass
class InteractionTensors:
    """Training sequences as tensors (NIFTY §3.1 and Appendix B's padding).

    Attributes:
        states: ``(N, T, 336)`` NIFTY Eq. 1 states in each sequence's canonical frame, padded to
            ``T = max_frames`` by repeating the last frame.
        valid: ``(N, T)`` bool, True for real frames (the padding is False).
        lengths: ``(N,)`` int64, real frames per sequence (≤ T).
        points: ``(N, P, 3)`` metres, the object point cloud ``P_o`` in the object's frame.
        object_pose: ``(N, 12)``, the top 3×4 of ``person_canonical_from_object`` (``R_o``).
        betas: ``(N, 10)`` body shapes ``b``.
        start_pose: ``(N, 336)``, the first frame's state ``X_0`` (equal to ``states[:, 0]``).
        world_from_canonical: ``(N, 4, 4)`` places each canonical motion back in the world.
    """

    states: torch.Tensor
    valid: torch.Tensor
    lengths: torch.Tensor
    points: torch.Tensor
    object_pose: torch.Tensor
    betas: torch.Tensor
    start_pose: torch.Tensor
    world_from_canonical: torch.Tensor

    @classmethod
    @single_threaded
    def from_sequences(cls, sequences: Sequence, max_frames: int, n_points: int, seed: int = 0) -> "InteractionTensors":
        """Tensorise interaction sequences.

        Each sequence longer than ``max_frames`` keeps its last ``max_frames`` frames (it must end
        in its anchor); then the motion is canonicalised to its (new) first frame, turned into
        Eq. 1 states and padded with its last frame. Each distinct object (by identity; the
        sequences of one anchor share theirs) gets one point cloud, the ``j``-th one drawn with
        the seed ``(seed, j)``.

        Args:
            sequences: records with ``motion`` (a world-frame ``Motion``) and ``obj`` (a placed
                object, see :func:`interaction_condition`), e.g. ``nifty.rollout.InteractionSequence``.
            max_frames: ``T``.
            n_points: object points per cloud.
            seed: base seed of the point sampling.
        """
        sequences = list(sequences)
        if not sequences:
            raise ValueError("sequences: expected at least one interaction sequence")
        max_frames, n_points = int(max_frames), int(n_points)
        if max_frames < 1 or n_points < 1:
            raise ValueError(f"max_frames, n_points: expected positive ints, got {max_frames}, {n_points}")
        rows = {name: [] for name in ("states", "valid", "lengths", "points", "object_pose", "betas",
                                      "start_pose", "world_from_canonical")}
        clouds = {}  # id(obj) -> its canonical-frame cloud
        for index, record in enumerate(sequences):
            motion, obj = getattr(record, "motion", None), getattr(record, "obj", None)
            if not isinstance(motion, Motion) or obj is None:
                raise TypeError(f"sequences[{index}]: expected a record with .motion (Motion) and .obj")
            if len(motion) > max_frames:
                motion = motion.slice(len(motion) - max_frames, len(motion))
            if id(obj) not in clouds:
                clouds[id(obj)] = obj.point_cloud(n_points, seed=np.random.default_rng([int(seed), len(clouds)]))
            cond = interaction_condition(motion, obj, n_points, points=clouds[id(obj)])
            states = nifty_pose_state(motion).to(torch.float32)
            length = states.shape[0]
            padding = states[-1:].expand(max_frames - length, -1)
            rows["states"].append(torch.cat([states, padding], dim=0))
            rows["valid"].append(torch.arange(max_frames) < length)
            rows["lengths"].append(length)
            for name in ("points", "object_pose", "betas", "start_pose", "world_from_canonical"):
                rows[name].append(cond[name])
        return cls(
            states=torch.stack(rows["states"]), valid=torch.stack(rows["valid"]),
            lengths=torch.tensor(rows["lengths"], dtype=torch.int64), points=torch.stack(rows["points"]),
            object_pose=torch.stack(rows["object_pose"]), betas=torch.stack(rows["betas"]),
            start_pose=torch.stack(rows["start_pose"]),
            world_from_canonical=torch.stack(rows["world_from_canonical"]),
        )

    def __len__(self) -> int:
        return int(self.states.shape[0])

    @property
    def max_frames(self) -> int:
        """``T``, frames per padded sequence."""
        return int(self.states.shape[1])

    def condition(self, index=None) -> dict:
        """The raw condition dict (``CONDITION_KEYS``) of sequences ``index`` (default all), batch first."""
        index = slice(None) if index is None else index
        return {name: getattr(self, name)[index] for name in CONDITION_KEYS}

    def normalisation(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Per-feature ``(mean (336,), std (336,))`` over the valid frames; std floored at 0.01."""
        frames = self.states[self.valid]
        mean = frames.mean(dim=0)
        std = frames.std(dim=0, unbiased=False) if frames.shape[0] > 1 else torch.zeros_like(mean)
        return mean, std.clamp_min(_STD_FLOOR)


# --------------------------------------------------------------------------- the model


class NiftyMotionModel(nn.Module):
    """``x̂0 = M_θ(τ^k, k, C)`` with ``C = {P_o, R_o, b, X_0}`` (NIFTY §3.1, Fig. 2 right).

    ``P_o`` goes through a PointNet and ``R_o`` through a three-layer MLP, each to a ``width``
    code; ``b`` and the standardised ``X_0`` are used as they are. Each becomes one condition token
    of the :class:`TransformerDenoiser` (whose per-condition Linear projects it), next to the step
    token and one token per frame. Motions live in standardised space (``state_mean``,
    ``state_std``, buffers saved with the weights).

    Args:
        config: a :class:`MotionModelConfig`.
        state_mean, state_std: ``(336,)`` normalisation statistics
            (:meth:`InteractionTensors.normalisation`); default 0 and 1 (e.g. before loading weights).
    """

    def __init__(self, config: MotionModelConfig, state_mean=None, state_std=None):
        super().__init__()
        self.config = config
        mean = torch.zeros(NIFTY_STATE_SIZE) if state_mean is None else as_tensor(state_mean, "state_mean")
        std = torch.ones(NIFTY_STATE_SIZE) if state_std is None else as_tensor(state_std, "state_std")
        check_shape(mean, (NIFTY_STATE_SIZE,), "state_mean")
        check_shape(std, (NIFTY_STATE_SIZE,), "state_std")
        if not bool((std > 0).all()):
            raise ValueError("state_std: expected every value > 0")
        self.register_buffer("state_mean", mean.detach().to(torch.float32).clone())
        self.register_buffer("state_std", std.detach().to(torch.float32).clone())
        width = config.width
        self.point_encoder = PointNetEncoder(width, hidden=tuple(config.pointnet_hidden))
        self.pose_encoder = MLP(OBJECT_POSE_SIZE, [width, width], width, activation="gelu")
        self.denoiser = TransformerDenoiser(
            NIFTY_STATE_SIZE,
            {"object_points": width, "object_pose": width, "betas": NUM_BETAS, "start_pose": NIFTY_STATE_SIZE},
            width=width, layers=config.layers, heads=config.heads, dropout=config.dropout,
            max_len=config.max_frames)

    def normalise(self, states: torch.Tensor) -> torch.Tensor:
        """``(..., 336)`` states -> standardised states."""
        return (states - self.state_mean) / self.state_std

    def denormalise(self, x: torch.Tensor) -> torch.Tensor:
        """``(..., 336)`` standardised states -> states (metres, radians, per second)."""
        return x * self.state_std + self.state_mean

    def encode_condition(self, cond: dict) -> dict:
        """Encode a raw condition once (for sampling, where it is reused at every step).

        Args:
            cond: ``{"points": (B, P, 3) metres, "object_pose": (B, 12), "betas": (B, 10),
                "start_pose": (B, 336) un-normalised}``.
        Returns:
            ``{name: (B, d)}`` as the :class:`TransformerDenoiser` takes it.
        """
        if not isinstance(cond, dict) or set(cond) != set(CONDITION_KEYS):
            got = sorted(cond) if isinstance(cond, dict) else type(cond).__name__
            raise ValueError(f"cond: expected a dict with the keys {list(CONDITION_KEYS)}, got {got}")
        batch = cond["points"].shape[0]
        check_shape(cond["points"], (batch, None, 3), "cond['points']")
        check_shape(cond["object_pose"], (batch, OBJECT_POSE_SIZE), "cond['object_pose']")
        check_shape(cond["betas"], (batch, NUM_BETAS), "cond['betas']")
        check_shape(cond["start_pose"], (batch, NIFTY_STATE_SIZE), "cond['start_pose']")
        dtype = self.state_mean.dtype
        return {
            "object_points": self.point_encoder(cond["points"].to(dtype)),
            "object_pose": self.pose_encoder(cond["object_pose"].to(dtype)),
            "betas": cond["betas"].to(dtype),
            "start_pose": self.normalise(cond["start_pose"].to(dtype)),
        }

    def denoise(self, x_k: torch.Tensor, k: torch.Tensor, encoded: dict, drop_cond: Optional[torch.Tensor] = None,
                padding_mask: Optional[torch.Tensor] = None) -> torch.Tensor:
        """:meth:`forward` with a condition already passed through :meth:`encode_condition`."""
        return self.denoiser(x_k, k, encoded, drop_cond, padding_mask)

    def forward(self, x_k: torch.Tensor, k: torch.Tensor, cond: dict, drop_cond: Optional[torch.Tensor] = None,
                padding_mask: Optional[torch.Tensor] = None) -> torch.Tensor:
        """Predict the clean motion (NIFTY §3.1: ``τ̂^0 = M_θ(τ^k, k, C)``).

        Args:
            x_k: ``(B, T, 336)`` noisy standardised motion, ``T ≤ max_frames``.
            k: ``(B,)`` int64 diffusion steps.
            cond: the raw condition (see :meth:`encode_condition`).
            drop_cond: ``(B,)`` bool, True where the whole condition is replaced by the learned
                null tokens (classifier-free guidance).
            padding_mask: ``(B, T)`` bool, True for frames nothing may attend to.
        Returns:
            ``(B, T, 336)`` x̂0, standardised.
        """
        return self.denoise(x_k, k, self.encode_condition(cond), drop_cond, padding_mask)


def build_motion_model(config: MotionModelConfig, state_mean=None, state_std=None) -> NiftyMotionModel:
    """A freshly initialised model, its weights seeded by ``config.seed`` (global RNG untouched)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return NiftyMotionModel(config, state_mean, state_std)


# --------------------------------------------------------------------------- training


@single_threaded
def train_motion_model(tensors: InteractionTensors, config: MotionModelConfig, device="cpu",
                       progress: bool = False) -> tuple[NiftyMotionModel, TrainResult]:
    """Train the motion model with the x0 loss (NIFTY §3.1): k uniform, L2 on x̂0, condition dropped 10 %.

    Padded frames count in the loss (Appendix B pads with the last frame and trains on it).
    Runs on one CPU thread, which is faster than two for the toy sizes on a two-core machine.

    Args:
        tensors: the training sequences (``tensors.max_frames`` must equal ``config.max_frames``).
        config: the model and training settings.
        device: ``"cpu"``, ``"cuda"``, ``"auto"``, ...; the model is returned there.
        progress: True always shows training's progress bar; False, where ``infra.progress`` shows one (a notebook).
    Returns:
        ``(model in eval mode, TrainResult)``.
    """
    if not isinstance(tensors, InteractionTensors):
        raise TypeError(f"tensors: expected InteractionTensors, got {type(tensors).__name__}")
    if tensors.max_frames != config.max_frames:
        raise ValueError(f"tensors: {tensors.max_frames} frames per sequence, but config.max_frames is "
                         f"{config.max_frames}")
    mean, std = tensors.normalisation()
    model = build_motion_model(config, mean, std)
    data = model.normalise(tensors.states)
    conditions = tensors.condition()
    result = train_denoiser(model, data, conditions, config.noise_schedule(),
                            trainer_config(config, device=device, progress=progress), p_uncond=config.p_uncond)
    return model.eval(), result


# The code a trained motion model depends on: its own, its networks', its trainer's, its data pipeline's
# and the toy world's (package-relative module names).
_MODEL_CODE = ("..nn.diffusion", "..nn.transformer", "..nn.pointnet", "..nn.mlp", "..infra.training", "..world",
               ".data", ".rollout", ".motion_prior", ".anchors")


def model_code() -> tuple:
    """The modules a trained motion model depends on, its data pipeline and the toy world included (its
    cache key's code: a change to any of them retrains the model)."""
    return (sys.modules[__name__],) + tuple(importlib.import_module(name, __package__) for name in _MODEL_CODE)


def trained_motion_model(dataset, config: MotionModelConfig, device="cpu", progress: bool = False):
    """The motion model for a synthetic dataset, trained once and then loaded from the artifact cache.

    Args:
        dataset: a ``nifty.data.SyntheticDataset`` (its ``sequences`` are the training data).
        config: a :class:`MotionModelConfig`.
        device: where to train (the returned model is on the CPU).
        progress: True always shows training's progress bar; False, where ``infra.progress`` shows one (a notebook).
    Returns:
        a :class:`~hoi_tutorial.infra.TrainedModel`: the model in eval mode on the CPU, its losses and
        training seconds, and ``details["n_sequences"]``, the training sequences.
    """
    if config.action != dataset.config.action:
        raise ValueError(f"config.action: {config.action!r}, but the dataset is {dataset.config.action!r}")

    def build():
        tensors = InteractionTensors.from_sequences(dataset.sequences, config.max_frames, config.n_points, config.seed)
        model, result = train_motion_model(tensors, config, device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_sequences": len(tensors)}

    key = {"data": dataclasses.asdict(dataset.config), "model": dataclasses.asdict(config)}
    artifact = load_or_build(f"nifty_{config.action}_motion_model", key, build, code=model_code())
    model = NiftyMotionModel(config)
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"],
                        {"n_sequences": artifact["n_sequences"]})


# --------------------------------------------------------------------------- sampling


def _repeat_rows(value: torch.Tensor, times: int) -> torch.Tensor:
    return value.repeat_interleave(times, dim=0) if times > 1 else value


@single_threaded
def sample_motions(model: NiftyMotionModel, cond: dict, config: Optional[MotionModelConfig] = None, *,
                   generator: torch.Generator, guidance: Optional[Callable[[torch.Tensor], torch.Tensor]] = None,
                   alpha=0.0, n_samples: int = 1, guidance_scale: Optional[float] = None,
                   guidance_steps=None, device=None) -> torch.Tensor:
    """Draw motions for a batch of conditions (NIFTY §3.1 "Sampling and Guidance").

    Ancestral sampling from ``K`` steps with the classifier-free guided
    ``x̂0 = M(τ^k, k) + s (M(τ^k, k, C) − M(τ^k, k))`` and, when ``guidance`` is given,
    reconstruction guidance ``x̃0 = x̂0 − α ∇_{τ^k} G(x̂0)`` (NIFTY Eq. 4) on every step but the last
    (``guidance_steps``; the Trace and Pace code NIFTY follows skips the last step, §3.2 says "at every
    denoising step").

    Args:
        model: a trained :class:`NiftyMotionModel` (its device is used unless ``device`` is given).
        cond: the raw condition of ``B`` scenes (``CONDITION_KEYS``, batch first), e.g.
            ``tensors.condition(index)`` or stacked :func:`interaction_condition` dicts.
        config: gives ``guidance_scale`` and K (default ``model.config``).
        generator: ``torch.Generator`` for all noise.
        guidance: ``G: states (B·n_samples, T, 336) un-normalised, canonical frame -> (B·n_samples,)``,
            lower is better, differentiable; or ``None``.
        alpha: the guidance step size α (or a function ``k -> α``).
        n_samples: samples per condition (NIFTY: 10, the best kept by the guidance objective).
        guidance_scale: overrides ``config.guidance_scale`` (``s``; 1 = conditional, 0 = unconditional).
        guidance_steps: the steps k that get guidance (default ``1 … K−1``; ``range(K)`` includes the last).
        device: where to sample.
    Returns:
        ``(B·n_samples, T, 336)`` states (un-normalised, each in its scene's canonical frame, on the
        CPU), condition-major: row ``i·n_samples + j`` is sample ``j`` of condition ``i``. Runs on one
        CPU thread (faster for these small batches on a two-core machine).
        :func:`sample_motions_with_record` also keeps every denoising step.
    """
    return _sample_motions(model, cond, config, generator, guidance, alpha, n_samples, guidance_scale, device,
                           with_record=False, guidance_steps=guidance_steps)


@single_threaded
def sample_motions_with_record(model: NiftyMotionModel, cond: dict, config: Optional[MotionModelConfig] = None, *,
                               generator: torch.Generator, guidance=None, alpha=0.0, n_samples: int = 1,
                               guidance_scale: Optional[float] = None, guidance_steps=None,
                               device=None) -> SamplingRecord:
    """:func:`sample_motions`, keeping each denoising step (for plots).

    Same arguments and noise draws as :func:`sample_motions`. Returns a
    :class:`~hoi_tutorial.nn.diffusion.SamplingRecord` whose ``sample`` is the states
    :func:`sample_motions` returns (un-normalised, CPU) and whose per-step ``x_k`` and ``x0_hat``
    are in the model's standardised space (``model.denormalise`` maps them to states).
    """
    return _sample_motions(model, cond, config, generator, guidance, alpha, n_samples, guidance_scale, device,
                           with_record=True, guidance_steps=guidance_steps)


def _sample_motions(model, cond, config, generator, guidance, alpha, n_samples, guidance_scale, device,
                    with_record: bool, guidance_steps=None):
    if not isinstance(model, NiftyMotionModel):
        raise TypeError(f"model: expected a NiftyMotionModel, got {type(model).__name__}")
    config = model.config if config is None else config
    if not isinstance(n_samples, int) or n_samples < 1:
        raise ValueError(f"n_samples: expected a positive int, got {n_samples!r}")
    scale = config.guidance_scale if guidance_scale is None else float(guidance_scale)
    device = torch.device(device) if device is not None else model.state_mean.device
    was_training = model.training
    model.to(device).eval()
    cond = {name: _repeat_rows(as_tensor(value, f"cond[{name!r}]").to(device), n_samples)
            for name, value in cond.items()} if isinstance(cond, dict) else cond
    with torch.no_grad():
        encoded = model.encode_condition(cond)
    batch = encoded["betas"].shape[0]
    shape = (batch, config.max_frames, NIFTY_STATE_SIZE)

    def x0_fn(x_k, k):
        return classifier_free_x0(model.denoise, x_k, k, encoded, scale)

    objective = None
    if guidance is not None:
        def objective(x0_hat):
            return guidance(model.denormalise(x0_hat))

    run = sample_with_record if with_record else sample
    out = run(x0_fn, shape, config.noise_schedule().to(device), generator=generator, guidance=objective,
              alpha=alpha, guidance_steps=guidance_steps, device=device)
    model.train(was_training)
    if with_record:
        return dataclasses.replace(out, sample=model.denormalise(out.sample).detach().cpu())
    return model.denormalise(out).detach().cpu()


def states_to_motions(states, betas, world_from_canonical, lengths=None) -> list[Motion]:
    """World-frame motions from generated states (NIFTY Appendix B).

    Joint rotations come from the 6D part; the root's ground-plane position is integrated from
    ``t^v`` and its height taken from ``t^p``
    (:func:`~hoi_tutorial.world.features.motion_from_nifty_state`); the result is moved from the
    canonical frame to the world.

    Args:
        states: ``(B, T, 336)`` Eq. 1 states, canonical frame.
        betas: ``(B, 10)`` or ``(10,)`` body shapes.
        world_from_canonical: ``(B, 4, 4)`` or ``(4, 4)`` rigid transforms, a yaw about +Z and a
            translation (as :func:`interaction_condition` gives).
        lengths: optional ``(B,)`` frames to keep per motion (drops the padding).
    Returns:
        a list of ``B`` ``Motion``s, world frame.
    """
    states = as_tensor(states, "states").detach().cpu()
    check_shape(states, (None, None, NIFTY_STATE_SIZE), "states")
    batch = states.shape[0]
    betas = as_tensor(betas, "betas").detach().cpu()
    if betas.dim() == 1:
        betas = betas.expand(batch, -1)
    check_shape(betas, (batch, NUM_BETAS), "betas")
    transforms = as_tensor(world_from_canonical, "world_from_canonical", dtype=torch.float64).detach().cpu()
    if transforms.dim() == 2:
        transforms = transforms.expand(batch, -1, -1)
    check_shape(transforms, (batch, 4, 4), "world_from_canonical")
    if lengths is not None:
        lengths = [int(n) for n in as_tensor(lengths, "lengths", dtype=torch.int64).reshape(-1)]
        if len(lengths) != batch or any(not 1 <= n <= states.shape[1] for n in lengths):
            raise ValueError(f"lengths: expected {batch} values in [1, {states.shape[1]}]")
    motions = []
    for i in range(batch):
        frames = states[i] if lengths is None else states[i, :lengths[i]]
        motion = motion_from_nifty_state(frames, betas[i], integrate_root=True)
        matrix = transforms[i]
        yaw = math.atan2(float(matrix[1, 0]), float(matrix[0, 0]))
        motions.append(motion.transformed(yaw, matrix[:3, 3].to(motion.root_position.dtype)))
    return motions


# --------------------------------------------------------------------------- evaluation helpers


def final_pelvis_distance(motion: Motion, obj) -> tuple[float, float]:
    """Ground-plane distances from the pelvis to the object's centre, at the last and first frame.

    The object's centre is its canonical origin, the centre of its footprint (as
    ``rollout.start_distance``). An interaction motion should end nearer than it started.

    Args:
        motion: a world-frame ``Motion``.
        obj: a placed object with ``pose`` ``(4, 4)`` world_from_object.
    Returns:
        ``(last, first)`` metres.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
    # The pelvis is the skeleton's root: forward kinematics puts it at root_position itself, in the joints' dtype, so
    # it is read from there without running FK over the motion (the same floats).
    dtype = torch.promote_types(motion.root_position.dtype, motion.local_rotations.dtype)
    centre = torch.as_tensor(np.asarray(obj.pose, dtype=np.float64)[:2, 3], dtype=dtype)
    pelvis = motion.root_position[[0, -1], :2].to(dtype)
    return float((pelvis[1] - centre).norm()), float((pelvis[0] - centre).norm())


def _in_root_frame(joints: torch.Tensor) -> torch.Tensor:
    """``(..., 22, 3)`` joints moved so their root frame is at the origin facing +Y."""
    origin, heading = root_frame(joints)
    rot_t = rotation_about_z(heading).transpose(-1, -2)
    return ((joints - origin[..., None, :]) @ rot_t.transpose(-1, -2))


def _in_object_frame(joints: torch.Tensor, obj) -> torch.Tensor:
    return torch.as_tensor(obj.to_canonical(joints.detach().double().cpu().numpy()), dtype=torch.float64)


def anchor_skeleton_distance(motion: Motion, anchors, obj=None) -> tuple[float, int]:
    """NIFTY's skeleton distance (§4.2, Appendix C.2): last frame vs the nearest anchor pose.

    ``min_a Σ_j ‖joints_j − anchor_{a,j}‖`` over the 22 joints
    (:func:`hoi_tutorial.metrics.skeleton_distance`). The poses are compared either in their own
    root frame (pelvis ground projection at the origin, facing +Y: pose only), or, with ``obj``,
    in the object's canonical frame (pose and placement relative to the object; each anchor in
    its own object's frame).

    Args:
        motion: a world-frame ``Motion``.
        anchors: a sequence of ``nifty.anchors.Anchor`` (``pose.joints (22, 3)``, ``obj``) or a
            ``(A, 22, 3)`` array of anchor joints in metres (root-frame comparison only).
        obj: the object of ``motion`` for the object-frame comparison, or ``None``.
    Returns:
        ``(distance in metres, index of the nearest anchor)``.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a Motion, got {type(motion).__name__}")
    final = motion.joints[-1].detach().double().cpu()
    if hasattr(anchors, "shape"):
        anchor_joints = as_tensor(anchors, "anchors", dtype=torch.float64).detach().cpu()
        check_shape(anchor_joints, (None, NUM_JOINTS, 3), "anchors")
        if obj is not None:
            raise ValueError("obj: an object-frame comparison needs Anchor records (with .obj), not joint arrays")
        return metrics.skeleton_distance(_in_root_frame(final), _in_root_frame(anchor_joints))
    anchors = list(anchors)
    if not anchors:
        raise ValueError("anchors: expected at least one anchor")
    joints = torch.stack([as_tensor(a.pose.joints, "anchor.pose.joints", dtype=torch.float64).detach().cpu()
                          for a in anchors])
    if obj is None:
        return metrics.skeleton_distance(_in_root_frame(final), _in_root_frame(joints))
    anchor_local = torch.stack([_in_object_frame(j, a.obj) for j, a in zip(joints, anchors)])
    return metrics.skeleton_distance(_in_object_frame(final, obj), anchor_local)
