"""NIFTY's object-conditioned motion diffusion model (§3.1, Appendix B): tensorisation, model,
training, sampling, the Appendix B recovery and the evaluation helpers."""
import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from hoi_tutorial.nifty.data import SyntheticDataset, synthetic_data_config
from hoi_tutorial.nifty.motion_model import (
    CONDITION_KEYS,
    InteractionTensors,
    MotionModelConfig,
    NiftyMotionModel,
    anchor_skeleton_distance,
    build_motion_model,
    canonical_from_world_matrix,
    final_pelvis_distance,
    interaction_condition,
    motion_model_config,
    sample_motions,
    states_to_motions,
    train_motion_model,
    trained_motion_model,
)
from hoi_tutorial.nifty.rollout import InteractionSequence
from hoi_tutorial.world.features import NIFTY_STATE_LAYOUT, NIFTY_STATE_SIZE, canonicalize, nifty_pose_state, nifty_state_to_pose
from hoi_tutorial.world.mocap import generate_clip
from hoi_tutorial.world.objects import make_object
from hoi_tutorial.world.skeleton import joint_index

PELVIS = joint_index("pelvis")
FRAMES = 61  # two seconds up to the anchor keep the tests fast; the toy preset uses 121


def rigid(yaw: float, translation) -> np.ndarray:
    out = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    out[:2, :2] = [[c, -s], [s, c]]
    out[:3, 3] = translation
    return out


def small_config(**overrides) -> MotionModelConfig:
    base = dict(max_frames=FRAMES, width=32, layers=1, heads=4, n_points=64, pointnet_hidden=(32,),
                diffusion_steps=20, steps=20, batch_size=4, warmup_steps=0, dropout=0.0)
    return motion_model_config("sit", "toy", **{**base, **overrides})


@pytest.fixture(scope="module")
def walk_clip():
    return generate_clip("walk", seed=0)


@pytest.fixture(scope="module")
def sit_records():
    """Two toy-mocap sit clips, each cut to end at its anchor (settle) frame, with its chair."""
    records = []
    for seed, (x, y, yaw) in enumerate([(0.5, -1.0, 0.3), (-1.0, 2.0, 2.0)]):
        obj = make_object("chair", seed=seed).placed(x, y, yaw)
        clip = generate_clip("sit", seed=seed, obj=obj)
        anchor = int(clip.meta["anchor_frame"])
        records.append(InteractionSequence(clip.slice(anchor - FRAMES + 1, anchor + 1), obj, None))
    return records


@pytest.fixture(scope="module")
def overfit(sit_records):
    """A model overfit on the two sit sequences (~200 steps)."""
    config = small_config(width=64, layers=2, n_points=128, pointnet_hidden=(64, 128), diffusion_steps=50,
                          steps=200, batch_size=8, lr=2e-3, warmup_steps=20)
    tensors = InteractionTensors.from_sequences(sit_records, FRAMES, config.n_points, seed=0)
    model, result = train_motion_model(tensors, config)
    return config, tensors, model, result


# --------------------------------------------------------------------------- configuration


def test_presets_name_the_paper_sizes():
    toy, paper = motion_model_config("sit", "toy"), motion_model_config("lift", "paper")
    assert (toy.max_frames, toy.width, toy.layers, toy.heads, toy.diffusion_steps, toy.n_points) == \
        (121, 64, 2, 4, 50, 256)
    assert (paper.max_frames, paper.width, paper.layers, paper.heads, paper.diffusion_steps, paper.n_points,
            paper.lr, paper.batch_size, paper.p_uncond, paper.guidance_scale, paper.dropout) == \
        (150, 512, 8, 4, 1000, 5000, 1e-4, 32, 0.1, 2.5, 0.1)
    assert motion_model_config("sit", "small", steps=7).steps == 7


def test_bad_configuration_is_rejected():
    with pytest.raises(ValueError, match="action"):
        motion_model_config("dance", "toy")
    with pytest.raises(ValueError, match="heads"):
        MotionModelConfig(width=30, heads=4)
    with pytest.raises(ValueError, match="scale"):
        motion_model_config("sit", "huge")


# --------------------------------------------------------------------------- tensorisation


def test_padding_repeats_the_last_frame(sit_records):
    short = InteractionSequence(sit_records[0].motion.slice(0, 40), sit_records[0].obj, None)
    tensors = InteractionTensors.from_sequences([short, sit_records[1]], FRAMES, 32, seed=0)
    assert tensors.states.shape == (2, FRAMES, NIFTY_STATE_SIZE)
    assert tensors.lengths.tolist() == [40, FRAMES]
    assert tensors.valid[0, :40].all() and not tensors.valid[0, 40:].any() and tensors.valid[1].all()
    expected = nifty_pose_state(short.motion)
    torch.testing.assert_close(tensors.states[0, :40], expected)
    torch.testing.assert_close(tensors.states[0, 40:], expected[-1:].expand(FRAMES - 40, -1))
    # statistics come from the valid frames only
    mean, std = tensors.normalisation()
    torch.testing.assert_close(mean, tensors.states[tensors.valid].mean(0))
    assert bool((std >= 1e-2).all())


def test_truncation_keeps_the_ending(walk_clip):
    obj = make_object("box", seed=0).placed(1.0, 1.0, 0.0)
    tensors = InteractionTensors.from_sequences([InteractionSequence(walk_clip, obj, None)], 50, 16)
    assert tensors.lengths.tolist() == [50] and tensors.valid.all()
    kept = walk_clip.slice(len(walk_clip) - 50, len(walk_clip))
    torch.testing.assert_close(tensors.states[0], nifty_pose_state(kept))
    # mapped back to the world, the last state's pelvis is the clip's last pelvis
    pelvis = tensors.states[0, -1, PELVIS * 3:PELVIS * 3 + 3].double()
    world = tensors.world_from_canonical[0].double()
    torch.testing.assert_close(world[:3, :3] @ pelvis + world[:3, 3], walk_clip.joints[-1, PELVIS].double(),
                               atol=1e-4, rtol=1e-5)


def test_start_pose_condition_is_frame_zero(sit_records):
    tensors = InteractionTensors.from_sequences(sit_records, FRAMES, 32, seed=0)
    # The start pose is computed from a 2-frame slice, the states from the whole clip: the same formula through
    # other kernel paths. The velocities are finite differences at 30 fps, which multiply the float32 positions'
    # last bits (2.4e-7 at 2 m) by 30: measured 1.4e-5 on one CPU, 0 on another. 5e-5 allows 7 ulp.
    torch.testing.assert_close(tensors.start_pose, tensors.states[:, 0], atol=5e-5, rtol=1e-5)
    assert tensors.points.shape == (2, 32, 3) and tensors.betas.shape == (2, 10)
    # the cloud is in the object's canonical frame: the object's SDF is ~0 there once placed back
    obj = sit_records[0].obj
    assert np.abs(obj.sdf(obj.to_world(tensors.points[0].numpy()))).max() < 1e-3
    # one cloud per object: sequences of the same object share it
    shared = InteractionTensors.from_sequences([sit_records[0], sit_records[1], sit_records[0]], FRAMES, 32)
    torch.testing.assert_close(shared.points[0], shared.points[2], rtol=0, atol=0)
    assert not torch.allclose(shared.points[0], shared.points[1])


def test_relative_object_pose_of_a_known_offset(walk_clip):
    canonical = canonicalize(walk_clip.slice(0, 30))
    world_from_canonical = rigid(0.7, (2.0, -1.0, 0.0))
    person = canonical.transformed(0.7, torch.tensor([2.0, -1.0, 0.0]))
    offset = rigid(0.4, (0.3, 1.2, 0.0))  # the object in the person's canonical frame
    obj = make_object("chair", seed=3).with_pose(world_from_canonical @ offset)
    cond = interaction_condition(person, obj, 16)
    np.testing.assert_allclose(cond["object_pose"].numpy(), offset[:3, :4].reshape(-1), atol=1e-5)
    np.testing.assert_allclose(cond["world_from_canonical"].numpy(), world_from_canonical, atol=1e-5)
    np.testing.assert_allclose(canonical_from_world_matrix(person) @ world_from_canonical, np.eye(4), atol=1e-5)


def test_tensorisation_rejects_bad_input():
    with pytest.raises(ValueError, match="sequences"):
        InteractionTensors.from_sequences([], FRAMES, 8)
    with pytest.raises(TypeError, match="motion"):
        InteractionTensors.from_sequences([SimpleNamespace(motion=None, obj=None)], FRAMES, 8)


# --------------------------------------------------------------------------- model


def random_condition(batch: int, n_points: int, seed: int) -> dict:
    g = torch.Generator().manual_seed(seed)
    return {"points": torch.randn(batch, n_points, 3, generator=g), "object_pose": torch.randn(batch, 12, generator=g),
            "betas": torch.randn(batch, 10, generator=g), "start_pose": torch.randn(batch, NIFTY_STATE_SIZE, generator=g)}


def test_model_output_shape_and_condition_checks():
    config = small_config()
    model = build_motion_model(config).eval()
    x = torch.randn(3, FRAMES, NIFTY_STATE_SIZE)
    k = torch.tensor([0, 5, 19])
    assert model(x, k, random_condition(3, 10, 0)).shape == (3, FRAMES, NIFTY_STATE_SIZE)
    assert model(x[:, :20], k, random_condition(3, 10, 0)).shape == (3, 20, NIFTY_STATE_SIZE)
    with pytest.raises(ValueError, match="keys"):
        model(x, k, {"points": torch.zeros(3, 10, 3)})
    with pytest.raises(ValueError, match="object_pose"):
        model(x, k, {**random_condition(3, 10, 0), "object_pose": torch.zeros(3, 16)})


def test_dropped_condition_is_irrelevant():
    model = build_motion_model(small_config()).eval()
    x = torch.randn(2, FRAMES, NIFTY_STATE_SIZE)
    k = torch.tensor([3, 11])
    first, second = random_condition(2, 10, 1), random_condition(2, 10, 2)
    drop = torch.ones(2, dtype=torch.bool)
    with torch.no_grad():
        torch.testing.assert_close(model(x, k, first, drop), model(x, k, second, drop))
        # without the drop, the condition changes the prediction
        assert not torch.allclose(model(x, k, first), model(x, k, second), atol=1e-4)
        # a per-sample drop only affects its own sample
        mixed = model(x, k, first, torch.tensor([True, False]))
        torch.testing.assert_close(mixed[0], model(x, k, second, drop)[0])
        torch.testing.assert_close(mixed[1], model(x, k, first)[1])


def test_training_lowers_the_loss(overfit):
    _, _, model, result = overfit
    assert isinstance(model, NiftyMotionModel) and not model.training
    assert len(result.losses) == 200
    assert np.mean(result.losses[-20:]) < 0.5 * np.mean(result.losses[:20])


def test_training_checks_the_frame_count(sit_records):
    tensors = InteractionTensors.from_sequences(sit_records, FRAMES, 16)
    with pytest.raises(ValueError, match="max_frames"):
        train_motion_model(tensors, small_config(max_frames=FRAMES + 1))


# --------------------------------------------------------------------------- sampling


def test_sampling_is_finite_shaped_and_seeded(overfit):
    config, tensors, model, _ = overfit
    cond = tensors.condition([0, 1])
    a = sample_motions(model, cond, generator=torch.Generator().manual_seed(5), n_samples=2)
    b = sample_motions(model, cond, generator=torch.Generator().manual_seed(5), n_samples=2)
    c = sample_motions(model, cond, generator=torch.Generator().manual_seed(6), n_samples=2)
    assert a.shape == (4, FRAMES, NIFTY_STATE_SIZE) and bool(torch.isfinite(a).all())
    torch.testing.assert_close(a, b, rtol=0, atol=0)
    assert not torch.allclose(a, c)


def test_guidance_hook_moves_the_final_root(overfit):
    """NIFTY Eq. 4 on un-normalised states: pulling the last frame's root towards a target works.

    The gradient is taken through the denoiser with respect to the noisy input; a model overfit
    on two sequences barely depends on that input, hence the large step size.
    """
    config, tensors, model, _ = overfit
    cond = tensors.condition([0])
    target = torch.tensor([0.5, 0.5])
    seen = []

    def objective(states):
        seen.append(states.detach())
        _, root = nifty_state_to_pose(states)  # Appendix B: the integrated root
        return ((root[:, -1, :2] - target) ** 2).sum(-1)

    plain = sample_motions(model, cond, generator=torch.Generator().manual_seed(0), n_samples=3)
    guided = sample_motions(model, cond, generator=torch.Generator().manual_seed(0), n_samples=3,
                            guidance=objective, alpha=600.0)
    assert len(seen) == config.diffusion_steps - 1  # every step but the last
    heights = seen[-1][..., NIFTY_STATE_LAYOUT["root_position"]][..., 2]
    assert bool(((heights > 0.3) & (heights < 1.2)).all())  # metres: the objective sees real states
    assert objective(guided).mean() < 0.75 * objective(plain).mean()


def test_states_to_motions_round_trip(walk_clip):
    """Appendix B recovery: states -> world motions -> states on a real toy clip."""
    obj = make_object("stool", seed=1).placed(0.0, 0.0, 0.0)
    tensors = InteractionTensors.from_sequences([InteractionSequence(walk_clip, obj, None)], 121, 8)
    (motion,) = states_to_motions(tensors.states, tensors.betas, tensors.world_from_canonical, tensors.lengths)
    original = walk_clip.slice(len(walk_clip) - 121, len(walk_clip))
    assert (motion.joints - original.joints).norm(dim=-1).max() < 3e-3  # metres
    torch.testing.assert_close(nifty_pose_state(motion), tensors.states[0], atol=2e-3, rtol=1e-5)


def test_states_to_motions_checks_shapes():
    with pytest.raises(ValueError, match="states"):
        states_to_motions(torch.zeros(2, 10, 300), torch.zeros(10), torch.eye(4))
    with pytest.raises(ValueError, match="lengths"):
        states_to_motions(torch.zeros(1, 10, NIFTY_STATE_SIZE), torch.zeros(10), torch.eye(4), lengths=[11])


def test_overfit_samples_end_nearer_the_object(overfit, sit_records):
    """The acceptance claim in miniature: sampled motions end nearer the object than they start."""
    config, tensors, model, _ = overfit
    states = sample_motions(model, tensors.condition(), generator=torch.Generator().manual_seed(1), n_samples=3)
    betas = tensors.betas.repeat_interleave(3, 0)
    places = tensors.world_from_canonical.repeat_interleave(3, 0)
    for i, motion in enumerate(states_to_motions(states, betas, places)):
        last, first = final_pelvis_distance(motion, sit_records[i // 3].obj)
        assert last < first, (i, last, first)
        assert last < 0.25, (i, last)  # the data end within 4 cm of the seat's centre


# --------------------------------------------------------------------------- evaluation helpers


def test_final_pelvis_distance_of_a_sit_clip(sit_records):
    record = sit_records[0]
    last, first = final_pelvis_distance(record.motion, record.obj)
    centre = torch.as_tensor(record.obj.translation[:2], dtype=torch.float32)
    assert last == pytest.approx(float((record.motion.joints[-1, PELVIS, :2] - centre).norm()), abs=1e-6)
    assert first == pytest.approx(float((record.motion.joints[0, PELVIS, :2] - centre).norm()), abs=1e-6)
    assert last < 0.1 < first


def test_anchor_skeleton_distance(sit_records, walk_clip):
    motion = sit_records[0].motion
    final = motion.joints[-1]
    moved = rigid(1.1, (3.0, -2.0, 0.0))
    R, t = torch.as_tensor(moved[:3, :3], dtype=final.dtype), torch.as_tensor(moved[:3, 3], dtype=final.dtype)
    others = torch.stack([walk_clip.joints[0], final @ R.T + t, sit_records[1].motion.joints[-1]])
    # root frame: the same pose elsewhere in the room is at distance 0
    distance, index = anchor_skeleton_distance(motion, others)
    assert index == 1 and distance < 1e-4
    # object frame: the pose moved with its object is at distance 0; left behind it is not
    obj = sit_records[0].obj
    with_obj = SimpleNamespace(pose=SimpleNamespace(joints=final @ R.T + t), obj=obj.with_pose(moved @ obj.pose))
    left_behind = SimpleNamespace(pose=SimpleNamespace(joints=final @ R.T + t), obj=obj)
    assert anchor_skeleton_distance(motion, [with_obj], obj=obj)[0] < 1e-4
    assert anchor_skeleton_distance(motion, [left_behind], obj=obj)[0] > 1.0
    with pytest.raises(ValueError, match="obj"):
        anchor_skeleton_distance(motion, others, obj=obj)


# --------------------------------------------------------------------------- cache


def test_trained_model_is_cached(tmp_cache, sit_records):
    dataset = SyntheticDataset(config=synthetic_data_config("sit", "toy"), anchors=[], sequences=sit_records,
                               leaves=[], all_paths=[], tree_stats=[], stats={})
    config = small_config(steps=3)
    trained = trained_motion_model(dataset, config, progress=False)
    model, again = trained.model, trained_motion_model(dataset, config, progress=False).model
    assert len(list(tmp_cache.glob("nifty_sit_motion_model-*.pt"))) == 1
    assert trained.details["n_sequences"] == 2 and len(trained.losses) == 3
    for name, value in model.state_dict().items():
        torch.testing.assert_close(value, again.state_dict()[name], rtol=0, atol=0)
    assert not torch.equal(model.state_std, torch.ones(NIFTY_STATE_SIZE))  # statistics travel with the weights
    with pytest.raises(ValueError, match="action"):
        trained_motion_model(dataset, motion_model_config("lift", "toy"), progress=False)


def test_model_code_covers_the_data_pipeline_and_the_toy_world():
    """A change to the mocap, the objects or the data pipeline must retrain the model (cache key)."""
    import hoi_tutorial.world as world
    from hoi_tutorial.nifty import data, motion_model, motion_prior, rollout

    code = motion_model.model_code()
    for module in (world, data, motion_prior, rollout, motion_model):
        assert module in code
