"""Conditional-VAE helpers: the Gaussian KL and the reparameterisation trick.

Used by SAMP's MotionNet and GoalNet, the HuMoR-style motion prior of NIFTY's data pipeline and
the Cond. VAE baseline.
"""
from __future__ import annotations

from typing import Optional

import torch

from .._validate import check_shape

__all__ = ["gaussian_kl", "reparameterize"]

def gaussian_kl(mu: torch.Tensor, logvar: torch.Tensor, prior_mu: Optional[torch.Tensor] = None,
                prior_logvar: Optional[torch.Tensor] = None) -> torch.Tensor:
    """``KL(N(mu, e^logvar) || N(prior_mu, e^prior_logvar))`` for diagonal Gaussians.

    ``½ Σ_d [log σ_p² - log σ² + (σ² + (μ - μ_p)²)/σ_p² - 1]``; the prior defaults to ``N(0, I)``
    (SAMP), or is a learned conditional prior ``p(z | x_{t-1})`` (HuMoR).

    Args:
        mu, logvar: ``(..., Z)`` the posterior's mean and log-variance.
        prior_mu, prior_logvar: ``(..., Z)`` (broadcastable) the prior's, or ``None`` for 0.

    Returns:
        ``(...)`` the KL per sample, summed over the Z latent dimensions.
    """
    check_shape(logvar, tuple(mu.shape), "logvar")
    prior_mu = torch.zeros_like(mu) if prior_mu is None else prior_mu
    prior_logvar = torch.zeros_like(logvar) if prior_logvar is None else prior_logvar
    terms = (prior_logvar - logvar
             + (torch.exp(logvar) + (mu - prior_mu) ** 2) * torch.exp(-prior_logvar) - 1.0)
    return 0.5 * terms.sum(dim=-1)


def reparameterize(mu: torch.Tensor, logvar: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
    """``z = μ + exp(½ logvar) ε`` with ``ε ~ N(0, I)`` drawn from ``generator``.

    Args:
        mu, logvar: ``(..., Z)``.
        generator: a ``torch.Generator`` (drawn on its own device, moved to ``mu``'s).

    Returns:
        ``(..., Z)`` a sample, differentiable with respect to ``mu`` and ``logvar``.
    """
    if not isinstance(generator, torch.Generator):
        raise TypeError(f"generator: expected a torch.Generator, got {type(generator).__name__}")
    check_shape(logvar, tuple(mu.shape), "logvar")
    eps = torch.randn(mu.shape, generator=generator, device=generator.device, dtype=mu.dtype).to(mu.device)
    return mu + torch.exp(0.5 * logvar) * eps
