"""MotionNet (SAMP §3.1, §3.4, Appendices B.1, B.3, C, D, G): training with scheduled sampling.

The algorithm box, as this module runs it:

1. **Data** (``motion_data``): toy clips as states ``X_i`` (Eq. 1), roots, goals and voxels, cut
   into windows of ``L + 1`` frames ("we divide our training data to equal-length clips of size L",
   B.3).
2. **A roll-out per window** (B.3): the first input is the ground-truth frame; each step predicts
   ``Ŷ_{i} = [X̂_i, root update]`` from ``X_{i−1}`` and ``I``. The next input is the ground truth
   with probability ``P`` and the model's own (detached) prediction with probability ``1 − P``,
   one coin per step for the whole batch (REFERENCE_NOTES); ``P`` follows Eq. 5 over the epochs
   (:func:`teacher_forcing_probability`). The prediction is already in the new root frame (our
   state is expressed in its own frame; the root update is predicted beside it). SAMP's public code
   then restores the goal ``g^p, g^d, g^a`` of the input from the ground truth ("the goal features of
   the input always come from ground truth", REFERENCE_NOTES; the predicted ``t̃^p, t̃^d`` stay;
   ``own_inputs="ground_truth"``). By default we do what
   the run-time loop does instead: move the root by the predicted update and recompute the goal
   features and the voxels from there (``own_inputs="recomputed"``), so the model learns from
   inputs that say where its own steps took it.
3. **Loss** (Eq. 3): ``‖Ŷ_i − Y_i‖² + β₁ KL(Q(Z | X_i, X_{i−1}, I) ‖ N(0, I))`` in standardised
   units, ``β₁ = 0.1`` (B.1); the deterministic baselines (MLP, MoE; Supp. C) have no KL term.

As in the NIFTY chapters' motion prior, a batch is computed in two passes: the inputs of the
window's steps in time order without gradients (only the own-prediction steps need the model), then
all ``L`` steps as one batch with gradients: the same loss as stepping through the window, at a
fraction of the autograd overhead.

Scaling (paper → toy): 100 epochs with ``C1 = 30``, ``C2 = 60`` and ``L = 60`` → 10 epochs with
``C1``, ``C2`` at the same 30 % and 60 % of them and ``L = 30`` (1 s); Adam at 5e-5 with linear weight
decay → Adam at 1e-3 with a cosine learning-rate decay (the paper's rate is for 100 epochs of 185K
frames; ours sees ~24K frames for 10 epochs); 12 experts → 4, latent 64 → 32, β₁ 0.1 → 1.0, and
narrower networks (``MOTIONNET_SCALES`` holds the paper's sizes under ``"paper"``). Two choices are
ours, each measured in the MotionNet chapter: β₁, and what an own-prediction input holds
(``own_inputs``). A third is stated, not measured: the public code (``SAMP_Training``) takes an optimiser
step at every frame of a window's roll-out, ``L`` per window, its windows not overlapping; we take one step
per window on the loss summed over its ``L`` frames, windows overlapping by ``L/2``, so at equal epochs a
preset makes ``L/2`` times fewer updates than the public code would (30 for ``"paper"``, 15 for ``"toy"``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Optional

import torch

from .._validate import check_choice, check_numbers, check_positive_ints
from ..infra import (TrainedModel, TrainerConfig, TrainResult, load_or_build, scaled_config, single_threaded,
                     state_dict_to_cpu, train)
from ..nn.cvae import gaussian_kl
from ..world.features import SAMP_STATE_LAYOUT, SAMP_STATE_SIZE
from . import goal_frame
from .core import MLPMotionModel, MotionModel, MotionNet
from .motion_data import (ROOT_SIZE, MotionData, MotionDataConfig, apply_root_displacement, motion_data,
                          root_displacement)
from .goal_frame import with_goal

__all__ = [
    "MODEL_KINDS",
    "OUTPUT_SIZE",
    "GOAL_FEATURES",
    "RESTORED_GOAL_FEATURES",
    "goal_feature_mask",
    "teacher_forcing_probability",
    "MotionNetConfig",
    "MOTIONNET_SCALES",
    "motionnet_config",
    "build_motion_model",
    "training_targets",
    "training_steps",
    "train_motion_model",
    "trained_motion_model",
]

# MotionNet; the MoE and MLP baselines of Supp. C; the NSM-like model of Table 5 (the MoE with the
# environment sensor of samp.sensor in place of the target's voxels)
MODEL_KINDS = ("samp", "moe", "mlp", "nsm")
OWN_INPUTS = ("recomputed", "ground_truth")
OUTPUT_SIZE = SAMP_STATE_SIZE + ROOT_SIZE
# The parts of X computed from the goal (Eq. 1: t̃^p, t̃^d, g^p, g^d, g^a).
GOAL_FEATURES = goal_frame.GOAL_FEATURES
# The parts SAMP's public training code restores from the ground truth in an own-prediction input
# (own_inputs="ground_truth"): the goal g^p, g^d, g^a; t̃^p and t̃^d stay the model's own.
RESTORED_GOAL_FEATURES = ("goal_positions", "goal_directions", "goal_actions")


def goal_feature_mask() -> torch.Tensor:
    """``(437,)`` bool, True on the parts of ``X`` an own-prediction input takes from the ground truth
    in the public code's variant (``RESTORED_GOAL_FEATURES``)."""
    mask = torch.zeros(SAMP_STATE_SIZE, dtype=torch.bool)
    for name in RESTORED_GOAL_FEATURES:
        mask[SAMP_STATE_LAYOUT[name]] = True
    return mask


def teacher_forcing_probability(epoch: float, c1: float, c2: float) -> float:
    """SAMP Eq. 5: the probability ``P`` that the next input is the ground truth.

    ``P = 1`` for ``epoch ≤ C1``, ``1 − (epoch − C1)/(C2 − C1)`` for ``C1 < epoch ≤ C2``, 0 after.
    """
    if not 0 <= c1 < c2:
        raise ValueError(f"c1, c2: expected 0 <= C1 < C2 (epochs), got {c1!r}, {c2!r}")
    if epoch <= c1:
        return 1.0
    if epoch <= c2:
        return 1.0 - (epoch - c1) / (c2 - c1)
    return 0.0


@dataclass(frozen=True)
class MotionNetConfig:
    """MotionNet (or a baseline) and its training (defaults: the ``toy`` preset).

    Attributes:
        model: ``"samp"`` (MotionNet), ``"moe"`` or ``"mlp"`` (the baselines of Supp. C), ``"nsm"`` (the
            NSM-like model of Table 5: the MoE baseline sensing its surroundings, ``samp.sensor``).
        use_interaction: False for Supp. G's ablation (no interaction encoder).
        scheduled_sampling: False for Supp. D's ablation (``P = 1`` throughout: ground-truth inputs only).
        state_hidden, interaction_hidden, interaction_out, gating_hidden, prediction_hidden,
        n_experts, latent, mlp_hidden: network sizes (Table S.3 under ``"paper"``).
        kl_weight: β₁ (0.1 in B.1; 1.0 at toy scale, ours: with 0.1 the toy latent carries the next
            second of trajectory (KL ≈ 20 nats), and at run time, where ``Z`` comes from the prior,
            the character walks wherever its draw says rather than to its goal).
        rollout: ``L``, steps per training window (B.3: 60).
        epochs, c1, c2: passes over the windows, and Eq. 5's breakpoints in epochs (B.3: 100, 30, 60).
        steps: a fixed number of optimiser steps, None (the presets) for ``epochs`` full passes.
            When set, Eq. 5's epochs are ``steps / epochs`` steps each, so the schedule keeps its
            shape whatever the amount of data: a model trained on more data (§4.2's augmentation)
            can be given the same budget as the one it is compared with.
        batch_size, lr, grad_clip: optimisation (the paper's batch size is not stated).
        own_inputs: what an own-prediction input holds besides the prediction. ``"ground_truth"``:
            the ground truth's goal ``g^p, g^d, g^a`` and voxels (SAMP's public training code, which
            restores those three from the data and keeps the predicted ``t̃^p, t̃^d``);
            ``"recomputed"``: the predicted root update is applied and the goal features and voxels
            are recomputed from the new root, as the run-time loop does (ours: with the ground
            truth's, the toy model never sees a goal feature that disagrees with where it went,
            and at run time it walks past its goals; see the MotionNet chapter).
        seed: seeds the weights, the batches, the coins and the latent draws.
    """

    model: str = "samp"
    use_interaction: bool = True
    scheduled_sampling: bool = True
    state_hidden: tuple = (256, 128, 128)
    interaction_hidden: tuple = (128, 128)
    interaction_out: int = 128
    gating_hidden: tuple = (128, 64)
    prediction_hidden: int = 192
    n_experts: int = 4
    latent: int = 32
    mlp_hidden: tuple = (256, 256, 256, 256)
    kl_weight: float = 1.0
    rollout: int = 30
    epochs: int = 10
    steps: Optional[int] = None
    c1: float = 3.0
    c2: float = 6.0
    batch_size: int = 16
    lr: float = 1e-3
    grad_clip: Optional[float] = 1.0
    own_inputs: str = "recomputed"
    seed: int = 0

    def __post_init__(self):
        check_choice(self.model, MODEL_KINDS, "model")
        check_choice(self.own_inputs, OWN_INPUTS, "own_inputs")
        check_positive_ints(self, ("interaction_out", "prediction_hidden", "n_experts", "latent", "rollout", "epochs",
                                   "batch_size"))
        if self.steps is not None and (not isinstance(self.steps, int) or isinstance(self.steps, bool) or self.steps < 1):
            raise ValueError(f"steps: expected a positive int or None (epochs of the data), got {self.steps!r}")
        teacher_forcing_probability(0, self.c1, self.c2)  # validates C1 < C2
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("kl_weight",), at_least=0)
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)


# The presets. Every one takes one optimiser step per window of L frames (windows overlapping by L/2), where SAMP's
# public code steps at every frame of a window: L/2 times fewer updates at equal epochs (the module docstring).
MOTIONNET_SCALES = {
    "small": {"epochs": 30, "c1": 9.0, "c2": 18.0, "n_experts": 8, "prediction_hidden": 256},
    "paper": {"state_hidden": (512, 256, 256), "interaction_hidden": (256, 256), "interaction_out": 256,
              "gating_hidden": (512, 256), "prediction_hidden": 512, "n_experts": 12, "latent": 64,
              "mlp_hidden": (512, 512, 512, 512), "kl_weight": 0.1, "rollout": 60, "epochs": 100, "c1": 30.0,
              "c2": 60.0, "lr": 5e-5, "batch_size": 32},
}


def motionnet_config(scale: str = "toy", **overrides) -> MotionNetConfig:
    """The preset for ``scale``, fields overridable."""
    return scaled_config(MotionNetConfig, scale, MOTIONNET_SCALES, overrides, factory="motionnet_config")


def build_motion_model(config: MotionNetConfig) -> MotionModel:
    """A freshly initialised model of ``config.model``, its weights seeded by ``config.seed``."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        if config.model == "mlp":
            return MLPMotionModel(SAMP_STATE_SIZE, OUTPUT_SIZE, tuple(config.mlp_hidden), tuple(config.interaction_hidden),
                                  config.interaction_out, config.use_interaction)
        return MotionNet(SAMP_STATE_SIZE, OUTPUT_SIZE, tuple(config.state_hidden), tuple(config.interaction_hidden),
                         config.interaction_out, tuple(config.gating_hidden), config.prediction_hidden,
                         config.n_experts, config.latent if config.model == "samp" else 0, config.use_interaction,
                         environment_sensor=config.model == "nsm")


def training_targets(data: MotionData) -> torch.Tensor:
    """``(N, 440)`` the output ``Y_i = [X_i, root update from frame i − 1]`` of every frame (the
    update of a clip's first frame is zero; no window uses it as a target)."""
    displacement = torch.zeros(len(data), ROOT_SIZE)
    update = root_displacement(data.roots)  # (N − 1, 3), across clip boundaries too
    displacement[1:] = update
    displacement[data.clip_start[:-1]] = 0.0
    return torch.cat([data.states, displacement], dim=-1)


def training_steps(data: MotionData, config: MotionNetConfig) -> int:
    """How many optimiser steps :func:`train_motion_model` takes on ``data``: ``config.steps``, or
    ``epochs`` passes over the windows of ``L + 1`` frames at ``batch_size``."""
    return config.steps or config.epochs * math.ceil(len(data.windows(config.rollout)) / config.batch_size)


@single_threaded
def train_motion_model(data: MotionData, config: MotionNetConfig, device="cpu",
                       progress: bool = False) -> tuple[MotionModel, TrainResult]:
    """Train ``config.model`` on windows of ``data`` with scheduled sampling (Eq. 3, Eq. 5).

    Returns:
        ``(model in eval mode, TrainResult)``; the result's ``extra`` holds ``"reconstruction"``,
        ``"kl"`` and ``"teacher_forcing"`` (``P``) per step.
    """
    if not isinstance(data, MotionData) or len(data) == 0:
        raise ValueError("data: expected MotionData with at least one frame")
    L = config.rollout
    starts = data.windows(L)
    targets = training_targets(data)
    model = build_motion_model(config)
    sample_frames = torch.randperm(len(data), generator=torch.Generator().manual_seed(config.seed))[:4096]
    sensor = model.environment_sensor
    model.set_statistics(data.states, targets[1:], data.voxels(sample_frames, sensor=sensor))
    mask = goal_feature_mask()
    goal_actions = data.goal_actions
    steps = training_steps(data, config)
    steps_per_epoch = steps / config.epochs  # Eq. 5's epoch; a fraction when the budget is fixed in steps
    latent = model.latent

    def sample_batch(step: int, generator: torch.Generator):
        epoch = int(step // steps_per_epoch) + 1
        p = teacher_forcing_probability(epoch, config.c1, config.c2) if config.scheduled_sampling else 1.0
        first = starts[torch.randint(0, len(starts), (config.batch_size,), generator=generator)]
        frames = first[:, None] + torch.arange(L + 1)[None]  # (B, L + 1)
        return {"frames": frames, "p": torch.tensor(p),
                "own": torch.rand(L, generator=generator) >= p,  # one coin per step for the batch
                "eps": torch.randn(L, config.batch_size, max(latent, 1), generator=generator)}

    def loss_fn(net: MotionModel, batch):
        # the data stay on the CPU (indexed there); what the network reads moves to its device
        dev = net.x_mean.device
        frames, own, eps = batch["frames"].cpu(), batch["own"].cpu(), batch["eps"].to(dev)
        B = frames.shape[0]
        inputs = data.states[frames[:, :-1]].clone().to(dev)  # (B, L, 437): ground truth, replaced where own
        voxels = data.voxels(frames[:, :-1].reshape(-1), sensor=sensor).reshape(B, L, -1).to(dev)
        y = targets[frames[:, 1:]].to(dev)  # (B, L, 440)
        if bool(own.any()):
            with torch.no_grad():
                x, root = inputs[:, 0], data.roots[frames[:, 0]].to(dev)
                for t in range(L - 1):
                    if bool(own[t]):
                        xn, code = net.normalise_input(x), net.code(voxels[:, t])
                        z = None
                        if latent:
                            mu, logvar = net.posterior(net.normalise_output(y[:, t]), xn, code)
                            z = mu + torch.exp(0.5 * logvar) * eps[t]
                        pred = net.decode_standardised(xn, code, z) * net.y_std + net.y_mean
                        if config.own_inputs == "recomputed":
                            # as at run time: the root moves by the predicted update, and the goal
                            # features and the voxels are those seen from there
                            root = apply_root_displacement(root, pred[:, SAMP_STATE_SIZE:])
                            nxt = frames[:, t + 1]
                            x = with_goal(pred[:, :SAMP_STATE_SIZE], root, data.goal_positions[nxt].to(dev),
                                          data.goal_directions[nxt].to(dev), goal_actions[nxt].to(dev))
                            voxels[:, t + 1] = data.voxels(nxt, root.cpu(), sensor=sensor).to(dev)
                        else:
                            x = torch.where(mask.to(dev), inputs[:, t + 1], pred[:, :SAMP_STATE_SIZE])
                        inputs[:, t + 1] = x
                    else:
                        x, root = inputs[:, t + 1], data.roots[frames[:, t + 1]].to(dev)
        xn = net.normalise_input(inputs.reshape(B * L, -1))
        code = net.code(voxels.reshape(B * L, -1))
        yn = net.normalise_output(y.reshape(B * L, -1))
        kl = torch.zeros((), device=dev)
        z = None
        if latent:
            mu, logvar = net.posterior(yn, xn, code)
            z = mu + torch.exp(0.5 * logvar) * eps.transpose(0, 1).reshape(B * L, -1)
            kl = gaussian_kl(mu, logvar).mean()
        reconstruction = (net.decode_standardised(xn, code, z) - yn).square().sum(-1).mean()
        return reconstruction + config.kl_weight * kl, {"reconstruction": reconstruction.detach(), "kl": kl.detach(),
                                                        "teacher_forcing": batch["p"]}

    trainer = TrainerConfig(steps=steps, batch_size=config.batch_size, lr=config.lr, lr_schedule="cosine",
                            warmup_steps=min(20, steps // 10), grad_clip=config.grad_clip, optimizer="adam",
                            device=str(device), progress=progress, seed=config.seed)
    result = train(model, sample_batch, loss_fn, trainer)
    return model.eval(), result


def trained_motion_model(data_config: MotionDataConfig, config: MotionNetConfig, device="cpu",
                         progress: bool = False) -> TrainedModel:
    """``config.model`` trained on ``motion_data(data_config, "train")`` once, then loaded from the cache.

    Returns:
        a :class:`~hoi_tutorial.infra.TrainedModel` whose ``details`` hold ``n_frames``,
        ``n_windows``, ``steps`` and the last 50 steps' mean ``reconstruction`` and ``kl``.
    """
    def build():
        data = motion_data(data_config, "train")
        model, result = train_motion_model(data, config, device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_frames": len(data),
                "n_windows": int(len(data.windows(config.rollout))), "steps": len(result.losses),
                "reconstruction": float(torch.tensor(result.extra["reconstruction"][-50:]).mean()),
                "kl": float(torch.tensor(result.extra["kl"][-50:]).mean())}

    key = {"data": dataclasses.asdict(data_config), "model": dataclasses.asdict(config)}
    artifact = load_or_build(f"samp_motion_{config.model}", key, build)
    model = build_motion_model(config)
    model.load_state_dict(artifact["state"])
    details = {name: artifact[name] for name in ("n_frames", "n_windows", "steps", "reconstruction", "kl")}
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"], details)
