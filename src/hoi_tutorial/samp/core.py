"""SAMP's networks (§3.1–3.2, Appendix B, Table S.3): the interaction encoder and GoalNet's cVAE.

Every network in SAMP is a three-layer fully connected network with ELU activations (Appendix B.1).
The object enters as its interaction voxels ``I``: 8×8×8 cells of the object's box, 4 numbers each
(the cell centre in the reference frame, and the occupancy), 2048 in all
(:meth:`~hoi_tutorial.world.objects.ToyObject.interaction_voxels`).
"""
from __future__ import annotations

import torch
from torch import nn

from .._validate import check_shape
from ..nn.cvae import reparameterize
from ..nn.mlp import MLP

__all__ = ["VOXEL_SIZE", "GOAL_SIZE", "InteractionEncoder", "GoalNetCVAE"]

VOXEL_SIZE = 8 * 8 * 8 * 4  # SAMP's interaction representation I, flattened
GOAL_SIZE = 6  # g^p (3) and g^d (3)


class InteractionEncoder(nn.Module):
    """``I (..., 2048) -> (..., out)``: three fully connected layers with ELU (SAMP §3.1 "Interaction Encoder").

    Args:
        hidden: the two hidden widths (MotionNet: 256, 256; GoalNet: 512, 512).
        out: the code size (MotionNet: 256; GoalNet: 64).
        in_dim: the voxel code's size (2048 for 8×8×8×4).
    """

    def __init__(self, hidden: tuple = (512, 512), out: int = 64, in_dim: int = VOXEL_SIZE):
        super().__init__()
        self.net = MLP(in_dim, hidden, out, activation="elu")

    def forward(self, voxels: torch.Tensor) -> torch.Tensor:
        return self.net(voxels)


class GoalNetCVAE(nn.Module):
    """GoalNet (SAMP §3.2, Fig. 4, Appendix B.2): ``q(Z_goal | g, I)`` and ``p(g | Z_goal, I)``.

    The encoder encodes ``I`` with an interaction encoder, concatenates the goal ``g = [g^p, g^d]``
    and maps it through three layers to ``(μ, log σ²)`` of ``Z_goal``. "The decoder has the same
    architecture as the encoder": its own interaction encoder, then ``[Z_goal, code]`` through three
    layers to the reconstructed goal ``ĝ`` (6 numbers). At test time only the decoder runs, with
    ``Z_goal ~ N(0, I)``.

    Args:
        interaction_hidden, interaction_out: the interaction encoders' sizes (SAMP: {512, 512, 64}).
        hidden: the widths of the encoder's hidden layers; the decoder uses them reversed
            (REFERENCE_NOTES: 32, 16, 8).
        latent: the size of ``Z_goal`` (SAMP: 3).
        goal_mean, goal_std, voxel_mean, voxel_std: ``(6,)`` and ``(2048,)`` statistics of the
            training data: goals and voxels are standardised inside the network (as the Neural State
            Machine code SAMP builds on standardises every input and output), so that Eq. 4's two
            squared errors and its KL term are measured in comparable units.
    """

    def __init__(self, interaction_hidden: tuple = (512, 512), interaction_out: int = 64,
                 hidden: tuple = (32, 16, 8), latent: int = 3, goal_mean=None, goal_std=None,
                 voxel_mean=None, voxel_std=None):
        super().__init__()
        self.latent = int(latent)
        self.encoder_interaction = InteractionEncoder(tuple(interaction_hidden), int(interaction_out))
        self.decoder_interaction = InteractionEncoder(tuple(interaction_hidden), int(interaction_out))
        self.encoder = MLP(GOAL_SIZE + int(interaction_out), tuple(hidden), 2 * self.latent, activation="elu")
        self.decoder = MLP(self.latent + int(interaction_out), tuple(reversed(hidden)), GOAL_SIZE, activation="elu")
        for name, size, value, fill in (("goal_mean", GOAL_SIZE, goal_mean, 0.0), ("goal_std", GOAL_SIZE, goal_std, 1.0),
                                        ("voxel_mean", VOXEL_SIZE, voxel_mean, 0.0),
                                        ("voxel_std", VOXEL_SIZE, voxel_std, 1.0)):
            value = torch.full((size,), fill) if value is None else torch.as_tensor(value, dtype=torch.float32)
            check_shape(value, (size,), name)
            self.register_buffer(name, value.detach().float().clone())

    def normalise_goals(self, goals: torch.Tensor) -> torch.Tensor:
        """Goals ``(..., 6)`` in metres and unit directions → standardised (the training data's mean and std)."""
        return (goals - self.goal_mean) / self.goal_std

    def _code(self, encoder: InteractionEncoder, voxels: torch.Tensor) -> torch.Tensor:
        return encoder((voxels - self.voxel_mean) / self.voxel_std)

    def posterior(self, goals: torch.Tensor, voxels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(μ, log σ²)``, each ``(B, latent)``, of ``q(Z_goal | g, I)``.

        Args:
            goals: ``(B, 6)`` ``[g^p (m), g^d (unit)]`` in the object's centre frame.
            voxels: ``(B, 2048)`` the object's interaction voxels in its centre frame.
        """
        check_shape(goals, (None, GOAL_SIZE), "goals")
        check_shape(voxels, (goals.shape[0], VOXEL_SIZE), "voxels")
        features = torch.cat([self.normalise_goals(goals), self._code(self.encoder_interaction, voxels)], dim=-1)
        mu, logvar = self.encoder(features).chunk(2, dim=-1)
        return mu, logvar

    def decode_standardised(self, z: torch.Tensor, voxels: torch.Tensor) -> torch.Tensor:
        """``ĝ (B, 6)`` standardised, from ``Z_goal (B, latent)`` and ``I (B, 2048)``."""
        check_shape(z, (None, self.latent), "z")
        check_shape(voxels, (z.shape[0], VOXEL_SIZE), "voxels")
        return self.decoder(torch.cat([z, self._code(self.decoder_interaction, voxels)], dim=-1))

    def decode(self, z: torch.Tensor, voxels: torch.Tensor) -> torch.Tensor:
        """``ĝ (B, 6)`` in metres (positions) and direction units, from ``Z_goal`` and ``I``."""
        return self.decode_standardised(z, voxels) * self.goal_std + self.goal_mean

    def forward(self, goals: torch.Tensor, voxels: torch.Tensor, generator: torch.Generator):
        """``(ĝ, g, μ, log σ²)`` for Eq. 4: the reconstruction through a sampled ``Z_goal`` and the
        target, both standardised."""
        mu, logvar = self.posterior(goals, voxels)
        return self.decode_standardised(reparameterize(mu, logvar, generator), voxels), \
            self.normalise_goals(goals), mu, logvar
