"""CHOICE's networks: the implicit trajectory planner's auto-decoder (§4.2, Fig. 3).

``FieldDecoder`` is ``f_θ(x, z; c) → (D_t, D_o, D_toa)``: DeepSDF's decoder ({cite}`park2019deepsdf`,
"an auto-decoder structure") reduced as CHOICE §8.1 says — an MLP of 6 layers of 256 with the input
concatenated again at the 4th — taking the query position ``x`` (grid frame, metres), the scene's
latent code ``z`` and the condition ``c ∈ R⁴``. Other channel sets give the 2-channel ablations of
§8.2.3: ``("t", "toa")`` is INTP-2Ch-D_t; ``("o'", "toa")`` is INTP-2Ch-D_o', where ``D_t`` and ``D_o``
are merged into one channel ``D_o'``, the inverse distance to the nearest surface, target or obstacle
(``max(D_t, D_o)``, :func:`channel_values`).

Ours, not stated: ReLU (DeepSDF's), no weight norm and no dropout (DeepSDF has both; the toy data is
small and clean), positions divided by the grid's half extent, field values multiplied by ``ε`` so that
they lie in ``[0, 1]`` (``1/max(d, ε)`` is at most ``1/ε``).
"""
from __future__ import annotations

import torch
import numpy as np
from torch import nn

from ..._validate import check_shape

__all__ = ["CHANNELS", "CHANNEL_SETS", "channel_values", "FieldDecoder"]

CHANNELS = ("t", "o", "o'", "toa")  # D_t, D_o, the merged D_o' (§8.2.3), D_toa
# The planner's channel sets: CHOICE's three fields and the two 2-channel ablations of §8.2.3.
CHANNEL_SETS = (("t", "o", "toa"), ("t", "toa"), ("o'", "toa"))


def channel_values(stacked, channels):
    """The fields of ``channels`` from Eq. 1's ``(D_t, D_o, D_toa)`` (..., 3) (numpy or torch) → (..., k);
    ``D_o' = max(D_t, D_o)`` is the inverse distance to the nearest of target and obstacles."""
    parts = {"t": stacked[..., 0], "o": stacked[..., 1], "toa": stacked[..., 2]}
    if "o'" in channels:
        parts["o'"] = (torch.maximum if isinstance(stacked, torch.Tensor) else np.maximum)(parts["t"], parts["o"])
    stack = torch.stack if isinstance(stacked, torch.Tensor) else np.stack
    return stack([parts[c] for c in channels], -1)


class FieldDecoder(nn.Module):
    """``f_θ(x, z; c)``: positions, latent codes and conditions → the fields of ``channels``.

    Args:
        latent: size of ``z`` (CHOICE: 128).
        condition: size of ``c`` (CHOICE: 4).
        width: hidden width (CHOICE §8.1: 256).
        layers: hidden layers (CHOICE §8.1: 6).
        skip: the hidden layer whose input is ``[h, x, z, c]`` again (CHOICE §8.1: the 4th; 1-based).
        channels: the output fields, one of ``CHANNEL_SETS``.
        half_extent: positions are divided by this (metres) before the first layer.
    """

    def __init__(self, latent: int, condition: int = 4, width: int = 256, layers: int = 6, skip: int = 4,
                 channels: tuple = CHANNEL_SETS[0], half_extent: float = 0.4):
        super().__init__()
        channels = tuple(channels)
        if channels not in CHANNEL_SETS:
            raise ValueError(f"channels: expected one of {[list(c) for c in CHANNEL_SETS]}, got {channels!r}")
        if not 1 <= skip <= layers:
            raise ValueError(f"skip: expected a hidden layer in [1, {layers}], got {skip}")
        self.latent, self.condition, self.channels, self.skip = int(latent), int(condition), channels, int(skip)
        self.half_extent = float(half_extent)
        in_dim = 3 + self.latent + self.condition
        self.hidden = nn.ModuleList()
        for k in range(1, layers + 1):
            width_in = in_dim if k == 1 else width
            if k == skip and k != 1:
                width_in = width + in_dim
            self.hidden.append(nn.Linear(width_in, width))
        self.out = nn.Linear(width, len(channels))

    def forward(self, x: torch.Tensor, z: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        """Args:
            x: (..., 3) metres, grid frame.
            z: (..., latent) codes (broadcast against ``x``'s leading dimensions).
            c: (..., condition) conditions (broadcast likewise).
        Returns:
            (..., len(channels)) fields times ``ε`` (about [0, 1]).
        """
        check_shape(x, (..., 3), "x")
        check_shape(z, (..., self.latent), "z")
        check_shape(c, (..., self.condition), "c")
        shape = torch.broadcast_shapes(x.shape[:-1], z.shape[:-1], c.shape[:-1])
        inputs = torch.cat([x.expand(*shape, 3) / self.half_extent, z.expand(*shape, self.latent),
                            c.expand(*shape, self.condition)], dim=-1)
        h = inputs
        for k, layer in enumerate(self.hidden, start=1):
            if k == self.skip and k != 1:
                h = torch.cat([h, inputs], dim=-1)
            h = torch.relu(layer(h))
        return self.out(h)
