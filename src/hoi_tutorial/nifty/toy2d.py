"""Two-dimensional teaching distributions for diffusion, with class labels and region objectives.

Distributions (``TOY2D_DISTRIBUTIONS``), points in arbitrary units ("metres" of a plane):

- ``"ring8"``: a mixture of 8 isotropic Gaussians (std 0.35) with centres evenly spaced on a
  circle of radius 2; the label is the component (0 … 7, counter-clockwise from +X).
- ``"moons_and_ring"``: two interleaved half-moons (labels 0 and 1) inside a ring of radius 2.6
  (label 2), each with Gaussian noise of std 0.08.

Guidance objectives (NIFTY Eq. 4's ``G``) are squared distances to a region, zero inside it:
:func:`disc_objective` and :func:`box_objective`. :func:`train_toy2d_denoiser` trains a
class-conditional :class:`~hoi_tutorial.nn.denoisers.MLPDenoiser` with the x0 loss of
:func:`~hoi_tutorial.nn.diffusion.training_loss` (labels dropped with probability 0.1), so one
network serves classifier-free guidance and unconditional sampling.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import torch

from .._validate import as_tensor, check_choice, check_numbers, check_shape
from ..infra.presets import scaled_config
from ..infra.seeding import rng as make_rng
from ..infra.device import single_threaded
from ..infra.cache import load_or_build, state_dict_to_cpu
from ..infra.training import TrainedModel, TrainResult, trainer_config
from ..nn.denoisers import MLPDenoiser
from ..nn.diffusion import NoiseSchedule, cosine_schedule, linear_schedule, train_denoiser

__all__ = [
    "TOY2D_DISTRIBUTIONS",
    "RING8_RADIUS",
    "RING8_STD",
    "ring8_centres",
    "ring8_exact_x0",
    "ring8_log_density",
    "ring8_class_posterior",
    "sample_toy2d",
    "toy2d_num_classes",
    "classify_toy2d",
    "disc_objective",
    "box_objective",
    "Toy2DConfig",
    "TOY2D_SCALES",
    "toy2d_config",
    "build_toy2d_denoiser",
    "train_toy2d_denoiser",
    "trained_toy2d_denoiser",
]

TOY2D_DISTRIBUTIONS = ("ring8", "moons_and_ring")
_NUM_CLASSES = {"ring8": 8, "moons_and_ring": 3}

RING8_RADIUS = 2.0
RING8_STD = 0.35
_MOON_NOISE = 0.08
# Per-coordinate standard deviation of each distribution (σ_d of the denoiser's preconditioning).
_DATA_STD = {"ring8": math.sqrt(RING8_RADIUS ** 2 / 2 + RING8_STD ** 2), "moons_and_ring": 1.3}
_OUTER_RING_RADIUS = 2.6


def toy2d_num_classes(name: str) -> int:
    """Number of class labels of the distribution ``name``."""
    check_choice(name, TOY2D_DISTRIBUTIONS, "name")
    return _NUM_CLASSES[name]


def ring8_centres() -> np.ndarray:
    """``(8, 2)`` the centres of the ``"ring8"`` components; row i is class i."""
    angles = 2.0 * math.pi * np.arange(8) / 8.0
    return RING8_RADIUS * np.stack([np.cos(angles), np.sin(angles)], axis=1)


def _ring8(n: int, generator: np.random.Generator):
    labels = generator.integers(0, 8, size=n)
    points = ring8_centres()[labels] + RING8_STD * generator.standard_normal((n, 2))
    return points, labels


def _moons_and_ring(n: int, generator: np.random.Generator):
    labels = generator.integers(0, 3, size=n)
    t = generator.uniform(0.0, math.pi, size=n)
    # Two half-moons as in scikit-learn's make_moons, centred on the origin and scaled by 1.2.
    moon0 = np.stack([np.cos(t) - 0.5, np.sin(t) - 0.25], axis=1) * 1.2
    moon1 = np.stack([0.5 - np.cos(t), 0.25 - np.sin(t)], axis=1) * 1.2
    theta = 2.0 * t  # reuse the draw: uniform on [0, 2π)
    ring = _OUTER_RING_RADIUS * np.stack([np.cos(theta), np.sin(theta)], axis=1)
    points = np.where(labels[:, None] == 0, moon0, np.where(labels[:, None] == 1, moon1, ring))
    points = points + _MOON_NOISE * generator.standard_normal((n, 2))
    return points, labels


def sample_toy2d(name: str, n: int, seed) -> tuple[torch.Tensor, torch.Tensor]:
    """Draw labelled points from a teaching distribution.

    Args:
        name: one of ``TOY2D_DISTRIBUTIONS`` (``"ring8"``, ``"moons_and_ring"``).
        n: number of points (>= 1).
        seed: int or ``numpy.random.Generator``.

    Returns:
        ``(points (n, 2) float32, labels (n,) int64)``; classes are equally likely.
    """
    check_choice(name, TOY2D_DISTRIBUTIONS, "name")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: expected a positive int, got {n!r}")
    generator = make_rng(seed)
    points, labels = (_ring8 if name == "ring8" else _moons_and_ring)(int(n), generator)
    return torch.as_tensor(points, dtype=torch.float32), torch.as_tensor(labels, dtype=torch.int64)


def ring8_log_density(points) -> torch.Tensor:
    """``log p(x)`` of the ``"ring8"`` mixture (equal weights), to judge how data-like samples are.

    Args:
        points: ``(N, 2)``.

    Returns:
        ``(N,)`` float64 log-densities.
    """
    points = as_tensor(points, "points", dtype=torch.float64).detach().cpu()
    check_shape(points, (None, 2), "points")
    centres = torch.as_tensor(ring8_centres(), dtype=torch.float64)
    squared = ((points[:, None, :] - centres[None]) ** 2).sum(dim=-1)
    log_components = -squared / (2.0 * RING8_STD ** 2) - math.log(2.0 * math.pi * RING8_STD ** 2)
    return torch.logsumexp(log_components, dim=1) - math.log(8.0)


def ring8_class_posterior(points) -> torch.Tensor:
    """``p(c | x)`` of the ``"ring8"`` mixture: the Bayes classifier's confidence in each class.

    Classifier-free guidance with scale s samples (approximately) from
    ``p(x | c) p(c | x)^(s-1)``, so this is the quantity it raises.

    Args:
        points: ``(N, 2)``.

    Returns:
        ``(N, 8)`` float64 probabilities, each row sums to 1.
    """
    points = as_tensor(points, "points", dtype=torch.float64).detach().cpu()
    check_shape(points, (None, 2), "points")
    centres = torch.as_tensor(ring8_centres(), dtype=torch.float64)
    squared = ((points[:, None, :] - centres[None]) ** 2).sum(dim=-1)
    return torch.softmax(-squared / (2.0 * RING8_STD ** 2), dim=1)


def classify_toy2d(name: str, points, k: int = 25, n_reference: int = 4000, seed: int = 12345) -> torch.Tensor:
    """The class whose data dominates around each point: a k-nearest-neighbour vote.

    The reference set is a fresh sample of ``n_reference`` labelled points of ``name``, so the
    vote approximates the Bayes classifier ``argmax_c p(c | x)``; it defines "class c's region"
    for measuring how strongly a sample follows its condition.

    Args:
        name: the distribution.
        points: ``(N, 2)`` query points.
        k: neighbours that vote.
        n_reference: size of the labelled reference sample.
        seed: seed of the reference sample.

    Returns:
        ``(N,)`` int64 labels.
    """
    points = as_tensor(points, "points").detach().cpu()
    check_shape(points, (None, 2), "points")
    if not 1 <= k <= n_reference:
        raise ValueError(f"k: expected an int in [1, n_reference={n_reference}], got {k!r}")
    reference, labels = sample_toy2d(name, n_reference, seed)
    nearest = torch.cdist(points, reference).topk(k, dim=1, largest=False).indices
    votes = torch.nn.functional.one_hot(labels[nearest], toy2d_num_classes(name)).sum(dim=1)
    return votes.argmax(dim=1)


def ring8_exact_x0(x_k: torch.Tensor, k: torch.Tensor, schedule: NoiseSchedule, labels=None) -> torch.Tensor:
    """The exact denoiser ``E[x_0 | x_k]`` (or ``E[x_0 | x_k, c]``) of the ``"ring8"`` mixture.

    For a Gaussian mixture the best possible x0-prediction is known in closed form: with
    ``x_k = √ᾱ_k x_0 + √(1-ᾱ_k) ε`` and component ``j ~ N(μ_j, s² I)``, ``x_k | j`` is Gaussian with
    mean ``√ᾱ_k μ_j`` and variance ``v_k = ᾱ_k s² + 1 - ᾱ_k``, and
    ``E[x_0 | x_k, j] = μ_j + √ᾱ_k s² / v_k · (x_k - √ᾱ_k μ_j)``; the unconditional mean weighs the
    components by their posterior ``p(j | x_k)``. A trained network can at best match it, so it
    is the yardstick for the learned model (and lets the sampler be tested without training).

    Args:
        x_k: ``(B, 2)`` noisy points.
        k: ``(B,)`` int64 steps.
        schedule: the noise schedule.
        labels: ``(B,)`` int64 components to condition on, or ``None`` for the unconditional mean.

    Returns:
        ``(B, 2)`` the posterior mean of x0.
    """
    check_shape(x_k, (None, 2), "x_k")
    check_shape(k, (x_k.shape[0],), "k")
    alpha_bar = schedule.alphas_cumprod.to(x_k.device, torch.float64)[k.long()][:, None, None]
    x = x_k.to(torch.float64)[:, None, :]
    centres = torch.as_tensor(ring8_centres(), dtype=torch.float64, device=x_k.device)[None]
    variance = alpha_bar * RING8_STD ** 2 + 1.0 - alpha_bar
    residual = x - alpha_bar.sqrt() * centres
    per_component = centres + alpha_bar.sqrt() * RING8_STD ** 2 / variance * residual  # (B, 8, 2)
    if labels is not None:
        check_shape(labels, (x_k.shape[0],), "labels")
        chosen = per_component[torch.arange(x_k.shape[0], device=x_k.device), labels.long()]
        return chosen.to(x_k.dtype)
    logits = -(residual ** 2).sum(dim=-1) / (2.0 * variance[..., 0])
    weights = torch.softmax(logits, dim=1)[..., None]
    return (weights * per_component).sum(dim=1).to(x_k.dtype)


# --------------------------------------------------------------------------- region objectives


def _points(x: torch.Tensor) -> torch.Tensor:
    if not isinstance(x, torch.Tensor):
        x = as_tensor(x, "points")
    check_shape(x, (None, 2), "points")
    return x


def disc_objective(centre, radius: float) -> Callable[[torch.Tensor], torch.Tensor]:
    """``G(x) = max(0, ‖x - centre‖ - radius)²``: squared distance to a disc, 0 inside it.

    A guidance objective for NIFTY Eq. 4 ("be inside this region"); differentiable, its negative
    gradient points towards the centre from outside.

    Args:
        centre: ``(2,)`` the disc's centre.
        radius: the disc's radius (> 0).

    Returns:
        ``G: points (B, 2) -> (B,)``.
    """
    centre = as_tensor(centre, "centre", dtype=torch.float64)
    check_shape(centre, (2,), "centre")
    if not radius > 0:
        raise ValueError(f"radius: expected a positive number, got {radius!r}")
    radius = float(radius)

    def objective(points: torch.Tensor) -> torch.Tensor:
        points = _points(points)
        offset = points - centre.to(points.device, points.dtype)
        # The small epsilon keeps the gradient of the norm finite at the centre.
        distance = torch.sqrt((offset ** 2).sum(dim=-1) + 1e-12)
        return torch.relu(distance - radius) ** 2

    return objective


def box_objective(lo, hi) -> Callable[[torch.Tensor], torch.Tensor]:
    """``G(x) = Σ_d max(0, lo_d - x_d)² + max(0, x_d - hi_d)²``: squared distance to a box.

    Args:
        lo: ``(2,)`` the lower corner.
        hi: ``(2,)`` the upper corner, ``hi > lo`` in both coordinates.

    Returns:
        ``G: points (B, 2) -> (B,)``, 0 inside the box.
    """
    lo = as_tensor(lo, "lo", dtype=torch.float64)
    hi = as_tensor(hi, "hi", dtype=torch.float64)
    check_shape(lo, (2,), "lo")
    check_shape(hi, (2,), "hi")
    if not bool((hi > lo).all()):
        raise ValueError(f"hi: expected hi > lo in both coordinates, got lo={lo.tolist()}, hi={hi.tolist()}")

    def objective(points: torch.Tensor) -> torch.Tensor:
        points = _points(points)
        below = torch.relu(lo.to(points.device, points.dtype) - points)
        above = torch.relu(points - hi.to(points.device, points.dtype))
        return (below ** 2 + above ** 2).sum(dim=-1)

    return objective


# --------------------------------------------------------------------------- training


@dataclass(frozen=True)
class Toy2DConfig:
    """Data, model and optimisation of the 2-D class-conditional denoiser.

    The defaults are the ``toy`` preset; :func:`toy2d_config` gives every scale.

    Attributes:
        distribution: one of ``TOY2D_DISTRIBUTIONS``.
        n_train: training points drawn once (a fixed data set, as a real one would be).
        diffusion_steps: K (NIFTY: 1000; 100 is plenty in two dimensions).
        schedule: ``"cosine"`` (MDM, NIFTY) or ``"linear"``.
        width, depth, time_embed_dim: the :class:`MLPDenoiser`'s size.
        fourier_features, fourier_scale: random Fourier features of the input point (an MLP fed
            raw 2-D coordinates learns the sharp, many-lobed unconditional denoiser slowly).
        steps, batch_size, lr: optimisation (AdamW).
        lr_schedule, warmup_steps: the learning-rate schedule after a linear warm-up (cosine decay).
        p_uncond: probability of dropping the label during training (NIFTY: 0.1).
        seed: seeds the data, the initial weights and the batches.
    """

    distribution: str = "ring8"
    n_train: int = 20000
    diffusion_steps: int = 100
    schedule: str = "cosine"
    width: int = 128
    depth: int = 3
    time_embed_dim: int = 32
    steps: int = 4000
    batch_size: int = 256
    lr: float = 2e-3
    lr_schedule: str = "cosine"
    warmup_steps: int = 100
    p_uncond: float = 0.1
    seed: int = 0
    fourier_features: int = 64
    fourier_scale: float = 0.5

    def __post_init__(self):
        check_choice(self.distribution, TOY2D_DISTRIBUTIONS, "distribution")
        check_choice(self.schedule, ("cosine", "linear"), "schedule")
        check_numbers(self, ("lr", "fourier_scale"), above=0)
        check_numbers(self, ("p_uncond",), at_least=0, at_most=1)

    def noise_schedule(self) -> NoiseSchedule:
        """The ``diffusion_steps``-step noise schedule named by ``schedule``."""
        make = cosine_schedule if self.schedule == "cosine" else linear_schedule
        return make(self.diffusion_steps)


# What the larger scales change from the defaults (the toy preset).
TOY2D_SCALES = {
    "small": {"width": 256, "depth": 4, "steps": 20000, "diffusion_steps": 1000},
    "paper": {"width": 256, "depth": 4, "steps": 50000, "diffusion_steps": 1000, "n_train": 100000},
}


def toy2d_config(scale: str = "toy", **overrides) -> Toy2DConfig:
    """The configuration for a scale preset (``"toy"``, ``"small"``, ``"paper"``), fields overridable.

    Two dimensions need no big network; larger scales train longer with a wider model and use
    K = 1000 as NIFTY does.
    """
    return scaled_config(Toy2DConfig, scale, TOY2D_SCALES, overrides, factory="toy2d_config")


def build_toy2d_denoiser(config: Toy2DConfig) -> MLPDenoiser:
    """A freshly initialised class-conditional :class:`MLPDenoiser` for ``config`` (weights seeded)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return MLPDenoiser(2, n_classes=toy2d_num_classes(config.distribution), width=config.width,
                           depth=config.depth, time_embed_dim=config.time_embed_dim,
                           schedule=config.noise_schedule(), data_std=_DATA_STD[config.distribution],
                           fourier_features=config.fourier_features, fourier_scale=config.fourier_scale)


@single_threaded  # a small MLP: one CPU thread is fastest
def train_toy2d_denoiser(config: Toy2DConfig, device="cpu", progress: bool = False) -> tuple[MLPDenoiser, TrainResult]:
    """Train the 2-D denoiser with the x0 loss and label dropout (NIFTY §3.1).

    Args:
        config: a :class:`Toy2DConfig`.
        device: where to train (``"cpu"``, ``"auto"``, ``"cuda"`` …); the model stays there.
        progress: True always shows training's progress bar; False, where ``infra.progress`` shows one (a notebook).

    Returns:
        ``(model in eval mode, TrainResult)``.
    """
    points, labels = sample_toy2d(config.distribution, config.n_train, config.seed)
    model = build_toy2d_denoiser(config)
    result = train_denoiser(model, points, labels, config.noise_schedule(),
                            trainer_config(config, device=device, progress=progress), p_uncond=config.p_uncond)
    return model.eval(), result


def trained_toy2d_denoiser(config: Toy2DConfig, device="cpu", progress: bool = False) -> TrainedModel:
    """The 2-D denoiser for ``config``, trained once and then loaded from the artifact cache.

    Returns:
        a :class:`~hoi_tutorial.infra.TrainedModel` (the model in eval mode on the CPU, its losses
        and training seconds; no details).
    """
    def build():
        model, result = train_toy2d_denoiser(config, device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds)}

    artifact = load_or_build("toy2d_denoiser", config, build)
    model = build_toy2d_denoiser(config)
    model.load_state_dict(artifact["state"])
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"])
