"""Mixture of experts with blended weights (SAMP Eq. 2, after Zhang et al. 2018).

A gating network outputs per-sample blending weights ``ω (B, K)`` (softmax, they sum to one);
each layer of the prediction network then uses the blended parameters
``W = Σ_k ω_k W_k`` and ``b = Σ_k ω_k b_k``. Because a layer is affine, this equals blending the
K experts' layer outputs; the nonlinearity comes after the blend, so the whole network is *not*
a blend of K separate networks.
"""
from __future__ import annotations

import math
from typing import Optional

import torch
from torch import nn

from .._validate import check_shape

__all__ = ["MixtureOfExpertsLinear", "GatingNetwork", "MoEMLP"]


class MixtureOfExpertsLinear(nn.Module):
    """A linear layer whose parameters are a per-sample blend of K experts' (SAMP Eq. 2).

    Parameters ``weight: (K, in_dim, out_dim)`` and ``bias: (K, out_dim)``, each expert initialised
    like ``nn.Linear``. ``forward(x: (B, in_dim), weights: (B, K)) -> (B, out_dim)``.
    """

    def __init__(self, in_dim: int, out_dim: int, n_experts: int):
        super().__init__()
        self.in_dim, self.out_dim, self.n_experts = int(in_dim), int(out_dim), int(n_experts)
        bound = 1.0 / math.sqrt(self.in_dim)
        self.weight = nn.Parameter(torch.empty(self.n_experts, self.in_dim, self.out_dim).uniform_(-bound, bound))
        self.bias = nn.Parameter(torch.empty(self.n_experts, self.out_dim).uniform_(-bound, bound))

    def blended_parameters(self, weights: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Eq. 2 literally: ``W = Σ_k ω_k W_k (B, in_dim, out_dim)`` and ``b = Σ_k ω_k b_k (B, out_dim)``."""
        check_shape(weights, (None, self.n_experts), "weights")
        return torch.einsum("bk,kio->bio", weights, self.weight), weights @ self.bias

    def forward(self, x: torch.Tensor, weights: torch.Tensor) -> torch.Tensor:
        check_shape(x, (None, self.in_dim), "x")
        check_shape(weights, (x.shape[0], self.n_experts), "weights")
        # x (Σ_k ω_k W_k) + Σ_k ω_k b_k = Σ_k ω_k (x W_k + b_k): the same numbers as the blended
        # parameters of ``blended_parameters``, without a (B, in_dim, out_dim) tensor per batch.
        experts = torch.matmul(x, self.weight)  # (K, B, out_dim): x W_k for every expert
        return torch.einsum("bk,kbo->bo", weights, experts) + weights @ self.bias


class GatingNetwork(nn.Module):
    """Three-layer ELU network giving the expert blending weights: ``(B, in_dim) -> (B, K)``.

    ``hidden`` is one width for both hidden layers or a pair (SAMP Table S.3: {512, 256, 12}).
    The output is a softmax, so each row is non-negative and sums to one.
    """

    def __init__(self, in_dim: int, hidden, n_experts: int, dropout: float = 0.0):
        super().__init__()
        self.in_dim, self.n_experts = int(in_dim), int(n_experts)
        first, second = (int(hidden), int(hidden)) if isinstance(hidden, (int, float)) else map(int, hidden)
        self.net = nn.Sequential(
            nn.Dropout(dropout), nn.Linear(self.in_dim, first), nn.ELU(),
            nn.Dropout(dropout), nn.Linear(first, second), nn.ELU(),
            nn.Dropout(dropout), nn.Linear(second, self.n_experts),
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        check_shape(x, (None, self.in_dim), "x")
        return torch.softmax(self.net(x), dim=-1)


class MoEMLP(nn.Module):
    """SAMP's prediction network: three blended layers with ELU, weights from a gating network.

    Args:
        in_dim: size of the main input.
        hidden: width of the two hidden layers.
        out_dim: size of the prediction.
        n_experts: K (SAMP: 12).
        gating_in: size of the gating network's input (SAMP: ``[z, x_{i-1}]``).
        gating_hidden: width of the gating network's hidden layers, one number or a pair
            (default ``hidden``).
        extra_dim: size of a vector concatenated to the input of *every* layer (SAMP feeds the
            latent z this way); 0 for none.
        dropout: dropout before each layer.
    """

    def __init__(self, in_dim: int, hidden: int, out_dim: int, n_experts: int, gating_in: int,
                 gating_hidden=None, extra_dim: int = 0, dropout: float = 0.0):
        super().__init__()
        self.in_dim, self.out_dim, self.extra_dim = int(in_dim), int(out_dim), int(extra_dim)
        self.gating = GatingNetwork(gating_in, hidden if gating_hidden is None else gating_hidden, n_experts, dropout)
        self.layers = nn.ModuleList([
            MixtureOfExpertsLinear(self.in_dim + self.extra_dim, hidden, n_experts),
            MixtureOfExpertsLinear(hidden + self.extra_dim, hidden, n_experts),
            MixtureOfExpertsLinear(hidden + self.extra_dim, self.out_dim, n_experts),
        ])
        self.activation = nn.ELU()
        self.dropout = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor, gating_input: torch.Tensor, extra: Optional[torch.Tensor] = None,
                return_weights: bool = False):
        """Predict from ``x: (B, in_dim)`` with experts chosen by ``gating_input: (B, gating_in)``.

        Args:
            extra: ``(B, extra_dim)`` concatenated to every layer's input (required when
                ``extra_dim > 0``).
            return_weights: also return the blending weights ``(B, K)``.

        Returns:
            ``(B, out_dim)``, or ``(prediction, weights)``.
        """
        check_shape(x, (None, self.in_dim), "x")
        # checked here, by the caller's name: the gating network and the layers would name their own arguments
        check_shape(gating_input, (x.shape[0], self.gating.in_dim), "gating_input")
        if self.extra_dim:
            if extra is None:
                raise ValueError(f"extra: expected a (B, {self.extra_dim}) tensor (extra_dim > 0)")
            check_shape(extra, (x.shape[0], self.extra_dim), "extra")
        weights = self.gating(gating_input)
        h = x
        for index, layer in enumerate(self.layers):
            if self.extra_dim:
                h = torch.cat([h, extra], dim=-1)
            h = layer(self.dropout(h), weights)
            if index < len(self.layers) - 1:
                h = self.activation(h)
        return (h, weights) if return_weights else h
