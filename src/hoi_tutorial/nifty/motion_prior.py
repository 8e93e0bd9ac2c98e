"""A time-reversed autoregressive motion prior in the manner of HuMoR (NIFTY §3.3, Appendix A.2).

NIFTY re-trains HuMoR on *reversed* AMASS clips so that, starting from an anchor pose ``X_N``, the
model generates ``X_{N-1}, X_{N-2}, ...``: played forwards, every rollout ends exactly in the
anchor. The prior is scene-unaware. Here it is a conditional VAE over one step:

- state ``x_t`` (HuMoR's: root height, velocity, orientation and angular velocity, joint
  rotations, joint positions and joint velocities), expressed in the *heading frame* of frame
  ``t`` (pelvis on the ground origin, facing +Y) — the re-canonicalisation HuMoR applies every step;
- learned conditional prior ``p(z | x_{t})``, encoder ``q(z | x_t, x_{t+1})``, decoder
  ``(x_t, z) -> x_{t+1}`` with ``z`` fed to every decoder layer. The decoder predicts the root
  transform of the next frame in the current heading frame and the *residual* of the joint
  rotations (``x_{t+1} = x_t + Δ``, rotations re-orthonormalised);
- joint positions of the next input come from forward kinematics of the predicted rotations, not
  from the network (HuMoR-Qual, NIFTY Appendix B).

"Next" here is the next frame of a reversed clip, i.e. the previous frame in real time. Training
uses scheduled sampling over short windows (HuMoR, REFERENCE_NOTES): with a probability that
grows during training, the model's own (detached) prediction replaces the ground truth as the
next step's input.

Scaled down from HuMoR: MLPs of width 256 (HuMoR: 1024), latent size 24 (48), trained for seconds
on toy mocap instead of days on AMASS.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import torch
from torch import nn

from .._validate import check_numbers, check_shape
from ..infra import TrainerConfig, single_threaded, train
from ..infra.presets import scaled_config
from ..nn.cvae import gaussian_kl
from ..nn.mlp import MLP
from ..world.features import feature_layout
from ..world.kinematics import forward_kinematics
from ..world.motion import FPS, Motion
from ..world.rotations import (
    matrix_to_axis_angle,
    matrix_to_rotation_6d,
    rotation_6d_to_matrix,
    rotation_about_z,
    yaw_of_matrix,
)
from ..world.skeleton import NUM_JOINTS, bone_offsets

__all__ = [
    "STATE_LAYOUT",
    "STATE_SIZE",
    "STEP_SIZE",
    "PriorConfig",
    "PRIOR_SCALES",
    "prior_config",
    "ReversePrior",
    "PoseTrack",
    "heading_state",
    "step_target",
    "apply_step",
    "training_windows",
    "train_reverse_prior",
    "rollout",
]

# Input state x_t, all in the heading frame of frame t.
_PARTS = (
    ("root_height", 1),
    ("root_velocity", 3),
    ("root_orientation", 6),
    ("root_angular_velocity", 3),
    ("joint_rotations", 6 * (NUM_JOINTS - 1)),
    ("joint_positions", 3 * NUM_JOINTS),
    ("joint_velocities", 3 * NUM_JOINTS),
)
STATE_LAYOUT, STATE_SIZE = feature_layout(_PARTS)
# Decoder output: next root position (3) and orientation (6D) in the current heading frame,
# and the residual of the 21 local joint rotations in 6D.
STEP_SIZE = 3 + 6 + 6 * (NUM_JOINTS - 1)


@dataclass
class PoseTrack:
    """World poses of a batch of rollouts: the minimal thing needed to continue or to play them.

    Attributes:
        local_rotations: ``(..., 22, 3, 3)``.
        root_position: ``(..., 3)`` metres.
        joints: ``(..., 22, 3)`` metres (forward kinematics of the two above).
    """

    local_rotations: torch.Tensor
    root_position: torch.Tensor
    joints: torch.Tensor


def _heading(root_rotation: torch.Tensor):
    """Yaw ``(...)`` and the world->heading rotation ``(..., 3, 3)`` of a root orientation."""
    yaw = yaw_of_matrix(root_rotation)
    return yaw, rotation_about_z(-yaw)


def heading_state(prev: PoseTrack, cur: PoseTrack, fps: float = FPS) -> torch.Tensor:
    """HuMoR state of frame ``cur`` in its own heading frame, velocities from ``prev -> cur``.

    Args:
        prev, cur: poses with matching batch shapes ``(...)``.
    Returns:
        ``(..., STATE_SIZE)``.
    """
    root_rot = cur.local_rotations[..., 0, :, :]
    _, to_heading = _heading(root_rot)
    origin = cur.root_position * torch.tensor([1.0, 1.0, 0.0], dtype=cur.root_position.dtype,
                                                device=cur.root_position.device)
    rel_rot = to_heading @ root_rot
    ang = matrix_to_axis_angle(root_rot @ prev.local_rotations[..., 0, :, :].transpose(-1, -2)) * fps
    parts = [
        cur.root_position[..., 2:3],
        (to_heading @ ((cur.root_position - prev.root_position) * fps)[..., None])[..., 0],
        matrix_to_rotation_6d(rel_rot),
        (to_heading @ ang[..., None])[..., 0],
        matrix_to_rotation_6d(cur.local_rotations[..., 1:, :, :]).flatten(-2),
        (to_heading[..., None, :, :] @ (cur.joints - origin[..., None, :])[..., None])[..., 0].flatten(-2),
        (to_heading[..., None, :, :] @ ((cur.joints - prev.joints) * fps)[..., None])[..., 0].flatten(-2),
    ]
    return torch.cat(parts, dim=-1)


def step_target(cur: PoseTrack, nxt: PoseTrack) -> torch.Tensor:
    """What the decoder must predict to go from ``cur`` to ``nxt``: ``(..., STEP_SIZE)``."""
    root_rot = cur.local_rotations[..., 0, :, :]
    _, to_heading = _heading(root_rot)
    origin = cur.root_position * torch.tensor([1.0, 1.0, 0.0], dtype=cur.root_position.dtype,
                                                device=cur.root_position.device)
    return torch.cat(
        [
            (to_heading @ (nxt.root_position - origin)[..., None])[..., 0],
            matrix_to_rotation_6d(to_heading @ nxt.local_rotations[..., 0, :, :]),
            (matrix_to_rotation_6d(nxt.local_rotations[..., 1:, :, :])
             - matrix_to_rotation_6d(cur.local_rotations[..., 1:, :, :])).flatten(-2),
        ],
        dim=-1,
    )


def apply_step(cur: PoseTrack, step: torch.Tensor, offsets: torch.Tensor) -> PoseTrack:
    """Inverse of :func:`step_target`: the next world pose from ``cur`` and a decoder output.

    Args:
        cur: current poses ``(...)``.
        step: ``(..., STEP_SIZE)``.
        offsets: ``(..., 22, 3)`` or ``(22, 3)`` bone offsets of the body.
    """
    check_shape(step, (..., STEP_SIZE), "step")
    root_rot = cur.local_rotations[..., 0, :, :]
    yaw, _ = _heading(root_rot)
    from_heading = rotation_about_z(yaw)
    origin = cur.root_position * torch.tensor([1.0, 1.0, 0.0], dtype=cur.root_position.dtype,
                                                device=cur.root_position.device)
    root = origin + (from_heading @ step[..., 0:3, None])[..., 0]
    root_orient = from_heading @ rotation_6d_to_matrix(step[..., 3:9])
    joints6d = matrix_to_rotation_6d(cur.local_rotations[..., 1:, :, :])
    joints6d = joints6d + step[..., 9:].unflatten(-1, (NUM_JOINTS - 1, 6))
    local = torch.cat([root_orient[..., None, :, :], rotation_6d_to_matrix(joints6d)], dim=-3)
    _, joints = forward_kinematics(local, root, offsets)
    return PoseTrack(local, root, joints)


_LEG_CHAINS = ((1, 4, 7, 10), (2, 5, 8, 11))  # hip, knee, ankle, foot of each leg


def leg_joint_positions(step: torch.Tensor, cur: PoseTrack, offsets: torch.Tensor) -> torch.Tensor:
    """Positions ``(..., 8, 3)`` of both legs' hip, knee, ankle and foot after a step, in the
    current heading frame: forward kinematics over the leg chains only (cheap to differentiate).

    Args:
        step: ``(..., STEP_SIZE)`` un-normalised decoder output.
        cur: current poses (their joint rotations receive the residual).
        offsets: ``(..., 22, 3)`` bone offsets.
    """
    root = step[..., 0:3]
    glob = rotation_6d_to_matrix(step[..., 3:9])
    joints6d = matrix_to_rotation_6d(cur.local_rotations[..., 1:, :, :])
    local = rotation_6d_to_matrix(joints6d + step[..., 9:].unflatten(-1, (NUM_JOINTS - 1, 6)))
    out = []
    for chain in _LEG_CHAINS:
        g, p = glob, root
        for j in chain:
            p = p + (g @ offsets[..., j, :, None])[..., 0]
            g = g @ local[..., j - 1, :, :]
            out.append(p)
    return torch.stack(out, dim=-2)


def _track_of(motion: Motion) -> PoseTrack:
    return PoseTrack(motion.local_rotations, motion.root_position, motion.joints)


def _index(track: PoseTrack, idx) -> PoseTrack:
    return PoseTrack(track.local_rotations[idx], track.root_position[idx], track.joints[idx])


@dataclass(frozen=True)
class PriorConfig:
    """Sizes and training settings of the reverse prior (HuMoR values in brackets).

    The defaults are the ``toy`` preset; :func:`prior_config` gives every scale.

    Attributes:
        latent: size of ``z`` [48].
        width: hidden width of prior, encoder and decoder MLPs [1024].
        depth: hidden layers per MLP [HuMoR: 2-5].
        window: frames per training window for scheduled sampling.
        steps: optimiser steps.
        batch_size: windows per batch.
        lr: Adam learning rate.
        kl_weight: final weight of the KL term (annealed from 0 over the first third).
        own_prediction_max: final probability of feeding the model's own prediction.
        input_noise: std of Gaussian noise added to normalised inputs (robustness).
        leg_weight: weight of the squared error (m²) of the leg joints' positions after the step.
        seed: training seed.
    """

    latent: int = 24
    width: int = 256
    depth: int = 2
    window: int = 8
    steps: int = 800
    batch_size: int = 64
    lr: float = 1e-3
    kl_weight: float = 3e-3
    own_prediction_max: float = 0.5
    input_noise: float = 0.02
    leg_weight: float = 1000.0
    seed: int = 0

    def __post_init__(self):
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("kl_weight", "input_noise", "leg_weight"), at_least=0)
        check_numbers(self, ("own_prediction_max",), at_least=0, at_most=1)


# What the larger scales change from the defaults (the toy preset); ``paper`` uses HuMoR's sizes.
PRIOR_SCALES = {
    "small": {"latent": 48, "width": 512, "steps": 10000},
    "paper": {"latent": 48, "width": 1024, "steps": 100000},
}


def prior_config(scale: str = "toy", **overrides) -> PriorConfig:
    """The reverse prior's preset for ``scale`` (``toy``: trains in under a minute on a CPU),
    fields overridable by keyword (``prior_config("small", steps=500)``)."""
    return scaled_config(PriorConfig, scale, PRIOR_SCALES, overrides, factory="prior_config")


class ReversePrior(nn.Module):
    """HuMoR-style conditional VAE for one (reversed) time step.

    ``prior(x_t) -> (mu, logvar)``, ``encoder(x_t, Δ) -> (mu, logvar)``,
    ``decoder(x_t, z) -> Δ`` with ``z`` concatenated to the input of every decoder layer.
    Inputs and outputs are normalised with statistics of the training data (buffers).
    """

    def __init__(self, config: PriorConfig):
        super().__init__()
        self.config = config
        w, d, zdim = config.width, config.depth, config.latent
        self.prior_net = MLP(STATE_SIZE, [w] * d, 2 * zdim, activation="relu")
        self.encoder_net = MLP(STATE_SIZE + STEP_SIZE, [w] * d, 2 * zdim, activation="relu")
        self.decoder_layers = nn.ModuleList()
        in_dim = STATE_SIZE
        for _ in range(d):
            self.decoder_layers.append(nn.Linear(in_dim + zdim, w))
            in_dim = w
        self.decoder_out = nn.Linear(w + zdim, STEP_SIZE)
        self.register_buffer("x_mean", torch.zeros(STATE_SIZE))
        self.register_buffer("x_std", torch.ones(STATE_SIZE))
        self.register_buffer("y_mean", torch.zeros(STEP_SIZE))
        self.register_buffer("y_std", torch.ones(STEP_SIZE))

    def normalise_state(self, x: torch.Tensor) -> torch.Tensor:
        return (x - self.x_mean) / self.x_std

    def prior(self, xn: torch.Tensor):
        mu, logvar = self.prior_net(xn).chunk(2, dim=-1)
        return mu, logvar.clamp(-10.0, 5.0)

    def encode(self, xn: torch.Tensor, yn: torch.Tensor):
        mu, logvar = self.encoder_net(torch.cat([xn, yn], dim=-1)).chunk(2, dim=-1)
        return mu, logvar.clamp(-10.0, 5.0)

    def decode(self, xn: torch.Tensor, z: torch.Tensor) -> torch.Tensor:
        """Normalised step ``(..., STEP_SIZE)`` from a normalised state and a latent."""
        h = xn
        for layer in self.decoder_layers:
            h = torch.relu(layer(torch.cat([h, z], dim=-1)))
        return self.decoder_out(torch.cat([h, z], dim=-1))

    def sample_step(self, x: torch.Tensor, generator: torch.Generator, temperature: float = 1.0) -> torch.Tensor:
        """Draw ``z ~ p(z | x)`` and decode: un-normalised step ``(..., STEP_SIZE)``."""
        xn = self.normalise_state(x)
        mu, logvar = self.prior(xn)
        eps = torch.randn(mu.shape, generator=generator, dtype=mu.dtype).to(mu.device)
        z = mu + temperature * torch.exp(0.5 * logvar) * eps
        return self.decode(xn, z) * self.y_std + self.y_mean


def training_windows(motions: Sequence[Motion], window: int):
    """Reverse each clip and cut it into overlapping windows for scheduled-sampling training.

    Returns a dict of tensors, ``W = window``:
        ``local_rotations (N, W+2, 22, 3, 3)``, ``root_position (N, W+2, 3)``,
        ``joints (N, W+2, 22, 3)``, ``offsets (N, 22, 3)``.
    Frame 0 of a window only provides velocities for frame 1, the first input state.
    """
    if not motions:
        raise ValueError("motions: expected at least one Motion")
    rots, roots, joints, offs = [], [], [], []
    for m in motions:
        r = m.reversed()
        T = len(r)
        if T < window + 2:
            continue
        track = _track_of(r)
        off = bone_offsets(r.betas)
        for s in range(0, T - window - 1, max(1, window // 2)):
            sl = slice(s, s + window + 2)
            rots.append(track.local_rotations[sl])
            roots.append(track.root_position[sl])
            joints.append(track.joints[sl])
            offs.append(off)
    if not rots:
        raise ValueError(f"motions: every clip is shorter than window + 2 = {window + 2} frames")
    return {
        "local_rotations": torch.stack(rots), "root_position": torch.stack(roots),
        "joints": torch.stack(joints), "offsets": torch.stack(offs),
    }


def _window_track(batch, t) -> PoseTrack:
    return PoseTrack(batch["local_rotations"][:, t], batch["root_position"][:, t], batch["joints"][:, t])


def _fit_normalisation(model: ReversePrior, data) -> None:
    n, W2 = data["root_position"].shape[:2]
    xs, ys = [], []
    for t in range(1, W2 - 1):
        prev, cur, nxt = (_window_track(data, t - 1), _window_track(data, t), _window_track(data, t + 1))
        xs.append(heading_state(prev, cur))
        ys.append(step_target(cur, nxt))
    x, y = torch.cat(xs), torch.cat(ys)
    model.x_mean.copy_(x.mean(0))
    model.x_std.copy_(x.std(0).clamp_min(1e-3))
    model.y_mean.copy_(y.mean(0))
    model.y_std.copy_(y.std(0).clamp_min(1e-3))


@single_threaded
def train_reverse_prior(motions: Sequence[Motion], config: Optional[PriorConfig] = None,
                        device: str = "cpu", progress: bool = False):
    """Train the reverse prior on reversed clips with scheduled sampling.

    Loss per step (HuMoR): ``||Δ̂ - Δ||²`` in normalised units, plus ``w_legs ·`` the squared error
    of the leg joints' positions after the step (forward kinematics of the predicted rotations),
    ``+ w_KL · KL(q(z|x,Δ) || p(z|x))``,
    where the target ``Δ`` always leads to the ground-truth next frame, also when the input came
    from the model's own prediction.
    With probability ``p_own`` (0 for the first third of training, then rising linearly to
    ``own_prediction_max``; one coin per step for the batch) the next input is the detached
    prediction instead of the ground truth.

    Each batch is computed in two passes: the inputs of the window's steps in time order without
    gradients (only the scheduled-sampling steps need the model), then all ``W`` steps at once with
    gradients. The loss is the one of stepping through the window with gradients, at a fraction of
    the autograd overhead.

    Returns ``(model, TrainResult)``.
    """
    config = config or PriorConfig()
    data = training_windows(motions, config.window)
    # The initial weights come from the config's seed, not from whatever the global RNG holds.
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        model = ReversePrior(config)
    _fit_normalisation(model, data)
    n = data["root_position"].shape[0]
    W = config.window
    third = max(1, config.steps // 3)

    def sample_batch(step, generator):
        idx = torch.randint(0, n, (config.batch_size,), generator=generator)
        batch = {k: v[idx] for k, v in data.items()}
        batch["step"] = torch.tensor(step)
        batch["coins"] = torch.rand(W, generator=generator)
        batch["noise"] = torch.randn(W, config.batch_size, STATE_SIZE, generator=generator)
        batch["eps"] = torch.randn(W, config.batch_size, config.latent, generator=generator)
        return batch

    def loss_fn(model, batch):
        step = int(batch["step"])
        kl_w = config.kl_weight * min(1.0, step / third)
        p_own = 0.0 if step < third else config.own_prediction_max * min(1.0, (step - third) / third)
        offsets = batch["offsets"]
        own = batch["coins"] < p_own  # (W,) one coin per step for the whole batch
        # Pass 1, in time order and without gradients: the input of every step. Scheduled sampling
        # replaces the next input by the model's own detached prediction, the same value pass 2
        # computes again with gradients (same weights, noise and latent draws).
        prevs, curs = [], []
        prev, cur = _window_track(batch, 0), _window_track(batch, 1)
        with torch.no_grad():
            for t in range(1, W + 1):
                prevs.append(prev)
                curs.append(cur)
                nxt = _window_track(batch, t + 1)
                if bool(own[t - 1]):
                    xn = model.normalise_state(heading_state(prev, cur)) + config.input_noise * batch["noise"][t - 1]
                    yn = (step_target(cur, nxt) - model.y_mean) / model.y_std
                    mu_q, logvar_q = model.encode(xn, yn)
                    yn_hat = model.decode(xn, mu_q + torch.exp(0.5 * logvar_q) * batch["eps"][t - 1])
                    nxt = apply_step(cur, yn_hat * model.y_std + model.y_mean, offsets)
                prev, cur = cur, nxt

        # Pass 2: all W steps as one batch of W·B with gradients; the target always leads to the
        # ground-truth next frame.
        def stacked(tracks):
            return PoseTrack(*(torch.stack([getattr(tr, name) for tr in tracks]).flatten(0, 1)
                               for name in ("local_rotations", "root_position", "joints")))

        prev, cur = stacked(prevs), stacked(curs)
        nxt = stacked([_window_track(batch, t + 1) for t in range(1, W + 1)])
        offsets_all = offsets[None].expand(W, -1, -1, -1).flatten(0, 1)
        with torch.no_grad():
            x = heading_state(prev, cur)
            y = step_target(cur, nxt)
            legs = leg_joint_positions(y, cur, offsets_all)
        xn = model.normalise_state(x) + config.input_noise * batch["noise"].flatten(0, 1)
        yn = (y - model.y_mean) / model.y_std
        mu_q, logvar_q = model.encode(xn, yn)
        mu_p, logvar_p = model.prior(xn)
        z = mu_q + torch.exp(0.5 * logvar_q) * batch["eps"].flatten(0, 1)
        yn_hat = model.decode(xn, z)
        # HuMoR also supervises joint positions; the legs' carry the ground contact.
        legs_hat = leg_joint_positions(yn_hat * model.y_std + model.y_mean, cur, offsets_all)
        rec_total = (yn_hat - yn).square().mean() + config.leg_weight * (legs_hat - legs).square().sum(-1).mean()
        kl_total = gaussian_kl(mu_q, logvar_q, mu_p, logvar_p).mean()
        return rec_total + kl_w * kl_total, {"reconstruction": float(rec_total.detach()), "kl": float(kl_total.detach())}

    result = train(
        model, sample_batch, loss_fn,
        TrainerConfig(steps=config.steps, batch_size=config.batch_size, lr=config.lr,
                      lr_schedule="cosine", warmup_steps=min(50, config.steps // 10), device=device, progress=progress,
                      seed=config.seed, grad_clip=1.0, optimizer="adam"),
    )
    return model.eval(), result


@torch.no_grad()
@single_threaded
def rollout(model: ReversePrior, start_prev: PoseTrack, start: PoseTrack, offsets: torch.Tensor,
            n_frames: int, generator: torch.Generator, temperature: float = 1.0) -> PoseTrack:
    """Autoregressive rollout of ``n_frames`` new frames from ``start`` (batched).

    Args:
        model: a trained :class:`ReversePrior`.
        start_prev, start: the last two poses ``(B, ...)`` (velocities come from their difference).
        offsets: ``(B, 22, 3)`` bone offsets.
        n_frames: frames to generate.
        generator: CPU generator for the latent draws.
        temperature: scale of the prior's standard deviation.
    Returns:
        a :class:`PoseTrack` with a time axis: ``(B, n_frames, ...)``.
    """
    device = model.x_mean.device
    prev, cur = start_prev, start
    out = []
    for _ in range(n_frames):
        x = heading_state(prev, cur).to(device)
        step = model.sample_step(x, generator, temperature).to(cur.root_position.device)
        nxt = apply_step(cur, step, offsets)
        out.append(nxt)
        prev, cur = cur, nxt
    return PoseTrack(
        torch.stack([p.local_rotations for p in out], dim=1),
        torch.stack([p.root_position for p in out], dim=1),
        torch.stack([p.joints for p in out], dim=1),
    )
