"""The controller's network and its training (CHOICE §5.1, Fig. 4, Eq. 13): steps 1 and 3 of the algorithm box in
``choice.controller``, with its configuration.

:func:`controller_data` cuts the toy clips into frames (``features.clip_features``); :class:`ControllerNet` is
Fig. 4's gated mixture of experts; :func:`train_controller` fits it, teacher-forced and then unrolled on its own
predictions; :func:`trained_controller` trains once and then loads from the artifact cache.
"""
from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from typing import NamedTuple, Optional

import torch
from torch import nn

from ..._validate import check_numbers, check_positive_ints, check_shape
from ...infra import TrainedModel, load_or_build, scaled_config, single_threaded, state_dict_to_cpu, train, trainer_config
from ...nn.moe import MoEMLP
from ...world import mocap
from ...world.motion import FPS
from . import phase
from .features import (CLIP_KINDS, KEY_JOINTS, PAST, SAMPLE_STEP, TRANSFORM, WINDOW, clip_features, io_layouts,
                       next_key_trajectories, next_root_trajectory)
from .phase import PhaseAutoencoder

__all__ = ["ControllerConfig", "CONTROLLER_SCALES", "controller_config", "ControllerData", "controller_data",
           "ControllerNet", "build_controller", "train_controller", "trained_controller"]

# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class ControllerConfig:
    """The controller, its data and its training (defaults: the ``toy`` preset).

    Attributes:
        clips: toy clips trained on, per kind.
        kinds: the ``world.mocap`` kinds of the clips, each with one hand keyframe (``meta["anchor_frame"]``):
            any of :data:`CLIP_KINDS`.
        hidden: the main network's width (CHOICE §8.1: 512).
        gating_hidden: the gating network's width (CHOICE §8.1: 128).
        n_experts: experts of the MoE (not stated by CHOICE; DeepPhase: 8).
        steps, batch_size, lr, lr_schedule, grad_clip, optimizer: training (CHOICE: 150 epochs, 8 h).
        phase_noise: standard deviation of Eq. 13's noise (CHOICE: 0.1).
        phase_dropout: probability that a training sample's goal phase is zeroed (ours; the ``"none"`` variant).
        key_noise: standard deviation of the noise on the key-joint trajectory input in training, metres and 6D
            units (ours, as Eq. 13 noises the goal phase: without it the network leans on the recorded future and
            its own fed-back trajectories drive it off).
        unroll, unroll_steps: the last ``unroll_steps`` of the ``steps`` run the network ``unroll`` frames on its
            own predicted pose, phase and trajectories (ours; see :func:`train_controller`).
        blend_radius: metres; the ego/goal-centric blend weight reaches 1 at the goal (ours).
        phase_scale, phase_steps: the PAE's preset and, when not ``None``, its training steps.
        seed: seeds the clips, the PAE, the weights, the batches and the noise.
    """

    clips: int = 48
    kinds: tuple = ("reach_grasp",)
    hidden: int = 128
    gating_hidden: int = 64
    n_experts: int = 4
    steps: int = 2400
    batch_size: int = 32
    lr: float = 1e-3
    lr_schedule: str = "cosine"
    grad_clip: Optional[float] = 1.0
    optimizer: str = "adam"
    phase_noise: float = 0.1
    phase_dropout: float = 0.2
    key_noise: float = 0.1
    unroll: int = 6
    unroll_steps: int = 400
    blend_radius: float = 1.0
    phase_scale: str = "toy"
    phase_steps: Optional[int] = None
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("clips", "hidden", "gating_hidden", "n_experts", "steps", "batch_size", "unroll"))
        if isinstance(self.unroll_steps, bool) or not isinstance(self.unroll_steps, int) \
                or not 0 <= self.unroll_steps <= self.steps:
            raise ValueError(f"unroll_steps: expected an int in [0, steps={self.steps}], got {self.unroll_steps!r}")
        for name in ("phase_noise", "key_noise"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name}: expected a standard deviation >= 0, got {getattr(self, name)!r}")
        if not 0 <= self.phase_dropout < 1:
            raise ValueError(f"phase_dropout: expected a probability in [0, 1), got {self.phase_dropout!r}")
        if self.phase_steps is not None:
            check_positive_ints(self, ("phase_steps",))
        kinds = self.kinds
        if isinstance(kinds, str) or not isinstance(kinds, tuple) or not kinds or len(set(kinds)) < len(kinds) \
                or not all(k in CLIP_KINDS for k in kinds):
            raise ValueError(f"kinds: expected a tuple of distinct names from {CLIP_KINDS}, got {kinds!r}")
        check_numbers(self, ("lr", "blend_radius"), above=0)
        check_numbers(self, ("phase_noise", "key_noise"), at_least=0)
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)


# CHOICE §8.1: gating 3 x 128, main network 3 x 512, 150 epochs over 70 % of ~150 x 3 min at 60 fps.
CONTROLLER_SCALES = {
    "small": {"clips": 64, "hidden": 256, "gating_hidden": 128, "n_experts": 8, "steps": 8000,
              "phase_scale": "small"},
    "paper": {"clips": 400, "hidden": 512, "gating_hidden": 128, "n_experts": 8, "steps": 200000, "batch_size": 64,
              "lr": 1e-4, "phase_scale": "paper"},
}


def controller_config(scale: str = "toy", **overrides) -> ControllerConfig:
    """The preset for ``scale``, fields overridable (``controller_config("toy", steps=100)``)."""
    return scaled_config(ControllerConfig, scale, CONTROLLER_SCALES, overrides, factory="controller_config")


# ----------------------------------------------------------------------------- data


class ControllerData(NamedTuple):
    """Every frame ``t`` of the training clips that has a next frame.

    Attributes:
        x: (N, in) the inputs (goal phase without noise). y: (N, out) the targets.
        phase_variance: (C, 3) ``σ̄``, the variance of ``[S, A, F]`` over the frames.
        clip: (N,) long, the clip of each frame (frames of a clip are consecutive); None: one clip.
        amplitude_max: the largest PAE amplitude over the frames (the run time's ``A_max``, as chapter 18 takes
            it from the data: CHOICE's ``A_max = 1`` is for its normalised latents).
    """

    x: torch.Tensor
    y: torch.Tensor
    phase_variance: torch.Tensor
    clip: Optional[torch.Tensor] = None
    amplitude_max: float = 1.0


def controller_data(config: ControllerConfig, pae: PhaseAutoencoder) -> ControllerData:
    """The training frames of ``config.clips`` toy clips of each of ``config.kinds`` (seeded by ``config.seed``)."""
    clips = mocap.generate_dataset(config.clips, seed=config.seed, kinds=config.kinds)
    parts = [clip_features(clip, pae) for clip in clips]
    states = torch.cat([s for _, _, s in parts])
    clip = torch.cat([torch.full((len(x),), i, dtype=torch.long) for i, (x, _, _) in enumerate(parts)])
    return ControllerData(torch.cat([x for x, _, _ in parts]), torch.cat([y for _, y, _ in parts]), states.var(0), clip,
                          float(states[..., 1].max()))  # [S, A, F]: the amplitudes


# ----------------------------------------------------------------------------- the network


class ControllerNet(nn.Module):
    """The MoE controller of Fig. 4: ``X_t (B, in) -> Y_{t+1} (B, out)``.

    The gating network compares the key joints' transformations and the phase, now and at the goal (Fig. 4): the
    hip's and wrists' position and 6D rotation at ``t`` and the four key joints' at the goal keyframe, with the
    current and goal phase-manifold features ``A·(sin, cos)`` (all standardised); the main network
    ``nn.moe.MoEMLP`` sees the whole standardised input. Inputs and outputs are standardised with buffers set from
    the training data. The trained PAE rides along, frozen, as
    ``phase_model`` (a rollout's first phase comes from it).
    """

    def __init__(self, pae: PhaseAutoencoder, hidden: int, gating_hidden: int, n_experts: int):
        super().__init__()
        self.channels = pae.channels
        (self.x_layout, self.in_size), (self.y_layout, self.out_size) = io_layouts(self.channels)
        C = self.channels
        gate = torch.zeros(self.in_size, dtype=torch.bool)
        for name in ("phase", "goal_phase"):  # the phase manifold A·(sin, cos), now and at the goal
            gate[self.x_layout[name].start:self.x_layout[name].start + 2 * C] = True
        keys = self.x_layout["keys"].start  # the hip's and wrists' transformations now (the trajectories' k = 0)
        gate[keys:keys + (len(KEY_JOINTS) - 1) * TRANSFORM] = True
        # the four key joints' at the goal keyframe (the window's pivot)
        goal = self.x_layout["goal"].start + (WINDOW // 2) * len(KEY_JOINTS) * TRANSFORM
        gate[goal:goal + len(KEY_JOINTS) * TRANSFORM] = True
        self.register_buffer("gating_mask", gate, persistent=False)
        self.net = MoEMLP(self.in_size, hidden, self.out_size, n_experts, gating_in=int(gate.sum()),
                          gating_hidden=gating_hidden)
        for name, size, fill in (("x_mean", self.in_size, 0.0), ("x_std", self.in_size, 1.0),
                                 ("y_mean", self.out_size, 0.0), ("y_std", self.out_size, 1.0)):
            self.register_buffer(name, torch.full((size,), fill))
        self.register_buffer("phase_variance", torch.ones(C, 3))
        self.register_buffer("phase_amplitude_max", torch.ones(()))
        self.phase_model = pae
        for p in pae.parameters():
            p.requires_grad_(False)

    def set_statistics(self, data: ControllerData) -> None:
        """Standardise with the data's mean and std (a constant coordinate keeps a unit scale); keep ``σ̄`` and the
        largest amplitude."""
        for name, values in (("x", data.x), ("y", data.y)):
            getattr(self, f"{name}_mean").copy_(values.mean(0))
            getattr(self, f"{name}_std").copy_(values.std(0).clamp_min(1e-3))
        self.phase_variance.copy_(data.phase_variance.clamp_min(1e-6))
        self.phase_amplitude_max.fill_(float(data.amplitude_max))

    def forward_standardised(self, xn: torch.Tensor) -> torch.Tensor:
        """``ŷ (B, out)`` standardised from ``xn (B, in)`` standardised."""
        return self.net(xn, xn[:, self.gating_mask])

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """``Y (B, out)`` in the data's units from ``X (B, in)``."""
        check_shape(x, (None, self.in_size), "x")
        return self.forward_standardised((x - self.x_mean) / self.x_std) * self.y_std + self.y_mean


def build_controller(config: ControllerConfig, pae: PhaseAutoencoder) -> ControllerNet:
    """A fresh controller for ``config`` on the PAE ``pae``, its weights seeded by ``config.seed``."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return ControllerNet(pae, config.hidden, config.gating_hidden, config.n_experts)


def _noised_inputs(x, layout, config: ControllerConfig, generator) -> torch.Tensor:
    """Eq. 13: ``N(0, phase_noise)`` on every goal phase feature, and the whole goal phase zeroed with
    probability ``phase_dropout`` (ours); ``N(0, key_noise)`` on the key-joint trajectories (ours). Returns a
    new ``x``."""
    x = x.clone()
    part = layout["goal_phase"]
    noise = torch.randn(x.shape[0], part.stop - part.start, generator=generator) * config.phase_noise
    keep = (torch.rand(x.shape[0], 1, generator=generator) >= config.phase_dropout).float()
    x[:, part] = (x[:, part] + noise) * keep
    keys = layout["keys"]
    x[:, keys] = x[:, keys] + config.key_noise * torch.randn(x.shape[0], keys.stop - keys.start, generator=generator)
    return x


@single_threaded
def train_controller(data: ControllerData, config: ControllerConfig, pae: PhaseAutoencoder, device="cpu",
                     progress: bool = False):
    """Fit the controller to ``data`` (mean squared error in standardised units).

    The first ``steps − unroll_steps`` batches are teacher-forced (single frames). The last ``unroll_steps``
    draw ``unroll`` consecutive frames of one clip and run the network on its own output: frame ``k + 1``'s
    pose, phase, future root trajectory and key-joint trajectories are the network's frame-``k`` predictions
    (:func:`next_key_trajectories`; the past root trajectory,
    goals and goal phase stay the data's), the loss averaged over the frames and back-propagated through them
    (ours: CHOICE trains for 150 epochs and does not say how; a teacher-forced toy controller wanders off on
    unseen clips, the autoregressive drift that scheduled sampling addresses, e.g. MVAE, Ling et al. 2020).
    At run time :func:`runtime.controller_step` also blends the pose (``features.blended_pose``); training feeds the raw
    prediction back (measured at toy: blending in training too gave runaway rollouts with seed 1).

    Returns:
        ``(ControllerNet in eval mode, TrainResult)``.
    """
    if not isinstance(data, ControllerData) or len(data.x) == 0:
        raise ValueError("data: expected ControllerData with at least one frame")
    model = build_controller(config, pae)
    check_shape(data.x, (None, model.in_size), "data.x")
    check_shape(data.y, (len(data.x), model.out_size), "data.y")
    model.set_statistics(data)
    clip = data.clip if data.clip is not None else torch.zeros(len(data.x), dtype=torch.long)
    U = config.unroll
    starts = torch.nonzero(clip[:len(clip) - U + 1] == clip[U - 1:]).flatten() if len(clip) >= U else clip[:0]
    if config.unroll_steps and U > 1 and len(starts) == 0:
        raise ValueError(f"data: no clip has the {U} consecutive frames that unroll={U} needs")
    fed = [(model.x_layout[name], model.y_layout[name]) for name in ("pose", "phase")]
    trajectory, ego, update = model.x_layout["trajectory"], model.y_layout["ego"], model.y_layout["root_update"]
    keys = model.x_layout["keys"]
    assert keys.stop == model.in_size  # the key-joint trajectories come last
    past = 4 * PAST // SAMPLE_STEP  # the past samples' numbers in the trajectory
    assert fed[0][0].start == 0 and fed[0][0].stop <= trajectory.start and trajectory.stop <= fed[1][0].start

    def sample_batch(step, generator):
        if step < config.steps - config.unroll_steps or U == 1:
            index = torch.randint(0, len(data.x), (config.batch_size, 1), generator=generator)
        else:
            index = starts[torch.randint(0, len(starts), (config.batch_size,), generator=generator)][:, None] \
                + torch.arange(U)
        x = _noised_inputs(data.x[index.flatten()], model.x_layout, config, generator)
        return {"x": x.reshape(*index.shape, -1), "y": data.y[index]}

    def loss_fn(net, batch):
        yn = (batch["y"] - net.y_mean) / net.y_std  # (B, U, out)
        loss, x = 0.0, batch["x"][:, 0]  # the input fed at frame k, in the data's units
        for k in range(yn.shape[1]):
            out = net.forward_standardised((x - net.x_mean) / net.x_std)
            loss = loss + (out - yn[:, k]).square().mean()
            if k + 1 < yn.shape[1]:  # the next frame sees the pose, phase and future root trajectory it made
                y = out * net.y_std + net.y_mean
                data = batch["x"][:, k + 1]
                x = torch.cat([y[:, fed[0][1]],
                               data[:, fed[0][0].stop:trajectory.start + past],
                               next_root_trajectory(y[:, ego], y[:, update]).flatten(1), data[:, trajectory.stop:fed[1][0].start],
                               y[:, fed[1][1]], data[:, fed[1][0].stop:keys.start],
                               next_key_trajectories(y[:, ego], y[:, update]).flatten(1)], dim=-1)
        return loss / yn.shape[1]

    result = train(model, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return model.eval(), result


def _phase_model(config: ControllerConfig, device, progress) -> TrainedModel:
    overrides = {} if config.phase_steps is None else {"steps": config.phase_steps}
    return phase.trained_phase_autoencoder(config.phase_scale, config.seed, device=device, progress=progress,
                                           **overrides)


def trained_controller(config: ControllerConfig, device="cpu", progress: bool = False) -> TrainedModel:
    """The controller trained on :func:`controller_data` once, then loaded from the cache (the PAE is
    ``phase.trained_phase_autoencoder``'s, cached on its own). ``details``: ``n_frames``, ``final_loss``."""
    pae = _phase_model(config, device, progress).model

    def build():
        data = controller_data(config, pae)
        # a copy: training moves the model, and with it its PAE, to ``device``; the shared PAE stays on the CPU
        model, result = train_controller(data, config, copy.deepcopy(pae), device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_frames": len(data.x), "final_loss": result.final_loss}

    key = {"model": dataclasses.asdict(config), "fps": FPS}
    artifact = load_or_build("choice_controller", key, build)
    model = build_controller(config, pae)
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"],
                        {"n_frames": artifact["n_frames"], "final_loss": artifact["final_loss"]})
