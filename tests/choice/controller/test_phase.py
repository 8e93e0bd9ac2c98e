"""The DeepPhase periodic autoencoder (Starke et al. 2022) as CHOICE uses it: the FFT parameter layer,
the phase of a trained PAE on pure sinusoids, shapes, determinism, the manifold features, the
input curves and windows, the cache, errors."""
import dataclasses
import math

import numpy as np
import pytest
import torch

from hoi_tutorial.choice.controller import phase as ctrl_phase
from hoi_tutorial.world import mocap
from hoi_tutorial.world.skeleton import NUM_JOINTS

pytestmark = pytest.mark.usefixtures("one_cpu_thread")

FPS, STEP = 30.0, 2  # the toy preset samples its windows every second frame: 15 Hz


def sines(freq: float, frames: int, phase0: float = 0.0, channels: int = 6) -> torch.Tensor:
    """(channels, frames) unit sinusoids at ``freq`` Hz sampled at ``FPS``, each channel shifted by 1/channels cycle."""
    t = torch.arange(frames) / FPS
    shifts = torch.arange(channels)[:, None] * (2 * math.pi / channels)
    return torch.sin(2 * math.pi * freq * t + phase0 + shifts)


@pytest.fixture(scope="module")
def toy_clip():
    return mocap.generate_clip("walk", seed=5)


# ----------------------------------------------------------------------------- the parameter layer


@pytest.mark.parametrize("freq", [0.5, 1.2, 2.0, 3.7])
def test_fft_parameters_find_a_sinusoids_frequency_within_a_bin(freq):
    T, rate = 31, FPS / STEP
    t = ctrl_phase.window_times(T, rate)
    curve = 0.7 * torch.sin(2 * math.pi * (freq * t + 0.3)) + 0.2
    f, a, b = ctrl_phase.fft_parameters(curve, rate)
    assert f.shape == a.shape == b.shape == ()
    assert abs(float(f) - freq) < rate / T  # one bin of the real FFT


def test_fft_parameters_are_exact_for_whole_cycles_and_batch():
    T, rate = 31, FPS / STEP
    bins = torch.fft.rfftfreq(T, d=1 / rate)
    params = ctrl_phase.PhaseParameters(phase=torch.tensor([[0.1, 0.6], [0.9, 0.25]]),
                                   frequency=torch.stack([bins[[2, 5]], bins[[1, 7]]]),
                                   amplitude=torch.tensor([[1.5, 0.3], [0.8, 2.0]]),
                                   offset=torch.tensor([[0.0, -0.4], [1.0, 0.25]]))
    curves = ctrl_phase.sinusoid(params, ctrl_phase.window_times(T, rate))
    assert curves.shape == (2, 2, T)
    f, a, b = ctrl_phase.fft_parameters(curves, rate)
    torch.testing.assert_close(f, params.frequency, atol=1e-4, rtol=1e-5)
    torch.testing.assert_close(a, params.amplitude, atol=1e-4, rtol=1e-5)
    torch.testing.assert_close(b, params.offset, atol=1e-5, rtol=1e-5)
    # S is the phase at the centre sample: the curve there is A sin 2πS + B
    centre = curves[..., T // 2]
    torch.testing.assert_close(centre, params.amplitude * torch.sin(2 * math.pi * params.phase) + params.offset)


def test_a_curve_without_power_has_zero_frequency_not_nan():
    f, a, b = ctrl_phase.fft_parameters(torch.zeros(3, 31), 15.0)
    assert torch.all(f == 0) and torch.all(a == 0) and torch.all(b == 0)
    f, a, b = ctrl_phase.fft_parameters(torch.full((3, 31), 2.0), 15.0)  # round-off power only
    assert torch.all(torch.isfinite(f)) and torch.all(a < 1e-5)
    torch.testing.assert_close(b, torch.full((3,), 2.0))


def test_a_tiny_pae_trained_on_sinusoids_advances_its_phase_at_their_frequency():
    config = ctrl_phase.phase_config("toy", channels=1, steps=300, batch_size=16, seed=0)
    g = torch.Generator().manual_seed(0)
    freqs = (0.75, 1.5)
    windows = torch.cat([ctrl_phase.clip_windows(sines(f, 120, float(torch.rand(1, generator=g)) * 2 * math.pi),
                                            config.window_frames, config.frame_step, torch.arange(30, 90))
                         for f in freqs for _ in range(4)])
    model, result = ctrl_phase.train_phase_autoencoder(windows, config, fps=FPS)
    assert result.final_loss < 0.1 * result.losses[0]
    bin_width = model.sample_rate / config.window_frames
    for f in freqs:
        params = ctrl_phase.clip_phase(model, sines(f, 150, 0.3))
        inner = slice(30, 120)  # windows that do not reach past the clip's ends
        S = params.phase[inner, 0].numpy()
        advance = (np.diff(S) + 0.5) % 1.0 - 0.5  # cycles per frame, unwrapped
        assert advance.mean() * FPS == pytest.approx(f, rel=0.1)  # S grows by F·Δt (CHOICE Eq. 16)
        assert abs(float(params.frequency[inner, 0].mean()) - f) < bin_width


# ----------------------------------------------------------------------------- the network


def test_shapes_of_the_forward_pass_and_the_clip_phase(toy_clip):
    config = ctrl_phase.phase_config("toy", channels=3)
    model = ctrl_phase.build_phase_autoencoder(config)
    D, T = 3 * NUM_JOINTS, config.window_frames
    windows = torch.randn(5, D, T)
    reconstruction, params, latent, signal = model(windows)
    assert reconstruction.shape == windows.shape
    assert latent.shape == signal.shape == (5, 3, T)
    assert all(p.shape == (5, 3) for p in params)
    assert model.sample_rate == FPS / config.frame_step
    per_frame = ctrl_phase.clip_phase(model, toy_clip)
    assert all(p.shape == (len(toy_clip), 3) for p in per_frame)
    assert torch.all((per_frame.phase >= 0) & (per_frame.phase <= 1))
    assert torch.all(per_frame.frequency >= 0) and torch.all(per_frame.frequency <= model.sample_rate / 2)
    small_batches = ctrl_phase.clip_phase(model, toy_clip, batch_size=7)
    for a, b in zip(per_frame, small_batches):
        torch.testing.assert_close(a, b)
    one = ctrl_phase.clip_windows(ctrl_phase.motion_curves(toy_clip), T, config.frame_step, [40])
    torch.testing.assert_close(model.encode(one).amplitude[0], per_frame.amplitude[40])


def test_features_are_phase_vectors_whose_norm_is_the_amplitude():
    model = ctrl_phase.build_phase_autoencoder(ctrl_phase.phase_config("toy"))
    windows = torch.randn(6, 3 * NUM_JOINTS, model.window_frames)
    features = ctrl_phase.phase_features(model, windows)
    params = model.encode(windows)
    assert features.shape == (6, model.channels, 2)
    torch.testing.assert_close(features.norm(dim=-1), params.amplitude)
    angle = 2 * math.pi * params.phase
    torch.testing.assert_close(features[..., 0], params.amplitude * torch.sin(angle))


def test_training_is_deterministic_for_a_seed_and_lowers_the_loss():
    config = ctrl_phase.phase_config("toy", clips_per_kind=1, steps=60, batch_size=8)
    windows = ctrl_phase.training_windows(config)
    assert windows.shape[1:] == (3 * NUM_JOINTS, config.window_frames)
    torch.testing.assert_close(windows, ctrl_phase.training_windows(config), rtol=0, atol=0)
    a, result_a = ctrl_phase.train_phase_autoencoder(windows, config)
    b, result_b = ctrl_phase.train_phase_autoencoder(windows, config)
    assert result_a.losses == result_b.losses
    for (name, x), y in zip(a.state_dict().items(), b.state_dict().values()):
        assert torch.equal(x, y), name
    assert np.mean(result_a.losses[-10:]) < np.mean(result_a.losses[:10])
    c, result_c = ctrl_phase.train_phase_autoencoder(windows, ctrl_phase.phase_config("toy", clips_per_kind=1, steps=60,
                                                                            batch_size=8, seed=1))
    assert result_c.losses != result_a.losses


def test_trained_pae_is_cached(module_cache):
    first = ctrl_phase.trained_phase_autoencoder("toy", seed=0, clips_per_kind=1, steps=5, batch_size=4)
    second = ctrl_phase.trained_phase_autoencoder("toy", seed=0, clips_per_kind=1, steps=5, batch_size=4)
    assert isinstance(first.model, ctrl_phase.PhaseAutoencoder) and not first.model.training
    assert first.details["config"] == ctrl_phase.phase_config("toy", clips_per_kind=1, steps=5, batch_size=4)
    assert first.details["n_windows"] > 0 and len(first.losses) == 5
    for x, y in zip(first.model.state_dict().values(), second.model.state_dict().values()):
        assert torch.equal(x, y)
    assert len(list(module_cache.glob("choice_phase_autoencoder-*.pt"))) == 1


# ----------------------------------------------------------------------------- data


def test_curves_are_root_frame_velocities_unchanged_by_turning_and_moving_the_clip(toy_clip):
    curves = ctrl_phase.motion_curves(toy_clip)
    assert curves.shape == (3 * NUM_JOINTS, len(toy_clip)) and curves.dtype == torch.float32
    moved = ctrl_phase.motion_curves(toy_clip.transformed(yaw=1.1, translation=(2.0, -1.0, 0.0)))
    torch.testing.assert_close(moved, curves, atol=1e-4, rtol=1e-4)
    # walking forward: the pelvis moves along +y (forward) of its own root frame
    walking = np.array(toy_clip.action_names()) == "walk"
    assert float(curves[1, walking].mean()) > 0.3 > abs(float(curves[0, walking].mean()))


def test_windows_are_centred_spaced_by_the_step_and_clamped_at_the_ends():
    curves = torch.arange(20.0)[None].repeat(2, 1)  # the value is the frame index
    windows = ctrl_phase.clip_windows(curves, 5, 3)
    assert windows.shape == (20, 2, 5)
    assert windows[10, 0].tolist() == [4, 7, 10, 13, 16]
    assert windows[0, 1].tolist() == [0, 0, 0, 3, 6]
    assert windows[19, 0].tolist() == [13, 16, 19, 19, 19]


# ----------------------------------------------------------------------------- errors


def test_errors_name_what_was_expected(toy_clip):
    model = ctrl_phase.build_phase_autoencoder(ctrl_phase.phase_config("toy"))
    with pytest.raises(ValueError, match=r"windows: expected shape \(\*, 66, 31\), got \(2, 66, 30\)"):
        model(torch.zeros(2, 3 * NUM_JOINTS, 30))
    with pytest.raises(ValueError, match=r"windows: expected shape \(\*, 66, 31\)"):
        ctrl_phase.phase_features(model, torch.zeros(2, 60, 31))
    for rate in (0, -15.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="sample_rate: expected a positive, finite rate"):
            ctrl_phase.fft_parameters(torch.zeros(31), rate)
    with pytest.raises(ValueError, match="fps: expected a positive, finite rate"):
        ctrl_phase.PhaseAutoencoder(66, 4, 31, 2, fps=0)
    with pytest.raises(ValueError, match="fps: expected a positive, finite rate"):
        ctrl_phase.train_phase_autoencoder(torch.zeros(4, 6, 31), ctrl_phase.phase_config("toy"), fps=-30.0)
    with pytest.raises(ValueError, match=r"windows: expected shape \(\*, \*, 31\)"):
        ctrl_phase.train_phase_autoencoder(torch.zeros(4, 6, 21), ctrl_phase.phase_config("toy"))
    with pytest.raises(ValueError, match="curves: expected a tensor of shape \\(..., T\\) with T >= 2"):
        ctrl_phase.fft_parameters(torch.zeros(3, 1), 15.0)
    with pytest.raises(ValueError, match="window_frames: expected an odd int >= 3"):
        ctrl_phase.phase_config("toy", window_frames=30)
    with pytest.raises(ValueError, match="kinds: expected a non-empty tuple of names"):
        ctrl_phase.phase_config("toy", kinds=("fly",))
    with pytest.raises(ValueError, match="channels: expected a positive int"):
        ctrl_phase.phase_config("toy", channels=0)
    with pytest.raises(ValueError, match="clip: expected a motion at the model's 30.0 fps, got 60.0 fps"):
        ctrl_phase.clip_phase(model, dataclasses.replace(toy_clip, fps=60.0))
    with pytest.raises(ValueError, match=r"clip: expected shape \(66, \*\)"):
        ctrl_phase.clip_phase(model, torch.zeros(6, 50))
    with pytest.raises(TypeError, match="motion: expected a world.motion.Motion"):
        ctrl_phase.motion_curves(torch.zeros(10, 22, 3))
