"""Conditional-VAE helpers: Gaussian KL, the reparameterisation trick and a plain MLP.

Used by SAMP's MotionNet and GoalNet, the HuMoR-style motion prior of NIFTY's data pipeline and
the Cond. VAE baseline.
"""
from __future__ import annotations

from typing import Callable, Optional, Sequence, Union

import torch
from torch import nn

from .._validate import check_choice, check_shape

__all__ = ["gaussian_kl", "reparameterize", "MLP", "ACTIVATIONS"]

ACTIVATIONS: dict = {
    "relu": nn.ReLU,
    "elu": nn.ELU,
    "gelu": nn.GELU,
    "silu": nn.SiLU,
    "tanh": nn.Tanh,
    "leaky_relu": nn.LeakyReLU,
}


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


class MLP(nn.Module):
    """``x (..., in_dim) -> (..., out_dim)``: Linear layers with an activation between them.

    Args:
        in_dim: input size.
        hidden: hidden widths (may be empty: a single Linear).
        out_dim: output size.
        activation: one of ``ACTIVATIONS`` (``"relu"``, ``"elu"``, ``"gelu"``, ``"silu"``, ``"tanh"``,
            ``"leaky_relu"``) or a callable returning an ``nn.Module``.
        dropout: dropout after each hidden activation.
        final_activation: also apply the activation to the output.
    """

    def __init__(self, in_dim: int, hidden: Sequence[int], out_dim: int,
                 activation: Union[str, Callable[[], nn.Module]] = "relu", dropout: float = 0.0,
                 final_activation: bool = False):
        super().__init__()
        if isinstance(activation, str):
            check_choice(activation, ACTIVATIONS, "activation")
            make_activation = ACTIVATIONS[activation]
        else:
            make_activation = activation
        self.in_dim, self.out_dim = int(in_dim), int(out_dim)
        layers, width = [], self.in_dim
        for size in hidden:
            layers += [nn.Linear(width, int(size)), make_activation()]
            if dropout > 0:
                layers.append(nn.Dropout(dropout))
            width = int(size)
        layers.append(nn.Linear(width, self.out_dim))
        if final_activation:
            layers.append(make_activation())
        self.net = nn.Sequential(*layers)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        check_shape(x, (..., self.in_dim), "x")
        return self.net(x)
