"""CHOICE's environment features and goal matching (§6.1): the fast-marching field around a goal, the 3D-CNN
autoencoder against the mean-grid baseline, the KD-tree matching against brute force, keyframes carried into
a scene, errors."""
import numpy as np
import pytest
import torch

from hoi_tutorial.choice.pick_and_place import environment, goal_library
from hoi_tutorial.choice.planner import fields
from hoi_tutorial.choice.planner.interactions import condition_vector
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.scenes import make_kitchen


@pytest.fixture(scope="module")
def tiny(module_cache, one_cpu_thread):
    """An autoencoder trained briefly on two kitchens' goals, and a library of four clips of each kind."""
    config = environment.environment_config("toy", n_kitchens=2, channels=(4, 8, 16), steps=150)
    trained = environment.trained_environment_autoencoder(config)
    rows = goal_library.goal_keyframes(config, goal_library.library_config("toy", n_clips=4))
    return config, trained, rows, goal_library.build_goal_library(trained.model, rows)


def test_the_field_is_the_truncated_distance_to_the_environment():
    config = environment.EnvironmentConfig()
    box = make_object("box", 0).placed(1.0, 1.0, 0.3)
    grid = fields.object_grid(box, config.field, centre=box.to_world(np.array([0.0, 0.0, 0.0])) + [0, 0.3, 0.2])
    field = environment.environment_field(grid, [box], config)
    assert field.shape == grid.shape and field.dtype == np.float32
    sdf = box.sdf(grid.points().reshape(-1, 3)).reshape(grid.shape)
    assert (sdf < 0).any() and (sdf > 0).any()
    expected = np.minimum(np.maximum(sdf, 0.0), config.truncation) / config.truncation
    assert np.all(field[sdf < 0] == 0.0) and field.max() <= 1.0
    # fast marching on the grid against the exact distance: within a cell everywhere outside
    assert np.max(np.abs(field - expected)[sdf > 0]) * config.truncation < config.field.spacing


def test_kitchen_goals_and_the_training_grids(tiny, module_cache):
    config, trained, *_ = tiny
    kitchen = make_kitchen(np.random.default_rng([config.seed, 0]))
    goals = environment.kitchen_goals(kitchen, config)
    assert [g.kind for g in goals] == ["item"] * len(kitchen.items) + ["door", "drawer"]
    for goal in goals:
        assert goal.grid.n == config.cells and goal.grid.contains(goal.contact)
        assert all(thing is not goal.obj for thing in goal.environment) or goal.kind != "item"
    grids = environment.training_grids(config)
    assert grids.shape == (config.n_kitchens * len(goals), config.cells, config.cells, config.cells)
    assert torch.equal(grids[0], torch.as_tensor(goals[0].field(config)))
    assert trained.details["n_grids"] == len(grids)


def test_the_autoencoder_beats_the_mean_grid(tiny):
    config, trained, *_ = tiny
    model = trained.model
    grids = environment.training_grids(config)
    z = model.encode(grids[:3])
    assert z.shape == (3, 16) and model.decode(z).shape == (3, config.cells, config.cells, config.cells)
    errors = environment.reconstruction_errors(model, grids)
    baseline = (grids - grids.mean(dim=0)).pow(2).mean().item()  # the mean training grid, for every grid
    assert errors.mean() == pytest.approx(trained.details["reconstruction"], rel=1e-5)
    assert trained.details["mean_grid"] == pytest.approx(baseline, rel=1e-5)
    assert errors.mean() < 0.5 * baseline
    assert float(trained.losses[-10:].mean()) < float(trained.losses[:10].mean())


def test_training_is_deterministic_for_a_seed(tiny):
    config, *_ = tiny
    grids = environment.training_grids(config)[:4]
    short = environment.environment_config("toy", n_kitchens=2, channels=(4, 8, 16), steps=5, batch_size=2)
    a, _ = environment.train_environment_autoencoder(grids, short)
    b, _ = environment.train_environment_autoencoder(grids, short)
    assert all(torch.equal(p, q) for p, q in zip(a.state_dict().values(), b.state_dict().values()))


def _brute_force(library, latent, condition, kind, k):
    same = [i for i in range(len(library)) if library.kinds[i] == kind
            and np.array_equal(library.conditions[i, 1:], condition[1:])]
    features = library.features(library.latents[same], library.conditions[same, 0])
    distances = np.linalg.norm(features - library.features(latent, condition[0]), axis=1)
    order = np.argsort(distances, kind="stable")[:k]
    return distances[order], np.asarray(same)[order]


def test_kd_tree_matching_equals_brute_force(tiny):
    *_, rows, library = tiny
    assert len(library) == len(rows) == 4 * 4  # per clip: a grasp, the same as a place, a door, a drawer
    rng = np.random.default_rng(0)
    for i in range(len(library)):
        for _ in range(3):
            latent = library.latents[i] + rng.normal(0.0, library.scales[0], library.latents.shape[1])
            condition = library.conditions[i].copy()
            condition[0] += rng.normal(0.0, 0.1)
            for k in (1, 2, 5):
                distances, indices = library.query(latent, condition, library.kinds[i], k)
                expected_d, expected_i = _brute_force(library, latent, condition, library.kinds[i], k)
                np.testing.assert_allclose(distances, expected_d, rtol=1e-9)
                assert np.array_equal(np.sort(indices), np.sort(expected_i))
    # a stored keyframe is its own nearest neighbour
    d, idx = library.query(library.latents[3], library.conditions[3], library.kinds[3], 1)
    assert idx[0] == 3 and d[0] == pytest.approx(0.0, abs=1e-12)


def test_matches_are_carried_onto_the_goal(tiny):
    config, trained, _, library = tiny
    kitchen = make_kitchen(7)
    for goal in (environment.item_goal(kitchen, 0, config), environment.handle_goal(kitchen, "door", config)):
        for hand in environment.HANDS:
            matches = goal_library.match_goal(library, trained.model, goal, hand, 2, config)
            assert len(matches) == 2 and matches[0].distance <= matches[1].distance
            for m in matches:
                assert library.kinds[m.index] == goal.kind and library.conditions[m.index, 1] == environment.HANDS.index(hand)
                np.testing.assert_allclose(m.contact.hand(hand), goal.contact, atol=1e-9)
                R = m.contact.rotations
                np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-9)


def test_key_poses_move_rigidly():
    pose = environment.KeyPose.standing((1.0, 2.0), 0.3)
    assert pose.pelvis[:2] == pytest.approx([1.0, 2.0])
    frame = np.eye(4)
    frame[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    frame[:3, 3] = [0.5, -0.2, 0.1]
    moved = pose.transformed(frame).transformed(np.linalg.inv(frame))
    np.testing.assert_allclose(moved.positions, pose.positions, atol=1e-12)
    np.testing.assert_allclose(moved.rotations, pose.rotations, atol=1e-12)
    other = pose.translated([0.0, 0.0, 1.0])
    assert np.array_equal(pose.with_joint(2, other).positions[2], other.positions[2])
    assert np.array_equal(pose.with_joint(2, other).positions[:2], pose.positions[:2])


def test_errors_name_what_was_expected(tiny):
    config, trained, _, library = tiny
    kitchen = make_kitchen(7)
    with pytest.raises(ValueError, match="inside the scene"):
        environment.item_goal(kitchen, 0, config, contact=[-1.0, 2.0, 0.8])
    with pytest.raises(ValueError, match="index: expected an item index"):
        environment.item_goal(kitchen, len(kitchen.items), config)
    with pytest.raises(ValueError, match="kind"):
        environment.handle_goal(kitchen, "window", config)
    with pytest.raises(ValueError, match="no goal keyframe"):  # the library has no door to place
        library.query(library.latents[0], condition_vector(0.8, "left", "place", "approach"), "door", 1)
    with pytest.raises(ValueError, match="k: expected a positive int"):
        library.query(library.latents[0], library.conditions[0], library.kinds[0], 0)
    with pytest.raises(ValueError, match="divisible by 8"):
        environment.environment_config("toy", field=fields.field_config("toy", spacing=0.8 / 12))
    with pytest.raises(ValueError, match="three positive ints"):
        environment.environment_config("toy", channels=(4, 8))


def test_room_sdf_with_and_without_the_floor():
    points = np.array([[1.0, 2.0, 0.5], [0.2, 2.0, 1.5], [1.0, 2.0, -0.1], [5.5, 1.0, 1.0]])
    np.testing.assert_allclose(environment.room_sdf((4.0, 3.0))(points), [0.5, 0.2, -0.1, -1.5])
    np.testing.assert_allclose(environment.room_sdf((4.0, 3.0), floor=False)(points), [1.0, 0.2, 1.0, -1.5])
