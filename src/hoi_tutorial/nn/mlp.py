"""A plain multilayer perceptron, the building block of the denoisers, the encoders and the cVAEs."""
from __future__ import annotations

from typing import Callable, Sequence, Union

import torch
from torch import nn

from .._validate import check_choice, check_shape

__all__ = ["MLP", "ACTIVATIONS"]

ACTIVATIONS: dict = {
    "relu": nn.ReLU,
    "elu": nn.ELU,
    "gelu": nn.GELU,
    "silu": nn.SiLU,
    "tanh": nn.Tanh,
    "leaky_relu": nn.LeakyReLU,
}



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
