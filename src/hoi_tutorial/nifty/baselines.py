"""NIFTY's Cond. VAE baseline (§4.3, Table 1): a conditional motion VAE trained on the same synthetic data.

NIFTY's baseline is HUMANISE's model with the language condition removed: "a conditional VAE with a GRU motion
encoder and sequence-level transformer decoder", trained on NIFTY's synthetic data with the same condition
``C = {P_o, R_o, b, X_0}``. Here:

- the condition is encoded as the motion model encodes it (a PointNet of ``P_o``, an MLP of ``R_o``, ``b`` and the
  standardised ``X_0`` as they are);
- the encoder is a GRU over the standardised motion whose last state, with the condition, gives the posterior
  ``q(z | τ, C) = N(μ, σ²)``;
- the decoder is a transformer over one query token per frame plus the condition tokens and ``z``
  (:class:`~hoi_tutorial.nn.transformer.TransformerDenoiser` used at a fixed step, its frame inputs zero);
- the loss is the reconstruction MSE plus ``kl_weight`` × KL to ``N(0, I)``; at sampling ``z ~ N(0, I)``.

Scaled down as the motion model is (width 64, 2 layers), and trained for the motion model's 1000 steps at the same
batch size, so Table 1 compares the two generative models at the same training budget (its GRU over 121 frames makes
a step slower than the diffusion model's: 1000 steps took 57–59 s against the 60 s budget). The KL weight, the latent
size and the GRU's width are ours: neither NIFTY nor this book's references state HUMANISE's values.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Optional

import torch
from torch import nn

from .._validate import check_choice, check_numbers, check_positive_ints, check_shape
from ..infra import (TrainedModel, TrainResult, load_or_build, scaled_config, single_threaded, state_dict_to_cpu,
                     train, trainer_config)
from ..nn.cvae import gaussian_kl, reparameterize
from ..nn.mlp import MLP
from ..nn.pointnet import PointNetEncoder
from ..nn.transformer import TransformerDenoiser
from ..world.features import NIFTY_STATE_SIZE
from ..world.skeleton import NUM_BETAS
from . import motion_model
from .motion_model import OBJECT_POSE_SIZE, InteractionTensors

__all__ = [
    "CondVAEConfig",
    "COND_VAE_SCALES",
    "cond_vae_config",
    "CondMotionVAE",
    "build_cond_vae",
    "train_cond_vae",
    "trained_cond_vae",
    "sample_cond_vae",
]


@dataclass(frozen=True)
class CondVAEConfig:
    """The Cond. VAE baseline and its training (defaults: the ``toy`` preset).

    Attributes:
        action: ``"sit"`` or ``"lift"`` (one model per action, as for NIFTY).
        max_frames: frames per motion (as the motion model's).
        width, layers, heads, dropout: the transformer decoder; ``width`` is also the GRU's size.
        latent: size of ``z``.
        n_points, pointnet_hidden: the object point cloud and its PointNet.
        kl_weight: weight of the KL term (ours).
        steps, batch_size, lr, lr_schedule, warmup_steps, grad_clip: training (NIFTY trains it 600K
            iterations at lr 1e-4, "with the recommended hyperparameters").
        seed: seeds the weights, the batches and the latent draws.
    """

    action: str = "sit"
    max_frames: int = 121
    width: int = 64
    layers: int = 2
    heads: int = 4
    dropout: float = 0.0
    latent: int = 32
    n_points: int = 256
    pointnet_hidden: tuple = (64, 128)
    kl_weight: float = 1e-2
    steps: int = 1000
    batch_size: int = 16
    lr: float = 2e-3
    lr_schedule: str = "cosine"
    warmup_steps: int = 100
    grad_clip: Optional[float] = 1.0
    seed: int = 0

    def __post_init__(self):
        check_choice(self.action, ("sit", "lift"), "action")
        check_positive_ints(self, ("max_frames", "width", "layers", "heads", "latent", "n_points", "steps",
                                   "batch_size"))
        if self.width % self.heads:
            raise ValueError(f"width: expected a multiple of heads={self.heads}, got {self.width}")
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("dropout",), at_least=0, below=1)
        check_numbers(self, ("kl_weight",), at_least=0)
        check_numbers(self, ("grad_clip",), above=0, allow_none=True)


# What the larger scales change (paper: NIFTY §4.3's 600K iterations at lr 1e-4; sizes as the motion model's).
COND_VAE_SCALES = {
    "small": {"max_frames": 151, "width": 256, "layers": 4, "dropout": 0.1, "n_points": 1024,
              "pointnet_hidden": (64, 128, 256), "steps": 30000, "batch_size": 32, "lr": 2e-4, "warmup_steps": 500},
    "paper": {"max_frames": 150, "width": 512, "layers": 8, "dropout": 0.1, "latent": 256, "n_points": 5000,
              "pointnet_hidden": (64, 128, 1024), "steps": 600_000, "batch_size": 32, "lr": 1e-4,
              "lr_schedule": "constant", "warmup_steps": 0, "grad_clip": None},
}


def cond_vae_config(action: str, scale: str = "toy", **overrides) -> CondVAEConfig:
    """The preset for ``action`` and ``scale``, fields overridable."""
    check_choice(action, ("sit", "lift"), "action")
    return scaled_config(CondVAEConfig, scale, COND_VAE_SCALES, overrides, factory="cond_vae_config",
                         fixed={"action": action})


class CondMotionVAE(nn.Module):
    """``q(z | τ, C)`` by a GRU, ``p(τ | z, C)`` by a transformer over frame queries (NIFTY's Cond. VAE).

    Args:
        config: a :class:`CondVAEConfig`.
        state_mean, state_std: ``(336,)`` normalisation statistics of the training states.
    """

    def __init__(self, config: CondVAEConfig, state_mean=None, state_std=None):
        super().__init__()
        self.config = config
        mean = torch.zeros(NIFTY_STATE_SIZE) if state_mean is None else torch.as_tensor(state_mean)
        std = torch.ones(NIFTY_STATE_SIZE) if state_std is None else torch.as_tensor(state_std)
        check_shape(mean, (NIFTY_STATE_SIZE,), "state_mean")
        check_shape(std, (NIFTY_STATE_SIZE,), "state_std")
        self.register_buffer("state_mean", mean.detach().float().clone())
        self.register_buffer("state_std", std.detach().float().clone())
        width = config.width
        self.point_encoder = PointNetEncoder(width, hidden=tuple(config.pointnet_hidden))
        self.pose_encoder = MLP(OBJECT_POSE_SIZE, [width, width], width, activation="gelu")
        self.motion_encoder = nn.GRU(NIFTY_STATE_SIZE, width, batch_first=True)
        self.to_posterior = MLP(3 * width + NUM_BETAS + NIFTY_STATE_SIZE, [width], 2 * config.latent, activation="gelu")
        self.decoder = TransformerDenoiser(
            NIFTY_STATE_SIZE,
            {"object_points": width, "object_pose": width, "betas": NUM_BETAS, "start_pose": NIFTY_STATE_SIZE,
             "z": config.latent},
            width=width, layers=config.layers, heads=config.heads, dropout=config.dropout, max_len=config.max_frames)

    # The state normalisation and the condition encoding are the motion model's, read off the same attributes
    # (``state_mean``, ``state_std``, ``point_encoder``, ``pose_encoder``).
    normalise = motion_model.NiftyMotionModel.normalise
    denormalise = motion_model.NiftyMotionModel.denormalise
    encode_condition = motion_model.NiftyMotionModel.encode_condition

    def posterior(self, x: torch.Tensor, encoded: dict) -> tuple[torch.Tensor, torch.Tensor]:
        """``(μ, log σ²)``, each ``(B, latent)``, of ``q(z | τ, C)`` for standardised motions ``x (B, T, 336)``."""
        check_shape(x, (None, None, NIFTY_STATE_SIZE), "x")
        _, last = self.motion_encoder(x)
        features = torch.cat([last[-1], encoded["object_points"], encoded["object_pose"], encoded["betas"],
                              encoded["start_pose"]], dim=-1)
        mu, logvar = self.to_posterior(features).chunk(2, dim=-1)
        return mu, logvar

    def decode(self, z: torch.Tensor, encoded: dict, frames: Optional[int] = None) -> torch.Tensor:
        """Standardised motions ``(B, frames, 336)`` from latents ``z (B, latent)`` and the condition."""
        frames = self.config.max_frames if frames is None else int(frames)
        check_shape(z, (None, self.config.latent), "z")
        queries = z.new_zeros(z.shape[0], frames, NIFTY_STATE_SIZE)
        step = torch.zeros(z.shape[0], dtype=torch.int64, device=z.device)
        return self.decoder(queries, step, {**encoded, "z": z})


def build_cond_vae(config: CondVAEConfig, state_mean=None, state_std=None) -> CondMotionVAE:
    """A freshly initialised model, its weights seeded by ``config.seed`` (global RNG untouched)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return CondMotionVAE(config, state_mean, state_std)


@single_threaded
def train_cond_vae(tensors: InteractionTensors, config: CondVAEConfig, device="cpu",
                   progress: bool = False) -> tuple[CondMotionVAE, TrainResult]:
    """Train with the reconstruction MSE plus ``kl_weight`` × KL(q(z | τ, C) ‖ N(0, I)), per sample.

    Returns:
        ``(model in eval mode, TrainResult)``; the result's ``extra`` holds ``"reconstruction"`` and
        ``"kl"`` per step.
    """
    if not isinstance(tensors, InteractionTensors) or len(tensors) == 0:
        raise ValueError("tensors: expected InteractionTensors with at least one training sequence")
    if tensors.max_frames != config.max_frames:
        raise ValueError(f"tensors: {tensors.max_frames} frames per sequence, but config.max_frames is "
                         f"{config.max_frames}")
    mean, std = tensors.normalisation()
    model = build_cond_vae(config, mean, std)
    data = model.normalise(tensors.states)
    conditions = tensors.condition()

    def sample_batch(step: int, generator: torch.Generator):
        index = torch.randint(0, len(tensors), (config.batch_size,), generator=generator)
        return {"x": data[index], "cond": {name: value[index] for name, value in conditions.items()},
                "seed": torch.randint(0, 2**62, (1,), generator=generator)}

    def loss_fn(net, batch):
        encoded = net.encode_condition(batch["cond"])
        mu, logvar = net.posterior(batch["x"], encoded)
        generator = torch.Generator(device=mu.device).manual_seed(int(batch["seed"]))
        z = reparameterize(mu, logvar, generator)
        reconstruction = (net.decode(z, encoded, batch["x"].shape[1]) - batch["x"]).pow(2).mean()
        kl = gaussian_kl(mu, logvar).mean()
        # Logged as tensors: the trainer reads them back with the loss, once per interval.
        return reconstruction + config.kl_weight * kl, {"reconstruction": reconstruction.detach(), "kl": kl.detach()}

    result = train(model, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return model.eval(), result


def trained_cond_vae(dataset, config: CondVAEConfig, device="cpu", progress: bool = False) -> TrainedModel:
    """The Cond. VAE for a synthetic dataset, trained once and then loaded from the artifact cache.

    Returns:
        a :class:`~hoi_tutorial.infra.TrainedModel` whose ``details`` hold ``n_sequences``.
    """
    if config.action != dataset.config.action:
        raise ValueError(f"config.action: {config.action!r}, but the dataset is {dataset.config.action!r}")

    def build():
        tensors = InteractionTensors.from_sequences(dataset.sequences, config.max_frames, config.n_points, config.seed)
        model, result = train_cond_vae(tensors, config, device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_sequences": len(tensors)}

    key = {"data": dataclasses.asdict(dataset.config), "model": dataclasses.asdict(config)}
    artifact = load_or_build(f"nifty_{config.action}_cond_vae", key, build,
                             code=motion_model.model_code())
    model = CondMotionVAE(config)
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"],
                        {"n_sequences": artifact["n_sequences"]})


@single_threaded
@torch.no_grad()
def sample_cond_vae(model: CondMotionVAE, cond: dict, *, generator: torch.Generator) -> torch.Tensor:
    """Draw one motion per condition: ``z ~ N(0, I)`` from ``generator``, decoded.

    Returns:
        ``(B, T, 336)`` states (un-normalised, each in its scene's canonical frame, CPU), as
        :func:`~hoi_tutorial.nifty.motion_model.sample_motions` returns them.
    """
    if not isinstance(model, CondMotionVAE):
        raise TypeError(f"model: expected a CondMotionVAE, got {type(model).__name__}")
    was_training = model.training
    model.eval()
    encoded = model.encode_condition(cond)
    batch = encoded["betas"].shape[0]
    z = torch.randn(batch, model.config.latent, generator=generator).to(encoded["betas"].device)
    out = model.denormalise(model.decode(z, encoded)).cpu()
    model.train(was_training)
    return out
