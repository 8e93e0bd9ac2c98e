"""SAMP's MotionNet: data (goals, roots, voxels), the networks, Eq. 5, training and the run-time loop."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import torch

from hoi_tutorial.samp import core, motion_data as md, motionnet as mn, runtime as rt
from hoi_tutorial.world.features import SAMP_ACTIONS, SAMP_STATE_LAYOUT, SAMP_STATE_SIZE, root_frame, samp_action_ids
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.rotations import rotation_about_z

pytestmark = pytest.mark.usefixtures("one_cpu_thread", "module_cache")  # rollouts are cached


def _tiny_data_config(**overrides):
    values = {"clips": (("idle", 1), ("walk", 2), ("sit", 2), ("lie", 1)), "test_clips": 1, "augmented": 0}
    values.update(overrides)
    return md.motion_data_config("toy", **values)


def _tiny_model_config(**overrides):
    values = {"state_hidden": (32, 16, 16), "interaction_hidden": (16, 16), "interaction_out": 8,
              "gating_hidden": (16, 8), "prediction_hidden": 32, "n_experts": 3, "latent": 4,
              "mlp_hidden": (32, 32), "rollout": 8, "epochs": 2, "steps": None, "c1": 0.0, "c2": 1.0, "batch_size": 4}
    values.update(overrides)
    return mn.motionnet_config("toy", **values)


def _frame(x, y, heading):
    F = np.eye(4)
    F[:3, :3] = rotation_about_z(torch.tensor(float(heading), dtype=torch.float64)).numpy()
    F[:2, 3] = (x, y)
    return F


# ----------------------------------------------------------------------------- Eq. 5


def test_teacher_forcing_probability_at_the_breakpoints():
    p = mn.teacher_forcing_probability
    assert p(0, 30, 60) == 1.0 and p(30, 30, 60) == 1.0  # epoch <= C1
    assert p(45, 30, 60) == pytest.approx(0.5)  # halfway between C1 and C2
    assert p(31, 30, 60) == pytest.approx(1 - 1 / 30)
    assert p(60, 30, 60) == 0.0 and p(61, 30, 60) == 0.0 and p(100, 30, 60) == 0.0
    with pytest.raises(ValueError, match="C1 < C2"):
        p(10, 60, 30)


# ----------------------------------------------------------------------------- voxels and roots


def test_voxels_in_root_frame_match_the_objects_own_voxels():
    obj = make_object("armchair", seed=4).placed(0.7, -1.1, 0.6)
    centres, occupancy = md.object_voxel_cells(obj)
    roots = torch.tensor([[0.3, 2.0, 0.4], [-1.5, 0.2, -2.8]])
    ours = md.voxels_in_root_frame(torch.as_tensor(centres), torch.as_tensor(occupancy), roots)
    assert ours.shape == (2, core.VOXEL_SIZE)
    for b, (x, y, h) in enumerate(roots.tolist()):
        reference = obj.interaction_voxels(_frame(x, y, h)).reshape(-1)
        np.testing.assert_allclose(ours[b].numpy(), reference, atol=1e-5)


def test_voxel_code_unchanged_when_character_and_object_move_together():
    obj = make_object("chair", seed=2)
    root = (0.4, -1.2, 0.3)
    code = obj.interaction_voxels(_frame(*root))
    # a rigid motion of the ground plane: rotate by 1.1 rad about the origin, then translate
    angle, shift = 1.1, np.array([2.0, -0.5])
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    moved_obj = obj.placed(*(rot @ obj.pose[:2, 3] + shift), float(np.arctan2(obj.pose[1, 0], obj.pose[0, 0]) + angle))
    moved_root = (*(rot @ np.array(root[:2]) + shift), root[2] + angle)
    np.testing.assert_allclose(moved_obj.interaction_voxels(_frame(*moved_root)), code, atol=1e-5)
    # and a move of the character alone does change it
    assert not np.allclose(obj.interaction_voxels(_frame(root[0] + 0.3, root[1], root[2])), code, atol=1e-3)


def test_root_displacement_integrates_back_to_the_roots():
    g = torch.Generator().manual_seed(0)
    roots = torch.cumsum(torch.randn(40, 3, generator=g) * torch.tensor([0.05, 0.05, 0.2]), dim=0)
    update = md.root_displacement(roots)
    assert update.shape == (39, 3)
    root = roots[0]
    for k in range(39):
        root = md.apply_root_displacement(root, update[k])
    torch.testing.assert_close(root[:2], roots[-1, :2], atol=1e-4, rtol=1e-5)
    assert abs(math.remainder(float(root[2] - roots[-1, 2]), 2 * math.pi)) < 1e-4


# ----------------------------------------------------------------------------- goals of the clips


def test_clip_goals_of_each_kind():
    walk, _ = md.make_clip("walk", 11)
    positions, directions, action = md.clip_goals(walk)
    waypoints = np.asarray(walk.meta["waypoints"])
    assert np.all(action == SAMP_ACTIONS.index("walk")) and positions.shape == (len(walk), 3)
    # the goals are the path's waypoints after the first, in order, ending on the last
    seen = [tuple(p) for p in np.unique(positions[:, :2], axis=0)]
    assert all(any(np.allclose(s, w) for w in waypoints[1:]) for s in seen)
    np.testing.assert_allclose(positions[-1, :2], waypoints[-1])
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-9)
    sit, obj = md.make_clip("sit", 12)
    positions, directions, action = md.clip_goals(sit)
    assert action[-1] == SAMP_ACTIONS.index("sit") and obj is not None
    np.testing.assert_allclose(positions[-1], sit.meta["sit_goal"]["position"])
    assert sit.meta["anchor_frame"] < len(sit)  # ends seated, the settle frame inside the clip
    lie, _ = md.make_clip("lie", 13)
    _, directions, action = md.clip_goals(lie)
    np.testing.assert_allclose(directions[-1], -np.asarray(lie.meta["lie_goal"]["direction"]))
    with pytest.raises(ValueError, match="kind"):
        md.make_clip("dance", 0)


def test_sit_and_lie_approaches_start_all_around_the_object_and_keep_out_of_it():
    # §4.1: "the subject starts from an A-Pose in a random location in the MoCap space": the
    # starts' directions from the object, seen from its front, fill every quarter of the circle
    angles, far = [], []
    for kind, seeds in (("sit", range(24)), ("lie", range(8))):
        for seed in seeds:
            clip, obj = md.make_clip(kind, seed)
            offset = clip.root_position[0, :2].double().numpy() - obj.pose[:2, 3]
            front = obj.pose[:2, 1]
            angles.append(math.atan2(front[0] * offset[1] - front[1] * offset[0], front @ offset))
            far.append(np.linalg.norm(offset))
            assert md.approach_clearance(clip, obj) >= -md.APPROACH_PENETRATION
    quarters = np.histogram(angles, bins=4, range=(-math.pi, math.pi))[0]
    assert quarters.min() >= 4, quarters  # 32 starts; ±70° of the front would leave the back quarter empty
    assert md.APPROACH_DISTANCE[0] - 0.2 < min(far) and max(far) < md.APPROACH_DISTANCE[1] + 0.2
    # the start itself is uniform over the circle at the stated distance
    rng = np.random.default_rng(0)
    _, chair = md.make_clip("sit", 3)
    starts = np.stack([md.approach_start(chair, rng) for _ in range(400)]) - chair.pose[:2, 3]
    radii = np.linalg.norm(starts, axis=1)
    assert md.APPROACH_DISTANCE[0] <= radii.min() and radii.max() <= md.APPROACH_DISTANCE[1]
    assert np.histogram(np.arctan2(starts[:, 1], starts[:, 0]), bins=8, range=(-math.pi, math.pi))[0].min() > 25


def test_walk_first_clips_switch_from_a_walk_goal_to_the_seat_near_the_standing_spot():
    kinds = {True: 0, False: 0}
    for seed in range(12):
        clip, _ = md.make_clip("sit", seed, walk_first_share=0.5)
        positions, directions, action = md.clip_goals(clip)
        seat = np.asarray(clip.meta["sit_goal"]["position"])
        walk = action == SAMP_ACTIONS.index("walk")
        kinds[bool(clip.meta["walk_first"])] += 1
        if not clip.meta["walk_first"]:
            assert not walk.any() and np.allclose(positions, seat)
            continue
        # a walk goal first, then the seat for the rest of the clip (one switch, never back)
        assert walk[0] and not walk[-1] and np.all(np.diff(walk.astype(int)) <= 0)
        switch = int(np.argmin(walk))
        root = root_frame(clip.joints)[0].numpy()[:, :2]
        spot = positions[0, :2]
        assert np.linalg.norm(root[switch] - spot) < md.WALK_SWITCH_RADIUS <= np.linalg.norm(root[switch - 1] - spot)
        np.testing.assert_allclose(positions[switch:], np.repeat(seat[None], len(clip) - switch, 0))
        # the walk goal faces along the approach, from the start to the spot
        leg = spot - root[0]
        np.testing.assert_allclose(directions[0, :2], leg / np.linalg.norm(leg), atol=1e-9)
        # the state carries the goal's action frame by frame
        states, _ = md.clip_states(clip)
        one_hot = states[:, SAMP_STATE_LAYOUT["goal_actions"]].reshape(len(clip), 7, 5)[:, 3].argmax(-1).numpy()
        np.testing.assert_array_equal(one_hot, action)
    assert kinds[True] > 0 and kinds[False] > 0
    # the share is a config field: none and all of the clips walk first at its ends
    assert not any(md.make_clip("sit", seed, walk_first_share=0.0)[0].meta["walk_first"] for seed in range(6))
    assert all(md.make_clip("lie", seed, walk_first_share=1.0)[0].meta["walk_first"] for seed in range(6))
    with pytest.raises(ValueError, match="walk_first_share"):
        md.motion_data_config(walk_first_share=1.5)


def test_goal_features_reproduce_the_clip_state():
    clip, _ = md.make_clip("walk", 5)
    positions, directions, action = md.clip_goals(clip)
    states, roots = md.clip_states(clip)
    ids = torch.as_tensor(action)
    scrambled = states.float().clone()
    for name in mn.GOAL_FEATURES:
        scrambled[:, SAMP_STATE_LAYOUT[name]] = 0.0
    rebuilt = rt.with_goal(scrambled, roots, torch.as_tensor(positions).float(), torch.as_tensor(directions).float(), ids)
    torch.testing.assert_close(rebuilt, states.float(), atol=1e-5, rtol=1e-5)


# ----------------------------------------------------------------------------- data, networks, training


def test_motion_data_layout(tmp_cache):
    data = md.motion_data(_tiny_data_config(), "train")
    assert data.n_clips == 6 and data.states.shape == (len(data), SAMP_STATE_SIZE)
    assert int(data.clip_start[-1]) == len(data)
    assert (data.clip_object >= 0).sum() == 3  # sit, sit and lie clips have objects
    windows = data.windows(10)
    clips = data.frame_clip()
    assert bool((clips[windows] == clips[windows + 10]).all())  # a window never crosses clips
    idle = int((data.clip_kind == 0).nonzero()[0])
    frames = torch.arange(data.clip_slice(idle).start, data.clip_slice(idle).start + 3)
    assert bool((data.voxels(frames) == 0).all())
    test = md.motion_data(_tiny_data_config(), "test")
    assert test.n_clips == 4 and not torch.equal(test.states[:10], data.states[:10])
    with pytest.raises(ValueError, match="split"):
        md.motion_data(_tiny_data_config(), "validation")
    with pytest.raises(ValueError, match="clips"):
        md.motion_data_config(clips=(("swim", 2),))


def test_augmented_copies_follow_the_captured_clips_on_new_objects_with_their_goals(tmp_cache):
    # §4.2: each sit and lie training clip again on another object of its category, its goal moved with the seat
    captured = md.motion_data(_tiny_data_config(), "train")
    data = md.motion_data(_tiny_data_config(augmented=2), "train")
    n = captured.n_clips
    assert data.n_clips == n + 2 * 3 and (data.clip_augmented[:n] == -1).all()  # 2 copies of sit, sit, lie
    torch.testing.assert_close(data.states[:len(captured)], captured.states)
    assert data.clip_augmented[n:].tolist() == [0, 1, 0, 1, 0, 1]
    moved = []
    for clip in range(n, data.n_clips):
        source = [c for c in range(n) if captured.clip_seeds[c] == data.clip_seeds[clip]
                  and captured.clip_kind[c] == data.clip_kind[clip]][0]
        kind = md.MOTION_KINDS[int(data.clip_kind[clip])]
        motion, obj = md.make_clip(kind, data.clip_seeds[clip])
        new = md.augmented_object(obj, data.clip_seeds[clip], int(data.clip_augmented[clip]))
        assert new.category == obj.category and new.params != obj.params
        # the copy's voxels are the new object's
        o = int(data.clip_object[clip])
        assert not torch.equal(data.voxel_occupancy[o], captured.voxel_occupancy[int(captured.clip_object[source])])
        # its goal keeps the captured goal's distance to the seat, now the new one's
        last, last_source = data.clip_slice(clip).stop - 1, captured.clip_slice(source).stop - 1
        key = "sit_goal" if kind == "sit" else "lie_goal"
        goal = data.goal_positions[last].double().numpy()
        assert abs(float(new.sdf(goal[None])[0]) - float(obj.sdf(np.asarray(motion.meta[key]["position"])[None])[0])) < 0.005
        moved.append(float((data.goal_positions[last] - captured.goal_positions[last_source]).norm()))
    assert max(moved) > 0.02, "some goal moved with its seat"
    test = md.motion_data(_tiny_data_config(augmented=2), "test")
    assert (test.clip_augmented == -1).all(), "the test split is never augmented"
    with pytest.raises(ValueError, match="augmented"):
        md.motion_data_config(augmented=-1)
    with pytest.raises(ValueError, match="copy"):
        md.augmented_object(obj, 0, -1)


def test_networks_shapes_and_errors():
    torch.manual_seed(0)
    x, v = torch.randn(5, SAMP_STATE_SIZE), torch.randn(5, core.VOXEL_SIZE)
    for kind in mn.MODEL_KINDS:
        model = mn.build_motion_model(_tiny_model_config(model=kind))
        z = torch.randn(5, model.latent) if model.latent else None
        assert model.predict(x, v, z).shape == (5, mn.OUTPUT_SIZE)
    samp = mn.build_motion_model(_tiny_model_config())
    assert samp.latent == 4 and mn.build_motion_model(_tiny_model_config(model="moe")).latent == 0
    with pytest.raises(ValueError, match="latent"):
        samp.predict(x, v)
    with pytest.raises(ValueError, match="voxels"):
        samp.predict(x, torch.randn(5, 8 * 8 * 4 * 4), torch.randn(5, 4))
    ablated = mn.build_motion_model(_tiny_model_config(use_interaction=False))
    out = ablated.predict(x, v, torch.zeros(5, 4))
    torch.testing.assert_close(ablated.predict(x, torch.randn(5, core.VOXEL_SIZE), torch.zeros(5, 4)), out)
    with pytest.raises(ValueError, match="model"):
        mn.motionnet_config(model="transformer")


def test_training_runs_scheduled_sampling_and_lowers_the_loss(tmp_cache):
    data = md.motion_data(_tiny_data_config(), "train")
    config = _tiny_model_config(epochs=6, c1=1.0, c2=3.0, lr=3e-3)
    model, result = mn.train_motion_model(data, config)
    p = result.extra["teacher_forcing"]
    assert p[0] == 1.0 and p[-1] == 0.0  # Eq. 5 ran from ground truth to own predictions
    early, late = np.mean(result.losses[:5]), np.mean(result.losses[-5:])
    assert np.isfinite(late) and late < early
    # a budget fixed in steps stretches Eq. 5 over them: P = 1 for the first C1 / epochs of the steps
    _, fixed = mn.train_motion_model(data, _tiny_model_config(epochs=4, steps=12, c1=1.0, c2=3.0))
    expected = [mn.teacher_forcing_probability(step // 3 + 1, 1.0, 3.0) for step in range(12)]
    assert len(fixed.losses) == 12 and fixed.extra["teacher_forcing"] == pytest.approx(expected)
    assert mn.training_steps(data, _tiny_model_config(epochs=4, steps=12)) == 12
    assert mn.training_steps(data, config) == len(result.losses) == 6 * math.ceil(len(data.windows(8)) / 4)
    with pytest.raises(ValueError, match="steps"):
        mn.motionnet_config(steps=0)
    # without scheduled sampling P stays 1
    _, flat = mn.train_motion_model(data, _tiny_model_config(epochs=1, scheduled_sampling=False))
    assert set(flat.extra["teacher_forcing"]) == {1.0}


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
@pytest.mark.parametrize("kind, own_inputs", [("samp", "recomputed"), ("nsm", "recomputed"), ("samp", "ground_truth")])
def test_training_runs_on_cuda_with_the_data_set_on_the_cpu(tmp_cache, kind, own_inputs):
    # the data set stays on the CPU; own-prediction steps (P = 0 from the start) move what the network reads,
    # the goal-feature mask of the "ground_truth" variant included
    data = md.motion_data(_tiny_data_config(), "train")
    config = _tiny_model_config(epochs=1, c1=0.0, c2=0.5, model=kind, own_inputs=own_inputs)
    model, result = mn.train_motion_model(data, config, device="cuda")
    assert model.x_mean.device.type == "cuda" and np.isfinite(result.losses).all()
    assert result.extra["teacher_forcing"][-1] == 0.0


def test_rollout_follows_goals_in_turn():
    torch.manual_seed(0)
    model = mn.build_motion_model(_tiny_model_config()).eval()
    goals = rt.GoalSequence.from_lists([
        [((1.0, 0.0, 0.0), (1, 0, 0), "walk", 0.5), ((0.0, 0.0, 0.5), (0, 1, 0), "sit", 0.0)],
        [((0.0, 2.0, 0.0), (0, 1, 0), "run", 0.0)],
    ])
    # a goal within its radius is passed; the last goal of a character never is
    index = torch.zeros(2, dtype=torch.int64)
    near = torch.tensor([[0.8, 0.1, 0.0], [0.0, 2.0, 0.0]])
    torch.testing.assert_close(goals.advance(index, near), torch.tensor([1, 0]))
    torch.testing.assert_close(goals.advance(torch.tensor([1, 0]), torch.zeros(2, 3)), torch.tensor([1, 0]))
    far = torch.tensor([[2.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    torch.testing.assert_close(goals.advance(index, far), index)
    out = rt.rollout(model, rt.standing_state(), far, goals, 5, torch.Generator().manual_seed(0))
    assert out.states.shape == (2, 6, SAMP_STATE_SIZE) and out.joints().shape == (2, 6, 22, 3)
    # the goal features of every frame are those of the goal it heads for
    for t in range(6):
        g = out.states[1, t, SAMP_STATE_LAYOUT["goal_actions"]].reshape(7, 5)
        assert bool((g.argmax(-1) == SAMP_ACTIONS.index("run")).all())
        current = int(goals.actions[0, out.goal_index[0, t]])
        assert int(out.states[0, t, SAMP_STATE_LAYOUT["goal_actions"]].reshape(7, 5)[3].argmax()) == current
    with pytest.raises(ValueError, match="action"):
        rt.GoalSequence.single([(0, 0, 0)], [(0, 1, 0)], ["dance"])
    with pytest.raises(ValueError, match="characters"):
        rt.rollout(model, rt.standing_state(), far[:1], goals, 5, torch.Generator())


def test_a_cached_rollout_is_the_run_itself_and_any_input_changes_its_key(tmp_cache, monkeypatch):
    from hoi_tutorial.infra import cache_only

    torch.manual_seed(0)
    model = mn.build_motion_model(_tiny_model_config()).eval()
    goals = rt.GoalSequence.single([(2.0, 1.0, 0.0), (0.0, 3.0, 0.0)], [(0, 1, 0), (1, 0, 0)], ["sit", "walk"])
    roots = torch.tensor([[0.0, 0.0, 0.3], [1.0, 0.0, -0.2]])

    def run(m=model, seed=0, cache=True, **kwargs):
        generator = torch.Generator().manual_seed(seed)
        out = rt.rollout(m, rt.standing_state(), roots, goals, 6, generator, cache=cache, **kwargs)
        return out, generator.get_state()

    def assert_same(a, b):
        for name in ("states", "roots", "goal_index", "actions"):
            assert torch.equal(getattr(a[0], name), getattr(b[0], name)), name
        assert torch.equal(a[1], b[1])  # the generator is left where the run left it

    direct = run(cache=False)
    assert not list(tmp_cache.iterdir())  # cache=False stores nothing
    built = run()
    assert_same(built, direct)
    files = sorted(p.name for p in tmp_cache.iterdir())
    assert len(files) == 1 and files[0].startswith("samp_rollout-")
    with monkeypatch.context() as patch, cache_only():
        patch.setattr(rt, "_rollout", lambda *args: pytest.fail("a cached run was run again"))
        assert_same(run(), direct)  # loaded, not run
    # another seed, latent scale, goal rule or changed weights is another run: never served the cached one
    changed = mn.build_motion_model(_tiny_model_config()).eval()
    changed.load_state_dict(model.state_dict())
    with torch.no_grad():
        for parameter in changed.parameters():
            parameter.add_(1e-3)
    for other in ({"seed": 1}, {"latent_scale": 0.5}, {"m": changed}, {"goal_correction": False}):
        assert_same(run(**other), run(cache=False, **other))
    assert len(list(tmp_cache.iterdir())) == 1 + 4
    with pytest.raises(TypeError, match="MotionModel"):
        rt.rollout(object(), rt.standing_state(), roots, goals, 6, torch.Generator())

    class MoreGoals(rt.GoalSequence):  # a goal type of its own holds state the key cannot see: never cached
        pass

    more = MoreGoals(goals.positions, goals.directions, goals.actions, goals.radii, goals.counts)
    rt.rollout(model, rt.standing_state(), roots, more, 6, torch.Generator().manual_seed(0))
    assert len(list(tmp_cache.iterdir())) == 1 + 4


def test_correction_pulls_the_future_onto_the_goal_only_near_it():
    clip, _ = md.make_clip("sit", 3)
    positions, directions, _ = md.clip_goals(clip)
    states, roots = md.clip_states(clip)
    goal_p, goal_d = torch.as_tensor(positions).float(), torch.as_tensor(directions).float()
    states = states.float()
    # on ground-truth states both readings of the trajectory agree, so the correction changes nothing
    torch.testing.assert_close(rt.correct_towards_goal(states, roots, goal_p, goal_d), states, atol=1e-5, rtol=1e-5)
    # a goal-frame prediction that disagrees moves the future samples near the goal, not far from it
    shifted = states.clone()
    shifted[:, SAMP_STATE_LAYOUT["goal_trajectory_positions"]] += 0.1
    moved = (rt.correct_towards_goal(shifted, roots, goal_p, goal_d) - shifted)[:, SAMP_STATE_LAYOUT["trajectory_positions"]]
    distance = (roots[:, :2] - goal_p[:, :2]).norm(dim=-1)
    assert moved.abs().amax(-1)[distance > 2.5].max() < 1e-4  # samples at most ~1.5 m ahead
    settle = int(clip.meta["anchor_frame"])
    assert moved[settle].abs().max() > 0.02
    assert moved[settle].reshape(7, 2)[:4].abs().max() < 1e-6  # past and current samples are kept


# ----------------------------------------------------------------------------- evaluation


def test_goal_tasks_start_in_front_and_runs_are_measured():
    from hoi_tutorial.samp import evaluation as ev

    tasks = ev.goal_tasks("sit", 3, seed=4)
    for t in tasks:
        distance = np.linalg.norm(t.start_root[:2] - t.goal_position[:2])
        assert 3.0 <= distance <= 4.0 and t.obj.category in md.OBJECT_CATEGORIES["sit"]
    lie = ev.goal_tasks("lie", 2, seed=4)
    positions, directions = lie[0].obj.lie_goals
    assert any(np.allclose(lie[0].goal_direction, -d) for d in directions)  # lie_facing
    torch.manual_seed(0)
    model = mn.build_motion_model(_tiny_model_config(model="moe")).eval()
    results = ev.run_goal_tasks(model, tasks, seconds=0.5)
    assert results.rollout.states.shape == (3, 16, SAMP_STATE_SIZE)
    assert results.execution_time.shape == (3,) and results.reached.dtype == bool
    # an untrained model does not sit within half a second with its pelvis on the seat
    assert results.summary()["runs"] == 3 and results.success_rate <= 1.0
    with pytest.raises(ValueError, match="action"):
        ev.goal_tasks("dance", 2)


def test_run_spread_separates_stochastic_from_deterministic_models():
    from hoi_tutorial.samp import evaluation as ev

    torch.manual_seed(0)
    task = ev.goal_tasks("sit", 1, seed=0)[0]
    deterministic = mn.build_motion_model(_tiny_model_config(model="moe")).eval()
    stochastic = mn.build_motion_model(_tiny_model_config()).eval()
    spread = {name: ev.run_spread(ev.repeated_goal_runs(m, task, n_runs=3, seconds=0.3).rollout.states)
              for name, m in (("moe", deterministic), ("samp", stochastic))}
    assert spread["moe"] < 1e-8 < spread["samp"]


def test_action_frames_keep_the_labelled_frames_per_run():
    from hoi_tutorial.samp import evaluation as ev

    clip, _ = md.make_clip("sit", 3)
    states, _ = md.clip_states(clip)
    sitting = ev.action_frames(states, "sit")
    labels = samp_action_ids(clip.actions)
    assert len(sitting) == int((labels == SAMP_ACTIONS.index("sit")).sum()) > 0
    assert len(ev.action_frames(torch.stack([states, states]), "sit", per_run=5)) == 10


def test_action_fd_is_eq9_on_the_action_frames_and_is_computed_once(tmp_cache, monkeypatch):
    from hoi_tutorial.infra import cache_only
    from hoi_tutorial.metrics import frechet_distance
    from hoi_tutorial.samp import evaluation as ev

    runs = torch.stack([md.clip_states(md.make_clip("sit", seed)[0])[0][-90:] for seed in (3, 4)])  # ending seated
    sitting = ev.action_frames(runs, "sit")
    reference = ev.state_features(md.clip_states(md.make_clip("sit", 5)[0])[0], ev.FD_FEATURES)
    direct = frechet_distance(ev.state_features(sitting, ev.FD_FEATURES), reference)
    assert ev.action_fd(runs, "sit", reference) == (direct, len(sitting)) and len(sitting) >= 2
    with monkeypatch.context() as patch, cache_only():
        patch.setattr(ev, "frechet_distance", lambda *a: pytest.fail("a cached FD was computed again"))
        assert ev.action_fd(runs, "sit", reference) == (direct, len(sitting))
    # other runs or another reference: computed for them, never the cached value
    other = reference[: len(reference) // 2]
    assert ev.action_fd(runs, "sit", other)[0] == frechet_distance(ev.state_features(sitting, ev.FD_FEATURES), other)
    assert ev.action_fd(runs[:1], "sit", reference)[1] == len(ev.action_frames(runs[:1], "sit"))
    assert ev.action_fd(runs, "lie", reference) == (math.inf, 0)  # no frame of the action: ∞ (the paper's)
    with pytest.raises(ValueError, match="action"):
        ev.action_fd(runs, "dance", reference)


def test_captured_states_and_voxel_cells_are_made_once_for_the_same_object(tmp_cache, monkeypatch):
    from hoi_tutorial.infra import cache_only
    from hoi_tutorial.samp import evaluation as ev

    chair = make_object("chair", 3)
    made = ev.captured_states("sit", chair, n=2)
    for k in range(2):
        assert torch.equal(made[k], md.clip_states(md.make_clip("sit", 5000 + k, obj=chair)[0])[0])
    with monkeypatch.context() as patch, cache_only():
        patch.setattr(ev, "make_clip", lambda *a, **k: pytest.fail("cached clips were made again"))
        assert all(torch.equal(a, b) for a, b in zip(ev.captured_states("sit", chair, n=2), made))
    moved = chair.placed(1.0, 0.0, 0.3)
    assert not torch.equal(ev.captured_states("sit", moved, n=1)[0], made[0])  # another object: made for it
    with pytest.raises(ValueError, match="n"):
        ev.captured_states("sit", chair, n=0)
    # the cells: the same as object_voxel_cells, copies, and those of the object as it is now
    cells = ev.voxel_cells(chair)
    for got, want in zip(cells, md.object_voxel_cells(chair)):
        assert np.array_equal(got, want)
    cells[0][:] = 0.0
    assert np.array_equal(ev.voxel_cells(chair)[0], md.object_voxel_cells(chair)[0])
    assert np.array_equal(ev.voxel_cells(moved)[0], md.object_voxel_cells(moved)[0])
    assert not np.array_equal(ev.voxel_cells(moved)[0], ev.voxel_cells(chair)[0])


def test_the_public_code_variant_restores_only_the_goal():
    # SAMP_Training restores g^p, g^d, g^a of an own-prediction input; t̃^p, t̃^d stay the model's
    mask = mn.goal_feature_mask()
    for name in ("goal_positions", "goal_directions", "goal_actions"):
        assert bool(mask[SAMP_STATE_LAYOUT[name]].all())
    assert not bool(mask[SAMP_STATE_LAYOUT["goal_trajectory_positions"]].any())
    assert not bool(mask[SAMP_STATE_LAYOUT["goal_trajectory_directions"]].any())
    assert int(mask.sum()) == 21 + 21 + 35


def test_precision_is_averaged_over_every_run_that_acted():
    from hoi_tutorial.samp import evaluation as ev

    inf = math.inf
    times = np.array([2.0, 3.0, inf, 5.0])
    pe = np.array([10.0, 50.0, inf, 20.0])  # the second run sat 50 cm away: a miss that acted
    re = np.array([5.0, 40.0, inf, 15.0])
    reached = np.isfinite(times) & (pe < 30.0)
    s = ev.precision_summary(times, pe, re, reached)
    assert (s["runs"], s["acted"], s["reached"]) == (4, 3, 2)
    assert s["PE"] == pytest.approx(80.0 / 3) and s["RE"] == pytest.approx(20.0)  # the miss counts
    assert s["PE_reached"] == pytest.approx(15.0) and s["RE_reached"] == pytest.approx(10.0)
    assert s["execution_time"] == inf  # one run never acted: Table 2's ∞
    assert s["execution_time_acted"] == pytest.approx(10.0 / 3)
    every = ev.precision_summary(times[[0, 1, 3]], pe[[0, 1, 3]], re[[0, 1, 3]], reached[[0, 1, 3]])
    assert every["execution_time"] == pytest.approx(10.0 / 3)
    none = ev.precision_summary([inf, inf], [inf, inf], [inf, inf], [False, False])
    assert none["PE"] == inf and none["acted"] == 0


def test_methods_are_compared_over_the_runs_both_performed():
    from hoi_tutorial.samp import evaluation as ev

    def results(times, pe):
        times, pe = np.asarray(times, dtype=float), np.asarray(pe, dtype=float)
        return ev.GoalRunResults(times, pe, pe, np.isfinite(times) & (pe < 30), rollout=None)

    inf = math.inf
    a = results([1, 1, 1, 1, 1, 1, 1, inf], [5, 6, 7, 5, 6, 5, 6, inf])
    b = results([1, 1, 1, 1, 1, 1, inf, 1], [15, 16, 17, 45, 16, 15, inf, 9])
    interval = ev.paired_over_acted(a, b, "position_error", seed=0)
    assert interval.n == 6 and interval.estimate == pytest.approx(-15.0)  # (5 × -10 - 40) / 6: both acted
    assert interval.holds("below")  # a's PE is lower on every run both performed, the 45 cm miss included
    four = ev.paired_over_acted(results(a.execution_time[:4], a.position_error[:4]),
                                results(b.execution_time[:4], b.position_error[:4]),
                                "position_error")
    assert four.n == 4 and four.verdict("below") == "inconclusive"  # four runs are too few for any 95 % interval
    assert ev.paired_over_acted(a, results([inf] * 8, [inf] * 8), "position_error") is None
    with pytest.raises(ValueError, match="measure"):
        ev.paired_over_acted(a, b, "speed")
    with pytest.raises(ValueError, match="same tasks"):
        ev.paired_over_acted(a, results([1, 1], [1, 1]), "position_error")
    # pooled over two sets of tasks: each run paired with its own, the runs of both sets together
    c = results([1, 1, 1], [20, 21, 22])
    d = results([1, inf, 1], [10, inf, 12])
    pooled = ev.paired_over_acted([a, c], [b, d], "position_error", seed=0)
    assert pooled.n == 8 and pooled.estimate == pytest.approx((-90 + 10 + 10) / 8)
    assert ev.paired_over_acted([a], [b], "position_error", seed=0).estimate == interval.estimate
    with pytest.raises(ValueError, match="equally long"):
        ev.paired_over_acted([a, c], [b], "position_error")
    with pytest.raises(ValueError, match="equally long"):
        ev.paired_over_acted([a], b, "position_error")


def test_onset_spread_aligns_runs_on_the_action_and_is_zero_for_identical_runs():
    from hoi_tutorial.samp import evaluation as ev

    clips = [md.clip_states(md.make_clip("sit", seed)[0])[0].float() for seed in (1, 2, 3)]
    windows = ev.onset_windows(clips, "sit", before=1.0, after=2.0)
    assert windows.shape == (3, 90, SAMP_STATE_SIZE)
    labels = rt.current_action(windows)
    sit = SAMP_ACTIONS.index("sit")
    assert bool((labels[:, 30] == sit).all()) and not bool((labels[:, 29] == sit).any())  # the onset at 1 s
    twin, n = ev.onset_spread([clips[0], clips[0].clone()], "sit")
    assert n == 2 and twin == pytest.approx(0.0, abs=1e-9)  # a deterministic model's runs of one task
    spread, n = ev.onset_spread(clips, "sit")
    assert n == 3 and spread > 0.1
    walk = md.clip_states(md.make_clip("walk", 4)[0])[0].float()
    assert ev.onset_spread(clips[:1] + [walk], "sit")[1] == 1  # a run that never sits is left out
    assert math.isnan(ev.onset_spread([walk], "sit")[0])
    with pytest.raises(ValueError, match="before, after"):
        ev.onset_windows(clips, "sit", before=-1.0)


def test_captured_states_are_the_toy_mocap_on_one_object():
    from hoi_tutorial.samp import evaluation as ev
    from hoi_tutorial.samp.pipeline import RoomRunResults

    obj = md.make_clip("sit", 7)[1]
    clips = ev.captured_states("sit", obj, n=3)
    assert len(clips) == 3 and all(c.shape[-1] == SAMP_STATE_SIZE for c in clips)
    torch.testing.assert_close(clips[1], md.clip_states(md.make_clip("sit", 5001, obj=obj)[0])[0])
    with pytest.raises(ValueError, match="action"):
        ev.captured_states("walk", obj)
    # the room runs read their numbers the same way as the goal runs
    room = RoomRunResults(np.array([1.0, math.inf]), np.array([40.0, math.inf]), np.array([5.0, math.inf]),
                          np.array([False, False]), np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2), rollout=None)
    assert room.summary()["PE"] == 40.0 and room.summary()["execution_time"] == math.inf and room.acted.sum() == 1


def test_onset_in_goal_frame_measures_in_front_aside_and_facing_against_the_goal():
    from hoi_tutorial.samp import evaluation as ev

    walk, sit = SAMP_ACTIONS.index("walk"), SAMP_ACTIONS.index("sit")
    goal, direction = np.array([1.0, 2.0, 0.45]), np.array([1.0, 0.0, 0.0])  # seated facing +x
    # forward (−sin h, cos h) = +x at h = −90°; the onset frame is the first labelled "sit"
    roots = np.array([[0.0, 0.0, 0.0], [1.5, 2.3, -math.pi / 2 + math.radians(30.0)], [1.2, 2.0, -math.pi / 2]])
    out = ev.onset_in_goal_frame(roots, [walk, sit, sit], goal, direction)
    assert out["in_front"] == pytest.approx(0.5) and out["aside"] == pytest.approx(0.3)  # +y is left of +x
    assert out["facing_off"] == pytest.approx(30.0)
    # the same run turned and moved with its goal measures the same
    turn = rotation_about_z(torch.tensor(0.7, dtype=torch.float64)).numpy()
    moved = roots.copy()
    moved[:, :2] = roots[:, :2] @ turn[:2, :2].T + [3.0, -1.0]
    moved[:, 2] += 0.7
    again = ev.onset_in_goal_frame(moved, [walk, sit, sit], turn @ goal + [3.0, -1.0, 0.0], turn @ direction)
    assert all(again[k] == pytest.approx(out[k]) for k in out)
    never = ev.onset_in_goal_frame(roots, [walk] * 3, goal, direction)
    assert all(math.isnan(v) for v in never.values())
    with pytest.raises(ValueError, match="actions"):
        ev.onset_in_goal_frame(roots, [walk, sit], goal, direction)


def test_execution_time_is_paired_over_every_run_a_failure_counted_as_the_time_limit():
    from hoi_tutorial.samp import evaluation as ev

    def results(times):
        times = np.asarray(times, dtype=float)
        return ev.GoalRunResults(times, np.zeros_like(times), np.zeros_like(times), np.isfinite(times), rollout=None)

    inf = math.inf
    a = results([2.0, 3.0, inf, 4.0])
    b = results([3.0, 3.5, 5.0, inf])
    both = ev.paired_execution_time(a, b, time_limit=20.0)
    assert both.n == 4 and both.estimate == pytest.approx(((2 - 3) + (3 - 3.5) + (20 - 5) + (4 - 20)) / 4)
    acted = ev.paired_over_acted(a, b, "execution_time")
    assert acted.n == 2  # the failures dropped: the other way of pairing
    pooled = ev.paired_execution_time([a, a], [b, b], time_limit=20.0)
    assert pooled.n == 8 and pooled.estimate == pytest.approx(both.estimate)
    with pytest.raises(ValueError, match="time_limit"):
        ev.paired_execution_time(a, b, time_limit=inf)
    with pytest.raises(ValueError, match="same tasks"):
        ev.paired_execution_time(a, results([1.0]), time_limit=20.0)


def test_the_captured_execution_time_starts_where_the_task_starts():
    from hoi_tutorial.samp import evaluation as ev

    tasks = ev.goal_tasks("sit", 2, seed=0)
    times = ev.captured_execution_times(tasks)
    assert times.shape == (2,) and np.all(np.isfinite(times)) and np.all(times > 1.0)
    # a start farther from the seat takes longer: the same task moved back along the way to the goal by 2 m
    far = [dataclasses.replace(t, start_root=np.r_[t.start_root[:2] + 2.0 * (t.start_root[:2] - t.goal_position[:2])
                                                   / np.linalg.norm(t.start_root[:2] - t.goal_position[:2]),
                                                   t.start_root[2]]) for t in tasks]
    assert np.all(ev.captured_execution_times(far) > times)
    np.testing.assert_array_equal(ev.captured_execution_times(tasks), times)  # deterministic for its seeds
