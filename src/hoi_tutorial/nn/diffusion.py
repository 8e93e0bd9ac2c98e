"""Denoising diffusion (DDPM) with the x0-parameterisation, classifier-free guidance and
reconstruction guidance, written close to the equations of NIFTY §3.1.

Notation (NIFTY uses ``k`` for the diffusion step and ``τ`` for a motion; here ``x`` is any tensor
whose first dimension is the batch ``B``):

- forward process (NIFTY Eq. 2): ``q(x_k | x_{k-1}) = N(√(1-β_k) x_{k-1}, β_k I)``, so in closed form
  ``x_k = √ᾱ_k x_0 + √(1-ᾱ_k) ε`` with ``ᾱ_k = Π_{j≤k} (1-β_j)``;
- reverse step (NIFTY Eq. 3): ``p(x_{k-1} | x_k) = N(μ, β̃_k I)`` where ``μ`` is the mean of the
  forward posterior ``q(x_{k-1} | x_k, x̂_0)`` evaluated at the model's clean prediction
  ``x̂_0 = M(x_k, k, C)`` (the model predicts x0, not the noise);
- classifier-free guidance: ``x̂_0 = M(x_k, k, ∅) + s (M(x_k, k, C) - M(x_k, k, ∅))``;
- reconstruction guidance (NIFTY Eq. 4): ``x̃_0 = x̂_0 - α ∇_{x_k} G(x̂_0)``.

Steps are indexed ``k = 0 … K-1`` (``k = 0`` is the least noisy step, whose posterior mean is
``x̂_0`` itself). Schedules are held in float64 and cast to the data's dtype when used.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Callable, Iterable, Optional, Union

import torch

from .._validate import check_shape
from ..infra.training import TrainerConfig, TrainResult, train

__all__ = [
    "NoiseSchedule",
    "cosine_schedule",
    "linear_schedule",
    "q_sample",
    "q_posterior",
    "p_mean_from_x0",
    "classifier_free_x0",
    "guided_x0",
    "sample",
    "SamplingRecord",
    "sample_with_record",
    "best_of_n",
    "training_loss",
    "train_denoiser",
]


# --------------------------------------------------------------------------- schedules


@dataclass(frozen=True)
class NoiseSchedule:
    """Every per-step constant of a DDPM, each a ``(K,)`` float tensor indexed by the step ``k``.

    Attributes:
        betas: ``β_k``, the variance added by forward step k (NIFTY Eq. 2).
        alphas: ``α_k = 1 - β_k``.
        alphas_cumprod: ``ᾱ_k = Π_{j≤k} α_j``.
        alphas_cumprod_prev: ``ᾱ_{k-1}`` with ``ᾱ_{-1} = 1``.
        sqrt_alphas_cumprod, sqrt_one_minus_alphas_cumprod: ``√ᾱ_k`` and ``√(1-ᾱ_k)``.
        posterior_variance: ``β̃_k = β_k (1-ᾱ_{k-1}) / (1-ᾱ_k)`` (0 at k = 0).
        posterior_log_variance_clipped: ``log β̃_k`` with the k = 0 entry replaced by ``log β̃_1``.
        posterior_mean_coef1: ``c1_k = β_k √ᾱ_{k-1} / (1-ᾱ_k)``, the weight of x̂0 in the mean.
        posterior_mean_coef2: ``c2_k = (1-ᾱ_{k-1}) √α_k / (1-ᾱ_k)``, the weight of x_k.
    """

    betas: torch.Tensor
    alphas: torch.Tensor
    alphas_cumprod: torch.Tensor
    alphas_cumprod_prev: torch.Tensor
    sqrt_alphas_cumprod: torch.Tensor
    sqrt_one_minus_alphas_cumprod: torch.Tensor
    posterior_variance: torch.Tensor
    posterior_log_variance_clipped: torch.Tensor
    posterior_mean_coef1: torch.Tensor
    posterior_mean_coef2: torch.Tensor

    @classmethod
    def from_betas(cls, betas) -> "NoiseSchedule":
        """Derive every constant from ``betas: (K,)``, each in (0, 1]. Computed in float64."""
        betas = torch.as_tensor(betas, dtype=torch.float64).detach().cpu()
        check_shape(betas, (None,), "betas")
        if betas.numel() < 2:
            raise ValueError(f"betas: expected at least 2 diffusion steps, got {betas.numel()}")
        if not bool(((betas > 0) & (betas <= 1)).all()):
            raise ValueError("betas: expected every value in (0, 1]")
        alphas = 1.0 - betas
        alphas_cumprod = torch.cumprod(alphas, dim=0)
        alphas_cumprod_prev = torch.cat([torch.ones(1, dtype=torch.float64), alphas_cumprod[:-1]])
        posterior_variance = betas * (1.0 - alphas_cumprod_prev) / (1.0 - alphas_cumprod)
        # β̃_0 = 0: its log is clipped to log β̃_1 (the value is never used to add noise).
        log_var = torch.log(torch.cat([posterior_variance[1:2], posterior_variance[1:]]))
        return cls(
            betas=betas,
            alphas=alphas,
            alphas_cumprod=alphas_cumprod,
            alphas_cumprod_prev=alphas_cumprod_prev,
            sqrt_alphas_cumprod=alphas_cumprod.sqrt(),
            sqrt_one_minus_alphas_cumprod=(1.0 - alphas_cumprod).sqrt(),
            posterior_variance=posterior_variance,
            posterior_log_variance_clipped=log_var,
            posterior_mean_coef1=betas * alphas_cumprod_prev.sqrt() / (1.0 - alphas_cumprod),
            posterior_mean_coef2=(1.0 - alphas_cumprod_prev) * alphas.sqrt() / (1.0 - alphas_cumprod),
        )

    @property
    def num_steps(self) -> int:
        """``K``, the number of diffusion steps."""
        return int(self.betas.shape[0])

    @property
    def device(self) -> torch.device:
        """The device the schedule's tensors live on."""
        return self.betas.device

    def to(self, device) -> "NoiseSchedule":
        """A copy with every tensor on ``device`` (float32 on MPS, which has no float64)."""
        device = torch.device(device)
        dtype = torch.float32 if device.type == "mps" else torch.float64
        return NoiseSchedule(**{f.name: getattr(self, f.name).to(device, dtype) for f in fields(self)})

    def __len__(self) -> int:
        return self.num_steps


def cosine_schedule(K: int, s: float = 0.008, max_beta: float = 0.999) -> NoiseSchedule:
    """Cosine schedule (Nichol & Dhariwal 2021), used by MDM and NIFTY.

    ``ᾱ(t) = cos²((t/K + s)/(1 + s) · π/2)`` and ``β_k = min(1 - ᾱ(k+1)/ᾱ(k), max_beta)``.

    Args:
        K: number of diffusion steps (NIFTY: 1000).
        s: small offset that keeps β_0 from being vanishingly small.
        max_beta: clip for the last betas (ᾱ(K) = 0 would make β = 1).
    """
    if int(K) < 2:
        raise ValueError(f"K: expected at least 2 diffusion steps, got {K}")

    def alpha_bar(t: float) -> float:
        return math.cos((t + s) / (1.0 + s) * math.pi / 2.0) ** 2

    betas = [min(1.0 - alpha_bar((k + 1) / K) / alpha_bar(k / K), max_beta) for k in range(int(K))]
    return NoiseSchedule.from_betas(torch.tensor(betas, dtype=torch.float64))


def linear_schedule(K: int, beta_start: float = 1e-4, beta_end: float = 0.02,
                    max_beta: float = 0.999) -> NoiseSchedule:
    """Linear schedule of Ho et al. 2020, rescaled for ``K`` steps as in improved DDPM.

    The betas run linearly from ``beta_start · 1000/K`` to ``beta_end · 1000/K``, so that a
    schedule with fewer steps reaches about the same final noise level as the 1000-step one.
    Below about 20 steps the rescaled betas would pass 1; they are clipped at ``max_beta``.
    """
    K = int(K)
    if K < 2:
        raise ValueError(f"K: expected at least 2 diffusion steps, got {K}")
    scale = 1000.0 / K
    betas = torch.linspace(beta_start * scale, beta_end * scale, K, dtype=torch.float64).clamp(max=max_beta)
    return NoiseSchedule.from_betas(betas)


# --------------------------------------------------------------------------- helpers


def _check_steps(schedule: NoiseSchedule, k: torch.Tensor, batch: int, name: str = "k") -> None:
    if not isinstance(k, torch.Tensor) or k.dtype not in (torch.int64, torch.int32, torch.int16, torch.uint8):
        raise TypeError(f"{name}: expected an integer tensor of shape ({batch},)")
    check_shape(k, (batch,), name)
    if k.numel() and (int(k.min()) < 0 or int(k.max()) >= schedule.num_steps):
        raise ValueError(f"{name}: expected steps in [0, {schedule.num_steps}), got "
                         f"[{int(k.min())}, {int(k.max())}]")


def _extract(values: torch.Tensor, k: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
    """``values[k]`` shaped ``(B, 1, …, 1)`` to broadcast against ``like: (B, ...)``."""
    out = values.to(like.device)[k.to(like.device).long()].to(like.dtype)
    return out.reshape((-1,) + (1,) * (like.dim() - 1))


def _randn(shape, generator: Optional[torch.Generator], device, dtype) -> torch.Tensor:
    """Standard normal noise drawn with ``generator`` (on its own device), moved to ``device``."""
    gen_device = generator.device if generator is not None else torch.device("cpu")
    return torch.randn(tuple(shape), generator=generator, device=gen_device, dtype=dtype).to(device)


def _require_generator(generator) -> torch.Generator:
    if not isinstance(generator, torch.Generator):
        raise TypeError("generator: expected a torch.Generator (e.g. infra.seed_everything(seed)); "
                        f"got {type(generator).__name__}")
    return generator


# --------------------------------------------------------------------------- forward process


def q_sample(schedule: NoiseSchedule, x0: torch.Tensor, k: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
    """Noise clean data to step k in one go (closed form of NIFTY Eq. 2).

    ``x_k = √ᾱ_k x_0 + √(1-ᾱ_k) ε``.

    Args:
        schedule: the noise schedule.
        x0: ``(B, ...)`` clean data.
        k: ``(B,)`` int64 steps in ``[0, K)``.
        noise: ``(B, ...)`` standard normal ε, same shape as ``x0``.

    Returns:
        ``(B, ...)`` the noisy ``x_k``.
    """
    check_shape(noise, tuple(x0.shape), "noise")
    _check_steps(schedule, k, x0.shape[0])
    return (_extract(schedule.sqrt_alphas_cumprod, k, x0) * x0
            + _extract(schedule.sqrt_one_minus_alphas_cumprod, k, x0) * noise)


def q_posterior(schedule: NoiseSchedule, x0: torch.Tensor, x_k: torch.Tensor, k: torch.Tensor):
    """Mean and variance of the forward posterior ``q(x_{k-1} | x_k, x_0)``.

    ``μ = c1_k x_0 + c2_k x_k`` with ``c1_k = β_k √ᾱ_{k-1}/(1-ᾱ_k)`` and
    ``c2_k = (1-ᾱ_{k-1}) √α_k/(1-ᾱ_k)``; variance ``β̃_k``. With ``x_0 = x̂_0`` from the model this
    is the reverse step of NIFTY Eq. 3.

    Args:
        x0: ``(B, ...)`` clean data or the model's prediction x̂0.
        x_k: ``(B, ...)`` the noisy sample at step k.
        k: ``(B,)`` int64 steps.

    Returns:
        ``(mean, variance, log_variance)``, each ``(B, ...)``; ``log_variance`` is clipped at k = 0.
    """
    check_shape(x_k, tuple(x0.shape), "x_k")
    _check_steps(schedule, k, x0.shape[0])
    mean = _extract(schedule.posterior_mean_coef1, k, x_k) * x0 + _extract(schedule.posterior_mean_coef2, k, x_k) * x_k
    variance = _extract(schedule.posterior_variance, k, x_k).expand_as(x_k)
    log_variance = _extract(schedule.posterior_log_variance_clipped, k, x_k).expand_as(x_k)
    return mean, variance, log_variance


def p_mean_from_x0(schedule: NoiseSchedule, x0_hat: torch.Tensor, x_k: torch.Tensor, k: torch.Tensor) -> torch.Tensor:
    """Mean ``μ_θ(x_k, k)`` of the reverse step (NIFTY Eq. 3) from the model's ``x0_hat: (B, ...)``."""
    return q_posterior(schedule, x0_hat, x_k, k)[0]


# --------------------------------------------------------------------------- guidance


def _repeat_batch(value):
    """Concatenate a tensor (or every tensor in a dict / list) with itself along dim 0."""
    if isinstance(value, torch.Tensor):
        return torch.cat([value, value], dim=0)
    if isinstance(value, dict):
        return {key: _repeat_batch(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_repeat_batch(item) for item in value)
    return value


def classifier_free_x0(model: Callable, x_k: torch.Tensor, k: torch.Tensor, cond, scale: float,
                       *, batched: bool = True, **model_kwargs) -> torch.Tensor:
    """Classifier-free guided clean prediction (NIFTY §3.1, Ho & Salimans 2022).

    ``x̂_0 = M(x_k, k, ∅) + s (M(x_k, k, C) - M(x_k, k, ∅))``: ``s = 1`` is the conditional model,
    ``s = 0`` the unconditional one (both are returned from a single pass, exactly), ``s > 1``
    pushes further towards the condition (MDM uses 2.5).

    Args:
        model: ``model(x_k, k, cond, drop_cond, **model_kwargs) -> x0_hat`` where
            ``drop_cond: (B,) bool`` replaces the condition by the null condition per sample.
        x_k: ``(B, ...)`` noisy input.
        k: ``(B,)`` int64 steps.
        cond: the condition (a tensor, a dict of tensors or ``None``), batch first.
        scale: the guidance scale ``s``.
        batched: run the conditional and unconditional passes as one batch of ``2B``.
        **model_kwargs: extra model inputs; tensors are batch first and are repeated for the
            batched call (e.g. ``padding_mask``).

    Returns:
        ``(B, ...)`` the guided x̂0.
    """
    batch = x_k.shape[0]
    scale = float(scale)
    keep = torch.zeros(batch, dtype=torch.bool, device=x_k.device)
    if scale == 1.0:
        return model(x_k, k, cond, keep, **model_kwargs)
    if scale == 0.0:
        return model(x_k, k, cond, ~keep, **model_kwargs)
    if batched:
        drop = torch.cat([keep, ~keep])
        both = model(_repeat_batch(x_k), _repeat_batch(k), _repeat_batch(cond), drop,
                     **{name: _repeat_batch(value) for name, value in model_kwargs.items()})
        conditional, unconditional = both[:batch], both[batch:]
    else:
        conditional = model(x_k, k, cond, keep, **model_kwargs)
        unconditional = model(x_k, k, cond, ~keep, **model_kwargs)
    return unconditional + scale * (conditional - unconditional)


def guided_x0(x0_fn: Callable[[torch.Tensor], torch.Tensor], x_k: torch.Tensor,
              objective: Callable[[torch.Tensor], torch.Tensor], alpha: float):
    """Reconstruction guidance, NIFTY Eq. 4: ``x̃_0 = x̂_0 - α ∇_{x_k} G(x̂_0)``.

    The gradient of the objective is taken through the denoiser with respect to its noisy input
    ``x_k`` (as in Trace and Pace), not with respect to x̂0. Model parameters get no gradient.

    Args:
        x0_fn: ``x_k -> x0_hat``, the denoiser with the step and condition closed over.
        x_k: ``(B, ...)`` noisy input (not modified).
        objective: ``x0_hat (B, ...) -> G (B,)``, lower is better; the batch sum is differentiated,
            so each sample gets the gradient of its own objective.
        alpha: the guidance step size α.

    Returns:
        ``(x0_tilde, G)``: ``(B, ...)`` the guided prediction (detached) and ``(B,)`` the objective
        at the unguided x̂0 (detached).

    With ``alpha == 0`` (NIFTY's *selection only* control) ``x̃_0 = x̂_0`` and the gradient is not taken:
    the step costs a forward pass instead of a forward and a backward one. The forward is the one a
    guided step runs (``x_k`` requires grad), so ``x̂_0`` has the same bits as with the gradient.
    """
    x_k = x_k.detach().requires_grad_(True)
    with torch.enable_grad():
        x0_hat = x0_fn(x_k)
        values = objective(x0_hat)
        check_shape(values, (x_k.shape[0],), "objective(x0_hat)")
        if alpha == 0:  # x̂0 − 0·∇G = x̂0: the backward pass would be multiplied away
            return x0_hat.detach(), values.detach()
        (grad,) = torch.autograd.grad(values.sum(), x_k, allow_unused=True)
    if grad is None:  # x0_fn ignores its input: the objective cannot be moved through x_k
        grad = torch.zeros_like(x_k)
    return x0_hat.detach() - alpha * grad, values.detach()


# --------------------------------------------------------------------------- sampling


def sample(model_x0_fn: Callable[[torch.Tensor, torch.Tensor], torch.Tensor], shape, schedule: NoiseSchedule,
           *, generator: torch.Generator,
           guidance: Optional[Callable[[torch.Tensor], torch.Tensor]] = None,
           alpha: Union[float, Callable[[int], float]] = 0.0,
           guidance_steps: Optional[Iterable[int]] = None,
           x_init: Optional[torch.Tensor] = None,
           inpaint=None,
           device=None) -> torch.Tensor:
    """Ancestral DDPM sampling with the x0-parameterisation, from ``k = K-1`` down to ``k = 0``.

    Each step: ``x̂_0 = model_x0_fn(x_k, k)``; optionally guided with NIFTY Eq. 4 (``guided_x0``);
    optionally known entries of x̂0 replaced (inpainting); ``μ`` from ``q_posterior(x̂_0, x_k)``
    (NIFTY Eq. 3); ``x_{k-1} = μ + exp(½ log β̃_k) z`` with no noise at the last step (k = 0),
    whose mean is x̂0 itself. x̂0 is never clipped.

    Args:
        model_x0_fn: ``(x_k (B, ...), k (B,) int64) -> x0_hat (B, ...)``; close over the condition
            and classifier-free scale (e.g. with :func:`classifier_free_x0`).
        shape: ``(B, ...)`` shape of the samples.
        schedule: the noise schedule (K steps).
        generator: a ``torch.Generator``; all noise is drawn from it, so a seed fixes the result.
        guidance: objective ``x0_hat (B, ...) -> G (B,)`` to lower (NIFTY Eq. 4), or ``None``.
        alpha: guidance step size α, or a function ``k -> α``.
        guidance_steps: steps k that get guidance; default every step but the last (k ≥ 1).
        x_init: ``(B, ...)`` the starting noise x_{K-1}; default standard normal from ``generator``.
        inpaint: ``(mask, values)``: where the bool ``mask`` (broadcastable to ``shape``) is True,
            x̂0 is replaced by ``values`` at every step (MDM-style), so the sample keeps them.
        device: where to sample; default the device of ``x_init``, else of ``schedule``.

    Returns:
        ``x_0: (B, ...)``. :func:`sample_with_record` also returns every step's input and x̂0.
    """
    return _ancestral_sampling(model_x0_fn, shape, schedule, generator, guidance, alpha, guidance_steps, x_init,
                               inpaint, device, record=None)


@dataclass
class SamplingRecord:
    """A sampling run step by step (for plots), as :func:`sample_with_record` returns it.

    Attributes:
        sample: ``(B, ...)`` the final sample x_0.
        k: the steps in sampling order, ``K-1 … 0``.
        x_k: per step, ``(B, ...)`` the step's noisy input.
        x0_hat: per step, ``(B, ...)`` the clean prediction after guidance and inpainting.
        objective: per step, ``(B,)`` the guidance objective G at the unguided x̂0, or ``None`` for a
            step without guidance.
    """

    sample: torch.Tensor
    k: list
    x_k: list
    x0_hat: list
    objective: list

    def at(self, k: int) -> int:
        """The index into the per-step lists of step ``k``."""
        if k not in self.k:
            raise ValueError(f"k: expected one of the recorded steps {self.k[0]} … {self.k[-1]}, got {k!r}")
        return self.k.index(k)


def sample_with_record(model_x0_fn, shape, schedule: NoiseSchedule, *, generator: torch.Generator,
                       guidance=None, alpha=0.0, guidance_steps=None, x_init=None, inpaint=None,
                       device=None) -> SamplingRecord:
    """:func:`sample`, keeping each step's input ``x_k``, prediction ``x̂_0`` and objective.

    Same arguments and the same noise draws as :func:`sample` (for one generator seed the final
    samples are identical); returns a :class:`SamplingRecord`.
    """
    record = {"k": [], "x_k": [], "x0_hat": [], "objective": []}
    x = _ancestral_sampling(model_x0_fn, shape, schedule, generator, guidance, alpha, guidance_steps, x_init,
                            inpaint, device, record=record)
    return SamplingRecord(sample=x, **record)


def _ancestral_sampling(model_x0_fn, shape, schedule, generator, guidance, alpha, guidance_steps, x_init,
                        inpaint, device, record: Optional[dict]) -> torch.Tensor:
    generator = _require_generator(generator)
    shape = tuple(int(s) for s in shape)
    if device is None:
        device = x_init.device if x_init is not None else schedule.device
    device = torch.device(device)
    dtype = x_init.dtype if x_init is not None else torch.float32
    K = schedule.num_steps
    if x_init is None:
        x = _randn(shape, generator, device, dtype)
    else:
        check_shape(x_init, shape, "x_init")
        x = x_init.detach().to(device)
    steps_with_guidance = set(range(1, K)) if guidance_steps is None else {int(k) for k in guidance_steps}
    if inpaint is not None:
        mask, values = inpaint
        mask = torch.as_tensor(mask, dtype=torch.bool, device=device)
        values = torch.as_tensor(values, dtype=dtype, device=device)
        torch.broadcast_shapes(mask.shape, values.shape, shape)  # raises on a mismatch
    for k in range(K - 1, -1, -1):
        k_batch = torch.full((shape[0],), k, dtype=torch.int64, device=device)
        values_g = None
        if guidance is not None and k in steps_with_guidance:
            step_alpha = alpha(k) if callable(alpha) else alpha
            x0_hat, values_g = guided_x0(lambda x_: model_x0_fn(x_, k_batch), x, guidance, step_alpha)
        else:
            with torch.no_grad():
                x0_hat = model_x0_fn(x, k_batch)
        x0_hat = x0_hat.detach()
        if inpaint is not None:
            x0_hat = torch.where(mask, values, x0_hat)
        if record is not None:
            record["k"].append(k)
            record["x_k"].append(x.clone())
            record["x0_hat"].append(x0_hat.clone())
            record["objective"].append(values_g)
        mean, _, log_variance = q_posterior(schedule, x0_hat, x, k_batch)
        if k > 0:
            x = mean + torch.exp(0.5 * log_variance) * _randn(shape, generator, device, dtype)
        else:
            x = mean
    return x


def best_of_n(samples: torch.Tensor, objective_values: torch.Tensor, lower_is_better: bool = True):
    """Keep the best of N samples by their guidance objective (NIFTY §4.1: 10 samples).

    Args:
        samples: ``(N, ...)`` candidates.
        objective_values: ``(N,)`` their objective G (lower is better unless told otherwise).

    Returns:
        ``(index, sample)``: the int index of the best candidate and ``samples[index]``.
    """
    check_shape(objective_values, (samples.shape[0],), "objective_values")
    values = torch.as_tensor(objective_values)
    if not bool(torch.isfinite(values).any()):
        raise ValueError("objective_values: expected at least one finite value")
    values = torch.where(torch.isfinite(values), values,
                         torch.full_like(values, math.inf if lower_is_better else -math.inf))
    index = int(values.argmin() if lower_is_better else values.argmax())
    return index, samples[index]


# --------------------------------------------------------------------------- training


def training_loss(model: Callable, x0: torch.Tensor, cond, schedule: NoiseSchedule, *,
                  generator: torch.Generator, p_uncond: float = 0.1,
                  mask: Optional[torch.Tensor] = None, model_kwargs: Optional[dict] = None) -> torch.Tensor:
    """The x0-prediction diffusion loss ``‖M(x_k, k, C) - x_0‖²`` (NIFTY §3.1).

    A step k is drawn uniformly per sample, ``x_k`` by :func:`q_sample`, and the condition is
    dropped (replaced by the null condition) for a Bernoulli(``p_uncond``) subset of the batch so
    the same model serves classifier-free guidance.

    Args:
        model: ``model(x_k, k, cond, drop_cond, **model_kwargs) -> x0_hat`` as in
            :func:`classifier_free_x0`.
        x0: ``(B, ...)`` clean data; ``(B, T, D)`` when ``mask`` is given.
        cond: the condition (tensor, dict of tensors or ``None``).
        schedule: the noise schedule.
        generator: ``torch.Generator`` for k, the noise and the dropout coin.
        p_uncond: probability of dropping the condition (NIFTY and MDM: 0.1).
        mask: optional ``(B, T)`` bool, True for the frames that count; padded frames are ignored.
            Without it every entry counts (NIFTY pads with the last frame and trains on all).
        model_kwargs: extra inputs passed to the model (e.g. ``{"padding_mask": ...}``).

    Returns:
        the scalar mean squared error over the counted entries.
    """
    generator = _require_generator(generator)
    if not 0.0 <= p_uncond <= 1.0:
        raise ValueError(f"p_uncond: expected a probability in [0, 1], got {p_uncond}")
    batch, device = x0.shape[0], x0.device
    gen_device = generator.device
    k = torch.randint(0, schedule.num_steps, (batch,), generator=generator, device=gen_device).to(device)
    noise = _randn(x0.shape, generator, device, x0.dtype)
    drop = (torch.rand(batch, generator=generator, device=gen_device) < p_uncond).to(device)
    x_k = q_sample(schedule, x0, k, noise)
    x0_hat = model(x_k, k, cond, drop, **(model_kwargs or {}))
    check_shape(x0_hat, tuple(x0.shape), "model output")
    squared = (x0_hat - x0) ** 2
    if mask is None:
        return squared.mean()
    check_shape(x0, (batch, None, None), "x0 (with mask)")
    check_shape(mask, tuple(x0.shape[:2]), "mask")
    weights = mask.to(squared.dtype)[..., None]
    count = weights.sum() * x0.shape[-1]
    if float(count) == 0.0:
        raise ValueError("mask: expected at least one frame marked True")
    return (squared * weights).sum() / count


def train_denoiser(model: torch.nn.Module, x0: torch.Tensor, cond, schedule: NoiseSchedule,
                   config: TrainerConfig, *, p_uncond: float = 0.1) -> TrainResult:
    """Fit a denoiser with the x0 loss (NIFTY §3.1) on a fixed data set: the training closure of every
    diffusion model in the book.

    Each step draws ``config.batch_size`` rows uniformly with replacement (the trainer's seeded
    generator), then a seed for that step's k, noise and condition-dropout coin, and calls
    :func:`training_loss`. The model is trained in place by :func:`hoi_tutorial.infra.train`.

    Args:
        model: ``model(x_k, k, cond, drop_cond) -> x0_hat``.
        x0: ``(N, ...)`` the training data (already normalised as the model expects).
        cond: ``None``, a ``(N, ...)`` tensor (e.g. class labels) or a dict of ``(N, ...)`` tensors,
            indexed with the same rows as ``x0``.
        schedule: the noise schedule (moved to the training device once).
        config: the optimisation settings (see :func:`hoi_tutorial.infra.trainer_config`).
        p_uncond: probability of dropping the condition (NIFTY and MDM: 0.1; 0 when unconditional).
    Returns:
        the :class:`~hoi_tutorial.infra.TrainResult`.
    """
    n = int(x0.shape[0])
    if n < 1:
        raise ValueError("x0: expected at least one training example")
    rows = cond.values() if isinstance(cond, dict) else ([] if cond is None else [cond])
    for value in rows:
        if int(value.shape[0]) != n:
            raise ValueError(f"cond: expected {n} rows as x0 has, got {int(value.shape[0])}")
    schedules = {}  # the schedule moved to each training device once

    def sample_batch(step: int, generator: torch.Generator):
        index = torch.randint(0, n, (config.batch_size,), generator=generator)
        if isinstance(cond, dict):
            batch_cond = {name: value[index] for name, value in cond.items()}
        else:
            batch_cond = None if cond is None else cond[index]
        return {"x0": x0[index], "cond": batch_cond, "seed": torch.randint(0, 2**62, (1,), generator=generator)}

    def loss_fn(net, batch):
        where = batch["x0"].device
        if where not in schedules:
            schedules[where] = schedule.to(where)
        generator = torch.Generator(device=where).manual_seed(int(batch["seed"]))
        return training_loss(net, batch["x0"], batch["cond"], schedules[where], generator=generator,
                             p_uncond=p_uncond)

    return train(model, sample_batch, loss_fn, config)
