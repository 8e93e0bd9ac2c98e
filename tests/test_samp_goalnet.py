"""SAMP's GoalNet: goal data in the object's frame, the cVAE's shapes and loss, sampling, clear errors."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from hoi_tutorial.samp import core, goalnet
from hoi_tutorial.world.objects import make_object


def _tiny_data_config(**overrides):
    values = {"instances": (("chair", 2), ("armchair", 2), ("sofa", 2)), "scalings": 3, "test_instances": 2}
    values.update(overrides)
    return goalnet.goal_data_config("toy", **values)


def test_object_goals_do_not_move_with_the_object():
    obj = make_object("sofa", seed=3)
    voxels, positions, directions = goalnet.object_goals(obj)
    moved = obj.placed(1.7, -0.4, 2.1)
    voxels2, positions2, directions2 = goalnet.object_goals(moved)
    assert voxels.shape == (core.VOXEL_SIZE,) and positions.shape == (len(obj.sit_goals[0]), 3)
    np.testing.assert_allclose(voxels, voxels2, atol=1e-5)
    np.testing.assert_allclose(positions, positions2, atol=1e-5)
    np.testing.assert_allclose(directions, directions2, atol=1e-6)
    # and back in the world they are the object's own goals
    centre = moved.centre_frame
    np.testing.assert_allclose(positions2 @ centre[:3, :3].T + centre[:3, 3], moved.sit_goals[0], atol=1e-5)


def test_goal_data_rows_and_split(tmp_cache):
    config = _tiny_data_config()
    train = goalnet.goal_data(config, "train")
    test = goalnet.goal_data(config, "test")
    assert train.n_objects == 6 * 3 and test.n_objects == 6
    assert train.voxels.shape == (len(train), core.VOXEL_SIZE) and train.goals.shape == (len(train), 6)
    # every object gives at least one goal row; directions are unit
    assert set(train.object_index.tolist()) == set(range(train.n_objects))
    np.testing.assert_allclose(train.goals[:, 3:].norm(dim=1), 1.0, atol=1e-5)
    # the test objects are other instances than the training ones
    assert not any(torch.equal(v, w) for v in test.object_voxels for w in train.object_voxels)
    with pytest.raises(ValueError, match="split"):
        goalnet.goal_data(config, "validation")


def test_goal_data_config_checks():
    with pytest.raises(ValueError, match="category"):
        goalnet.goal_data_config("toy", instances=(("bottle", 2),))
    with pytest.raises(ValueError, match="scale_range"):
        goalnet.goal_data_config("toy", scale_range=(1.2, 0.8))
    assert hash(goalnet.goal_data_config()) == hash(goalnet.goal_data_config())


def test_goalnet_shapes_standardisation_and_errors():
    torch.manual_seed(0)
    goals = torch.randn(32, 6) * torch.tensor([0.5, 0.3, 0.1, 1.0, 1.0, 0.01]) + 2.0
    voxels = torch.rand(32, core.VOXEL_SIZE)
    model = core.GoalNetCVAE(goal_mean=goals.mean(0), goal_std=goals.std(0), voxel_mean=voxels.mean(0),
                             voxel_std=voxels.std(0))
    mu, logvar = model.posterior(goals, voxels)
    assert mu.shape == logvar.shape == (32, 3)
    out, target, _, _ = model(goals, voxels, torch.Generator().manual_seed(0))
    assert out.shape == target.shape == (32, 6)
    # the target is standardised: zero mean, unit spread per coordinate
    np.testing.assert_allclose(target.mean(0).detach(), 0.0, atol=1e-5)
    np.testing.assert_allclose(target.std(0).detach(), 1.0, atol=1e-5)
    # decode maps back to metres: the standardised output, un-standardised
    z = torch.zeros(4, 3)
    np.testing.assert_allclose(model.decode(z, voxels[:4]).detach(),
                               (model.decode_standardised(z, voxels[:4]) * goals.std(0) + goals.mean(0)).detach(),
                               rtol=1e-5, atol=1e-5)
    with pytest.raises(ValueError, match="voxels"):
        model.posterior(goals, torch.rand(32, 512))
    with pytest.raises(ValueError, match="goals"):
        model.posterior(torch.rand(32, 5), voxels)


def test_training_lowers_the_loss_and_sampling_lands_in_the_world(tmp_cache):
    data_config = _tiny_data_config()
    config = goalnet.goalnet_config("toy", steps=150, interaction_hidden=(64, 64), interaction_out=16)
    trained = goalnet.trained_goalnet(data_config, config)
    losses = trained.losses.numpy()
    assert losses[-20:].mean() < losses[:20].mean()
    assert trained.details["n_objects"] == 18
    obj = make_object("chair", seed=11).placed(3.0, 2.0, 0.7)
    positions, directions = goalnet.sample_goals(trained.model, obj, 5, generator=torch.Generator().manual_seed(0))
    assert positions.shape == directions.shape == (5, 3)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-6)
    # the same latent draws give the same goals in the object's frame wherever the object stands
    here, _ = goalnet.sample_goals(trained.model, obj, 5, generator=torch.Generator().manual_seed(0), frame="centre")
    there, _ = goalnet.sample_goals(trained.model, obj.placed(-1.0, 0.5, -2.0), 5,
                                    generator=torch.Generator().manual_seed(0), frame="centre")
    np.testing.assert_allclose(here, there, atol=1e-5)
    with pytest.raises(ValueError, match="positive int"):
        goalnet.sample_goals(trained.model, obj, 0, generator=torch.Generator())
    with pytest.raises(ValueError, match="frame"):
        goalnet.sample_goals(trained.model, obj, 2, generator=torch.Generator(), frame="room")
    evaluation = goalnet.evaluate_goalnet(trained.model, goalnet.goal_data(data_config, "test"), n_generated=4)
    assert evaluation.n_test_objects == 6 and evaluation.position_error >= 0
    assert set(evaluation.apd_by_category) == {"chair", "armchair", "sofa"}
    # the per-case arrays behind the means: per goal, per object (a category's mean is its entry)
    assert evaluation.position_errors.shape == (evaluation.n_test_goals,)
    assert evaluation.position_errors.mean() == pytest.approx(evaluation.position_error, rel=1e-5)
    categories = np.asarray(goalnet.goal_data(data_config, "test").categories)
    for category, apd in evaluation.apd_by_category.items():
        assert evaluation.apd_pos_by_object[categories == category].mean() == pytest.approx(apd["apd_pos"], rel=1e-9)
    with pytest.raises(ValueError, match="n_generated"):
        goalnet.evaluate_goalnet(trained.model, goalnet.goal_data(data_config, "test"), n_generated=1)


def test_configs_are_frozen():
    config = goalnet.goalnet_config()
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.steps = 3
    with pytest.raises(TypeError, match="unknown"):
        goalnet.goalnet_config("toy", stepz=3)
