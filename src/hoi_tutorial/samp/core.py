"""SAMP's networks (§3.1–3.2, Appendices B–C, Table S.3): the interaction encoder, GoalNet's cVAE,
MotionNet's cVAE with its mixture-of-experts decoder, and the MLP, MoE and NSM-like baselines.

Every network in SAMP is a three-layer fully connected network with ELU activations (Appendix B.1).
The object enters as its interaction voxels ``I``: 8×8×8 cells of the object's box, 4 numbers each
(the cell centre in the reference frame, and the occupancy), 2048 in all
(:meth:`~hoi_tutorial.world.objects.ToyObject.interaction_voxels`).
"""
from __future__ import annotations

import abc

import torch
from torch import nn

from .._validate import check_shape
from ..nn.cvae import reparameterize
from ..nn.mlp import MLP
from ..nn.moe import MoEMLP

__all__ = ["VOXEL_SIZE", "GOAL_SIZE", "InteractionEncoder", "GoalNetCVAE", "MotionModel", "MotionNet",
           "MLPMotionModel"]

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


class MotionModel(nn.Module, abc.ABC):
    """What MotionNet and its baselines share: the standardisation of inputs and outputs, and the
    interaction encoder (or none, SAMP Supp. G's ablation).

    A model maps the previous state ``X_{i−1} (B, state_size)`` and the object's voxels
    ``I (B, 2048)`` (seen from the root of frame ``i − 1``) to the next frame's output
    ``Y_i = [X_i, root update] (B, output_size)``. Inputs and outputs are standardised with the
    training data's mean and standard deviation, as the Neural State Machine's code SAMP builds on
    does; the losses are measured in those units.

    Subclasses implement ``decode_standardised(xn, code, z) -> ŷ (B, output_size)`` (standardised).
    """

    latent = 0  # deterministic unless a subclass has a latent code

    def __init__(self, state_size: int, output_size: int, interaction_hidden: tuple, interaction_out: int,
                 use_interaction: bool = True, environment_sensor: bool = False):
        super().__init__()
        self.state_size, self.output_size = int(state_size), int(output_size)
        self.use_interaction = bool(use_interaction)
        # True: the 2048 voxel inputs are the NSM-like environment sensor's (samp.sensor), not the target's voxels
        self.environment_sensor = bool(environment_sensor)
        self.code_size = int(interaction_out) if self.use_interaction else 0
        self.interaction = (InteractionEncoder(tuple(interaction_hidden), int(interaction_out))
                            if self.use_interaction else None)
        for name, size, fill in (("x_mean", self.state_size, 0.0), ("x_std", self.state_size, 1.0),
                                 ("y_mean", self.output_size, 0.0), ("y_std", self.output_size, 1.0),
                                 ("voxel_mean", VOXEL_SIZE, 0.0), ("voxel_std", VOXEL_SIZE, 1.0)):
            self.register_buffer(name, torch.full((size,), fill))

    def set_statistics(self, x: torch.Tensor, y: torch.Tensor, voxels: torch.Tensor) -> None:
        """Standardise with the mean and std of training inputs ``x``, outputs ``y`` and ``voxels``
        (a coordinate that never varies keeps a unit scale)."""
        for name, values in (("x", x), ("y", y), ("voxel", voxels)):
            getattr(self, f"{name}_mean").copy_(values.mean(0))
            getattr(self, f"{name}_std").copy_(values.std(0).clamp_min(1e-3))

    def normalise_input(self, x: torch.Tensor) -> torch.Tensor:
        check_shape(x, (None, self.state_size), "x")
        return (x - self.x_mean) / self.x_std

    def normalise_output(self, y: torch.Tensor) -> torch.Tensor:
        check_shape(y, (None, self.output_size), "y")
        return (y - self.y_mean) / self.y_std

    def code(self, voxels: torch.Tensor) -> torch.Tensor:
        """The interaction code ``(B, interaction_out)`` of ``I (B, 2048)``; ``(B, 0)`` without the encoder."""
        check_shape(voxels, (None, VOXEL_SIZE), "voxels")
        if self.interaction is None:
            return voxels.new_zeros(voxels.shape[0], 0)
        return self.interaction((voxels - self.voxel_mean) / self.voxel_std)

    @abc.abstractmethod
    def decode_standardised(self, xn: torch.Tensor, code: torch.Tensor, z=None) -> torch.Tensor:
        """``ŷ (B, output_size)`` standardised, from ``xn (B, state_size)`` standardised, the interaction
        code and, for a cVAE, ``z``."""

    def predict(self, x_prev: torch.Tensor, voxels: torch.Tensor, z=None) -> torch.Tensor:
        """``Y_i (B, output_size)`` in the data's units from ``X_{i−1}``, ``I`` and (for a cVAE) ``Z``."""
        y = self.decode_standardised(self.normalise_input(x_prev), self.code(voxels), z)
        return y * self.y_std + self.y_mean


class MotionNet(MotionModel):
    """SAMP's MotionNet (§3.1, Fig. 3, Eq. 2–3), or with ``latent=0`` the deterministic MoE baseline
    (Supp. C, Fig. S.5: the same interaction encoder, gating and prediction networks, no latent).

    - **State Encoder**: ``[Y_i, X_{i−1}]`` through three ELU layers (``state_hidden``, Table S.3
      {512, 256, 256}).
    - **Interaction Encoder**: ``I`` through three ELU layers ({256, 256, 256}), shared with the
      decoder (it needs the code at run time, when the encoder is gone).
    - the two codes concatenated, then "two identical fully connected layers" give ``μ`` and
      ``log σ²`` of ``Z`` (64 in the paper).
    - **Decoder**: a mixture of ``n_experts`` (12) whose prediction network's *weights* are blended
      (Eq. 2, :class:`~hoi_tutorial.nn.MoEMLP`, {512, 512, out}); the gating network ({512, 256, 12})
      sees ``[Z, X_{i−1}]``; the prediction network sees ``[X_{i−1}, code]`` with ``Z`` concatenated
      to every layer's input (REFERENCE_NOTES).

    Args:
        state_size, output_size: sizes of ``X`` and of ``Y = [X, root update]``.
        state_hidden: the state encoder's three widths (the last is its output).
        interaction_hidden, interaction_out: the interaction encoder's widths and output.
        gating_hidden: the gating network's two hidden widths.
        prediction_hidden: the prediction network's hidden width.
        n_experts: K.
        latent: size of ``Z``; 0 makes the deterministic MoE (no encoder).
        use_interaction: False for SAMP Supp. G's ablation (no interaction encoder).
        environment_sensor: True for the NSM-like model of Table 5 (with ``latent=0``): the voxel inputs
            come from the environment sensor around the character (``samp.sensor``).
    """

    def __init__(self, state_size: int, output_size: int, state_hidden: tuple = (512, 256, 256),
                 interaction_hidden: tuple = (256, 256), interaction_out: int = 256,
                 gating_hidden: tuple = (512, 256), prediction_hidden: int = 512, n_experts: int = 12,
                 latent: int = 64, use_interaction: bool = True, environment_sensor: bool = False):
        super().__init__(state_size, output_size, interaction_hidden, interaction_out, use_interaction,
                         environment_sensor)
        self.latent = int(latent)
        if self.latent:
            self.state_encoder = MLP(self.output_size + self.state_size, tuple(state_hidden[:-1]), int(state_hidden[-1]),
                                     activation="elu", final_activation=True)
            joint = int(state_hidden[-1]) + self.code_size
            self.mu_head = nn.Linear(joint, self.latent)
            self.logvar_head = nn.Linear(joint, self.latent)
        self.decoder = MoEMLP(self.state_size + self.code_size, int(prediction_hidden), self.output_size, int(n_experts),
                              gating_in=self.latent + self.state_size, gating_hidden=tuple(gating_hidden),
                              extra_dim=self.latent)

    def posterior(self, yn: torch.Tensor, xn: torch.Tensor, code: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(μ, log σ²)`` of ``Q(Z | X_i, X_{i−1}, I)``, each ``(B, latent)``, from standardised inputs."""
        if not self.latent:
            raise ValueError("posterior: this MotionNet is deterministic (latent=0)")
        h = torch.cat([self.state_encoder(torch.cat([yn, xn], dim=-1)), code], dim=-1)
        return self.mu_head(h), self.logvar_head(h).clamp(-10.0, 5.0)

    def decode_standardised(self, xn: torch.Tensor, code: torch.Tensor, z=None, return_weights: bool = False):
        """``ŷ (B, output_size)`` standardised (and the blending weights ``ω (B, K)``)."""
        if self.latent:
            if z is None:
                raise ValueError(f"z: expected a (B, {self.latent}) latent code for a stochastic MotionNet")
            check_shape(z, (xn.shape[0], self.latent), "z")
            return self.decoder(torch.cat([xn, code], dim=-1), torch.cat([z, xn], dim=-1), extra=z,
                                return_weights=return_weights)
        return self.decoder(torch.cat([xn, code], dim=-1), xn, return_weights=return_weights)


class MLPMotionModel(MotionModel):
    """SAMP's MLP baseline (Supp. C, Fig. S.4): the interaction encoder, then four fully connected
    ELU layers of ``hidden`` (512) on ``[X_{i−1}, code]`` and an output layer; deterministic."""

    def __init__(self, state_size: int, output_size: int, hidden: tuple = (512, 512, 512, 512),
                 interaction_hidden: tuple = (256, 256), interaction_out: int = 256, use_interaction: bool = True):
        super().__init__(state_size, output_size, interaction_hidden, interaction_out, use_interaction)
        self.net = MLP(self.state_size + self.code_size, tuple(hidden), self.output_size, activation="elu")

    def decode_standardised(self, xn: torch.Tensor, code: torch.Tensor, z=None) -> torch.Tensor:
        return self.net(torch.cat([xn, code], dim=-1))
