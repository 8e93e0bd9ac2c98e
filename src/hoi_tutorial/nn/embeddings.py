"""Embeddings of scalars, continuous inputs and sequence positions.

- :class:`SinusoidalEmbedding`: a diffusion step (or any scalar) as sines and cosines
  (Vaswani et al. 2017, used for k in NIFTY §3.1 "k is encoded using a positional embedding");
- :class:`TimestepEmbedding`: MDM's step embedder, sinusoid → Linear → SiLU → Linear;
- :class:`FourierFeatures`: random Fourier features of a continuous vector (Tancik et al. 2020);
- :class:`PositionalEncoding`: the sinusoid table added to a token sequence.
"""
from __future__ import annotations

import math

import torch
from torch import nn

from .._validate import check_shape

__all__ = ["SinusoidalEmbedding", "TimestepEmbedding", "FourierFeatures", "PositionalEncoding",
           "sinusoid_table"]


def sinusoid_table(positions: torch.Tensor, dim: int, max_period: float = 10000.0) -> torch.Tensor:
    """``[sin(p ω_i), cos(p ω_i)]`` with ``ω_i = max_period^(-i / (dim/2))``.

    Args:
        positions: ``(...)`` positions or steps (int or float).
        dim: output size; an odd ``dim`` gets a trailing zero.

    Returns:
        ``(..., dim)`` float32 (float64 when ``positions`` is float64).
    """
    if dim < 1:
        raise ValueError(f"dim: expected a positive int, got {dim}")
    dtype = positions.dtype if positions.is_floating_point() else torch.float32
    half = dim // 2
    freqs = torch.exp(-math.log(max_period) * torch.arange(half, dtype=dtype, device=positions.device) / max(half, 1))
    angles = positions.to(dtype)[..., None] * freqs
    table = torch.cat([torch.sin(angles), torch.cos(angles)], dim=-1)
    if dim % 2:
        table = torch.cat([table, torch.zeros_like(table[..., :1])], dim=-1)
    return table


class SinusoidalEmbedding(nn.Module):
    """Fixed sinusoidal embedding of a scalar: ``k (...) -> (..., dim)``."""

    def __init__(self, dim: int, max_period: float = 10000.0):
        super().__init__()
        self.dim = int(dim)
        self.max_period = float(max_period)

    def forward(self, k: torch.Tensor) -> torch.Tensor:
        return sinusoid_table(torch.as_tensor(k), self.dim, self.max_period)


class TimestepEmbedding(nn.Module):
    """MDM's diffusion-step embedder: sinusoid → Linear → SiLU → Linear.

    ``forward(k: (B,) int64) -> (B, dim)``.
    """

    def __init__(self, dim: int, hidden: int | None = None):
        super().__init__()
        hidden = int(hidden or dim)
        self.sinusoid = SinusoidalEmbedding(dim)
        self.mlp = nn.Sequential(nn.Linear(dim, hidden), nn.SiLU(), nn.Linear(hidden, dim))

    def forward(self, k: torch.Tensor) -> torch.Tensor:
        emb = self.sinusoid(k).to(self.mlp[0].weight.dtype)
        return self.mlp(emb)


class FourierFeatures(nn.Module):
    """Random Fourier features ``[sin(2π B x), cos(2π B x)]`` of a continuous input.

    ``B: (n_freqs, in_dim)`` is drawn from ``N(0, scale²)`` with a fixed seed; ``learnable`` makes it
    a parameter. ``forward(x: (..., in_dim)) -> (..., out_dim)`` with ``out_dim = 2·n_freqs``
    (+ ``in_dim`` when ``include_input``).

    Args:
        in_dim: size of the input vectors (e.g. 3 for points in metres).
        n_freqs: number of random frequencies.
        learnable: train the frequencies.
        scale: standard deviation of the frequencies (cycles per input unit).
        include_input: append the raw input to the features.
        seed: seed of the frequency draw.
    """

    def __init__(self, in_dim: int, n_freqs: int, learnable: bool = False, scale: float = 1.0,
                 include_input: bool = False, seed: int = 0):
        super().__init__()
        self.in_dim, self.n_freqs, self.include_input = int(in_dim), int(n_freqs), bool(include_input)
        generator = torch.Generator().manual_seed(int(seed))
        freqs = torch.randn(self.n_freqs, self.in_dim, generator=generator) * float(scale)
        if learnable:
            self.freqs = nn.Parameter(freqs)
        else:
            self.register_buffer("freqs", freqs)
        self.out_dim = 2 * self.n_freqs + (self.in_dim if self.include_input else 0)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        check_shape(x, (..., self.in_dim), "x")
        angles = 2.0 * math.pi * (x.to(self.freqs.dtype) @ self.freqs.T)
        parts = [torch.sin(angles), torch.cos(angles)]
        if self.include_input:
            parts.append(x.to(self.freqs.dtype))
        return torch.cat(parts, dim=-1)


class PositionalEncoding(nn.Module):
    """Adds the sinusoid table to a token sequence: ``x (B, T, dim) -> (B, T, dim)``.

    ``forward(x, offset=0)`` adds the rows ``offset … offset+T-1``; ``T + offset ≤ max_len``.
    """

    def __init__(self, dim: int, max_len: int = 512, dropout: float = 0.0):
        super().__init__()
        self.dim, self.max_len = int(dim), int(max_len)
        self.register_buffer("table", sinusoid_table(torch.arange(self.max_len), self.dim), persistent=False)
        self.dropout = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor, offset: int = 0) -> torch.Tensor:
        check_shape(x, (None, None, self.dim), "x")
        length = x.shape[1]
        if offset + length > self.max_len:
            raise ValueError(f"x: sequence of {length} tokens (offset {offset}) is longer than "
                             f"max_len={self.max_len}")
        return self.dropout(x + self.table[offset:offset + length].to(x.dtype))
