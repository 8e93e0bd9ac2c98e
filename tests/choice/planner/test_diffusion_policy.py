"""The diffusion-policy baseline of Table 3 (Chi et al. 2023 on ``nn.diffusion``): its scene code, its
training pairs, its closed-loop rollout, errors."""
import numpy as np
import pytest

from hoi_tutorial.choice.planner import baselines, fields, interactions


def test_scene_code_min_pools_clips_and_scales():
    rng = np.random.default_rng(0)
    obstacle, target = rng.uniform(-0.5, 0.5, (8, 8, 8)), rng.uniform(-0.5, 0.5, (8, 8, 8))
    code = baselines.scene_code(obstacle, target, 2, 0.3)
    assert code.shape == (16,) and code.dtype == np.float32
    # brute force: the minimum of each 4x4x4 block, clipped to +-0.3 m, divided by 0.3
    for part, sdf in ((code[:8], obstacle), (code[8:], target)):
        blocks = [sdf[i:i + 4, j:j + 4, k:k + 4].min() for i in (0, 4) for j in (0, 4) for k in (0, 4)]
        np.testing.assert_allclose(part, np.clip(blocks, -0.3, 0.3) / 0.3, rtol=1e-6)
    with pytest.raises(ValueError, match="pool: expected a divisor"):
        baselines.scene_code(obstacle, target, 3, 0.3)
    with pytest.raises(ValueError, match="target_sdf"):
        baselines.scene_code(obstacle, target[:4], 2, 0.3)


def test_training_chunks_are_the_next_positions_padded_with_the_last():
    path = np.cumsum(np.ones((5, 3)), axis=0)
    starts, chunks = baselines._action_windows(path, 4)
    assert chunks.shape == (5, 4, 3)
    np.testing.assert_allclose(chunks[0], path[1:5] - path[0])
    np.testing.assert_allclose(chunks[3], np.stack([path[4]] * 4) - path[3])  # after the end: the last frame
    np.testing.assert_allclose(chunks[4], 0.0)  # at the contact the policy learns to stay


@pytest.fixture(scope="module")
def tiny(module_cache):
    dcfg = interactions.planner_data_config("toy", n_clips=2, n_test_clips=1)
    train = interactions.interaction_set(dcfg, "train")
    cfg = baselines.diffusion_policy_config("toy", steps=400, width=64, diffusion_steps=10, max_frames=60)
    model, result = baselines.train_diffusion_policy(train, cfg)
    return dcfg, train, cfg, model, result


def test_training_pairs_cover_every_frame(tiny):
    dcfg, train, cfg, model, result = tiny
    obs, chunks = baselines.policy_training_data(train, cfg)
    assert len(obs) == len(chunks) == sum(len(i.wrist) for i in train.interactions)
    assert obs.shape[1] == 10 + 2 * cfg.pool ** 3 and chunks.shape[1:] == (cfg.horizon, 3)
    assert model.denoiser.cond_dim == obs.shape[1]
    losses = np.asarray(result.losses)
    assert losses[-50:].mean() < 0.7 * losses[:50].mean()  # measured: 0.25 against 0.43


def _scene(inter):
    return fields.scene_fields(inter.grid, inter.target_object(), inter.obstacle_objects(), None)


def test_rollout_heads_for_the_goal_from_a_training_start(tiny):
    dcfg, train, cfg, model, _ = tiny
    inters = [i for i in train.interactions if i.condition[2] == 0]
    scenes = [_scene(i) for i in inters]
    starts = np.stack([i.wrist[0] for i in inters])
    goals = np.stack([i.wrist[-1] for i in inters])
    paths = baselines.diffusion_policy_rollout(model, scenes, starts, goals, [i.condition for i in inters], seed=0)
    for path, start, goal in zip(paths, starts, goals):
        np.testing.assert_allclose(path[0], start)
        assert 1 < len(path) <= cfg.max_frames
        # nearer the goal than it started (the baseline: staying put)
        assert np.linalg.norm(path - goal, axis=1).min() < 0.5 * np.linalg.norm(start - goal)
    again = baselines.diffusion_policy_rollout(model, scenes, starts, goals, [i.condition for i in inters], seed=0)
    assert all(np.array_equal(a, b) for a, b in zip(paths, again))


def test_rollout_rejects_mismatched_inputs(tiny):
    dcfg, train, cfg, model, _ = tiny
    inter = train.interactions[0]
    with pytest.raises(ValueError, match="starts"):
        baselines.diffusion_policy_rollout(model, [_scene(inter)], np.zeros((2, 3)), np.zeros((1, 3)), [inter.condition])
    with pytest.raises(ValueError, match="conditions"):
        baselines.diffusion_policy_rollout(model, [_scene(inter)], np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="action_steps"):
        baselines.diffusion_policy_config("toy", horizon=4, action_steps=8)
