"""Transformer denoiser for motion diffusion, in the style of MDM and NIFTY (§3.1, Appendix B).

Token sequence, batch first::

    [ step token | one token per condition | one token per frame ]  + positional encoding
      → torch.nn.TransformerEncoder (GELU) → Linear on the frame tokens → x̂0

Each frame of the noisy motion ``x_k`` is a token; each condition vector (already encoded by the
caller: a PointNet code of the object points, an MLP code of the object pose, the body shape,
the start pose, …) is projected to one token; the diffusion step k becomes a token through
MDM's step embedder. The model predicts the clean motion x̂0 (x0-parameterisation).

For classifier-free guidance a condition can be dropped per sample (``drop_cond``): its tokens are
replaced by learned null tokens, which start at zero, MDM's null condition.
"""
from __future__ import annotations

from typing import Dict, Optional

import torch
from torch import nn

from .._validate import check_shape
from .embeddings import PositionalEncoding, TimestepEmbedding

__all__ = ["TransformerDenoiser"]


class TransformerDenoiser(nn.Module):
    """``x̂0 = M(x_k, k, C)``: an encoder-only transformer over frame, condition and step tokens.

    Args:
        x_dim: D, the size of one frame's pose state (e.g. NIFTY Eq. 1's vector).
        cond_dims: ``{name: size}`` of the condition vectors, one token each (may be empty).
        width: token size (NIFTY: 512).
        layers: number of encoder layers (NIFTY: 8).
        heads: attention heads (NIFTY: 4).
        dropout: dropout in the encoder and on the positional encoding (MDM: 0.1).
        max_len: the longest motion, in frames (NIFTY: 150).
        ff_dim: feed-forward width inside each layer (default ``2 · width``, as MDM's 1024 for 512).
    """

    def __init__(self, x_dim: int, cond_dims: Dict[str, int], width: int = 256, layers: int = 4,
                 heads: int = 4, dropout: float = 0.1, max_len: int = 256, ff_dim: Optional[int] = None):
        super().__init__()
        self.x_dim, self.width, self.max_len = int(x_dim), int(width), int(max_len)
        self.cond_dims = {str(name): int(size) for name, size in dict(cond_dims).items()}
        self.n_prefix = 1 + len(self.cond_dims)
        self.input_projection = nn.Linear(self.x_dim, self.width)
        self.step_embedding = TimestepEmbedding(self.width)
        self.cond_projections = nn.ModuleDict(
            {name: nn.Linear(size, self.width) for name, size in self.cond_dims.items()})
        self.null_tokens = nn.Parameter(torch.zeros(len(self.cond_dims), self.width))
        self.positional = PositionalEncoding(self.width, self.max_len + self.n_prefix, dropout)
        layer = nn.TransformerEncoderLayer(
            d_model=self.width, nhead=int(heads), dim_feedforward=int(ff_dim or 2 * self.width),
            dropout=dropout, activation="gelu", batch_first=True)
        self.encoder = nn.TransformerEncoder(layer, num_layers=int(layers), enable_nested_tensor=False)
        self.output_projection = nn.Linear(self.width, self.x_dim)

    def condition_tokens(self, cond: Optional[Dict[str, torch.Tensor]], drop_cond: Optional[torch.Tensor],
                         batch: int) -> torch.Tensor:
        """One token per condition, ``(B, n_cond, width)``; null tokens where ``drop_cond`` is True.

        Args:
            cond: ``{name: (B, cond_dims[name])}`` encoded condition vectors.
            drop_cond: ``(B,)`` bool or ``None`` (keep every condition).
        """
        cond = {} if cond is None else cond
        if set(cond) != set(self.cond_dims):
            raise ValueError(f"cond: expected the keys {sorted(self.cond_dims)}, got {sorted(cond)}")
        if not self.cond_dims:
            return self.null_tokens.new_zeros(batch, 0, self.width)
        tokens = []
        for name, size in self.cond_dims.items():
            check_shape(cond[name], (batch, size), f"cond[{name!r}]")
            tokens.append(self.cond_projections[name](cond[name].to(self.null_tokens.dtype)))
        tokens = torch.stack(tokens, dim=1)
        if drop_cond is not None:
            check_shape(drop_cond, (batch,), "drop_cond")
            drop = drop_cond.to(device=tokens.device, dtype=torch.bool)[:, None, None]
            tokens = torch.where(drop, self.null_tokens.expand_as(tokens), tokens)
        return tokens

    def forward(self, x_k: torch.Tensor, k: torch.Tensor, cond: Optional[Dict[str, torch.Tensor]] = None,
                drop_cond: Optional[torch.Tensor] = None,
                padding_mask: Optional[torch.Tensor] = None) -> torch.Tensor:
        """Predict the clean motion.

        Args:
            x_k: ``(B, T, x_dim)`` noisy motion, ``T ≤ max_len``.
            k: ``(B,)`` int64 diffusion steps.
            cond: ``{name: (B, cond_dims[name])}`` condition vectors.
            drop_cond: ``(B,)`` bool, True where the condition is replaced by the null condition.
            padding_mask: ``(B, T)`` bool, True for padded frames (PyTorch's key-padding
                convention): no token attends to them; their outputs are meaningless.

        Returns:
            ``(B, T, x_dim)`` the prediction x̂0.
        """
        check_shape(x_k, (None, None, self.x_dim), "x_k")
        batch, frames = x_k.shape[:2]
        if frames > self.max_len:
            raise ValueError(f"x_k: {frames} frames is more than max_len={self.max_len}")
        check_shape(k, (batch,), "k")
        step = self.step_embedding(k)[:, None, :]
        tokens = torch.cat([step, self.condition_tokens(cond, drop_cond, batch),
                            self.input_projection(x_k)], dim=1)
        tokens = self.positional(tokens)
        key_padding = None
        if padding_mask is not None:
            check_shape(padding_mask, (batch, frames), "padding_mask")
            prefix = torch.zeros(batch, self.n_prefix, dtype=torch.bool, device=padding_mask.device)
            key_padding = torch.cat([prefix, padding_mask.to(torch.bool)], dim=1).to(tokens.device)
        hidden = self.encoder(tokens, src_key_padding_mask=key_padding)
        return self.output_projection(hidden[:, self.n_prefix:])
