"""2-D teaching distributions, region objectives, the exact ring8 denoiser, the MLP denoiser's
classifier-free interface and the toy trainer."""
import math

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from hoi_tutorial.nifty import toy2d
from hoi_tutorial.nn.denoisers import MLPDenoiser
from hoi_tutorial.nn.diffusion import classifier_free_x0, cosine_schedule, q_sample, sample


@pytest.fixture(autouse=True, scope="module")
def _one_cpu_thread(one_cpu_thread):
    """Tiny models run fastest on one thread (the shared fixture in conftest)."""

# --------------------------------------------------------------------------- distributions


@pytest.mark.parametrize("name", toy2d.TOY2D_DISTRIBUTIONS)
def test_sample_shapes_labels_and_determinism(name):
    points, labels = toy2d.sample_toy2d(name, 500, seed=3)
    assert points.shape == (500, 2) and points.dtype == torch.float32
    assert labels.shape == (500,) and labels.dtype == torch.int64
    assert set(labels.tolist()) == set(range(toy2d.toy2d_num_classes(name)))
    again, again_labels = toy2d.sample_toy2d(name, 500, seed=np.random.default_rng(3))
    assert torch.equal(points, again) and torch.equal(labels, again_labels)
    other, _ = toy2d.sample_toy2d(name, 500, seed=4)
    assert not torch.equal(points, other)


def test_ring8_points_sit_around_their_centres():
    points, labels = toy2d.sample_toy2d("ring8", 4000, seed=0)
    centres = torch.as_tensor(toy2d.ring8_centres(), dtype=torch.float32)
    distance = (points - centres[labels]).norm(dim=1)
    # The mean of a 2-D isotropic Gaussian's radius is σ √(π/2).
    assert distance.mean().item() == pytest.approx(toy2d.RING8_STD * math.sqrt(math.pi / 2), rel=0.05)


def test_bad_distribution_and_size_raise():
    with pytest.raises(ValueError, match="name"):
        toy2d.sample_toy2d("spiral", 10, 0)
    with pytest.raises(ValueError, match="n"):
        toy2d.sample_toy2d("ring8", 0, 0)


def test_ring8_density_integrates_to_one_and_posterior_is_normalised():
    grid = torch.linspace(-5, 5, 401, dtype=torch.float64)
    xx, yy = torch.meshgrid(grid, grid, indexing="xy")
    points = torch.stack([xx.reshape(-1), yy.reshape(-1)], dim=1)
    cell = (grid[1] - grid[0]) ** 2
    mass = (toy2d.ring8_log_density(points).exp() * cell).sum().item()
    assert mass == pytest.approx(1.0, abs=1e-3)
    posterior = toy2d.ring8_class_posterior(points[::97])
    torch.testing.assert_close(posterior.sum(dim=1), torch.ones(posterior.shape[0], dtype=torch.float64))


def test_classifiers_agree_near_the_centres():
    centres = torch.as_tensor(toy2d.ring8_centres(), dtype=torch.float32)
    near = centres + 0.1 * torch.tensor([[1.0, -1.0]])
    assert torch.equal(toy2d.classify_toy2d("ring8", near), torch.arange(8))
    assert torch.equal(toy2d.ring8_class_posterior(near).argmax(dim=1), torch.arange(8))


# --------------------------------------------------------------------------- objectives


def test_disc_objective_value_and_gradient_point_inwards():
    centre, radius = torch.tensor([1.0, 2.0]), 0.5
    G = toy2d.disc_objective(centre, radius)
    points = torch.tensor([[1.0, 2.0], [1.3, 2.0], [3.0, 2.0], [1.0, -1.0]], requires_grad=True)
    values = G(points)
    torch.testing.assert_close(values.detach(), torch.tensor([0.0, 0.0, 1.5 ** 2, 2.5 ** 2]))
    (grad,) = torch.autograd.grad(values.sum(), points)
    assert torch.isfinite(grad).all()
    assert torch.equal(grad[:2], torch.zeros(2, 2))  # inside: nothing to correct
    inward = (centre - points.detach()[2:]) / (centre - points.detach()[2:]).norm(dim=1, keepdim=True)
    torch.testing.assert_close(-grad[2:] / grad[2:].norm(dim=1, keepdim=True), inward)


@given(x=st.floats(-4, 4), y=st.floats(-4, 4))
def test_a_small_step_against_the_gradient_enters_the_region(x, y):
    for G in (toy2d.disc_objective([0.5, -0.5], 0.7), toy2d.box_objective([-1.0, 0.0], [0.5, 1.5])):
        point = torch.tensor([[x, y]], dtype=torch.float64, requires_grad=True)
        value = G(point)
        (grad,) = torch.autograd.grad(value.sum(), point)
        if value.item() == 0.0:
            # Inside (or so close outside that the squared distance underflows): no correction.
            assert grad.abs().max().item() < 1e-100
        else:
            # G is a squared distance: a gradient step of 1/2 lands exactly on the region.
            assert G(point.detach() - 0.5 * grad).item() < 1e-9


def test_box_objective_value_and_bad_corners():
    G = toy2d.box_objective([0.0, 0.0], [1.0, 2.0])
    values = G(torch.tensor([[0.5, 1.0], [2.0, 1.0], [-1.0, 3.0]]))
    torch.testing.assert_close(values, torch.tensor([0.0, 1.0, 2.0]))
    with pytest.raises(ValueError, match="hi"):
        toy2d.box_objective([0.0, 0.0], [1.0, 0.0])
    with pytest.raises(ValueError, match="points"):
        G(torch.zeros(3, 3))


# --------------------------------------------------------------------------- the exact denoiser


def test_exact_denoiser_is_the_posterior_mean():
    """E[x0 | x_k] is the best predictor: its error is below that of any perturbed version."""
    schedule = cosine_schedule(50)
    x0, labels = toy2d.sample_toy2d("ring8", 3000, seed=1)
    k = torch.full((3000,), 20)
    x_k = q_sample(schedule, x0, k, torch.randn(3000, 2, generator=torch.Generator().manual_seed(2)))
    exact = toy2d.ring8_exact_x0(x_k, k, schedule)
    exact_given_label = toy2d.ring8_exact_x0(x_k, k, schedule, labels)
    error = ((exact - x0) ** 2).mean()
    assert ((exact_given_label - x0) ** 2).mean() < error  # knowing the label helps
    assert error < ((0.9 * exact - x0) ** 2).mean() and error < ((1.1 * exact - x0) ** 2).mean()


def test_sampling_with_the_exact_denoiser_reproduces_ring8():
    """An end-to-end check of the sampler that needs no training."""
    schedule = cosine_schedule(50)
    samples = sample(lambda x, k: toy2d.ring8_exact_x0(x, k, schedule), (600, 2), schedule,
                     generator=torch.Generator().manual_seed(0))
    centres = torch.as_tensor(toy2d.ring8_centres(), dtype=torch.float32)
    nearest = torch.cdist(samples, centres).min(dim=1)
    expected = toy2d.RING8_STD * math.sqrt(math.pi / 2)
    assert nearest.values.mean().item() == pytest.approx(expected, rel=0.15)
    counts = torch.bincount(nearest.indices, minlength=8)
    assert counts.min().item() > 40  # every component is visited (75 expected each)


# --------------------------------------------------------------------------- the MLP denoiser


def _labelled_model(**kwargs):
    torch.manual_seed(0)
    return MLPDenoiser(2, n_classes=8, width=32, depth=2, time_embed_dim=16, **kwargs).eval()


def test_denoiser_shapes_for_points_and_trajectories():
    model = _labelled_model()
    k = torch.tensor([0, 5, 9])
    assert model(torch.randn(3, 2), k, torch.tensor([1, 2, 3])).shape == (3, 2)
    trajectory_model = MLPDenoiser(12, width=32, depth=1)
    assert trajectory_model(torch.randn(3, 4, 3), k).shape == (3, 4, 3)
    with pytest.raises(ValueError, match="x_k"):
        trajectory_model(torch.randn(3, 5, 3), k)


def test_drop_cond_gives_the_unconditional_output():
    model = _labelled_model()
    x, k, labels = torch.randn(6, 2), torch.arange(6), torch.tensor([0, 1, 2, 3, 4, 5])
    with torch.no_grad():
        unconditional = model(x, k, None)
        conditional = model(x, k, labels)
        dropped = model(x, k, labels, torch.ones(6, dtype=torch.bool))
        mixed = model(x, k, labels, torch.tensor([True, False, True, False, False, True]))
        cfg_zero = classifier_free_x0(model, x, k, labels, 0.0)
        cfg_one = classifier_free_x0(model, x, k, labels, 1.0)
        cfg_two = classifier_free_x0(model, x, k, labels, 2.0)
    torch.testing.assert_close(dropped, unconditional)
    assert not torch.allclose(conditional, unconditional)
    keep = torch.tensor([False, True, False, True, True, False])
    torch.testing.assert_close(mixed[keep], conditional[keep])
    torch.testing.assert_close(mixed[~keep], unconditional[~keep])
    torch.testing.assert_close(cfg_zero, unconditional)
    torch.testing.assert_close(cfg_one, conditional)
    torch.testing.assert_close(cfg_two, unconditional + 2.0 * (conditional - unconditional))


def test_vector_condition_uses_a_learned_null_vector():
    torch.manual_seed(0)
    model = MLPDenoiser(2, cond_dim=3, width=16, depth=1).eval()
    x, k, cond = torch.randn(4, 2), torch.arange(4), torch.randn(4, 3)
    with torch.no_grad():
        torch.testing.assert_close(model(x, k, cond, torch.ones(4, dtype=torch.bool)), model(x, k, None))
        assert not torch.allclose(model(x, k, cond), model(x, k, None))
    assert "null_condition" in dict(model.named_parameters())


def test_denoiser_rejects_bad_conditions():
    model = _labelled_model()
    x, k = torch.randn(2, 2), torch.tensor([0, 1])
    with pytest.raises(ValueError, match="cond"):
        model(x, k, torch.tensor([0, 8]))
    with pytest.raises(TypeError, match="cond"):
        model(x, k, torch.tensor([0.0, 1.0]))
    with pytest.raises(ValueError, match="cond"):
        MLPDenoiser(2)(x, k, torch.tensor([0, 1]))
    with pytest.raises(ValueError, match="cond_dim and n_classes"):
        MLPDenoiser(2, cond_dim=3, n_classes=4)


def test_preconditioning_builds_in_the_skip_connection():
    """With F ≡ 0 the model returns c_skip(k) x_k = σ_d² √ᾱ_k / (1 - ᾱ_k + ᾱ_k σ_d²) · x_k."""
    schedule = cosine_schedule(20)
    model = _labelled_model(schedule=schedule, data_std=1.5)
    torch.nn.init.zeros_(model.output_projection.weight)
    torch.nn.init.zeros_(model.output_projection.bias)
    x, k = torch.randn(3, 2), torch.tensor([0, 10, 19])
    alpha_bar = schedule.alphas_cumprod[k].float()[:, None]
    expected = 2.25 * alpha_bar.sqrt() / (1 - alpha_bar + alpha_bar * 2.25) * x
    with torch.no_grad():
        torch.testing.assert_close(model(x, k, torch.tensor([0, 1, 2])), expected)
    with pytest.raises(ValueError, match="k"):
        model(x, torch.tensor([0, 1, 20]), None)


# --------------------------------------------------------------------------- training


def test_config_presets_and_overrides():
    assert toy2d.toy2d_config("toy").diffusion_steps == 100
    assert toy2d.toy2d_config("paper").diffusion_steps == 1000
    assert toy2d.toy2d_config("toy", steps=7).steps == 7
    with pytest.raises(ValueError, match="distribution"):
        toy2d.toy2d_config("toy", distribution="spiral")


def test_training_is_deterministic_and_loads_back():
    config = toy2d.toy2d_config("toy", steps=25, n_train=500, batch_size=64, width=32, depth=1,
                                fourier_features=8)
    trained, result = toy2d.train_toy2d_denoiser(config)
    again, result_again = toy2d.train_toy2d_denoiser(config)
    losses = result.losses
    assert len(losses) == 25 and all(math.isfinite(v) for v in losses)
    assert losses == result_again.losses
    for name, value in trained.state_dict().items():
        assert torch.equal(value, again.state_dict()[name])
    model = toy2d.build_toy2d_denoiser(config)
    model.load_state_dict(trained.state_dict())
    assert sum(losses[-5:]) < sum(losses[:5])  # it learns
