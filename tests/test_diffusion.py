"""Diffusion: schedules and posterior vs diffusers' DDPM scheduler, the forward process,
classifier-free guidance, reconstruction guidance (NIFTY Eq. 4), sampling and the loss."""
import math

import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from hoi_tutorial.nn import diffusion as dif
from hoi_tutorial.nn.diffusion import (
    sample_with_record,
    train_denoiser,
    best_of_n,
    classifier_free_x0,
    cosine_schedule,
    guided_x0,
    linear_schedule,
    p_mean_from_x0,
    q_posterior,
    q_sample,
    sample,
    training_loss,
)

diffusers = pytest.importorskip("diffusers")


def _diffusers_scheduler(kind: str, K: int):
    if kind == "cosine":
        return diffusers.DDPMScheduler(
            num_train_timesteps=K, beta_schedule="squaredcos_cap_v2", prediction_type="sample",
            variance_type="fixed_small", clip_sample=False)
    scale = 1000.0 / K  # our linear schedule is rescaled for K steps as in improved DDPM
    return diffusers.DDPMScheduler(
        num_train_timesteps=K, beta_schedule="linear", beta_start=1e-4 * scale, beta_end=0.02 * scale,
        prediction_type="sample", variance_type="fixed_small", clip_sample=False)


def _ours(kind: str, K: int):
    return cosine_schedule(K) if kind == "cosine" else linear_schedule(K)


# --------------------------------------------------------------------------- reference cross-checks


@pytest.mark.parametrize("kind", ["cosine", "linear"])
@pytest.mark.parametrize("K", [50, 1000])
def test_schedule_matches_diffusers(kind, K):
    ours, ref = _ours(kind, K), _diffusers_scheduler(kind, K)
    assert ours.num_steps == K
    torch.testing.assert_close(ours.betas.float(), ref.betas.float(), atol=1e-6, rtol=1e-5)
    torch.testing.assert_close(ours.alphas_cumprod.float(), ref.alphas_cumprod.float(), atol=1e-6, rtol=1e-5)


@pytest.mark.parametrize("kind", ["cosine", "linear"])
def test_posterior_mean_and_variance_match_diffusers_step(kind):
    """diffusers' step with x0-prediction: prev = μ(x0, x_t) + √β̃_t z, with z from the seed."""
    K, shape = 100, (3, 5)
    ours, ref = _ours(kind, K), _diffusers_scheduler(kind, K)
    data = torch.Generator().manual_seed(1)
    for t in [0, 1, 2, 17, 50, 98, 99]:
        x0 = torch.randn(shape, generator=data)
        x_t = torch.randn(shape, generator=data)

        def step(model_output, sample_, seed=7):
            g = torch.Generator().manual_seed(seed)
            return ref.step(model_output=model_output, timestep=t, sample=sample_, generator=g).prev_sample

        # The noise term is the same for the same seed: differences give the mean exactly.
        noise_term = step(torch.zeros(shape), torch.zeros(shape))
        expected_mean = step(x0, x_t) - noise_term
        k = torch.full((shape[0],), t, dtype=torch.int64)
        mean, variance, log_variance = q_posterior(ours, x0, x_t, k)
        torch.testing.assert_close(mean.float(), expected_mean, atol=1e-5, rtol=1e-5)
        torch.testing.assert_close(p_mean_from_x0(ours, x0, x_t, k), mean)
        z = torch.randn(shape, generator=torch.Generator().manual_seed(7))
        if t > 0:
            torch.testing.assert_close((variance.sqrt() * z).float(), noise_term, atol=1e-5, rtol=1e-4)
            torch.testing.assert_close(log_variance, variance.log())
        else:
            assert torch.all(noise_term == 0) and torch.all(variance == 0)
            # log-variance at k = 0 is clipped to the value of k = 1
            assert torch.allclose(log_variance, ours.posterior_log_variance_clipped[1].float().expand(shape))


def test_q_sample_matches_diffusers_add_noise():
    K = 200
    ours, ref = cosine_schedule(K), _diffusers_scheduler("cosine", K)
    g = torch.Generator().manual_seed(0)
    x0, noise = torch.randn(6, 4, 3, generator=g), torch.randn(6, 4, 3, generator=g)
    k = torch.tensor([0, 1, 50, 100, 150, 199])
    torch.testing.assert_close(q_sample(ours, x0, k, noise), ref.add_noise(x0, noise, k), atol=1e-5, rtol=1e-5)


# --------------------------------------------------------------------------- schedule properties


@given(K=st.integers(2, 400), kind=st.sampled_from(["cosine", "linear"]))
def test_schedule_invariants(K, kind):
    s = _ours(kind, K)
    assert torch.all(s.betas > 0) and torch.all(s.betas <= 0.999 + 1e-12)
    assert torch.all(s.alphas_cumprod[1:] < s.alphas_cumprod[:-1])  # noise only grows
    assert s.alphas_cumprod_prev[0] == 1.0
    # the posterior mean of x0 itself is x0 at k = 0 (c1 = 1, c2 = 0)
    assert math.isclose(float(s.posterior_mean_coef1[0]), 1.0, abs_tol=1e-12)
    assert float(s.posterior_mean_coef2[0]) == 0.0
    # posterior variance is below the forward variance: β̃_k ≤ β_k
    assert torch.all(s.posterior_variance <= s.betas + 1e-15)
    assert torch.all(torch.isfinite(s.posterior_log_variance_clipped))


def test_linear_schedule_is_rescaled_for_fewer_steps():
    s = linear_schedule(100)
    assert math.isclose(float(s.betas[0]), 1e-3, rel_tol=1e-12)
    assert math.isclose(float(s.betas[-1]), 0.2, rel_tol=1e-12)
    # with very few steps the rescaled betas would pass 1: they are clipped like the cosine's
    assert math.isclose(float(linear_schedule(10).betas[-1]), 0.999, rel_tol=1e-12)


def test_schedule_to_device_keeps_values():
    s = cosine_schedule(10)
    moved = s.to("cpu")
    assert moved.device.type == "cpu" and len(moved) == 10
    assert torch.equal(moved.posterior_mean_coef2, s.posterior_mean_coef2)


def test_bad_inputs_raise_clear_errors():
    s = cosine_schedule(10)
    x0 = torch.zeros(2, 3)
    with pytest.raises(ValueError, match=r"k: expected steps in \[0, 10\)"):
        q_sample(s, x0, torch.tensor([0, 10]), torch.zeros(2, 3))
    with pytest.raises(TypeError, match="integer tensor"):
        q_sample(s, x0, torch.tensor([0.0, 1.0]), torch.zeros(2, 3))
    with pytest.raises(ValueError, match="noise"):
        q_sample(s, x0, torch.tensor([0, 1]), torch.zeros(2, 4))
    with pytest.raises(TypeError, match="generator"):
        sample(lambda x, k: x, (2, 3), s, generator=0)
    with pytest.raises(ValueError, match="betas"):
        dif.NoiseSchedule.from_betas(torch.tensor([0.1, 1.5]))


def test_q_sample_statistics():
    """x_k given x0 has mean √ᾱ_k x0 and standard deviation √(1-ᾱ_k) (NIFTY Eq. 2 closed form)."""
    s = cosine_schedule(100)
    g = torch.Generator().manual_seed(3)
    n = 20000
    x0 = torch.full((n, 1), 2.0)
    for step in [0, 30, 99]:
        k = torch.full((n,), step, dtype=torch.int64)
        x_k = q_sample(s, x0, k, torch.randn(n, 1, generator=g))
        mean, std = float(s.sqrt_alphas_cumprod[step]) * 2.0, float(s.sqrt_one_minus_alphas_cumprod[step])
        assert abs(float(x_k.mean()) - mean) < 4 * std / math.sqrt(n) + 1e-6
        assert abs(float(x_k.std()) - std) < 0.03 * std
    # the last step is (nearly) pure noise
    assert float(s.sqrt_alphas_cumprod[-1]) < 0.01


# --------------------------------------------------------------------------- classifier-free guidance


class _ToyConditionalModel(torch.nn.Module):
    """x0_hat = tanh(W x_k) + cond (or + null) + k/100; counts calls to check batching."""

    def __init__(self):
        super().__init__()
        self.linear = torch.nn.Linear(3, 3)
        self.null = torch.nn.Parameter(torch.tensor([0.5, -0.5, 0.25]))
        self.calls = 0

    def forward(self, x_k, k, cond, drop_cond, offset=None):
        self.calls += 1
        c = torch.where(drop_cond[:, None], self.null.expand_as(cond), cond)
        out = torch.tanh(self.linear(x_k)) + c + k[:, None].float() / 100
        return out if offset is None else out + offset


def test_classifier_free_scale_zero_and_one_are_exact():
    torch.manual_seed(0)
    model = _ToyConditionalModel()
    g = torch.Generator().manual_seed(0)
    x, cond = torch.randn(4, 3, generator=g), torch.randn(4, 3, generator=g)
    k = torch.tensor([0, 3, 7, 9])
    keep, drop = torch.zeros(4, dtype=torch.bool), torch.ones(4, dtype=torch.bool)
    conditional, unconditional = model(x, k, cond, keep), model(x, k, cond, drop)
    assert torch.equal(classifier_free_x0(model, x, k, cond, 1.0), conditional)
    assert torch.equal(classifier_free_x0(model, x, k, cond, 0.0), unconditional)
    assert not torch.allclose(conditional, unconditional)
    # a general scale, in one batched call, extrapolates past the conditional prediction
    model.calls = 0
    guided = classifier_free_x0(model, x, k, cond, 2.5)
    assert model.calls == 1
    torch.testing.assert_close(guided, unconditional + 2.5 * (conditional - unconditional))
    separate = classifier_free_x0(model, x, k, cond, 2.5, batched=False)
    torch.testing.assert_close(guided, separate)
    # extra model inputs are repeated for the batched call
    offset = torch.arange(4.0)[:, None]
    torch.testing.assert_close(classifier_free_x0(model, x, k, cond, 2.5, offset=offset), guided + offset)


# --------------------------------------------------------------------------- reconstruction guidance


def test_guided_x0_equals_analytic_gradient_step():
    """Denoiser x0 = 2 x_k and G = ||x0 - target||²: ∇_{x_k} G = 4 (2 x_k - target)."""
    g = torch.Generator().manual_seed(0)
    x_k, target = torch.randn(5, 4, generator=g), torch.randn(5, 4, generator=g)
    alpha = 0.05

    def objective(x0_hat):
        return ((x0_hat - target) ** 2).sum(dim=-1)

    x0_tilde, values = guided_x0(lambda x: 2.0 * x, x_k, objective, alpha)
    x0_hat = 2.0 * x_k
    torch.testing.assert_close(x0_tilde, x0_hat - alpha * 4.0 * (x0_hat - target))
    torch.testing.assert_close(values, objective(x0_hat))
    # moves towards the target, for every sample
    assert torch.all(objective(x0_tilde) < objective(x0_hat))
    assert not x_k.requires_grad and not x0_tilde.requires_grad


def test_guided_x0_leaves_model_gradients_alone():
    model = torch.nn.Linear(3, 3)
    x_k = torch.randn(2, 3, generator=torch.Generator().manual_seed(0))
    guided_x0(model, x_k, lambda x0: x0.pow(2).sum(-1), 0.1)
    assert model.weight.grad is None
    with pytest.raises(ValueError, match=r"objective\(x0_hat\)"):
        guided_x0(model, x_k, lambda x0: x0.pow(2).sum(), 0.1)


def test_guided_x0_at_alpha_zero_is_the_prediction_without_a_backward_pass():
    """α = 0 (NIFTY's *selection only* control): x̃0 is x̂0 to the bit, as x̂0 − 0·∇G is, with G at x̂0, and the
    objective is never differentiated (the step is a forward pass only)."""

    class NoBackward(torch.autograd.Function):
        @staticmethod
        def forward(ctx, x):
            return x.clone()

        @staticmethod
        def backward(ctx, grad):
            raise AssertionError("the objective was differentiated")

    model = torch.nn.Sequential(torch.nn.Linear(4, 16), torch.nn.Tanh(), torch.nn.Linear(16, 4))
    x_k = torch.randn(6, 4, generator=torch.Generator().manual_seed(0))
    x0_tilde, values = guided_x0(model, x_k, lambda x0: NoBackward.apply(x0).pow(2).sum(-1), 0.0)
    x_grad = x_k.clone().requires_grad_(True)
    x0_hat = model(x_grad)
    (grad,) = torch.autograd.grad(x0_hat.pow(2).sum(), x_grad)
    assert torch.equal(x0_tilde, x0_hat.detach() - 0.0 * grad)
    assert torch.equal(values, x0_hat.detach().pow(2).sum(-1))
    assert not x0_tilde.requires_grad and not values.requires_grad
    with pytest.raises(AssertionError, match="differentiated"):  # the same objective with α > 0 is differentiated
        guided_x0(model, x_k, lambda x0: NoBackward.apply(x0).pow(2).sum(-1), 0.1)


# --------------------------------------------------------------------------- sampling


MEAN = torch.tensor([1.5, -0.5], dtype=torch.float64)
VAR = torch.tensor([0.25, 2.0], dtype=torch.float64)


def _optimal_gaussian_denoiser(schedule):
    """E[x0 | x_k] for x0 ~ N(MEAN, diag VAR): the exact optimum of the x0-prediction loss."""
    a_all, s2_all = schedule.sqrt_alphas_cumprod, 1.0 - schedule.alphas_cumprod

    def x0_fn(x_k, k):
        a, s2 = a_all[k][:, None], s2_all[k][:, None]
        return MEAN + a * VAR / (a * a * VAR + s2) * (x_k - a * MEAN)

    return x0_fn


def _exact_sampler_moments(schedule):
    """Mean and variance of our sampler's output for the optimal Gaussian denoiser (linear chain)."""
    mean, var = torch.zeros(2, dtype=torch.float64), torch.ones(2, dtype=torch.float64)
    for k in range(schedule.num_steps - 1, -1, -1):
        a, s2 = schedule.sqrt_alphas_cumprod[k], 1.0 - schedule.alphas_cumprod[k]
        gain = a * VAR / (a * a * VAR + s2)
        c1, c2 = schedule.posterior_mean_coef1[k], schedule.posterior_mean_coef2[k]
        mean = (c1 * gain + c2) * mean + c1 * (MEAN - gain * a * MEAN)
        var = (c1 * gain + c2) ** 2 * var + (schedule.posterior_variance[k] if k > 0 else 0.0)
    return mean, var


def test_sampling_recovers_gaussian_data():
    schedule = cosine_schedule(200)
    n = 10000
    x0_fn = _optimal_gaussian_denoiser(schedule)
    g = torch.Generator().manual_seed(0)
    x_init = torch.randn(n, 2, generator=g, dtype=torch.float64)
    samples = sample(x0_fn, (n, 2), schedule, generator=g, x_init=x_init)
    exact_mean, exact_var = _exact_sampler_moments(schedule)
    # the sampler's output matches its exact law (up to Monte-Carlo error) ...
    se_mean, se_var = (exact_var / n).sqrt(), exact_var * math.sqrt(2.0 / n)
    assert torch.all((samples.mean(0) - exact_mean).abs() < 4 * se_mean)
    assert torch.all((samples.var(0) - exact_var).abs() < 4 * se_var)
    # ... which is the data distribution up to the discretisation with 200 steps
    assert torch.all((exact_mean - MEAN).abs() < 1e-3)
    assert torch.all((exact_var / VAR - 1).abs() < 0.05)
    assert torch.all((_exact_sampler_moments(cosine_schedule(1000))[1] / VAR - 1).abs() < 0.01)


def test_guidance_pulls_samples_towards_the_objective():
    schedule = cosine_schedule(50)
    x0_fn = _optimal_gaussian_denoiser(schedule)
    target = torch.tensor([3.0, 2.0], dtype=torch.float64)

    def objective(x0_hat):
        return ((x0_hat - target) ** 2).sum(-1)

    def draw(alpha, seed=1):
        g = torch.Generator().manual_seed(seed)
        x_init = torch.randn(2000, 2, generator=g, dtype=torch.float64)
        return sample(x0_fn, (2000, 2), schedule, generator=g, x_init=x_init, guidance=objective, alpha=alpha)

    plain, guided = draw(0.0), draw(0.2)
    assert float(objective(guided).mean()) < 0.5 * float(objective(plain).mean())
    assert torch.equal(draw(0.2), guided)  # deterministic for a seed


def test_sample_shape_determinism_and_trajectory():
    schedule = cosine_schedule(8)
    model = torch.nn.Linear(3, 3)

    def x0_fn(x_k, k):
        return model(x_k) * (1 + k[:, None, None].float() / 8)

    out = sample(x0_fn, (2, 4, 3), schedule, generator=torch.Generator().manual_seed(5))
    again = sample(x0_fn, (2, 4, 3), schedule, generator=torch.Generator().manual_seed(5))
    other = sample(x0_fn, (2, 4, 3), schedule, generator=torch.Generator().manual_seed(6))
    assert out.shape == (2, 4, 3) and torch.equal(out, again) and not torch.equal(out, other)
    record = sample_with_record(x0_fn, (2, 4, 3), schedule, generator=torch.Generator().manual_seed(5))
    final = record.sample
    assert torch.equal(final, out)
    assert record.k == list(range(7, -1, -1)) and record.at(7) == 0 and record.at(0) == 7
    assert len(record.x_k) == len(record.x0_hat) == 8
    assert record.objective == [None] * 8
    # no noise at the last step: the sample is the last clean prediction
    assert torch.allclose(final, record.x0_hat[-1], atol=1e-6)
    with pytest.raises(ValueError, match="recorded steps"):
        record.at(8)


def test_guidance_steps_default_skips_the_last_step():
    schedule = cosine_schedule(6)
    seen = []

    def objective(x0_hat):
        seen.append(1)
        return x0_hat.pow(2).sum(-1)

    traj = sample_with_record(lambda x, k: 0.5 * x, (3, 2), schedule, generator=torch.Generator().manual_seed(0),
                              guidance=objective, alpha=0.1)
    assert len(seen) == 5 and traj.objective[-1] is None and traj.objective[0].shape == (3,)
    seen.clear()
    sample(lambda x, k: 0.5 * x, (3, 2), schedule, generator=torch.Generator().manual_seed(0),
           guidance=objective, alpha=lambda k: 0.1 * k, guidance_steps=[5, 0])
    assert len(seen) == 2


def test_inpainting_keeps_known_entries():
    schedule = cosine_schedule(10)
    mask = torch.zeros(2, 5, 3, dtype=torch.bool)
    mask[:, 0] = True  # the first frame is given
    values = torch.full((2, 5, 3), 0.7)
    out = sample(lambda x, k: 0.3 * x, (2, 5, 3), schedule, generator=torch.Generator().manual_seed(0),
                 inpaint=(mask, values))
    torch.testing.assert_close(out[:, 0], values[:, 0])
    assert not torch.allclose(out[:, 1:], values[:, 1:])


def test_best_of_n():
    samples = torch.arange(12.0).reshape(4, 3)
    index, best = best_of_n(samples, torch.tensor([3.0, 0.5, float("nan"), 2.0]))
    assert index == 1 and torch.equal(best, samples[1])
    index, _ = best_of_n(samples, torch.tensor([3.0, 0.5, 9.0, 2.0]), lower_is_better=False)
    assert index == 2
    with pytest.raises(ValueError, match="objective_values"):
        best_of_n(samples, torch.zeros(3))


# --------------------------------------------------------------------------- training loss


def test_training_loss_is_zero_for_a_perfect_model_and_drops_conditions():
    schedule = cosine_schedule(20)
    x0 = torch.randn(64, 6, 3, generator=torch.Generator().manual_seed(0))
    drops = []

    def oracle(x_k, k, cond, drop_cond):
        drops.append(drop_cond)
        return x0.clone()

    loss = training_loss(oracle, x0, None, schedule, generator=torch.Generator().manual_seed(1), p_uncond=0.25)
    assert float(loss) == 0.0
    assert drops[0].dtype == torch.bool and 0 < int(drops[0].sum()) < 64
    loss_again = training_loss(lambda *a: torch.zeros_like(x0), x0, None, schedule,
                               generator=torch.Generator().manual_seed(1))
    torch.testing.assert_close(loss_again, (x0 ** 2).mean())


def test_training_loss_mask_ignores_padding():
    schedule = cosine_schedule(20)
    x0 = torch.randn(4, 6, 3, generator=torch.Generator().manual_seed(0))
    mask = torch.ones(4, 6, dtype=torch.bool)
    mask[:, 4:] = False

    def wrong_on_padding(x_k, k, cond, drop_cond):
        out = x0.clone()
        out[:, 4:] += 10.0
        return out

    masked = training_loss(wrong_on_padding, x0, None, schedule, generator=torch.Generator().manual_seed(0), mask=mask)
    unmasked = training_loss(wrong_on_padding, x0, None, schedule, generator=torch.Generator().manual_seed(0))
    assert float(masked) == 0.0 and float(unmasked) > 10.0


def test_training_reduces_loss_for_a_tiny_denoiser():
    """A few optimiser steps on the loss make the denoiser better than predicting zeros."""
    torch.manual_seed(0)
    schedule = cosine_schedule(50)
    data_gen = torch.Generator().manual_seed(0)
    x0 = MEAN.float() + VAR.float().sqrt() * torch.randn(256, 2, generator=data_gen)
    net = torch.nn.Sequential(torch.nn.Linear(3, 64), torch.nn.SiLU(), torch.nn.Linear(64, 2))

    def model(x_k, k, cond, drop_cond):
        return net(torch.cat([x_k, k[:, None].float() / 50], dim=-1))

    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    g = torch.Generator().manual_seed(1)
    losses = []
    for _ in range(150):
        loss = training_loss(model, x0, None, schedule, generator=g)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()))
    assert sum(losses[-20:]) / 20 < 0.5 * sum(losses[:5]) / 5


# --------------------------------------------------------------------------- the training helper


def _tiny_denoiser(seed=0):
    from hoi_tutorial.nn.denoisers import MLPDenoiser

    torch.manual_seed(seed)
    return MLPDenoiser(2, n_classes=3, width=16, depth=1, time_embed_dim=8, schedule=cosine_schedule(10))


def test_train_denoiser_matches_a_hand_written_closure():
    """The helper draws rows, then a per-step seed for k, noise and dropout: the same run as writing
    the closure by hand around ``infra.train`` and ``training_loss``."""
    from hoi_tutorial.infra import TrainerConfig, train

    x0 = torch.randn(50, 2, generator=torch.Generator().manual_seed(1))
    labels = torch.randint(0, 3, (50,), generator=torch.Generator().manual_seed(2))
    schedule = cosine_schedule(10)
    config = TrainerConfig(steps=12, batch_size=8, lr=1e-2, progress=False, seed=3)
    ours = _tiny_denoiser()
    result = train_denoiser(ours, x0, labels, schedule, config, p_uncond=0.3)

    def sample_batch(step, generator):
        index = torch.randint(0, 50, (8,), generator=generator)
        return x0[index], labels[index], torch.randint(0, 2**62, (1,), generator=generator)

    def loss_fn(net, batch):
        generator = torch.Generator().manual_seed(int(batch[2]))
        return training_loss(net, batch[0], batch[1], schedule, generator=generator, p_uncond=0.3)

    reference = _tiny_denoiser()
    expected = train(reference, sample_batch, loss_fn, config)
    assert result.losses == expected.losses
    for p, q in zip(ours.parameters(), reference.parameters()):
        assert torch.equal(p, q)
    with pytest.raises(ValueError, match="rows"):
        train_denoiser(_tiny_denoiser(), x0, labels[:10], schedule, config)
    with pytest.raises(ValueError, match="rows"):
        train_denoiser(_tiny_denoiser(), x0, {"labels": labels[:10]}, schedule, config)
