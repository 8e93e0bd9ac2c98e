"""The goal-driven controller (CHOICE §5.1, Table 4's goal-phase variants) at a tiny scale."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from hoi_tutorial.choice.controller import features, kalman, network, runtime
from hoi_tutorial.world import mocap
from hoi_tutorial.world.rotations import rotation_about_z

pytestmark = pytest.mark.usefixtures("one_cpu_thread", "module_cache")

TINY = dict(clips=4, steps=300, unroll=3, unroll_steps=60, hidden=48, gating_hidden=16, phase_steps=30)


@pytest.fixture(scope="module")
def trained():
    return network.trained_controller(network.controller_config("toy", **TINY))


@pytest.fixture(scope="module")
def clips():
    return mocap.generate_dataset(TINY["clips"], seed=0, kinds=("reach_grasp",))[:2]


@pytest.fixture(scope="module")
def start(trained, clips):
    return runtime.initial_state(trained.model, clips, 0), runtime.clip_goal(trained.model, clips)


def test_window_constants_follow_the_paper():
    assert features.WINDOW == 13
    assert int(features.WINDOW_OFFSETS[-1] - features.WINDOW_OFFSETS[0]) / 30.0 == pytest.approx(2.0)
    assert int(features.FUTURE_OFFSETS[-1]) / 30.0 == pytest.approx(1.0)


def test_phase_features_round_trip():
    state = torch.tensor([[[0.3, 0.5, 2.0], [0.9, 0.1, 1.0]]])
    goal_features = features.goal_phase_features(state)
    assert goal_features.shape == (1, 6)
    assert torch.allclose(goal_features[0, :2], 0.5 * torch.tensor([np.sin(0.6 * np.pi), np.cos(0.6 * np.pi)]).float())
    assert torch.allclose(features.phase_state(goal_features), state, atol=1e-5)


def test_output_shapes(trained, start):
    model = trained.model
    state, goal = start
    B, C = 2, model.channels
    assert model(torch.zeros(B, model.in_size)).shape == (B, model.out_size)
    nxt, out = runtime.controller_step(model, state, goal, torch.zeros(B, 3 * C))
    assert nxt.pose.shape == state.pose.shape and nxt.history.shape == state.history.shape
    assert nxt.future.shape == state.future.shape and nxt.phase.shape == state.phase.shape
    for name in ("ego", "goal_centric", "blended"):
        assert out[name].shape == (B, 7, 4, 9)
    assert out["goal"].shape == (B, 13, 4, 9) and out["goal_phase_state"].shape == (B, C, 3)
    assert out["deviation"].shape == (B,) and bool((out["deviation"] >= 0).all())
    assert out["wrist"].shape == (B, 2, 3) and bool(((out["blend"] >= 0) & (out["blend"] <= 1)).all())


def test_eq14_goal_centric_targets_map_back_to_the_egocentric_ones(trained, clips):
    x, y, _ = features.clip_features(clips[0], trained.model.phase_model)
    layout = trained.model.y_layout
    ego = y[:, layout["ego"]].reshape(-1, 7, 4, 9).double()
    inv_p, inv_r = features.decode_transform(y[:, layout["inv"]].reshape(-1, 7, 4, 9).double())
    goal = x[:, trained.model.x_layout["goal"]].reshape(-1, 13, 4, 9).double()[:, 6]
    g_p, g_r = features.decode_transform(goal)
    mapped = features.encode_transform(torch.einsum("nkij,nskj->nski", g_r, inv_p) + g_p[:, None], g_r[:, None] @ inv_r)
    assert torch.allclose(mapped, ego, atol=1e-4)
    deviation = runtime._deviation(*features.decode_transform(ego), *features.decode_transform(mapped),
                                   kalman.PhaseFilterConfig())
    assert np.allclose(deviation, 0.0, atol=1e-3)


def test_training_lowers_the_loss(trained):
    losses = trained.losses
    assert float(losses[-30:].mean()) < 0.5 * float(losses[:30].mean())
    assert trained.details["n_frames"] > 0


def test_deterministic_for_a_seed(tmp_cache, trained):
    config = network.controller_config("toy", **{**TINY, "steps": 20, "unroll_steps": 5})
    pae = trained.model.phase_model
    data = network.controller_data(config, pae)
    a, _ = network.train_controller(data, config, pae)
    b, _ = network.train_controller(data, config, pae)
    for (name, p), q in zip(a.state_dict().items(), b.state_dict().values()):
        assert torch.equal(p, q), name
    c, _ = network.train_controller(data, dataclasses.replace(config, seed=1), pae)
    assert not torch.equal(a.net.layers[0].weight, c.net.layers[0].weight)


def test_rollout_moves_the_wrist_toward_the_goal(trained, start, clips):
    state, goal = start
    frames = min(c.meta["anchor_frame"] for c in clips)
    hand = goal.hand
    target = goal.positions[torch.arange(2), 6, 2 + hand]
    wrists = state.pose[:, :66].reshape(2, 22, 3)[torch.arange(2), torch.tensor(features.WRIST_JOINTS)[hand]]
    still = torch.einsum("bij,bj->bi", rotation_about_z(state.heading), wrists) + state.origin  # standing still
    result = runtime.rollout(trained.model, state, goal, frames, "matched")
    final = (result.wrist[-1, torch.arange(2), hand] - target).norm(dim=-1)
    assert bool((final < (still - target).norm(dim=-1)).all())


def _matched_goal_phases(model, goal, frames):
    """(frames + 1, B, C, 3) the matched goal phase of each step of a rollout, by the goal-phase model."""
    keyframe = kalman.constrain(goal.phase.double().numpy(), runtime.phase_filter_config(model))
    return np.stack([kalman.goal_phase_at(keyframe, goal.due.double().numpy()[:, None] - k, kalman.PhaseFilterConfig())
                     for k in range(frames + 1)])


def test_the_variants_differ_only_in_the_goal_phase(trained, start):
    state, goal = start
    runs = {v: runtime.rollout(trained.model, state, goal, 5, v) for v in features.VARIANTS}
    assert torch.equal(runs["none"].goal_phase, torch.zeros_like(runs["none"].goal_phase))
    matched = features.goal_phase_features(_matched_goal_phases(trained.model, goal, 5)[:5])  # (5, B, 3C)
    assert torch.allclose(runs["matched"].goal_phase, matched, atol=1e-6)
    assert not torch.allclose(matched[0], matched[1], atol=1e-3)  # the goal phase advances frame by frame
    for v in ("predicted", "kalman"):
        assert torch.allclose(runs[v].goal_phase[0], matched[0])  # both start from the matched phase
    pred = runs["predicted"]
    assert torch.allclose(pred.goal_phase[1:], features.goal_phase_features(pred.predicted_goal_phase[:-1]), atol=1e-5)
    # the same goal phase gives the same step whatever the variant's name
    assert torch.equal(runs["matched"].wrist[0], runs["kalman"].wrist[0])
    assert not torch.equal(runs["none"].wrist[-1], runs["matched"].wrist[-1])


def test_the_deviation_weighs_with_the_rollouts_filter_config(trained, start):
    # Eq. 22's weights come from the filter_config passed in: both doubled, c doubles (exactly: powers of two)
    state, goal = start
    default = runtime.phase_filter_config(trained.model)  # the rollout's own (A_max from the data)
    doubled = runtime.phase_filter_config(trained.model, rotation_weight=2 * default.rotation_weight,
                                          body_width=kalman.mean_body_width() / 2)
    run = runtime.rollout(trained.model, state, goal, 3, "none")
    assert bool((run.deviation > 0).all())
    assert torch.equal(runtime.rollout(trained.model, state, goal, 3, "none", filter_config=doubled).deviation,
                       2 * run.deviation)
    _, out = runtime.controller_step(trained.model, state, goal, torch.zeros_like(state.phase), filter_config=doubled)
    assert torch.equal(out["deviation"], 2 * run.deviation[0])


def test_the_kalman_goal_phase_is_filter_step_by_hand(trained, start):
    state, goal = start
    run = runtime.rollout(trained.model, state, goal, 4, "kalman")
    # A_max is the training data's largest amplitude; the matched phase enters bounded by it
    config, variance = runtime.phase_filter_config(trained.model), trained.model.phase_variance.double().numpy()
    assert config.amplitude_max == pytest.approx(float(trained.model.phase_amplitude_max))
    matched = _matched_goal_phases(trained.model, goal, 4)  # M_k, the matched keyframe carried to step k
    estimate, covariance = matched[0], np.zeros(tuple(goal.phase.shape) + (3,))
    s = state
    for t in range(4):
        fed = features.goal_phase_features(estimate)
        assert torch.equal(run.goal_phase[t], fed)
        s, out = runtime.controller_step(trained.model, s, goal, fed)
        # the rollout checks its inputs once and steps unchecked: the same numbers as the checked step
        assert torch.equal(run.wrist[t], out["wrist"]) and torch.equal(run.deviation[t], out["deviation"])
        centre = goal.positions[:, 6]
        active = kalman.matched_measurement_active(
            s.origin[:, :2].numpy(), centre[:, 0, :2].numpy(), out["wrist"][torch.arange(2), goal.hand].numpy(),
            centre[torch.arange(2), 2 + goal.hand].numpy(), config)
        estimate, covariance = kalman.filter_step(estimate, covariance, variance,
                                                  out["goal_phase_state"].double().numpy(),
                                                  out["deviation"].double().numpy()[:, None], config,
                                                  matched_goal=matched[t + 1], use_matched=active[:, None])


def test_clear_errors(trained, start):
    state, goal = start
    with pytest.raises(ValueError, match="variant: expected one of"):
        runtime.rollout(trained.model, state, goal, 3, "oracle")
    with pytest.raises(ValueError, match="frames: expected a positive int"):
        runtime.rollout(trained.model, state, goal, 0, "none")
    with pytest.raises(ValueError, match=r"goal_phase: expected shape \(2, 12\)"):
        runtime.controller_step(trained.model, state, goal, torch.zeros(2, 5))
    with pytest.raises(ValueError, match="state.pose: expected shape"):
        runtime.controller_step(trained.model, state._replace(pose=state.pose[:, :10]), goal, torch.zeros(2, 12))
    with pytest.raises(ValueError, match="state.history: expected shape"):
        runtime.rollout(trained.model, state._replace(history=state.history[:, :5]), goal, 3, "kalman")
    with pytest.raises(ValueError, match="goal.positions: expected shape"):
        runtime.rollout(trained.model, state, goal._replace(positions=goal.positions[:1]), 3, "none")
    with pytest.raises(ValueError, match="x: expected shape"):
        trained.model(torch.zeros(2, 3))
    with pytest.raises(ValueError, match="phase_dropout"):
        network.controller_config("toy", phase_dropout=1.5)
    with pytest.raises(ValueError, match="key_noise: expected a standard deviation"):
        network.controller_config("toy", key_noise=-0.1)
    with pytest.raises(ValueError, match="state.keys: expected shape"):
        runtime.rollout(trained.model, state._replace(keys=state.keys[:, :3]), goal, 3, "kalman")
    with pytest.raises(ValueError, match=r"unroll_steps: expected an int in \[0, steps=100\]"):
        network.controller_config("toy", steps=100, unroll_steps=200)
    with pytest.raises(ValueError, match="speed: expected a positive"):
        runtime.toward_goal(state, goal, speed=0.0)
    with pytest.raises(ValueError, match="clips: expected reach-and-grasp clips"):
        runtime.clip_goal(trained.model, mocap.generate_dataset(1, seed=0, kinds=("walk",)))
    with pytest.raises(ValueError, match="goal.due: expected"):
        runtime.rollout(trained.model, state, goal._replace(due=None), 3, "matched")
    with pytest.raises(ValueError, match="goal.due: expected shape"):
        runtime.rollout(trained.model, state, goal._replace(due=goal.due[:1]), 3, "kalman")
    with pytest.raises(ValueError, match="frame: expected an int"):
        runtime.clip_goal(trained.model, [], frame=1.5)


def test_the_key_joint_trajectories_fed_back_are_the_next_frames_input(trained, clips, start):
    # the hip's and wrists' trajectory input of t + 1 is the ego target of t carried into the root frame of t + 1
    x, y, _ = features.clip_features(clips[0], trained.model.phase_model)
    xl, yl = trained.model.x_layout, trained.model.y_layout
    carried = features.next_key_trajectories(y[:-1, yl["ego"]], y[:-1, yl["root_update"]])
    torch.testing.assert_close(carried.flatten(1), x[1:, xl["keys"]], atol=2e-6, rtol=1e-5)
    assert x[1:, xl["keys"]].std(0).max() > 0.1  # they move
    # at run time the blend of the step becomes the next state's input
    state, goal = start
    state = state._replace(future=state.future + 0.05)
    nxt, out = runtime.controller_step(trained.model, state, goal, features.goal_phase_features(goal.phase))
    frame = rotation_about_z(state.heading)
    update_p = torch.einsum("bji,bj->bi", frame, nxt.origin - state.origin)[:, :2]
    update = torch.cat([update_p, (nxt.heading - state.heading)[:, None]], dim=-1)
    torch.testing.assert_close(nxt.keys, features.next_key_trajectories(out["blended"], update), atol=1e-5, rtol=1e-5)
    assert not torch.allclose(nxt.keys, state.keys, atol=1e-3)


def test_the_data_holds_the_clips_of_each_kind(trained):
    pae = trained.model.phase_model
    config = network.controller_config("toy", clips=1, kinds=("reach_grasp", "open_door"))
    data = network.controller_data(config, pae)
    reach, door = mocap.generate_dataset(1, seed=0, kinds=("reach_grasp", "open_door"))
    assert door.meta["kind"] == "open_door" and "anchor_frame" in door.meta
    x_reach, y_reach, _ = features.clip_features(reach, pae)
    x_door, y_door, _ = features.clip_features(door, pae)
    assert torch.equal(data.clip, torch.cat([torch.zeros(len(x_reach)), torch.ones(len(x_door))]).long())
    assert torch.equal(data.x, torch.cat([x_reach, x_door])) and torch.equal(data.y, torch.cat([y_reach, y_door]))
    only_reach = network.controller_data(network.controller_config("toy", clips=1), pae)
    assert torch.equal(only_reach.x, x_reach)
    for bad in (("walk",), "reach_grasp", ("open_door", "open_door"), ()):
        with pytest.raises(ValueError, match="kinds: expected a tuple of distinct names"):
            network.controller_config("toy", kinds=bad)


def test_next_future_agrees_with_the_data(trained, clips):
    """The unrolled training's future root trajectory, made from the targets of frame t (ego root samples and the
    root update), is the data's input future of frame t + 1."""
    model = trained.model
    x, y, _ = features.clip_features(clips[0], model.phase_model)
    future = features.next_root_trajectory(y[:-1, model.y_layout["ego"]].double(), y[:-1, model.y_layout["root_update"]].double())
    data = x[1:, model.x_layout["trajectory"]].reshape(-1, 13, 4)[:, 6:].double()
    inside = torch.arange(len(future)) + 1 + 30 < len(clips[0])  # the data's window is clamped at the clip's end
    assert torch.allclose(future[inside], data[inside], atol=1e-4)


def test_unrolled_training_feeds_back_its_own_predictions(tmp_cache, trained):
    """Teacher forcing and unrolling give different networks from the same data and seed, both finite."""
    pae = trained.model.phase_model
    config = network.controller_config("toy", **{**TINY, "steps": 12, "unroll_steps": 0})
    data = network.controller_data(config, pae)
    forced, r1 = network.train_controller(data, config, pae)
    unrolled, r2 = network.train_controller(data, dataclasses.replace(config, unroll_steps=6), pae)
    assert torch.equal(torch.tensor(r1.losses[:6]), torch.tensor(r2.losses[:6]))  # the same first batches
    assert not torch.equal(forced.net.layers[0].weight, unrolled.net.layers[0].weight)
    assert np.isfinite(r2.losses).all()
    with pytest.raises(ValueError, match="consecutive frames"):
        network.train_controller(data._replace(clip=torch.arange(len(data.x))), dataclasses.replace(config, unroll_steps=6),
                             pae)


def test_toward_goal_walks_the_straight_line(trained, start):
    state, goal = start
    moved = runtime.toward_goal(state, goal, speed=1.0)
    frame = rotation_about_z(state.heading)
    target = torch.einsum("bji,bj->bi", frame, goal.positions[:, 6, 0] - state.origin)[:, :2]
    steps = moved.future[:, 1:, :2] - moved.future[:, :-1, :2]
    assert torch.allclose(moved.future[:, 0, :2], torch.zeros(2, 2))
    for b in range(2):
        direction = target[b] / target[b].norm()
        along = steps[b] @ direction
        assert bool((along >= -1e-6).all()) and bool((along <= 5 / 30 + 1e-6).all())  # 1 m/s, never backwards
        assert float(moved.future[b, -1, :2].norm()) <= float(target[b].norm()) + 1e-5  # stops at the goal


def test_blended_pose_carries_the_previous_pose_into_the_next_root_frame(trained, clips):
    """With the data's next pose as the prediction, the kept pose stays within a centimetre of it: the previous
    joints, moved into the next root frame by the root update and on by the velocities, land where the data is."""
    model = trained.model
    x, y, _ = features.clip_features(clips[0], model.phase_model)
    previous, nxt = x[:, model.x_layout["pose"]].double(), y[:, model.y_layout["pose"]].double()
    update = y[:, model.y_layout["root_update"]].double()
    kept = features.blended_pose(previous, nxt, update)
    error = (kept[:, :66] - nxt[:, :66]).reshape(-1, 22, 3).norm(dim=-1)
    assert float(error.mean()) < 0.01
    assert torch.equal(kept[:, 66:], nxt[:, 66:])  # the velocities are the prediction's
    wrong = features.blended_pose(previous, nxt, update * torch.tensor([1.0, 1.0, -1.0]).double())  # the turn reversed
    turning = update[:, 2].abs() > 0.02
    if bool(turning.any()):
        assert float((wrong[turning, :66] - nxt[turning, :66]).abs().max()) > float(error[turning].max())


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_the_cached_controller_trained_on_cuda_comes_back_wholly_on_the_cpu(tmp_cache):
    # training moves the model to CUDA; the PAE it shares with the caller must stay on the CPU
    config = network.controller_config(clips=1, steps=4, unroll_steps=2, phase_steps=4, hidden=32, gating_hidden=16,
                                   n_experts=2, batch_size=8, unroll=3)
    trained = network.trained_controller(config, device="cuda")
    tensors = [*trained.model.named_parameters(), *trained.model.named_buffers()]
    assert [name for name, t in tensors if t.device.type != "cpu"] == []


def test_every_goal_phase_source_is_bounded_by_the_same_amplitude(trained, start):
    model = trained.model
    data = network.controller_data(network.controller_config("toy", **TINY), model.phase_model)
    assert float(model.phase_amplitude_max) == pytest.approx(data.amplitude_max) and data.amplitude_max > 0
    state, goal = start
    config = runtime.phase_filter_config(model)
    assert config.amplitude_max == pytest.approx(data.amplitude_max)
    loud = goal._replace(phase=goal.phase.clone())
    loud.phase[..., 1] = 10 * data.amplitude_max  # a matched amplitude far above any in the data
    for variant in ("matched", "predicted", "kalman"):
        run = runtime.rollout(model, state, loud, 1, variant)
        fed = features.phase_state(run.goal_phase[0])  # (B, C, 3) [S, A, F] fed at the first step
        assert float(fed[..., 1].max()) == pytest.approx(data.amplitude_max, rel=1e-5), variant


def test_the_phase_moves_by_eqs_15_and_16(trained, start):
    model = trained.model
    state, goal = start
    config = runtime.phase_filter_config(model)
    fed = features.goal_phase_features(goal.phase)
    nxt, out = runtime.controller_step(model, state, goal, fed)
    x = features.phase_state(state.phase).double().numpy()
    x_hat = features.phase_state(out["network_phase"]).double().numpy()
    # by hand: S advances by Δt F and moves β of the way to the network's; A and F are the network's, in bounds
    advanced = x[..., 0] + config.dt * x[..., 2]
    S = kalman.wrap_phase(advanced + config.phase_blend * kalman.phase_difference(x_hat[..., 0], advanced))
    got = features.phase_state(nxt.phase).double().numpy()
    assert np.abs(kalman.phase_difference(got[..., 0], S)).max() < 1e-4
    np.testing.assert_allclose(got[..., 1], np.clip(x_hat[..., 1], 0, config.amplitude_max), atol=1e-4)
    np.testing.assert_allclose(got[..., 2], np.clip(x_hat[..., 2], 0, config.frequency_max), atol=1e-4)
    # β = 1 gives the network's phase back; the paper's β = 0.5 does not
    one, _ = runtime.controller_step(model, state, goal, fed,
                                     filter_config=runtime.phase_filter_config(model, phase_blend=1.0))
    assert np.abs(kalman.phase_difference(features.phase_state(one.phase)[..., 0].double().numpy(),
                                          x_hat[..., 0])).max() < 1e-4
    assert np.abs(kalman.phase_difference(got[..., 0], x_hat[..., 0])).max() > 1e-3


def test_local_rotations_pose_the_clip_back_and_keep_every_bone_length():
    from hoi_tutorial.world.features import root_frame
    from hoi_tutorial.world.skeleton import PARENTS, bone_lengths, bone_offsets

    clip = mocap.generate_dataset(1, seed=3, kinds=("reach_grasp",))[0]
    frames = torch.arange(0, len(clip), 7)
    origin, heading = root_frame(clip.joints)
    frame = rotation_about_z(heading)[frames]
    rotations = features.local_rotation_features(clip, frames, frame)
    assert rotations.shape == (len(frames), 22 * 6)
    local = ((clip.joints[frames] - origin[frames, None]) @ frame)  # Rᵀ p: the joints in the root frame
    posed = features.pose_from_rotations(rotations, local[:, 0], bone_offsets(clip.betas))
    torch.testing.assert_close(posed, local, atol=1e-5, rtol=0)  # the clip's own pose, back through FK
    # any 6 numbers a network may write give a body whose bones have the character's lengths, exactly
    noisy = rotations + torch.randn(rotations.shape, generator=torch.Generator().manual_seed(0))
    body = features.pose_from_rotations(noisy, local[:, 0], bone_offsets(clip.betas))
    lengths = (body[:, 1:] - body[:, list(PARENTS[1:])]).norm(dim=-1)
    torch.testing.assert_close(lengths, bone_lengths(clip.betas)[1:].to(lengths.dtype).expand_as(lengths),
                               atol=1e-5, rtol=0)
    assert float((body - posed).norm(dim=-1).max()) > 0.05  # the noise did move the body
    with pytest.raises(ValueError, match="rotations: expected shape"):
        features.pose_from_rotations(rotations[:, :6], local[:, 0], bone_offsets(clip.betas))


def test_the_controllers_bodies_keep_every_bone_length(trained, start, clips):
    from hoi_tutorial.world.skeleton import PARENTS, bone_lengths

    state, goal = start
    run = runtime.rollout(trained.model, state, goal, 5, "kalman")
    lengths = (run.joints[:, :, 1:] - run.joints[:, :, list(PARENTS[1:])]).norm(dim=-1)  # (frames, B, 21)
    expected = torch.stack([bone_lengths(c.betas)[1:] for c in clips]).to(lengths.dtype)
    torch.testing.assert_close(lengths, expected.expand_as(lengths), atol=1e-5, rtol=0)


def test_the_gating_compares_key_joint_transformations_and_phases(trained):
    """Fig. 4: the experts' weights move with the key joints now and at the goal and with the phases, and with
    nothing else (the pose, the root trajectory, the rest of the goal window)."""
    model = trained.model
    layout = model.x_layout
    x = model.x_mean + model.x_std * torch.randn(4, model.in_size, generator=torch.Generator().manual_seed(0))

    @torch.no_grad()
    def weights(inputs):
        xn = (inputs - model.x_mean) / model.x_std
        return model.net.gating(xn[:, model.gating_mask])

    base = weights(x)
    centre = layout["goal"].start + (features.WINDOW // 2) * len(features.KEY_JOINTS) * features.TRANSFORM
    moved = {"the hip now": layout["keys"].start, "the goal keyframe's right wrist": centre + 3 * features.TRANSFORM,
             "the goal phase": layout["goal_phase"].start, "the current phase": layout["phase"].start}
    for name, index in moved.items():
        changed = x.clone()
        changed[:, index] += 5 * model.x_std[index]
        assert (weights(changed) - base).abs().max() > 1e-4, name
    still = {"the pose": layout["pose"].start, "the root trajectory": layout["trajectory"].start,
             "the goal window's first sample": layout["goal"].start, "the hip a second ahead": layout["keys"].stop - 1}
    for name, index in still.items():
        changed = x.clone()
        changed[:, index] += 5 * model.x_std[index]
        torch.testing.assert_close(weights(changed), base, atol=0, rtol=0, msg=name)


def test_step_timing_times_the_step_and_the_network_and_leaves_the_model_as_it_was(trained, start):
    """``runtime.step_timing`` (what the bench and chapter 19 print): every timing positive and consistent, the
    network's forward put back afterwards (no instance attribute left), and the same rollout after it."""
    model = trained.model
    before = runtime.rollout(model, *start, 5, "kalman").joints
    timing = runtime.step_timing(model, *start, steps=5)
    assert set(timing) == {"step_ms", "network_ms", "network_in_step_ms", "steps_per_second", "ratio", "ratio_in_step"}
    assert all(v > 0 for v in timing.values())
    # the step contains the network: it costs more than the network's share inside it
    assert timing["step_ms"] > timing["network_in_step_ms"] and timing["ratio_in_step"] > 1
    assert timing["steps_per_second"] == pytest.approx(1e3 / timing["step_ms"])
    assert "forward" not in vars(model)
    assert torch.equal(runtime.rollout(model, *start, 5, "kalman").joints, before)
    with pytest.raises(ValueError, match="steps: expected a positive int"):
        runtime.step_timing(model, *start, steps=0)


# ----------------------------------------------------------------------------- one goal-phase model (§5.2)


def _segments(clip):
    """Frames t of ``features.clip_features``' rows whose next row has the same keyframe g (t < anchor or later)."""
    anchor, T = int(clip.meta["anchor_frame"]), len(clip)
    t = np.arange(T - 2)
    return t[t != anchor]  # at t = anchor the keyframe of t + 1 switches to the clip's last frame


def test_training_goal_phase_is_the_keyframe_carried_by_the_goal_phase_model(trained, clips):
    """The goal phase input of frame t is the next keyframe's PAE phase state carried to t by
    ``kalman.goal_phase_at``; the target ``P̂_g`` of frame t is the input of t + 1; and from one frame to the next
    the goal phase moves exactly as the filter's Eq. 18 predicts it (F of Eq. 19), not held."""
    model = trained.model
    clip = clips[0]
    x, y, states = features.clip_features(clip, model.phase_model)
    fed = features.phase_state(x[:, model.x_layout["goal_phase"]]).double().numpy()  # (T − 1, C, 3)
    target = features.phase_state(y[:, model.y_layout["goal_phase"]]).double().numpy()
    anchor, T = int(clip.meta["anchor_frame"]), len(clip)
    t = np.arange(T - 1)
    g = np.where(t <= anchor, anchor, T - 1)
    expected = kalman.goal_phase_at(states.double().numpy()[g], (g - t)[:, None], kalman.PhaseFilterConfig())
    assert np.abs(kalman.phase_difference(fed[..., 0], expected[..., 0])).max() < 1e-5
    np.testing.assert_allclose(fed[..., 1:], expected[..., 1:], atol=1e-5)
    np.testing.assert_allclose(fed[anchor], states[anchor].double().numpy(), atol=1e-5)  # the keyframe's at g
    assert np.abs(kalman.phase_difference(target[:-1, :, 0], fed[1:, :, 0])).max() < 1e-5
    np.testing.assert_allclose(target[:-1, :, 1:], fed[1:, :, 1:], atol=1e-5)
    # Eq. 18's prediction of each frame's goal phase is the next frame's
    inside = _segments(clip)
    config = kalman.PhaseFilterConfig()
    zero = np.zeros(fed.shape[1:] + (3,))
    predicted = np.stack([kalman.predict(fed[i], zero, zero, config)[0] for i in inside])
    assert np.abs(kalman.phase_difference(predicted[..., 0], fed[inside + 1, :, 0])).max() < 1e-4
    assert np.abs(kalman.phase_difference(fed[1:anchor, :, 0], fed[:anchor - 1, :, 0])).max() > 1e-2  # it moves


def test_run_time_matched_goal_phase_is_the_training_goal_phase(trained, clips, start):
    """A training clip's own keyframe as the matched goal, rolled out from the clip's first frame: the matched goal
    phase fed at step k is the goal phase training fed at frame k (one goal-phase model, ``kalman.goal_phase_at``);
    from a later start (``clip_goal(frame=...)``) it is the training goal phase of that later frame."""
    model = trained.model
    state, goal = start
    assert goal.due.tolist() == [int(c.meta["anchor_frame"]) for c in clips]
    frames = 8
    run = runtime.rollout(model, state, goal, frames, "matched")
    for b, clip in enumerate(clips):
        x, _, _ = features.clip_features(clip, model.phase_model)
        torch.testing.assert_close(run.goal_phase[:, b], x[:frames, model.x_layout["goal_phase"]], atol=2e-5, rtol=0)
        later = runtime.clip_goal(model, [clip], frame=5)
        assert int(later.due[0]) == int(clip.meta["anchor_frame"]) - 5
        one = runtime.rollout(model, runtime.initial_state(model, [clip], 5), later, 3, "matched")
        torch.testing.assert_close(one.goal_phase[:, 0], x[5:8, model.x_layout["goal_phase"]], atol=2e-5, rtol=0)


def test_the_filters_prediction_agrees_with_the_run_time_matched_measurement(trained, start):
    """Algorithm 1's prediction ``F G^p`` (Eq. 18) of a rollout's matched goal phase M_k is M_{k+1}; fed M_k as both
    measurements, noiselessly, the filter stays on it frame by frame: no steady bias."""
    model = trained.model
    state, goal = start
    frames = 12
    run = runtime.rollout(model, state, goal, frames, "matched")
    measured = features.phase_state(run.goal_phase).double().numpy()  # (frames, B, C, 3): M_k as fed
    config = runtime.phase_filter_config(model)
    zero = np.zeros(measured.shape[1:] + (3,))
    predicted = np.stack([kalman.predict(m, zero, zero, config)[0] for m in measured[:-1]])
    assert np.abs(kalman.phase_difference(predicted[..., 0], measured[1:, ..., 0])).max() < 1e-5
    variance = model.phase_variance.double().numpy()
    deviations = np.random.default_rng(0).uniform(0.05, 3.0, measured.shape[:2] + (1,))
    estimates, _ = kalman.filter_sequence(variance, measured[1:], deviations[1:], config, matched_goals=measured[1:],
                                          initial=(measured[0], zero))
    assert np.abs(kalman.phase_difference(estimates[..., 0], measured[1:, ..., 0])).max() < 1e-5
    np.testing.assert_allclose(estimates[..., 1:], measured[1:, ..., 1:], atol=1e-6)
