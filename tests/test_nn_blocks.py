"""Neural building blocks: embeddings, PointNet, the transformer denoiser, cVAE helpers, MoE."""
import math

import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from hoi_tutorial.nn import (
    MLP,
    FourierFeatures,
    GatingNetwork,
    MixtureOfExpertsLinear,
    MoEMLP,
    PointNetEncoder,
    PositionalEncoding,
    SinusoidalEmbedding,
    TimestepEmbedding,
    TransformerDenoiser,
    classifier_free_x0,
    cosine_schedule,
    gaussian_kl,
    reparameterize,
    sample,
    sinusoid_table,
    training_loss,
)


def _gen(seed=0):
    return torch.Generator().manual_seed(seed)


# --------------------------------------------------------------------------- embeddings


def test_sinusoidal_embedding_values_and_shapes():
    emb = SinusoidalEmbedding(8)(torch.tensor([0, 5, 999]))
    assert emb.shape == (3, 8)
    # position 0: sines 0, cosines 1; the first frequency is 1 rad per step
    assert torch.equal(emb[0], torch.tensor([0.0] * 4 + [1.0] * 4))
    assert math.isclose(float(emb[1, 0]), math.sin(5.0), rel_tol=1e-6)
    assert math.isclose(float(emb[1, 4]), math.cos(5.0), rel_tol=1e-6)
    assert sinusoid_table(torch.arange(4), 7).shape == (4, 7)  # odd size padded
    # distinct steps get distinct codes
    assert torch.cdist(emb, emb)[~torch.eye(3, dtype=torch.bool)].min() > 0.1


def test_timestep_and_positional_encoding():
    torch.manual_seed(0)
    out = TimestepEmbedding(16)(torch.tensor([0, 10, 999]))
    assert out.shape == (3, 16) and torch.isfinite(out).all()
    pe = PositionalEncoding(6, max_len=10)
    x = torch.zeros(2, 4, 6)
    torch.testing.assert_close(pe(x), sinusoid_table(torch.arange(4), 6).expand(2, 4, 6))
    torch.testing.assert_close(pe(x, offset=3)[0, 0], sinusoid_table(torch.tensor(3), 6))
    with pytest.raises(ValueError, match="max_len"):
        pe(torch.zeros(1, 11, 6))


def test_fourier_features():
    ff = FourierFeatures(3, 16, scale=2.0, include_input=True, seed=4)
    x = torch.randn(5, 7, 3, generator=_gen())
    out = ff(x)
    assert out.shape == (5, 7, ff.out_dim) and ff.out_dim == 35
    assert torch.allclose(out[..., :16] ** 2 + out[..., 16:32] ** 2, torch.ones(5, 7, 16))
    assert torch.equal(FourierFeatures(3, 16, scale=2.0, seed=4).freqs, ff.freqs)  # seeded
    assert not list(ff.parameters())
    assert len(list(FourierFeatures(3, 16, learnable=True).parameters())) == 1
    with pytest.raises(ValueError, match=r"x: expected shape \(\.\.\., 3\)"):
        ff(torch.zeros(4, 2))


# --------------------------------------------------------------------------- PointNet


@given(seed=st.integers(0, 1000))
def test_pointnet_is_permutation_invariant(seed):
    torch.manual_seed(0)
    net = PointNetEncoder(out_dim=12, hidden=(16, 32))
    points = torch.randn(3, 50, 3, generator=_gen(seed))
    perm = torch.randperm(50, generator=_gen(seed + 1))
    code = net(points)
    assert code.shape == (3, 12)
    torch.testing.assert_close(net(points[:, perm]), code)


def test_pointnet_point_mask_ignores_padding_points():
    torch.manual_seed(0)
    net = PointNetEncoder(out_dim=8)
    points = torch.randn(2, 20, 3, generator=_gen())
    mask = torch.ones(2, 20, dtype=torch.bool)
    mask[0, 12:] = False
    padded = points.clone()
    padded[0, 12:] = 100.0  # would dominate the max if it were not masked
    torch.testing.assert_close(net(padded, mask)[0], net(points[:1, :12])[0])
    with pytest.raises(ValueError, match="points"):
        net(torch.zeros(2, 20, 2))


# --------------------------------------------------------------------------- transformer denoiser


def _denoiser():
    torch.manual_seed(0)
    model = TransformerDenoiser(x_dim=5, cond_dims={"object": 7, "start_pose": 4}, width=32, layers=2,
                                heads=4, dropout=0.0, max_len=16)
    return model.eval()


def _inputs(batch=3, frames=10, seed=0):
    g = _gen(seed)
    x = torch.randn(batch, frames, 5, generator=g)
    k = torch.randint(0, 100, (batch,), generator=g)
    cond = {"object": torch.randn(batch, 7, generator=g), "start_pose": torch.randn(batch, 4, generator=g)}
    return x, k, cond


def test_transformer_shapes_and_conditioning():
    model = _denoiser()
    x, k, cond = _inputs()
    out = model(x, k, cond)
    assert out.shape == x.shape
    other = {name: value + 1.0 for name, value in cond.items()}
    assert not torch.allclose(model(x, k, other), out)  # the condition matters
    assert not torch.allclose(model(x, k + 1, cond), out)  # the step matters
    with pytest.raises(ValueError, match="cond: expected the keys"):
        model(x, k, {"object": cond["object"]})
    with pytest.raises(ValueError, match="max_len"):
        model(torch.zeros(1, 17, 5), torch.zeros(1, dtype=torch.int64), {n: v[:1] for n, v in cond.items()})


def test_transformer_drop_cond_gives_the_null_condition():
    model = _denoiser()
    with torch.no_grad():
        model.null_tokens.normal_()  # a trained null token is not zero
    x, k, cond = _inputs()
    drop = torch.tensor([True, False, True])
    out = model(x, k, cond, drop)
    other = {name: torch.randn(value.shape, generator=_gen(9)) for name, value in cond.items()}
    out_other = model(x, k, other, drop)
    # dropped samples ignore the condition values; kept samples do not
    torch.testing.assert_close(out_other[drop], out[drop])
    assert not torch.allclose(out_other[~drop], out[~drop])
    # a dropped condition's tokens are the null tokens
    tokens = model.condition_tokens(cond, drop, 3)
    torch.testing.assert_close(tokens[0], model.null_tokens)
    assert not torch.allclose(tokens[1], model.null_tokens)
    # per-sample dropping in a batch equals dropping the whole batch for that sample
    all_dropped = model(x, k, cond, torch.ones(3, dtype=torch.bool))
    torch.testing.assert_close(out[drop], all_dropped[drop], atol=1e-5, rtol=1e-5)


def test_transformer_null_condition_starts_at_zero_tokens():
    """Untrained null tokens are zero vectors (MDM's null condition): a condition whose
    projection is zero gives the same output as a dropped one."""
    model = _denoiser()
    with torch.no_grad():
        for projection in model.cond_projections.values():
            projection.bias.zero_()
    x, k, cond = _inputs()
    zeros = {name: torch.zeros_like(value) for name, value in cond.items()}
    torch.testing.assert_close(model(x, k, cond, torch.ones(3, dtype=torch.bool)), model(x, k, zeros),
                               atol=1e-5, rtol=1e-5)


def test_transformer_padding_mask_hides_padded_frames():
    model = _denoiser()
    x, k, cond = _inputs(frames=12)
    padding = torch.zeros(3, 12, dtype=torch.bool)
    padding[:, 8:] = True
    out = model(x, k, cond, padding_mask=padding)
    changed = x.clone()
    changed[:, 8:] = torch.randn(3, 4, 5, generator=_gen(5)) * 10
    out_changed = model(changed, k, cond, padding_mask=padding)
    torch.testing.assert_close(out_changed[:, :8], out[:, :8], atol=1e-5, rtol=1e-5)
    # equals running the unpadded 8-frame motion
    torch.testing.assert_close(model(x[:, :8], k, cond), out[:, :8], atol=1e-5, rtol=1e-5)
    # without the mask the padded frames do leak
    assert not torch.allclose(model(changed, k, cond)[:, :8], model(x, k, cond)[:, :8])


def test_transformer_works_with_diffusion_helpers():
    """End to end: loss, a gradient step, classifier-free sampling — on a 2-core CPU in < 1 s."""
    model = _denoiser().train()
    schedule = cosine_schedule(10)
    x0, _, cond = _inputs(batch=4, frames=6)
    loss = training_loss(model, x0, cond, schedule, generator=_gen(1))
    loss.backward()
    assert model.input_projection.weight.grad.abs().sum() > 0
    model.eval()
    out = sample(lambda x_k, k: classifier_free_x0(model, x_k, k, cond, 2.5), (4, 6, 5), schedule,
                 generator=_gen(2))
    assert out.shape == (4, 6, 5) and torch.isfinite(out).all()


# --------------------------------------------------------------------------- cVAE helpers


@given(seed=st.integers(0, 1000))
def test_gaussian_kl_properties(seed):
    g = _gen(seed)
    mu, logvar = torch.randn(4, 6, generator=g), torch.randn(4, 6, generator=g)
    kl = gaussian_kl(mu, logvar)
    assert kl.shape == (4,) and torch.all(kl >= 0)
    torch.testing.assert_close(gaussian_kl(mu, logvar, mu, logvar), torch.zeros(4))
    # against torch.distributions
    q = torch.distributions.Normal(mu, (0.5 * logvar).exp())
    p_mu, p_logvar = torch.randn(4, 6, generator=g), torch.randn(4, 6, generator=g)
    p = torch.distributions.Normal(p_mu, (0.5 * p_logvar).exp())
    expected = torch.distributions.kl_divergence(q, p).sum(-1)
    torch.testing.assert_close(gaussian_kl(mu, logvar, p_mu, p_logvar), expected, atol=1e-4, rtol=1e-4)
    standard = torch.distributions.Normal(torch.zeros(4, 6), torch.ones(4, 6))
    torch.testing.assert_close(kl, torch.distributions.kl_divergence(q, standard).sum(-1), atol=1e-4, rtol=1e-4)


def test_reparameterize_statistics_and_gradients():
    mu = torch.tensor([1.0, -2.0]).expand(20000, 2).clone().requires_grad_(True)
    logvar = torch.log(torch.tensor([0.25, 4.0])).expand(20000, 2).clone().requires_grad_(True)
    z = reparameterize(mu, logvar, _gen(3))
    assert torch.allclose(z.mean(0), torch.tensor([1.0, -2.0]), atol=0.05)
    assert torch.allclose(z.std(0), torch.tensor([0.5, 2.0]), rtol=0.03)
    z.sum().backward()
    assert torch.all(mu.grad == 1.0) and logvar.grad.abs().sum() > 0
    torch.testing.assert_close(reparameterize(mu, logvar, _gen(3)), z)
    with pytest.raises(TypeError, match="generator"):
        reparameterize(mu, logvar, None)


def test_mlp():
    torch.manual_seed(0)
    net = MLP(4, [8, 8], 3, activation="elu", dropout=0.1)
    assert net(torch.zeros(2, 5, 4)).shape == (2, 5, 3)
    assert sum(isinstance(m, torch.nn.ELU) for m in net.modules()) == 2
    assert isinstance(MLP(4, [], 3, final_activation=True, activation=torch.nn.Tanh).net[-1], torch.nn.Tanh)
    with pytest.raises(ValueError, match="activation"):
        MLP(4, [8], 3, activation="swish!")


# --------------------------------------------------------------------------- mixture of experts


def test_moe_blending_weights_equals_blending_outputs():
    torch.manual_seed(0)
    layer = MixtureOfExpertsLinear(6, 4, n_experts=5)
    g = _gen(1)
    x = torch.randn(7, 6, generator=g)
    weights = torch.softmax(torch.randn(7, 5, generator=g), dim=-1)
    expert_outputs = torch.stack([x @ layer.weight[e] + layer.bias[e] for e in range(5)], dim=1)  # (B, K, out)
    expected = (weights[..., None] * expert_outputs).sum(1)
    blended_weight, blended_bias = layer.blended_parameters(weights)  # Eq. 2: W = Σ ω_k W_k
    assert blended_weight.shape == (7, 6, 4) and blended_bias.shape == (7, 4)
    by_parameters = torch.einsum("bi,bio->bo", x, blended_weight) + blended_bias
    torch.testing.assert_close(by_parameters, expected, atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(layer(x, weights), by_parameters, atol=1e-5, rtol=1e-5)


def test_moe_one_hot_gating_reduces_to_one_expert():
    torch.manual_seed(0)
    layer = MixtureOfExpertsLinear(3, 2, n_experts=4)
    x = torch.randn(4, 3, generator=_gen())
    one_hot = torch.eye(4)
    out = layer(x, one_hot)
    for e in range(4):
        torch.testing.assert_close(out[e], x[e] @ layer.weight[e] + layer.bias[e])
    with pytest.raises(ValueError, match="weights"):
        layer(x, torch.ones(4, 3))


def test_gating_and_moe_mlp():
    torch.manual_seed(0)
    gating = GatingNetwork(5, 16, 3)
    w = gating(torch.randn(10, 5, generator=_gen()))
    assert [m.out_features for m in GatingNetwork(5, (12, 8), 3).net if isinstance(m, torch.nn.Linear)] == [12, 8, 3]
    assert w.shape == (10, 3) and torch.all(w >= 0)
    torch.testing.assert_close(w.sum(-1), torch.ones(10))
    net = MoEMLP(in_dim=6, hidden=16, out_dim=4, n_experts=3, gating_in=5, extra_dim=2)
    x, gate_in, z = torch.randn(10, 6), torch.randn(10, 5), torch.randn(10, 2)
    out, weights = net(x, gate_in, z, return_weights=True)
    assert out.shape == (10, 4) and weights.shape == (10, 3)
    assert not torch.allclose(net(x, gate_in, z + 1), out)  # the extra input reaches the layers
    with pytest.raises(ValueError, match="extra"):
        net(x, gate_in)
    # A gating input of the wrong width or batch is named as the caller passed it (not the gating net's "x").
    for wrong in (torch.randn(10, 4), torch.randn(9, 5)):
        with pytest.raises(ValueError, match="gating_input"):
            net(x, wrong, z)
    out.sum().backward()
    assert all(p.grad is not None for p in net.parameters())
