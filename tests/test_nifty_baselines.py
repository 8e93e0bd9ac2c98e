"""NIFTY's Cond. VAE baseline (§4.3): a conditional motion VAE on the same data and conditions."""
import math

import pytest
import torch

from hoi_tutorial.nifty import baselines
from hoi_tutorial.nifty.data import SyntheticDataset, synthetic_data_config
from hoi_tutorial.nifty.motion_model import InteractionTensors
from hoi_tutorial.nifty.rollout import InteractionSequence
from hoi_tutorial.world.features import NIFTY_STATE_SIZE
from hoi_tutorial.world.mocap import generate_clip
from hoi_tutorial.world.objects import make_object

FRAMES = 31


@pytest.fixture(scope="module")
def sit_records():
    records = []
    for seed, (x, y, yaw) in enumerate([(0.5, -1.0, 0.3), (-1.0, 2.0, 2.0), (2.0, 0.5, -1.0)]):
        obj = make_object("chair", seed=seed).placed(x, y, yaw)
        clip = generate_clip("sit", seed=seed, obj=obj)
        a = int(clip.meta["anchor_frame"])
        records.append(InteractionSequence(clip.slice(a - FRAMES + 1, a + 1), obj, None))
    return records


def _tiny(**overrides):
    values = dict(max_frames=FRAMES, width=32, layers=1, heads=4, latent=8, n_points=64, pointnet_hidden=(32,),
                  steps=60, batch_size=3, lr=3e-3, warmup_steps=0)
    values.update(overrides)
    return baselines.cond_vae_config("sit", "toy", **values)


def test_training_lowers_the_loss_and_samples_have_the_motion_models_shape(sit_records):
    config = _tiny()
    tensors = InteractionTensors.from_sequences(sit_records, FRAMES, config.n_points, seed=0)
    model, result = baselines.train_cond_vae(tensors, config)
    assert len(result.losses) == 60 and all(math.isfinite(v) for v in result.losses)
    assert sum(result.losses[-10:]) < sum(result.losses[:10])
    assert set(result.extra) == {"reconstruction", "kl"} and len(result.extra["kl"]) == 60
    states = baselines.sample_cond_vae(model, tensors.condition(), generator=torch.Generator().manual_seed(0))
    again = baselines.sample_cond_vae(model, tensors.condition(), generator=torch.Generator().manual_seed(0))
    other = baselines.sample_cond_vae(model, tensors.condition(), generator=torch.Generator().manual_seed(1))
    assert states.shape == (3, FRAMES, NIFTY_STATE_SIZE)
    assert torch.equal(states, again) and not torch.equal(states, other)
    # The posterior mean reconstructs the training motions better than a motion drawn for another condition.
    with torch.no_grad():
        encoded = model.encode_condition(tensors.condition())
        mu, _ = model.posterior(model.normalise(tensors.states), encoded)
        recon = model.denormalise(model.decode(mu, encoded))
    error = (recon - tensors.states).pow(2).mean()
    shuffled = (recon[[1, 2, 0]] - tensors.states).pow(2).mean()
    assert error < shuffled


def test_trained_model_is_cached(sit_records, tmp_cache):
    dataset = SyntheticDataset(config=synthetic_data_config("sit", "toy"), anchors=[], sequences=sit_records,
                               leaves=[], all_paths=[], tree_stats=[], stats={})
    trained = baselines.trained_cond_vae(dataset, _tiny(steps=3))
    again = baselines.trained_cond_vae(dataset, _tiny(steps=3))
    assert len(list(tmp_cache.glob("nifty_sit_cond_vae-*.pt"))) == 1
    assert trained.details["n_sequences"] == 3 and len(trained.losses) == 3
    for name, value in trained.model.state_dict().items():
        assert torch.equal(value, again.model.state_dict()[name])
    with pytest.raises(ValueError, match="action"):
        baselines.trained_cond_vae(dataset, baselines.cond_vae_config("lift", "toy"))


def test_bad_inputs_name_what_was_expected(sit_records):
    with pytest.raises(ValueError, match="action"):
        baselines.cond_vae_config("dance")
    with pytest.raises(ValueError, match="kl_weight"):
        baselines.cond_vae_config("sit", kl_weight=-1.0)
    with pytest.raises(TypeError, match="unknown field"):
        baselines.cond_vae_config("sit", latnet=4)
    tensors = InteractionTensors.from_sequences(sit_records, FRAMES, 64, seed=0)
    with pytest.raises(ValueError, match="max_frames"):
        baselines.train_cond_vae(tensors, _tiny(max_frames=FRAMES + 1))
    model = baselines.build_cond_vae(_tiny())
    with pytest.raises(ValueError, match="cond"):
        baselines.sample_cond_vae(model, {"points": tensors.points}, generator=torch.Generator())
    with pytest.raises(TypeError, match="CondMotionVAE"):
        baselines.sample_cond_vae(torch.nn.Linear(2, 2), tensors.condition(), generator=torch.Generator())
