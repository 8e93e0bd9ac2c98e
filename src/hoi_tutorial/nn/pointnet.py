"""PointNet encoder (Qi et al. 2017): a shared per-point MLP, then a max over the points.

The max makes the code invariant to the order of the points; NIFTY encodes the object point
cloud with it (§3.1, "the object point cloud P_o is encoded with a PointNet").
"""
from __future__ import annotations

from typing import Optional, Sequence

import torch
from torch import nn

from .._validate import check_shape

__all__ = ["PointNetEncoder"]


class PointNetEncoder(nn.Module):
    """``points (B, P, in_dim) -> code (B, out_dim)``, invariant to the order of the P points.

    Args:
        out_dim: size of the code.
        hidden: widths of the shared per-point layers (ReLU after each).
        in_dim: coordinates per point (3 for xyz in metres; more for extra point features).
    """

    def __init__(self, out_dim: int, hidden: Sequence[int] = (64, 128), in_dim: int = 3):
        super().__init__()
        if not hidden:
            raise ValueError("hidden: expected at least one shared layer width")
        self.in_dim, self.out_dim = int(in_dim), int(out_dim)
        layers, width = [], self.in_dim
        for size in hidden:
            layers += [nn.Linear(width, int(size)), nn.ReLU()]
            width = int(size)
        self.shared = nn.Sequential(*layers)  # a Linear on the last axis = a 1x1 convolution
        self.head = nn.Linear(width, self.out_dim)

    def forward(self, points: torch.Tensor, point_mask: Optional[torch.Tensor] = None) -> torch.Tensor:
        """Encode a batch of point clouds.

        Args:
            points: ``(B, P, in_dim)`` points (metres, in the frame the caller chose).
            point_mask: optional ``(B, P)`` bool, True for real points (to batch clouds of different
                sizes); every cloud needs at least one.

        Returns:
            ``(B, out_dim)`` the global feature.
        """
        check_shape(points, (None, None, self.in_dim), "points")
        features = self.shared(points)
        if point_mask is not None:
            check_shape(point_mask, tuple(points.shape[:2]), "point_mask")
            if not bool(point_mask.any(dim=1).all()):
                raise ValueError("point_mask: every cloud needs at least one real point")
            features = features.masked_fill(~point_mask[..., None], float("-inf"))
        return self.head(features.max(dim=1).values)
