"""The DeepPhase periodic autoencoder (PAE) that CHOICE's controller is built on (§5, §7, §8.1).

DeepPhase (Starke, Mason & Komura 2022) learns a few *phase channels* from motion. A convolutional
encoder turns a window of joint velocities into ``C`` latent curves; each curve is summarised by the
four numbers of one sinusoid — frequency ``F``, amplitude ``A`` and offset ``B`` read off its FFT,
phase ``S`` from a small learned layer — and a decoder has to rebuild the window from those sinusoids
alone. That bottleneck makes ``(S, F, A, B)`` a periodic description of the motion around the
window's centre frame. A channel's point on the *phase manifold* is the 2D vector
``A·(sin 2πS, cos 2πS)``.

CHOICE uses the PAE unchanged: "we extract 8 channels in the frequency domain with the same network
structure as [Starke et al. 2022]" (§8.1). The phase latent of "the [-1s, 1s] time window pivoted on
each frame" (§7) is computed ahead of time for all the motion data. Its ``(S, A, F)`` are the state of
the phase-space dynamics (Eqs. 15–17) and the goal phase features of Eq. 13.

The algorithm, as this module runs it (``B`` windows, ``J = 22`` joints, ``C`` channels, ``T`` samples):

1. **Input** (:func:`motion_curves`, :func:`clip_windows`): every frame's joint velocities in that
   frame's root frame, ``(3J, frames)`` in m/s. The window of frame ``i`` takes every
   ``frame_step``-th frame from ``i − (T−1)/2·frame_step`` to ``i + (T−1)/2·frame_step``. At a clip's
   ends the edge frames are repeated, as DeepPhase clamps the frames it gathers.
2. **Encoder**: Conv1d(3J → J, kernel T) → normalisation over time → ELU → Conv1d(J → C, kernel T),
   giving the latent curves ``(B, C, T)``.
3. **Parameters** (:func:`fft_parameters`, :meth:`PhaseAutoencoder.fit_sinusoids`): a real FFT per
   channel, with power ``p_k = |X_k|²`` and the DC term left out. ``F = Σ f_k p_k / Σ p_k`` (Hz),
   ``A = 2 √(Σ p_k) / T``, ``B = Re X_0 / T``. ``S = atan2(v_y, v_x) / 2π`` with
   ``v = Linear_c(latent_c)`` (T → 2), one layer per channel.
4. **Sinusoids** (:func:`sinusoid`): ``A·sin(2π(F·t + S)) + B`` at ``t_k = (k − (T−1)/2)·Δt``. The time
   step is ``Δt = frame_step / fps``, so ``S`` is the phase at the centre frame.
5. **Decoder**, mirroring the encoder: Conv1d(C → J) → normalisation over time → ELU →
   Conv1d(J → 3J). The loss is the reconstruction's mean squared error and nothing else.

The sign of ``S``: DeepPhase's paper writes ``sin(2π(F·x − S))``, but its public code (``PAE.py``) adds
``S``, and so do we. With ``+S``, ``S`` grows by ``F·Δt`` when the window moves on by ``Δt``, as CHOICE's
dynamics need (Eq. 16: ``S_{t+Δt} = S_t + Δt·F``). The manifold feature's order ``(A sin, A cos)`` is
DeepPhase's code; CHOICE's Eq. 13 lists the same two numbers as ``(A cos, A sin)``.

Choices the papers do not state (ours):

- The time axis and the FFT bins both come from the sample rate ``fps / frame_step`` (bins at
  ``k / (T·Δt)`` Hz). DeepPhase's code spaces the time axis ±1 s over 121 samples at 60 fps but puts its
  bins at ``k / 2 s``, as if the 121 samples lasted 2 s rather than 121/60 s.
- ``S`` is wrapped into ``[0, 1]``, the range CHOICE §5.2 gives; DeepPhase's ``atan2`` gives ``(−½, ½]``.
- "In the root frame" is read as each frame's own root frame, with the heading taken from the hips
  (``world.features.body_heading``).
- The inputs stay in m/s, not standardised.
- ``Σ p_k`` is clamped at the smallest normal float, so a curve with no power at all gets ``F = 0``
  instead of NaN.
- Training uses every frame of every clip as a window centre, with AdamW and a cosine decay. DeepPhase
  uses AdamW at 1e-4 with weight decay 1e-4, cosine warm restarts and batches of 32.

Scaling, paper → toy:

- Channels: 8 → 4.
- Window: DeepPhase's 2 s at 60 fps (121 samples; CHOICE's ±1 s) → 2 s at 15 Hz (31 samples: every
  second frame of the 30-fps toy mocap). The ``"paper"`` preset here takes 61 samples at 30 fps.
- Data: CHOICE's capture (150 sequences of about 3 min) → ``clips_per_kind`` toy walking and
  reach-and-grasp clips.
- Training: 120 epochs in 10 h → ``steps`` batches of ``batch_size`` windows.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple, Union

import torch
import torch.nn.functional as F
from torch import nn

from ..._validate import check_numbers, check_positive_ints, check_shape
from ...infra import TrainedModel, load_or_build, scaled_config, single_threaded, state_dict_to_cpu, train, trainer_config
from ...world import mocap
from ...world.features import body_heading
from ...world.motion import FPS, Motion
from ...world.rotations import rotation_about_z
from ...world.skeleton import NUM_JOINTS

__all__ = [
    "PhaseConfig",
    "PHASE_SCALES",
    "phase_config",
    "PhaseParameters",
    "fft_parameters",
    "window_times",
    "sinusoid",
    "manifold_features",
    "PhaseAutoencoder",
    "build_phase_autoencoder",
    "motion_curves",
    "clip_windows",
    "training_windows",
    "train_phase_autoencoder",
    "trained_phase_autoencoder",
    "phase_features",
    "clip_phase",
]


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class PhaseConfig:
    """The PAE, its training windows and its training (defaults: the ``toy`` preset).

    Attributes:
        channels: phase channels ``C`` (CHOICE §8.1: 8; DeepPhase: "usually between 2-10").
        window_frames: samples per window ``T``, odd so that the window is centred on its frame.
        frame_step: clip frames between two samples of a window. The window spans
            ``(T − 1)·frame_step`` frames and is sampled at ``fps / frame_step`` Hz.
        clips_per_kind: toy-mocap clips of each of ``kinds``; every frame of each is a window centre.
        kinds: the ``world.mocap`` clip kinds trained on (walking and reaching/grasping, as CHOICE's
            pick-and-place capture).
        steps, batch_size, lr, weight_decay, lr_schedule, optimizer: training (DeepPhase: AdamW, 1e-4,
            weight decay 1e-4, batches of 32).
        seed: seeds the clips, the weights and the batches.
    """

    channels: int = 4
    window_frames: int = 31
    frame_step: int = 2
    clips_per_kind: int = 8
    kinds: tuple = ("walk", "reach_grasp")
    steps: int = 1500
    batch_size: int = 32
    lr: float = 2e-3
    weight_decay: float = 1e-4
    lr_schedule: str = "cosine"
    optimizer: str = "adamw"
    seed: int = 0

    def __post_init__(self):
        check_positive_ints(self, ("channels", "window_frames", "frame_step", "clips_per_kind", "steps",
                                   "batch_size"))
        _check_window_frames(self.window_frames)
        if not self.kinds or any(kind not in mocap.ACTION_GENERATORS for kind in self.kinds):
            raise ValueError(f"kinds: expected a non-empty tuple of names from {sorted(mocap.ACTION_GENERATORS)}, "
                             f"got {self.kinds!r}")
        check_numbers(self, ("lr",), above=0)
        check_numbers(self, ("weight_decay",), at_least=0)


# DeepPhase / CHOICE §8.1: 8 channels, 2 s windows, 120 epochs; 400 toy clips of ~190 frames are ~76 000
# windows, and 120 epochs of them in batches of 32 are ~285 000 steps.
PHASE_SCALES = {
    "small": {"channels": 8, "clips_per_kind": 24, "steps": 4000},
    "paper": {"channels": 8, "window_frames": 61, "frame_step": 1, "clips_per_kind": 200, "steps": 285000,
              "lr": 1e-4},
}


def phase_config(scale: str = "toy", **overrides) -> PhaseConfig:
    """The preset for ``scale``, any field overridable (``phase_config("toy", channels=8)``)."""
    return scaled_config(PhaseConfig, scale, PHASE_SCALES, overrides, factory="phase_config")


def _check_window_frames(window_frames) -> None:
    if isinstance(window_frames, bool) or not isinstance(window_frames, int) or window_frames < 3 \
            or window_frames % 2 == 0:
        raise ValueError(f"window_frames: expected an odd int >= 3 (a window centred on its frame), "
                         f"got {window_frames!r}")


def _check_rate(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0 or math.isinf(value):
        raise ValueError(f"{name}: expected a positive, finite rate (samples per second), got {value!r}")
    return float(value)


# ----------------------------------------------------------------------------- the parameter layer


class PhaseParameters(NamedTuple):
    """The four numbers of each channel's sinusoid, each ``(..., C)``.

    Attributes:
        phase: ``S`` in cycles, wrapped into [0, 1]; the phase at the window's centre frame.
        frequency: ``F`` in Hz.
        amplitude: ``A`` in latent units.
        offset: ``B`` in latent units.
    """

    phase: torch.Tensor
    frequency: torch.Tensor
    amplitude: torch.Tensor
    offset: torch.Tensor

    def state(self) -> torch.Tensor:
        """(..., C, 3) the phase state ``X^p = [S, A, F]`` of CHOICE §5.2 per channel (``kalman``'s order)."""
        return torch.stack([self.phase, self.amplitude, self.frequency], dim=-1)


def fft_parameters(curves: torch.Tensor, sample_rate: float):
    """Frequency, amplitude and offset of curves from their real FFT (DeepPhase's ``FFT``).

    Power ``p_k = |X_k|²`` without the DC term. ``F = Σ f_k p_k / Σ p_k`` is the power-weighted mean
    frequency, ``A = 2 √(Σ p_k) / T`` and ``B = Re X_0 / T``. For a sinusoid that fits a whole number of
    cycles into the window, ``F``, ``A`` and ``B`` are exactly its frequency, amplitude and mean.

    Args:
        curves: (..., T) samples at ``sample_rate``, T >= 2.
        sample_rate: samples per second (Hz), > 0.
    Returns:
        ``(frequency, amplitude, offset)``, each (...): Hz, and the curves' units twice.
    """
    sample_rate = _check_rate(sample_rate, "sample_rate")
    if not isinstance(curves, torch.Tensor) or curves.ndim < 1 or curves.shape[-1] < 2:
        shape = tuple(curves.shape) if hasattr(curves, "shape") else type(curves).__name__
        raise ValueError(f"curves: expected a tensor of shape (..., T) with T >= 2 samples, got {shape}")
    T = curves.shape[-1]
    spectrum = torch.fft.rfft(curves, dim=-1)
    power = spectrum.real[..., 1:].square() + spectrum.imag[..., 1:].square()
    bins = torch.fft.rfftfreq(T, d=1.0 / sample_rate, dtype=curves.dtype, device=curves.device)[1:]
    total = power.sum(-1)
    frequency = (power * bins).sum(-1) / total.clamp_min(torch.finfo(total.dtype).tiny)
    amplitude = 2.0 * total.sqrt() / T
    offset = spectrum.real[..., 0] / T
    return frequency, amplitude, offset


def window_times(window_frames: int, sample_rate: float) -> torch.Tensor:
    """(T,) seconds of a window's samples relative to its centre: ``(k − (T−1)/2) / sample_rate``."""
    _check_window_frames(window_frames)
    sample_rate = _check_rate(sample_rate, "sample_rate")
    return (torch.arange(window_frames, dtype=torch.float32) - (window_frames - 1) / 2) / sample_rate


def sinusoid(params: PhaseParameters, times: torch.Tensor) -> torch.Tensor:
    """DeepPhase's latent reconstruction ``A·sin(2π(F·t + S)) + B`` (its code's sign, see the module).

    Args:
        params: each (..., C).
        times: (T,) seconds (:func:`window_times`).
    Returns:
        (..., C, T) in latent units.
    """
    S, f, A, B = (p[..., None] for p in params)
    return A * torch.sin(2 * math.pi * (f * times + S)) + B


def manifold_features(params: PhaseParameters) -> torch.Tensor:
    """The phase-manifold vector of each channel, ``A·(sin 2πS, cos 2πS)`` (DeepPhase; CHOICE Eq. 13
    without its noise): (..., C, 2), whose norm is ``A``."""
    angle = 2 * math.pi * params.phase
    return torch.stack([params.amplitude * torch.sin(angle), params.amplitude * torch.cos(angle)], dim=-1)


# ----------------------------------------------------------------------------- the network


def _same_conv(in_channels: int, out_channels: int, kernel: int) -> nn.Conv1d:
    """A Conv1d whose kernel spans the window, zero-padded to keep the length (DeepPhase's)."""
    return nn.Conv1d(in_channels, out_channels, kernel, padding=kernel // 2)


class PhaseAutoencoder(nn.Module):
    """DeepPhase's periodic autoencoder (Starke et al. 2022, Fig. 2; the network CHOICE §8.1 trains).

    Args:
        input_channels: ``D``, the curves per window (``3J`` joint-velocity components; channel
            ``3j + d`` is axis ``d`` of joint ``j``).
        channels: phase channels ``C``.
        window_frames: samples per window ``T`` (odd).
        frame_step: clip frames between two samples.
        fps: the clips' frame rate. The window is sampled at ``sample_rate = fps / frame_step`` Hz.

    The hidden width is ``D // 3`` (DeepPhase's ``3J → J``; at least 1). "Normalisation over time" is a
    ``LayerNorm`` over the ``T`` samples with a learned scale and bias per sample (DeepPhase's ``LN_v2``).
    """

    def __init__(self, input_channels: int, channels: int, window_frames: int, frame_step: int = 1,
                 fps: float = FPS):
        super().__init__()
        for name, value in (("input_channels", input_channels), ("channels", channels), ("frame_step", frame_step)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name}: expected a positive int, got {value!r}")
        _check_window_frames(window_frames)
        self.input_channels, self.channels, self.window_frames = input_channels, channels, window_frames
        self.frame_step, self.fps = frame_step, _check_rate(fps, "fps")
        hidden, T = max(1, input_channels // 3), window_frames
        self.encoder = nn.Sequential(_same_conv(input_channels, hidden, T), nn.LayerNorm(T), nn.ELU(),
                                     _same_conv(hidden, channels, T))
        self.phase_layers = nn.ModuleList(nn.Linear(T, 2) for _ in range(channels))
        self.decoder = nn.Sequential(_same_conv(channels, hidden, T), nn.LayerNorm(T), nn.ELU(),
                                     _same_conv(hidden, input_channels, T))
        self.register_buffer("times", window_times(T, self.sample_rate), persistent=False)

    @property
    def sample_rate(self) -> float:
        """Samples per second within a window (Hz)."""
        return self.fps / self.frame_step

    def _check_windows(self, windows: torch.Tensor) -> None:
        check_shape(windows, (None, self.input_channels, self.window_frames), "windows")

    def fit_sinusoids(self, latent: torch.Tensor) -> PhaseParameters:
        """The parameter layer: ``(S, F, A, B)`` of latent curves (B, C, T), each (B, C)."""
        frequency, amplitude, offset = fft_parameters(latent, self.sample_rate)
        v = torch.stack([layer(latent[:, c]) for c, layer in enumerate(self.phase_layers)], dim=1)  # (B, C, 2)
        phase = torch.remainder(torch.atan2(v[..., 1], v[..., 0]) / (2 * math.pi), 1.0)
        return PhaseParameters(phase, frequency, amplitude, offset)

    def encode(self, windows: torch.Tensor) -> PhaseParameters:
        """``(S, F, A, B)`` of windows (B, D, T), each (B, C)."""
        self._check_windows(windows)
        return self.fit_sinusoids(self.encoder(windows))

    def forward(self, windows: torch.Tensor):
        """Encode, parametrise, rebuild.

        Args:
            windows: (B, D, T).
        Returns:
            ``(reconstruction (B, D, T), params (each (B, C)), latent (B, C, T), signal (B, C, T))``;
            ``signal`` holds the parametrised sinusoids that the decoder reads.
        """
        self._check_windows(windows)
        latent = self.encoder(windows)
        params = self.fit_sinusoids(latent)
        signal = sinusoid(params, self.times)
        return self.decoder(signal), params, latent, signal


def build_phase_autoencoder(config: PhaseConfig, input_channels: int = 3 * NUM_JOINTS,
                            fps: float = FPS) -> PhaseAutoencoder:
    """A fresh PAE for ``config``, its weights seeded by ``config.seed`` (the global RNG untouched)."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        return PhaseAutoencoder(input_channels, config.channels, config.window_frames, config.frame_step, fps)


# ----------------------------------------------------------------------------- data


def motion_curves(motion: Motion) -> torch.Tensor:
    """The PAE's input curves of a clip: each frame's joint velocities in that frame's root frame
    (the heading from the hips, ``world.features.body_heading``; Z stays up).

    Returns:
        (3J, frames) float32, m/s; channel ``3j + d`` is axis ``d`` (x right, y forward, z up) of joint ``j``.
    """
    if not isinstance(motion, Motion):
        raise TypeError(f"motion: expected a world.motion.Motion, got {type(motion).__name__}")
    velocities = motion.joint_velocities()  # (frames, J, 3) world frame
    heading = rotation_about_z(body_heading(motion.joints))  # (frames, 3, 3)
    local = torch.einsum("tij,tki->tkj", heading, velocities)  # R^T v per frame and joint
    return local.reshape(len(motion), -1).T.contiguous().float()


def clip_windows(curves: torch.Tensor, window_frames: int, frame_step: int = 1, centres=None) -> torch.Tensor:
    """The windows of a clip's curves centred on ``centres`` (default: every frame), the edge frames
    repeated where a window runs past the clip's ends.

    Args:
        curves: (D, frames).
        window_frames: samples per window ``T`` (odd).
        frame_step: frames between two samples.
        centres: (N,) frame indices.
    Returns:
        (N, D, T).
    """
    _check_window_frames(window_frames)
    if isinstance(frame_step, bool) or not isinstance(frame_step, int) or frame_step < 1:
        raise ValueError(f"frame_step: expected a positive int, got {frame_step!r}")
    check_shape(curves, (None, None), "curves")
    frames = curves.shape[1]
    if frames < 1:
        raise ValueError("curves: expected at least one frame")
    centres = torch.arange(frames) if centres is None else torch.as_tensor(centres, dtype=torch.long).reshape(-1)
    offsets = (torch.arange(window_frames) - window_frames // 2) * frame_step
    index = (centres[:, None] + offsets).clamp(0, frames - 1)  # (N, T)
    return curves[:, index].permute(1, 0, 2).contiguous()


def training_windows(config: PhaseConfig) -> torch.Tensor:
    """The PAE's training windows: every frame of ``config.clips_per_kind`` toy-mocap clips of each of
    ``config.kinds`` (``world.mocap.generate_dataset`` with ``config.seed``).

    Returns:
        (N, 3J, T) float32, m/s.
    """
    clips = mocap.generate_dataset(config.clips_per_kind, seed=config.seed, kinds=config.kinds)
    return torch.cat([clip_windows(motion_curves(clip), config.window_frames, config.frame_step) for clip in clips])


# ----------------------------------------------------------------------------- training


@single_threaded
def train_phase_autoencoder(windows: torch.Tensor, config: PhaseConfig, fps: float = FPS, device="cpu",
                            progress: bool = False):
    """Fit a PAE to ``windows`` by the reconstruction's mean squared error, DeepPhase's only loss.

    Args:
        windows: (N, D, T) with ``T = config.window_frames``, sampled every ``config.frame_step``
            frames of clips at ``fps``.
        fps: the clips' frame rate (> 0).
    Returns:
        ``(PhaseAutoencoder in eval mode, TrainResult)``.
    """
    _check_rate(fps, "fps")
    check_shape(windows, (None, None, config.window_frames), "windows")
    if len(windows) == 0:
        raise ValueError("windows: expected at least one window")
    windows = windows.float()
    model = build_phase_autoencoder(config, windows.shape[1], fps)

    def sample_batch(step, generator):
        return windows[torch.randint(0, len(windows), (config.batch_size,), generator=generator)]

    def loss_fn(net, batch):
        reconstruction = net(batch)[0]
        return F.mse_loss(reconstruction, batch)

    result = train(model, sample_batch, loss_fn, trainer_config(config, device=device, progress=progress))
    return model.eval(), result


def trained_phase_autoencoder(scale: str = "toy", seed: int = 0, *, device="cpu", progress: bool = False,
                              **overrides) -> TrainedModel:
    """The PAE of ``phase_config(scale, seed=seed, **overrides)`` trained on :func:`training_windows`
    once, then loaded from the cache.

    ``details``: ``config`` (the :class:`PhaseConfig`), ``n_windows`` and ``final_loss`` (the mean
    over the last 5 % of steps, (m/s)²).
    """
    config = phase_config(scale, seed=seed, **overrides)

    def build():
        windows = training_windows(config)
        model, result = train_phase_autoencoder(windows, config, device=device, progress=progress)
        return {"state": state_dict_to_cpu(model), "losses": torch.tensor(result.losses),
                "seconds": float(result.seconds), "n_windows": len(windows), "final_loss": result.final_loss}

    key = {"model": dataclasses.asdict(config), "fps": FPS}
    artifact = load_or_build("choice_phase_autoencoder", key, build)
    model = build_phase_autoencoder(config)
    model.load_state_dict(artifact["state"])
    details = {"config": config, "n_windows": artifact["n_windows"], "final_loss": artifact["final_loss"]}
    return TrainedModel(model.eval(), artifact["losses"], artifact["seconds"], details)


# ----------------------------------------------------------------------------- phase features


@torch.no_grad()
def phase_features(model: PhaseAutoencoder, windows: torch.Tensor) -> torch.Tensor:
    """The phase-manifold features of windows (B, D, T): (B, C, 2), ``A·(sin 2πS, cos 2πS)`` per channel
    (CHOICE's ``p`` of Eq. 13, computed ahead of time for the motion data)."""
    return manifold_features(model.encode(windows))


@torch.no_grad()
def clip_phase(model: PhaseAutoencoder, clip: Union[Motion, torch.Tensor], batch_size: int = 512) -> PhaseParameters:
    """``(S, F, A, B)`` at every frame of a clip, the window slid over it (in batches of windows).

    Args:
        clip: a ``Motion`` at the model's ``fps`` (its :func:`motion_curves`) or curves (D, frames).
        batch_size: windows per forward pass.
    Returns:
        :class:`PhaseParameters`, each (frames, C).
    """
    if isinstance(clip, Motion):
        if abs(clip.fps - model.fps) > 1e-9:
            raise ValueError(f"clip: expected a motion at the model's {model.fps} fps, got {clip.fps} fps")
        curves = motion_curves(clip)
    else:
        curves = clip
    check_shape(curves, (model.input_channels, None), "clip")
    if isinstance(batch_size, bool) or not isinstance(batch_size, int) or batch_size < 1:
        raise ValueError(f"batch_size: expected a positive int, got {batch_size!r}")
    curves = curves.float().to(model.times.device)
    frames = curves.shape[1]
    parts = [model.encode(clip_windows(curves, model.window_frames, model.frame_step,
                                       torch.arange(start, min(start + batch_size, frames))))
             for start in range(0, frames, batch_size)]
    return PhaseParameters(*(torch.cat(values) for values in zip(*parts)))
