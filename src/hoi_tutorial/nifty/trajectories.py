"""A small diffusion model over toy walking trajectories, guided by an analytic goal (NIFTY §3.1).

This is the guidance chapter's stepping stone to NIFTY: the "motion" is the pelvis trajectory
of a 2-second toy walk, ``τ ∈ R^{T×3}`` (T = 60 frames at 30 fps, metres), in NIFTY's canonical
frame (the first pose at the origin facing +Y, heights kept). An unconditional
:class:`~hoi_tutorial.nn.denoisers.MLPDenoiser` over the trajectory's smooth-basis code
(:class:`TrajectoryCodec`: 16 DCT coefficients per coordinate, standardised) is trained with
the x0 loss of :func:`~hoi_tutorial.nn.diffusion.training_loss`; at test time
:func:`end_position_objective` is the guidance objective G of NIFTY Eq. 4 on the last frame,
``G(τ) = ‖τ_T^{xy} − g‖²`` — the analytic stand-in for NIFTY's learned interaction field, which
is also evaluated on the last frame of the motion.

Data (:func:`make_walk_trajectories`): each clip starts standing at the origin facing +Y and walks
a smooth path through two random waypoints (``world.mocap.gait.walk_path``: random speed, step
length and style); the first ``T`` frames of the pelvis path are kept (a clip that stops earlier
is padded with its last frame, as NIFTY pads its sequences), and every path is added once more
mirrored left-right (x → −x).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable, Optional

import numpy as np
import torch

from .._validate import as_tensor, check_numbers, check_shape
from ..infra.presets import scaled_config
from ..infra.seeding import rng as make_rng
from ..infra.device import single_threaded
from ..infra.cache import load_or_build, state_dict_to_cpu
from ..infra.training import TrainedModel, TrainResult, trainer_config
from ..nn.denoisers import MLPDenoiser
from ..nn.diffusion import NoiseSchedule, SamplingRecord, cosine_schedule, sample, sample_with_record, train_denoiser
from ..world.features import canonical_transform
from ..world.mocap.gait import walk_path
from ..world.motion import FPS
from ..world.rotations import rotation_about_z

__all__ = [
    "WalkDataConfig",
    "WALK_DATA_SCALES",
    "walk_data_config",
    "random_walk_waypoints",
    "canonical_pelvis_trajectory",
    "make_walk_trajectories",
    "dct_basis",
    "TrajectoryCodec",
    "TrajectoryModelConfig",
    "TRAJECTORY_MODEL_SCALES",
    "trajectory_model_config",
    "build_trajectory_denoiser",
    "train_trajectory_denoiser",
    "walk_trajectories",
    "trained_trajectory_denoiser",
    "sample_walks",
    "sample_walks_with_record",
    "end_position_objective",
    "path_statistics",
]


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class WalkDataConfig:
    """How the toy walking trajectories are made.

    The defaults are the ``toy`` preset; :func:`walk_data_config` gives every scale.

    Attributes:
        n_clips: walks generated (the data set holds twice as many paths: each is also mirrored).
        frames: frames kept per clip (60 = 2 s at 30 fps at ``toy``; NIFTY: up to 150).
        first_leg: range of the distance to the first waypoint, straight ahead, metres.
        turn_deg: range of the turn at the first waypoint, degrees (positive: to the left).
        second_leg: range of the distance from the first to the second waypoint, metres.
        seed: seeds the waypoints and the walking styles.
    """

    n_clips: int = 600
    frames: int = 60
    first_leg: tuple = (0.5, 1.0)
    turn_deg: tuple = (-75.0, 75.0)
    second_leg: tuple = (0.8, 2.5)
    seed: int = 0

    def __post_init__(self):
        if isinstance(self.n_clips, bool) or not isinstance(self.n_clips, int) or self.n_clips < 1:
            raise ValueError(f"n_clips: expected a positive int, got {self.n_clips!r}")
        if isinstance(self.frames, bool) or not isinstance(self.frames, int) or self.frames < 2:
            raise ValueError(f"frames: expected an int >= 2, got {self.frames!r}")


# What the larger scales change from the defaults (the toy preset); NIFTY's motions are 150 frames.
WALK_DATA_SCALES = {
    "small": {"n_clips": 3000, "frames": 120},
    "paper": {"n_clips": 10000, "frames": 150},
}


def walk_data_config(scale: str = "toy", **overrides) -> WalkDataConfig:
    """The data configuration of a scale preset (``"toy"``: 600 walks of 2 s), fields overridable."""
    return scaled_config(WalkDataConfig, scale, WALK_DATA_SCALES, overrides, factory="walk_data_config")


def random_walk_waypoints(generator: np.random.Generator, config: WalkDataConfig) -> np.ndarray:
    """``(3, 2)`` ground waypoints in metres: the origin, a point straight ahead (+Y), a turn.

    Args:
        generator: numpy random generator (advanced by the draw).
        config: the ranges of the legs and of the turn.
    """
    first = generator.uniform(*config.first_leg)
    turn = math.radians(generator.uniform(*config.turn_deg))
    second = generator.uniform(*config.second_leg)
    p1 = np.array([0.0, first])
    # Heading θ faces (−sin θ, cos θ): positive turns go left, as rotation_about_z.
    p2 = p1 + second * np.array([-math.sin(turn), math.cos(turn)])
    return np.stack([np.zeros(2), p1, p2])


def canonical_pelvis_trajectory(motion, frames: int) -> torch.Tensor:
    """The first ``frames`` pelvis positions of ``motion`` in its canonical frame (NIFTY §3.1).

    The canonical frame puts frame 0's pelvis over the origin facing +Y (facing from the hips,
    :func:`hoi_tutorial.world.features.canonical_transform`); heights are kept. A clip shorter
    than ``frames`` is padded with its last position.

    Args:
        motion: a ``world.Motion``.
        frames: number of frames to return.

    Returns:
        ``(frames, 3)`` float32 metres.
    """
    yaw, translation = canonical_transform(motion)
    rotation = rotation_about_z(torch.tensor(yaw, dtype=torch.float32))
    pelvis = motion.root_position[:frames].to(torch.float32) @ rotation.T + translation.to(torch.float32)
    if pelvis.shape[0] < frames:
        pelvis = torch.cat([pelvis, pelvis[-1:].expand(frames - pelvis.shape[0], 3)])
    return pelvis


@single_threaded  # many small ops (gait synthesis, forward kinematics): one CPU thread is fastest
def make_walk_trajectories(config: WalkDataConfig) -> torch.Tensor:
    """Generate the walking data set (see the module docstring).

    Args:
        config: a :class:`WalkDataConfig`.

    Returns:
        ``(2 · n_clips, frames, 3)`` float32 pelvis trajectories in metres, canonical frame: the
        first ``n_clips`` as walked, then the same paths mirrored (x → −x).
    """
    generator = make_rng(config.seed)
    paths = []
    for _ in range(config.n_clips):
        waypoints = random_walk_waypoints(generator, config)
        motion = walk_path(waypoints, seed=int(generator.integers(0, 2**31 - 1)))
        paths.append(canonical_pelvis_trajectory(motion, config.frames))
    walked = torch.stack(paths)
    mirrored = walked * torch.tensor([-1.0, 1.0, 1.0])
    return torch.cat([walked, mirrored])


def dct_basis(frames: int, n_coefficients: int) -> torch.Tensor:
    """``(frames, n_coefficients)`` orthonormal DCT-II basis: column m is ``cos(π (t + ½) m / T)``, normalised.

    Projecting a trajectory on the first columns keeps its slow, smooth part; a 2-second pelvis
    path needs about 16 of them for millimetre accuracy (the step bob is the fastest part).
    """
    if not 1 <= n_coefficients <= frames:
        raise ValueError(f"n_coefficients: expected an int in [1, frames={frames}], got {n_coefficients!r}")
    t = torch.arange(frames, dtype=torch.float64)
    basis = torch.stack([torch.cos(math.pi * (t + 0.5) * m / frames) for m in range(n_coefficients)], dim=1)
    return (basis / basis.norm(dim=0)).to(torch.float32)


@dataclass
class TrajectoryCodec:
    """Trajectories ↔ the diffusion model's vectors: smooth-basis coefficients, standardised.

    ``encode``: ``τ (B, T, 3)`` metres → ``c = Bᵀτ`` (the first ``M`` DCT coefficients of each
    coordinate, :func:`dct_basis`) → ``(c − mean) / std`` per coefficient. ``decode`` inverts it
    (``τ = B c``, up to the discarded fast components) and is differentiable, so a guidance
    objective written in metres can be applied to the model's output. Standardising is what MDM
    does with its features; the smooth basis makes every decoded sample smooth by construction.

    Attributes:
        basis: ``(T, M)`` orthonormal columns.
        mean: ``(M, 3)`` coefficient means.
        std: ``(M, 3)`` coefficient standard deviations (floored at 0.1 mm).
    """

    basis: torch.Tensor
    mean: torch.Tensor
    std: torch.Tensor

    @classmethod
    def fit(cls, trajectories: torch.Tensor, n_coefficients: int) -> "TrajectoryCodec":
        """From ``trajectories: (N, T, 3)`` metres, keeping ``n_coefficients`` per coordinate."""
        trajectories = as_tensor(trajectories, "trajectories")
        check_shape(trajectories, (None, None, 3), "trajectories")
        basis = dct_basis(trajectories.shape[1], n_coefficients)
        coefficients = torch.einsum("tm,btc->bmc", basis, trajectories)
        return cls(basis=basis, mean=coefficients.mean(dim=0), std=coefficients.std(dim=0).clamp(min=1e-4))

    @property
    def frames(self) -> int:
        """T, frames per trajectory."""
        return int(self.basis.shape[0])

    @property
    def shape(self) -> tuple:
        """``(M, 3)``, the shape of one encoded trajectory."""
        return tuple(self.mean.shape)

    def encode(self, trajectories: torch.Tensor) -> torch.Tensor:
        """``(B, T, 3)`` metres → ``(B, M, 3)`` standardised coefficients."""
        check_shape(trajectories, (None, self.frames, 3), "trajectories")
        coefficients = torch.einsum("tm,btc->bmc", self.basis.to(trajectories), trajectories)
        return (coefficients - self.mean.to(trajectories)) / self.std.to(trajectories)

    def decode(self, x: torch.Tensor) -> torch.Tensor:
        """``(B, M, 3)`` standardised coefficients → ``(B, T, 3)`` metres (differentiable)."""
        check_shape(x, (None,) + self.shape, "x")
        coefficients = x * self.std.to(x) + self.mean.to(x)
        return torch.einsum("tm,bmc->btc", self.basis.to(x), coefficients)

    def state(self) -> dict:
        """The tensors, for the artifact cache (rebuild with ``TrajectoryCodec(**state)``)."""
        return {"basis": self.basis.detach().cpu(), "mean": self.mean.detach().cpu(), "std": self.std.detach().cpu()}


# --------------------------------------------------------------------------- model


@dataclass(frozen=True)
class TrajectoryModelConfig:
    """The trajectory denoiser and its training.

    The defaults are the ``toy`` preset; :func:`trajectory_model_config` gives every scale.

    Attributes:
        n_coefficients: smooth-basis coefficients per coordinate (:class:`TrajectoryCodec`).
        diffusion_steps: K (NIFTY: 1000; 100 at ``toy``).
        width, depth, time_embed_dim: the :class:`MLPDenoiser` over the flattened coefficients.
        steps, batch_size, lr: optimisation (AdamW).
        lr_schedule, warmup_steps: the learning-rate schedule after a linear warm-up (cosine decay).
        seed: seeds the initial weights and the batches.
    """

    n_coefficients: int = 16
    diffusion_steps: int = 100
    width: int = 256
    depth: int = 3
    time_embed_dim: int = 64
    steps: int = 3000
    batch_size: int = 128
    lr: float = 1e-3
    lr_schedule: str = "cosine"
    warmup_steps: int = 100
    seed: int = 0

    def noise_schedule(self) -> NoiseSchedule:
        """The cosine schedule with ``diffusion_steps`` steps (MDM's and NIFTY's choice)."""
        return cosine_schedule(self.diffusion_steps)

    def __post_init__(self):
        check_numbers(self, ("lr",), above=0)


# What the larger scales change from the defaults (the toy preset).
TRAJECTORY_MODEL_SCALES = {
    "small": {"n_coefficients": 32, "diffusion_steps": 1000, "width": 512, "depth": 4, "steps": 30000},
    "paper": {"n_coefficients": 40, "diffusion_steps": 1000, "width": 512, "depth": 6, "steps": 100000},
}


def trajectory_model_config(scale: str = "toy", **overrides) -> TrajectoryModelConfig:
    """The model configuration of a scale preset, fields overridable."""
    return scaled_config(TrajectoryModelConfig, scale, TRAJECTORY_MODEL_SCALES, overrides,
                         factory="trajectory_model_config")


def build_trajectory_denoiser(config: TrajectoryModelConfig) -> MLPDenoiser:
    """A freshly initialised (seeded) unconditional denoiser of ``(B, n_coefficients, 3)`` codes.

    The codes are standardised, so the preconditioning uses σ_d = 1.
    """
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return MLPDenoiser(config.n_coefficients * 3, width=config.width, depth=config.depth,
                           time_embed_dim=config.time_embed_dim, schedule=config.noise_schedule(),
                           data_std=1.0)


@single_threaded  # a small MLP: one CPU thread is fastest
def train_trajectory_denoiser(config: TrajectoryModelConfig, trajectories: torch.Tensor, device="cpu",
                              progress: bool = False) -> tuple[MLPDenoiser, TrajectoryCodec, TrainResult]:
    """Fit the codec and train the unconditional trajectory denoiser with the x0 loss (NIFTY §3.1).

    Args:
        config: a :class:`TrajectoryModelConfig`.
        trajectories: ``(N, T, 3)`` metres, canonical frame (:func:`make_walk_trajectories`).
        device: where to train; the model stays there.
        progress: True always shows training's progress bar; False, where ``infra.progress`` shows one (a notebook).

    Returns:
        ``(model in eval mode, codec, TrainResult)``.
    """
    trajectories = as_tensor(trajectories, "trajectories")
    check_shape(trajectories, (None, None, 3), "trajectories")
    codec = TrajectoryCodec.fit(trajectories, config.n_coefficients)
    model = build_trajectory_denoiser(config)
    result = train_denoiser(model, codec.encode(trajectories), None, config.noise_schedule(),
                            trainer_config(config, device=device, progress=progress), p_uncond=0.0)
    return model.eval(), codec, result


def walk_trajectories(config: WalkDataConfig) -> torch.Tensor:
    """:func:`make_walk_trajectories` through the artifact cache (made once, then loaded)."""
    return load_or_build("walk_trajectories", config, lambda: make_walk_trajectories(config))


def trained_trajectory_denoiser(walk_config: WalkDataConfig, config: TrajectoryModelConfig, device="cpu",
                                progress: bool = False) -> TrainedModel:
    """The trajectory denoiser trained on the walks of ``walk_config``, once, then from the cache.

    Returns:
        a :class:`~hoi_tutorial.infra.TrainedModel` (the denoiser in eval mode on the CPU, its
        losses and training seconds) whose ``details["codec"]`` is the :class:`TrajectoryCodec`
        its samples are decoded with.
    """
    def build():
        model, codec, result = train_trajectory_denoiser(config, walk_trajectories(walk_config), device=device,
                                                         progress=progress)
        return {"state": state_dict_to_cpu(model), "codec": codec.state(), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds)}

    artifact = load_or_build("walk_trajectory_denoiser", {"data": walk_config, "model": config}, build)
    model = build_trajectory_denoiser(config)
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"],
                        {"codec": TrajectoryCodec(**artifact["codec"])})


@single_threaded
def sample_walks(model: torch.nn.Module, codec: TrajectoryCodec, schedule: NoiseSchedule, n: int, *,
                 generator: torch.Generator, objective: Optional[Callable[[torch.Tensor], torch.Tensor]] = None,
                 alpha: float = 0.0, device=None) -> torch.Tensor:
    """Draw walks from the trajectory model, optionally guided (NIFTY Eq. 4).

    ``objective`` is written in metres; it is composed with :meth:`TrajectoryCodec.decode`, so the
    guidance gradient ``∇_{x_k} G(decode(x̂0))`` flows through the decoder and the denoiser to the
    noisy input (:func:`hoi_tutorial.nn.diffusion.guided_x0`).

    Args:
        model: the trained denoiser (``model(x_k, k, None, None)`` on ``(B, M, 3)`` codes).
        codec: the data set's :class:`TrajectoryCodec`.
        schedule: the noise schedule the model was trained with.
        n: number of walks.
        generator: ``torch.Generator`` for all noise.
        objective: ``G: trajectories (B, T, 3) metres -> (B,)``, or ``None`` for unguided samples.
        alpha: guidance step size α.
        device: where to sample (default: the model's device).

    Returns:
        ``(n, T, 3)`` walks in metres (CPU).
    """
    return _sample_walks(model, codec, schedule, n, generator, objective, alpha, device, with_record=False)


@single_threaded
def sample_walks_with_record(model: torch.nn.Module, codec: TrajectoryCodec, schedule: NoiseSchedule, n: int, *,
                             generator: torch.Generator, objective=None, alpha: float = 0.0,
                             device=None) -> SamplingRecord:
    """:func:`sample_walks`, keeping each denoising step: a
    :class:`~hoi_tutorial.nn.diffusion.SamplingRecord` whose ``sample`` is the walks in metres
    (CPU) and whose per-step ``x_k``, ``x0_hat`` are codes (``codec.decode`` maps them to metres)."""
    return _sample_walks(model, codec, schedule, n, generator, objective, alpha, device, with_record=True)


def _sample_walks(model, codec, schedule, n, generator, objective, alpha, device, with_record: bool):
    device = device or next(model.parameters()).device
    shape = (int(n),) + codec.shape
    guidance = None
    if objective is not None:
        def guidance(x0_hat):
            return objective(codec.decode(x0_hat))
    run = sample_with_record if with_record else sample
    out = run(lambda x, k: model(x, k, None, None), shape, schedule.to(device), generator=generator,
              guidance=guidance, alpha=alpha, device=device)
    if with_record:
        return dataclasses.replace(out, sample=codec.decode(out.sample).cpu())
    return codec.decode(out).cpu()


# --------------------------------------------------------------------------- objectives and statistics


def end_position_objective(target_xy) -> Callable[[torch.Tensor], torch.Tensor]:
    """``G(τ) = ‖τ_T^{xy} − g‖²``: squared ground distance of the last frame to a goal (NIFTY Eq. 4).

    NIFTY guides with an objective on the last frame of the motion (its learned interaction
    field); this is the analytic version: "end the walk at g".

    Args:
        target_xy: ``(2,)`` or ``(B, 2)`` goal position(s) on the ground, metres, canonical frame.

    Returns:
        ``G: trajectories (B, T, 3) metres -> (B,)`` in m², differentiable.
    """
    target = as_tensor(target_xy, "target_xy")
    if target.dim() == 1:
        check_shape(target, (2,), "target_xy")
    else:
        check_shape(target, (None, 2), "target_xy")

    def objective(trajectories: torch.Tensor) -> torch.Tensor:
        check_shape(trajectories, (None, None, 3), "trajectories")
        goal = target.to(trajectories)
        if goal.dim() == 2 and goal.shape[0] != trajectories.shape[0]:
            raise ValueError(f"target_xy: {goal.shape[0]} goals for {trajectories.shape[0]} trajectories")
        return ((trajectories[:, -1, :2] - goal) ** 2).sum(dim=-1)

    return objective


def path_statistics(trajectories, fps: float = FPS) -> dict:
    """Per-path plausibility measures of pelvis trajectories, to compare samples with the data.

    Args:
        trajectories: ``(N, T, 3)`` metres.
        fps: frames per second.

    Returns:
        dict of ``(N,)`` tensors: ``"mean_speed"`` and ``"max_speed"`` (ground speed, m/s),
        ``"mean_acceleration"`` (ground, m/s²), ``"path_length"`` (m), ``"end_distance"``
        (ground distance from start to end, m) and ``"height_range"`` (max − min pelvis height, m).
    """
    trajectories = as_tensor(trajectories, "trajectories").detach().cpu()
    check_shape(trajectories, (None, None, 3), "trajectories")
    if trajectories.shape[1] < 3:
        raise ValueError(f"trajectories: expected at least 3 frames, got {trajectories.shape[1]}")
    ground = trajectories[..., :2]
    velocity = (ground[:, 1:] - ground[:, :-1]) * fps
    speed = velocity.norm(dim=-1)
    acceleration = ((velocity[:, 1:] - velocity[:, :-1]) * fps).norm(dim=-1)
    height = trajectories[..., 2]
    return {
        "mean_speed": speed.mean(dim=1),
        "max_speed": speed.max(dim=1).values,
        "mean_acceleration": acceleration.mean(dim=1),
        "path_length": (speed / fps).sum(dim=1),
        "end_distance": (ground[:, -1] - ground[:, 0]).norm(dim=-1),
        "height_range": height.max(dim=1).values - height.min(dim=1).values,
    }
