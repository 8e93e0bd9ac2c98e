"""Toy walking trajectories for the guidance chapter: the data set in the canonical frame, the
smooth-basis codec, the last-frame goal objective, path statistics and the model's plumbing."""
import math

import pytest
import torch

from hoi_tutorial.nifty import trajectories as tj
from hoi_tutorial.world.mocap.gait import walk_path


@pytest.fixture(autouse=True, scope="module")
def _one_cpu_thread(one_cpu_thread):
    """Tiny models run fastest on one thread (the shared fixture in conftest)."""


@pytest.fixture(scope="module")
def small_walks():
    return tj.make_walk_trajectories(tj.walk_data_config("toy", n_clips=3, frames=40, seed=5))


def test_walks_start_at_the_origin_facing_plus_y(small_walks):
    assert small_walks.shape == (6, 40, 3) and small_walks.dtype == torch.float32
    torch.testing.assert_close(small_walks[:, 0, :2], torch.zeros(6, 2), atol=1e-5, rtol=1e-5)
    assert ((small_walks[:, 0, 2] > 0.7) & (small_walks[:, 0, 2] < 1.2)).all()  # a standing pelvis height
    # Facing +Y: after a second and a bit the walker is ahead, not beside.
    ahead = small_walks[:, 35, :2]
    assert (ahead[:, 1] > 0.3).all() and (ahead[:, 1] > ahead[:, 0].abs()).all()


def test_second_half_is_the_mirror_image(small_walks):
    torch.testing.assert_close(small_walks[3:], small_walks[:3] * torch.tensor([-1.0, 1.0, 1.0]))


def test_data_are_deterministic_for_a_seed(small_walks):
    again = tj.make_walk_trajectories(tj.walk_data_config("toy", n_clips=3, frames=40, seed=5))
    assert torch.equal(small_walks, again)
    other = tj.make_walk_trajectories(tj.walk_data_config("toy", n_clips=3, frames=40, seed=6))
    assert not torch.equal(small_walks, other)


def test_canonical_trajectory_undoes_a_rotation_and_pads():
    motion = walk_path([[2.0, 1.0], [1.0, 1.0], [0.0, 2.0]], seed=0)  # starts facing −X
    path = tj.canonical_pelvis_trajectory(motion, len(motion) + 10)
    assert path.shape == (len(motion) + 10, 3)
    torch.testing.assert_close(path[0, :2], torch.zeros(2), atol=1e-5, rtol=1e-5)
    assert path[20, 1] > 0.05 and abs(path[20, 0]) < 0.5 * path[20, 1]
    assert torch.equal(path[-1], path[len(motion) - 1])  # padded with the last frame


def test_waypoints_begin_at_the_origin_straight_ahead():
    config = tj.walk_data_config("toy")
    generator = __import__("numpy").random.default_rng(0)
    waypoints = tj.random_walk_waypoints(generator, config)
    assert waypoints.shape == (3, 2)
    assert waypoints[0].tolist() == [0.0, 0.0] and waypoints[1][0] == 0.0
    assert config.first_leg[0] <= waypoints[1][1] <= config.first_leg[1]


# --------------------------------------------------------------------------- codec


def test_dct_basis_is_orthonormal_and_full_basis_round_trips():
    basis = tj.dct_basis(30, 30)
    torch.testing.assert_close(basis.T @ basis, torch.eye(30), atol=1e-5, rtol=1e-5)
    paths = torch.randn(5, 30, 3)
    codec = tj.TrajectoryCodec.fit(paths, 30)
    torch.testing.assert_close(codec.decode(codec.encode(paths)), paths, atol=1e-4, rtol=1e-5)
    with pytest.raises(ValueError, match="n_coefficients"):
        tj.dct_basis(10, 11)


def test_truncated_codec_keeps_smooth_walks_to_millimetres(small_walks):
    codec = tj.TrajectoryCodec.fit(small_walks, 16)
    assert codec.shape == (16, 3) and codec.frames == 40
    error = (codec.decode(codec.encode(small_walks)) - small_walks).abs()
    assert error.max().item() < 0.02
    code = codec.encode(small_walks)
    torch.testing.assert_close(code.mean(dim=0), torch.zeros(16, 3), atol=1e-4, rtol=1e-5)


# --------------------------------------------------------------------------- objective and statistics


def test_end_position_objective_value_and_gradient():
    G = tj.end_position_objective([1.0, 2.0])
    paths = torch.zeros(2, 5, 3)
    paths[0, -1] = torch.tensor([1.0, 2.0, 0.9])
    paths[1, -1] = torch.tensor([4.0, -2.0, 0.9])
    paths.requires_grad_(True)
    values = G(paths)
    torch.testing.assert_close(values.detach(), torch.tensor([0.0, 25.0]))
    (grad,) = torch.autograd.grad(values.sum(), paths)
    assert torch.equal(grad[:, :-1], torch.zeros(2, 4, 3))  # only the last frame matters
    torch.testing.assert_close(grad[1, -1], torch.tensor([6.0, -8.0, 0.0]))
    per_path = tj.end_position_objective(torch.tensor([[1.0, 2.0], [4.0, -2.0]]))
    torch.testing.assert_close(per_path(paths).detach(), torch.zeros(2))
    with pytest.raises(ValueError, match="target_xy"):
        tj.end_position_objective([1.0, 2.0, 3.0])


def test_path_statistics_of_a_straight_constant_speed_walk():
    t = torch.arange(31, dtype=torch.float32) / 30.0
    path = torch.stack([0.0 * t, 1.2 * t, 0.95 + 0.0 * t], dim=1)[None]
    stats = tj.path_statistics(path)
    assert stats["mean_speed"].item() == pytest.approx(1.2, rel=1e-4)
    assert stats["max_speed"].item() == pytest.approx(1.2, rel=1e-4)
    assert stats["mean_acceleration"].item() == pytest.approx(0.0, abs=1e-3)
    assert stats["path_length"].item() == pytest.approx(1.2, rel=1e-4)
    assert stats["end_distance"].item() == pytest.approx(1.2, rel=1e-4)
    assert stats["height_range"].item() == pytest.approx(0.0, abs=1e-6)


# --------------------------------------------------------------------------- model plumbing


def test_training_and_sampling_plumbing(small_walks):
    config = tj.trajectory_model_config("toy", steps=20, width=32, depth=1, batch_size=8, n_coefficients=8,
                                        diffusion_steps=10)
    model, codec, result = tj.train_trajectory_denoiser(config, small_walks)
    assert len(result.losses) == 20 and all(math.isfinite(v) for v in result.losses)
    assert not model.training
    schedule = config.noise_schedule()
    walks = tj.sample_walks(model, codec, schedule, 4, generator=torch.Generator().manual_seed(0))
    assert walks.shape == (4, 40, 3)
    # α = 0 leaves the samples unchanged; α > 0 moves them (the gradient reaches x_k).
    goal = tj.end_position_objective([0.5, 1.0])
    same = tj.sample_walks(model, codec, schedule, 4, generator=torch.Generator().manual_seed(0),
                           objective=goal, alpha=0.0)
    moved = tj.sample_walks(model, codec, schedule, 4, generator=torch.Generator().manual_seed(0),
                            objective=goal, alpha=1.0)
    torch.testing.assert_close(same, walks)
    assert not torch.allclose(moved, walks)
