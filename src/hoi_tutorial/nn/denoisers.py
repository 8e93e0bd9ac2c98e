"""A small x0-predicting denoiser for vectors: 2-D points, flattened short trajectories.

:class:`MLPDenoiser` has the interface that :func:`hoi_tutorial.nn.diffusion.classifier_free_x0`
and :func:`hoi_tutorial.nn.diffusion.training_loss` expect, ``model(x_k, k, cond, drop_cond)``::

    e = E_step(k) + E_cond(C)                     (E_cond(∅) is a learned null embedding)
    h = W_in φ(x_k) + e                           (φ: identity, or random Fourier features)
    h = h + MLP(LayerNorm(h) + e)                 for each of ``depth`` residual blocks
    F = W_out h                                   (a linear read-out of the residual stream)

Without a schedule the prediction is ``x̂0 = F`` (as MDM's). Optionally (``schedule=...``) ``F``
is wrapped in the preconditioning of Karras et al. (2022), written for the variance-preserving
process of NIFTY Eq. 2::

    x̂0 = c_skip(k) x_k + c_out(k) F(c_in(k) x_k, k, C),   D_k = 1 - ᾱ_k + ᾱ_k σ_d²,
    c_in = 1/√D_k,   c_skip = σ_d² √ᾱ_k / D_k,   c_out = σ_d √(1-ᾱ_k) / √D_k

(σ_d: the data's standard deviation). It is still an x0 prediction trained with the same loss,
but at low noise the near-identity ``x̂0 ≈ x_k/√ᾱ_k`` is built in, so the last sampling steps
neither blur nor shrink the samples; with the plain x0 loss a bare network learns that identity
poorly, because low-noise steps contribute almost nothing to the loss.

The condition is either a class label (``n_classes``: an embedding table with one extra row, the
null class) or a vector (``cond_dim``: a linear map, and a learned null vector). Dropping the
condition per sample (``drop_cond``) swaps in the null embedding, so one network is both the
conditional and the unconditional model of classifier-free guidance (NIFTY §3.1).
"""
from __future__ import annotations

import math
from typing import Optional

import torch
from torch import nn

from .._validate import check_shape
from .mlp import MLP
from .diffusion import NoiseSchedule
from .embeddings import FourierFeatures, TimestepEmbedding

__all__ = ["MLPDenoiser"]


class _ResidualBlock(nn.Module):
    """``h + MLP(LayerNorm(h) + e)``: the step/condition embedding ``e`` re-enters every block."""

    def __init__(self, width: int):
        super().__init__()
        self.norm = nn.LayerNorm(width)
        self.mlp = MLP(width, [width], width, activation="silu")

    def forward(self, h: torch.Tensor, emb: torch.Tensor) -> torch.Tensor:
        return h + self.mlp(self.norm(h) + emb)


class MLPDenoiser(nn.Module):
    """``x̂0 = M(x_k, k, C)`` for inputs whose trailing dimensions hold ``x_dim`` numbers.

    Args:
        x_dim: the number of values in one sample (2 for a 2-D point, ``T·3`` for a trajectory
            of T frames); inputs ``(B, *event_shape)`` with ``prod(event_shape) = x_dim`` are
            flattened on the way in and reshaped on the way out.
        cond_dim: size of a vector condition; 0 for none.
        n_classes: number of class labels for a label condition; ``None`` for none. At most one
            of ``cond_dim`` and ``n_classes`` may be used.
        width: hidden width of the residual MLP.
        depth: number of residual blocks.
        time_embed_dim: width of the sinusoidal step embedding before it is projected to
            ``width`` (MDM's step embedder: sinusoid → Linear → SiLU → Linear).
        schedule: the :class:`~hoi_tutorial.nn.diffusion.NoiseSchedule` the model will be used
            with, to precondition as above; ``None`` for a bare network (``x̂0 = F``, as MDM).
        data_std: σ_d, the standard deviation of the data (used only with ``schedule``).
        fourier_features: when > 0, the (scaled) input is first mapped to that many random
            Fourier features (plus the input itself); helps an MLP on low-dimensional inputs such
            as 2-D points learn sharp functions.
        fourier_scale: standard deviation of the Fourier frequencies (cycles per input unit).
    """

    def __init__(self, x_dim: int, cond_dim: int = 0, n_classes: Optional[int] = None, width: int = 128,
                 depth: int = 3, time_embed_dim: int = 64, schedule: Optional[NoiseSchedule] = None,
                 data_std: float = 1.0, fourier_features: int = 0, fourier_scale: float = 1.0):
        super().__init__()
        for name, value, low in (("x_dim", x_dim, 1), ("cond_dim", cond_dim, 0), ("width", width, 1),
                                 ("depth", depth, 1), ("time_embed_dim", time_embed_dim, 2)):
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"{name}: expected an int >= {low}, got {value!r}")
        if n_classes is not None and (isinstance(n_classes, bool) or not isinstance(n_classes, int)
                                      or n_classes < 1):
            raise ValueError(f"n_classes: expected None or an int >= 1, got {n_classes!r}")
        if cond_dim and n_classes is not None:
            raise ValueError("cond_dim and n_classes: expected at most one kind of condition, got both")
        if not (isinstance(data_std, (int, float)) and data_std > 0):
            raise ValueError(f"data_std: expected a positive number, got {data_std!r}")
        if isinstance(fourier_features, bool) or not isinstance(fourier_features, int) or fourier_features < 0:
            raise ValueError(f"fourier_features: expected an int >= 0, got {fourier_features!r}")
        if schedule is not None and not isinstance(schedule, NoiseSchedule):
            raise TypeError(f"schedule: expected a NoiseSchedule or None, got {type(schedule).__name__}")
        self.x_dim, self.cond_dim, self.n_classes = x_dim, cond_dim, n_classes
        self.data_std = float(data_std)
        self.preconditioned = schedule is not None
        if schedule is not None:
            self.register_buffer("alphas_cumprod", schedule.alphas_cumprod.to(torch.float32).clone())
        self.width, self.depth = width, depth
        self.fourier = None
        in_dim = x_dim
        if fourier_features:
            self.fourier = FourierFeatures(x_dim, fourier_features, scale=float(fourier_scale),
                                           include_input=True)
            in_dim = self.fourier.out_dim
        self.input_projection = nn.Linear(in_dim, width)
        self.step_embedding = nn.Sequential(TimestepEmbedding(time_embed_dim), nn.Linear(time_embed_dim, width))
        if n_classes is not None:
            # Row n_classes is the null class (the condition dropped).
            self.class_embedding = nn.Embedding(n_classes + 1, width)
        elif cond_dim:
            self.cond_projection = nn.Linear(cond_dim, width)
            self.null_condition = nn.Parameter(torch.zeros(width))
        self.blocks = nn.ModuleList(_ResidualBlock(width) for _ in range(depth))
        self.output_projection = nn.Linear(width, x_dim)

    @property
    def conditional(self) -> bool:
        """Whether the model takes a condition (a label or a vector)."""
        return self.n_classes is not None or self.cond_dim > 0

    def condition_embedding(self, cond, drop_cond: Optional[torch.Tensor], batch: int,
                            device: torch.device) -> torch.Tensor:
        """``(B, width)``: the condition's embedding, the null embedding where it is dropped.

        Args:
            cond: ``(B,)`` int64 labels in ``[0, n_classes)``, or ``(B, cond_dim)`` vectors, or
                ``None`` (the null condition for every sample).
            drop_cond: ``(B,)`` bool, True where the condition is replaced by the null one; or None.
        """
        dtype = self.input_projection.weight.dtype
        if not self.conditional:
            if cond is not None:
                raise ValueError("cond: this model is unconditional (cond_dim=0, n_classes=None); pass None")
            return torch.zeros(batch, self.width, device=device, dtype=dtype)
        drop = torch.zeros(batch, dtype=torch.bool, device=device)
        if drop_cond is not None:
            check_shape(drop_cond, (batch,), "drop_cond")
            drop = drop_cond.to(device=device, dtype=torch.bool)
        if self.n_classes is not None:
            null = torch.full((batch,), self.n_classes, dtype=torch.long, device=device)
            if cond is None:
                return self.class_embedding(null)
            if not isinstance(cond, torch.Tensor) or cond.is_floating_point() or cond.dtype == torch.bool:
                raise TypeError(f"cond: expected an int64 tensor of {batch} class labels")
            check_shape(cond, (batch,), "cond")
            labels = cond.to(device=device, dtype=torch.long)
            if labels.numel() and (int(labels.min()) < 0 or int(labels.max()) >= self.n_classes):
                raise ValueError(f"cond: expected labels in [0, {self.n_classes}), got "
                                 f"[{int(labels.min())}, {int(labels.max())}]")
            return self.class_embedding(torch.where(drop, null, labels))
        null = self.null_condition.expand(batch, self.width)
        if cond is None:
            return null
        check_shape(cond, (batch, self.cond_dim), "cond")
        embedded = self.cond_projection(cond.to(device=device, dtype=dtype))
        return torch.where(drop[:, None], null, embedded)

    def forward(self, x_k: torch.Tensor, k: torch.Tensor, cond=None,
                drop_cond: Optional[torch.Tensor] = None) -> torch.Tensor:
        """Predict the clean sample.

        Args:
            x_k: ``(B, *event_shape)`` noisy samples, ``prod(event_shape) = x_dim``.
            k: ``(B,)`` int64 diffusion steps.
            cond: ``(B,)`` int64 labels, ``(B, cond_dim)`` vectors, or ``None`` (null condition).
            drop_cond: ``(B,)`` bool, True where the condition is dropped (classifier-free guidance).

        Returns:
            ``(B, *event_shape)`` the prediction x̂0.
        """
        if not isinstance(x_k, torch.Tensor) or x_k.dim() < 2:
            raise ValueError(f"x_k: expected a tensor of shape (B, ...) with {self.x_dim} values per sample")
        batch, event_shape = x_k.shape[0], tuple(x_k.shape[1:])
        if math.prod(event_shape) != self.x_dim:
            raise ValueError(f"x_k: expected {self.x_dim} values per sample, got shape {tuple(x_k.shape)}")
        check_shape(k, (batch,), "k")
        flat = x_k.reshape(batch, self.x_dim).to(self.input_projection.weight.dtype)
        k = k.to(x_k.device)
        if self.preconditioned:
            if k.numel() and (int(k.min()) < 0 or int(k.max()) >= self.alphas_cumprod.shape[0]):
                raise ValueError(f"k: expected steps in [0, {self.alphas_cumprod.shape[0]}) of the model's schedule")
            alpha_bar = self.alphas_cumprod[k.long()][:, None].to(flat.dtype)
            variance = self.data_std ** 2
            denominator = 1.0 - alpha_bar + alpha_bar * variance
            c_in = denominator.rsqrt()
            c_skip = variance * alpha_bar.sqrt() / denominator
            c_out = self.data_std * (1.0 - alpha_bar).sqrt() * c_in
        else:
            c_in, c_skip, c_out = 1.0, 0.0, 1.0
        emb = self.step_embedding(k) + self.condition_embedding(cond, drop_cond, batch, x_k.device)
        features = c_in * flat
        if self.fourier is not None:
            features = self.fourier(features)
        h = self.input_projection(features) + emb
        for block in self.blocks:
            h = block(h, emb)
        out = c_skip * flat + c_out * self.output_projection(h)
        return out.reshape((batch,) + event_shape)
