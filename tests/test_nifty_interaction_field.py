"""NIFTY's object interaction field (§3.2) and the guided sampling it drives (Eq. 4, §4.1)."""
import dataclasses
import functools

import numpy as np
import pytest
import torch

from hoi_tutorial.nifty import guidance
from hoi_tutorial.nifty import interaction_field as field_module
from hoi_tutorial.nifty.anchors import Anchor
from hoi_tutorial.nifty.interaction_field import (InteractionField, field_training_pairs, interaction_field_config,
                                                  simplified_pose, to_field_frame, train_interaction_field)
from hoi_tutorial.nifty.motion_model import (InteractionTensors, build_motion_model, motion_model_config,
                                             sample_motions, sample_motions_with_record)
from hoi_tutorial.nifty.motion_prior import PoseTrack
from hoi_tutorial.nifty.rollout import InteractionSequence
from hoi_tutorial.nn.diffusion import guided_x0
from hoi_tutorial.world.features import NIFTY_STATE_LAYOUT
from hoi_tutorial.world.mocap import generate_clip
from hoi_tutorial.world.objects import make_object

FRAMES = 31


@pytest.fixture(scope="module")
def sit_tensors():
    """Three short sit clips ending at their settle frame, as the motion model's tensors."""
    records = []
    for seed, (x, y, yaw) in enumerate([(0.5, -1.0, 0.3), (-1.0, 2.0, 2.0), (2.0, 0.5, -1.0)]):
        obj = make_object("chair", seed=seed).placed(x, y, yaw)
        clip = generate_clip("sit", seed=seed, obj=obj)
        a = int(clip.meta["anchor_frame"])
        pose = PoseTrack(clip.local_rotations[a], clip.root_position[a], clip.joints[a])
        anchor = Anchor("sit", pose, pose, clip.betas, seed, obj, clip)
        records.append(InteractionSequence(clip.slice(a - FRAMES + 1, a + 1), obj, anchor))
    return records, InteractionTensors.from_sequences(records, FRAMES, 64, seed=0)


def _tiny_model(tensors):
    config = motion_model_config("sit", "toy", max_frames=FRAMES, width=32, layers=1, heads=4, n_points=64,
                                 pointnet_hidden=(32,), diffusion_steps=10, steps=2, batch_size=2, warmup_steps=0)
    mean, std = tensors.normalisation()
    return build_motion_model(config, mean, std).eval()


def _tiny_field_config(**overrides):
    values = dict(width=32, layers=1, heads=4, pointnet_hidden=(32,), copies_per_sequence=2, steps=30,
                  batch_size=8)
    values.update(overrides)
    return interaction_field_config("sit", "toy", **values)


def _rigid(yaw, shift):
    out = torch.eye(4)
    c, s = np.cos(yaw), np.sin(yaw)
    out[:2, :2] = torch.tensor([[c, -s], [s, c]])
    out[:3, 3] = torch.tensor(shift)
    return out


def test_training_pairs_target_the_ground_truth_minus_the_prediction(sit_tensors):
    """With a model that denoises perfectly, the invalid poses are the ground truth (offset 0) unless a
    rigid transform moved them; the targets are the last frames' joints in each chair's own frame."""
    records, tensors = sit_tensors
    model = _tiny_model(tensors)
    clean = model.normalise(tensors.states)
    model.denoise = lambda x_k, k, encoded, drop_cond=None, **kwargs: clean.repeat(x_k.shape[0] // len(clean), 1, 1)
    config = _tiny_field_config(copies_per_sequence=4, augment_fraction=0.5, seed=3)
    pairs = field_training_pairs(model, tensors, config)
    assert len(pairs) == 4 * len(records) and pairs.poses.shape == (12, 1, 23, 3)
    offsets = pairs.offsets.flatten(1).norm(dim=1)
    assert pairs.augmented.any() and (~pairs.augmented).any()
    assert offsets[~pairs.augmented].max() < 1e-4
    assert offsets[pairs.augmented].min() > 1e-3
    for row in range(len(pairs)):
        record = records[int(pairs.sequence[row])]
        world = torch.cat([record.motion.joints[-1], record.motion.root_position[-1:]]).double().numpy()
        expected = torch.as_tensor(record.obj.to_canonical(world), dtype=torch.float32)
        torch.testing.assert_close(pairs.targets[row, 0], expected, atol=1e-4, rtol=1e-5)


def test_training_pairs_come_from_the_models_own_predictions(sit_tensors):
    _, tensors = sit_tensors
    model = _tiny_model(tensors)  # untrained: its predictions are far from the data
    pairs = field_training_pairs(model, tensors, _tiny_field_config(augment_fraction=0.0))
    assert pairs.offsets.flatten(1).norm(dim=1).min() > 0.01
    assert (pairs.step >= 0).all() and (pairs.step < model.config.diffusion_steps).all()
    again = field_training_pairs(model, tensors, _tiny_field_config(augment_fraction=0.0))
    torch.testing.assert_close(pairs.poses, again.poses, rtol=0, atol=0)  # seeded


def test_field_learns_the_offsets(sit_tensors):
    _, tensors = sit_tensors
    model = _tiny_model(tensors)
    config = _tiny_field_config(steps=150, lr=3e-3)
    pairs = field_training_pairs(model, tensors, config)
    field, result = train_interaction_field(pairs, config)
    zero_field = pairs.offsets.abs().mean().item()
    assert np.mean(result.losses[-10:]) < 0.7 * zero_field  # better than answering 0
    assert not field.training


@pytest.mark.parametrize("output", ["offset", "distance"])
def test_object_frame_field_is_invariant_to_moving_person_and_object_together(sit_tensors, output):
    """The same interaction seen from another canonical frame: the object-frame field gives the same
    objective; a human-frame field need not."""
    _, tensors = sit_tensors
    states, cond = tensors.states[:2], tensors.condition(slice(0, 2))
    moved_states = states.clone()
    transform = _rigid(0.7, [0.4, -0.3, 0.0])
    for name in ("joint_positions", "root_position", "joint_velocities", "root_velocity"):
        part = moved_states[..., NIFTY_STATE_LAYOUT[name]].reshape(2, FRAMES, -1, 3)
        moved = part @ transform[:3, :3].T + (transform[:3, 3] if name.endswith("positions") or name == "root_position"
                                               else 0.0)  # velocities rotate, positions also move
        moved_states[..., NIFTY_STATE_LAYOUT[name]] = moved.reshape(2, FRAMES, -1)
    canonical_from_object = torch.eye(4).repeat(2, 1, 1)
    canonical_from_object[:, :3, :] = cond["object_pose"].reshape(2, 3, 4)
    moved_cond = dict(cond, object_pose=(transform @ canonical_from_object)[:, :3, :].reshape(2, 12))
    values = {}
    for frame in ("object", "human"):
        torch.manual_seed(0)
        field = InteractionField(_tiny_field_config(frame=frame, output=output)).eval()
        g = guidance.field_objective(field, cond)(states)
        g_moved = guidance.field_objective(field, moved_cond)(moved_states)
        values[frame] = (g, g_moved)
    torch.testing.assert_close(values["object"][0], values["object"][1], atol=1e-4, rtol=1e-4)
    assert not torch.allclose(values["human"][0], values["human"][1], atol=1e-4, rtol=1e-4)


def test_simplified_pose_places_the_pose_where_the_integrated_root_ends(sit_tensors):
    from hoi_tutorial.world.features import nifty_state_to_pose

    _, tensors = sit_tensors
    states = tensors.states[:2]
    # Data: the integrated root and t^p agree, so the simplified pose is j^p and t^p as they are.
    pose = simplified_pose(states, 1)[:, 0]
    torch.testing.assert_close(pose[:, -1], states[:, -1, NIFTY_STATE_LAYOUT["root_position"]], atol=1e-4, rtol=1e-5)
    # Velocities that walk 1 m further along +x than t^p says: the pose moves with the integrated root.
    drifted = states.clone()
    drifted[:, :-1, NIFTY_STATE_LAYOUT["root_velocity"].start] += 30.0 / (FRAMES - 1)  # 1 m over the clip at 30 fps
    moved = simplified_pose(drifted, 1)[:, 0]
    _, root = nifty_state_to_pose(drifted)
    torch.testing.assert_close(moved[:, -1, :2], root[:, -1, :2].float(), atol=1e-4, rtol=1e-5)
    torch.testing.assert_close(moved - pose, torch.tensor([1.0, 0.0, 0.0]).expand_as(pose), atol=1e-4, rtol=1e-5)
    # Padding frames hold still: with every frame after the first marked as padding, only the first step counts.
    valid = torch.zeros(2, FRAMES, dtype=torch.bool)
    valid[:, 0] = True
    still = simplified_pose(drifted, 1, valid)[:, 0]
    first = drifted[:, 0, NIFTY_STATE_LAYOUT["root_position"]][:, :2]
    step = drifted[:, 0, NIFTY_STATE_LAYOUT["root_velocity"]][:, :2] / 30.0
    torch.testing.assert_close(still[:, -1, :2], first + step)


def _tiny_model_and_field(tensors):
    """A tiny motion model and an untrained field with seeded weights (the guidance tests' pair)."""
    model = _tiny_model(tensors)
    torch.manual_seed(1)
    return model, InteractionField(_tiny_field_config()).eval()


def test_guidance_with_the_field_lowers_the_objective_on_a_fixed_noisy_input(sit_tensors):
    _, tensors = sit_tensors
    model, field = _tiny_model_and_field(tensors)
    cond = tensors.condition()
    objective = guidance.field_objective(field, cond)
    encoded = model.encode_condition(cond)
    k = torch.full((len(tensors),), 1)
    x_k = model.normalise(tensors.states) + 0.1 * torch.randn(tensors.states.shape,
                                                              generator=torch.Generator().manual_seed(2))

    def x0_fn(x):
        # A denoiser near k = 0 returns (about) its input: the guidance gradient with respect to x_k is
        # then the field's own gradient, a descent direction of G.
        return x + 0.0 * model.denoise(x, k, encoded)

    x0_tilde, before = guided_x0(x0_fn, x_k, lambda x0: objective(model.denormalise(x0)), alpha=0.05)
    after = objective(model.denormalise(x0_tilde))
    assert (after < before).all()


def test_best_of_n_keeps_the_lowest_objective(sit_tensors):
    _, tensors = sit_tensors
    model, field = _tiny_model_and_field(tensors)
    out = guidance.guided_samples(model, tensors.condition(), functools.partial(guidance.field_objective, field),
                                  n_samples=3, alpha=0.1, generator=torch.Generator().manual_seed(0))
    assert out.states.shape == (3, FRAMES, tensors.states.shape[-1]) and out.all_objectives.shape == (3, 3)
    torch.testing.assert_close(out.objective, out.all_objectives.min(dim=1).values)
    assert torch.equal(out.chosen, out.all_objectives.argmin(dim=1))


def test_selection_only_is_unguided_sampling_selected_by_the_same_objective(sit_tensors):
    # Chapter 6's "selection only" control: alpha = 0 draws exactly the unguided samples (same noise) and keeps
    # the one the same G scores lowest; a positive alpha moves the samples.
    _, tensors = sit_tensors
    model, field = _tiny_model_and_field(tensors)
    cond = tensors.condition()
    objective_for = functools.partial(guidance.field_objective, field)
    selected = guidance.guided_samples(model, cond, objective_for, n_samples=3, alpha=0.0,
                                       generator=torch.Generator().manual_seed(0))
    unguided = sample_motions(model, cond, generator=torch.Generator().manual_seed(0), n_samples=3)
    with torch.no_grad():
        values = objective_for(cond, 3)(unguided).reshape(3, 3)
    torch.testing.assert_close(selected.all_objectives, values)
    rows = torch.arange(3)
    torch.testing.assert_close(selected.states, unguided.reshape(3, 3, *unguided.shape[1:])[rows, values.argmin(1)])
    guided = guidance.guided_samples(model, cond, objective_for, n_samples=3, alpha=0.1,
                                     generator=torch.Generator().manual_seed(0))
    assert not torch.allclose(guided.all_objectives, selected.all_objectives)
    with pytest.raises(ValueError, match="alpha"):
        guidance.guided_samples(model, cond, objective_for, n_samples=3, alpha=-1.0, generator=torch.Generator())


def test_nearest_anchor_objective_is_zero_at_an_anchor(sit_tensors):
    records, tensors = sit_tensors
    anchors = guidance.anchor_simplified_poses([r.anchor for r in records])
    assert anchors.shape == (3, 23, 3)
    objective = guidance.nearest_anchor_objective(anchors, tensors.condition())
    values = objective(tensors.states)  # the sequences end in their anchors
    assert values.max() < 1e-6
    # Their training poses in the field's object frame are the anchors themselves.
    poses, _ = to_field_frame(simplified_pose(tensors.states), tensors.points, tensors.object_pose, "object")
    torch.testing.assert_close(poses[:, 0], anchors, atol=1e-4, rtol=1e-5)
    shifted = tensors.states.clone()
    shifted[..., NIFTY_STATE_LAYOUT["joint_positions"]] += 0.1
    assert objective(shifted).min() > 0.01
    # Restricted to the anchors of each scene's object (D.1), a sequence whose own anchor is excluded is not at 0,
    # and its value is the distance to the nearest anchor it may use.
    others = ~torch.eye(3, dtype=torch.bool)
    restricted = guidance.nearest_anchor_objective(anchors, tensors.condition(), allowed=others)(tensors.states)
    spread = (anchors[:, None] - anchors[None]).pow(2).flatten(2).sum(-1) + torch.diag(torch.full((3,), float("inf")))
    torch.testing.assert_close(restricted, spread.min(dim=1).values, atol=1e-4, rtol=1e-4)
    own = guidance.nearest_anchor_objective(anchors, tensors.condition(), allowed=torch.eye(3, dtype=torch.bool))
    assert own(tensors.states).max() < 1e-6
    with pytest.raises(ValueError, match="allowed"):
        guidance.nearest_anchor_objective(anchors, tensors.condition(), allowed=torch.zeros(3, 3, dtype=torch.bool))


def test_bad_inputs_name_what_was_expected(sit_tensors):
    _, tensors = sit_tensors
    with pytest.raises(ValueError, match="action"):
        interaction_field_config("dance")
    with pytest.raises(ValueError, match="frame"):
        interaction_field_config("sit", frame="world")
    with pytest.raises(TypeError, match="unknown field"):
        interaction_field_config("sit", widht=8)
    field = InteractionField(_tiny_field_config())
    with pytest.raises(ValueError, match="poses"):
        field(torch.zeros(2, 1, 22, 3), torch.zeros(2, 10, 3))
    with pytest.raises(ValueError, match="states"):
        simplified_pose(torch.zeros(2, 5, 300))
    with pytest.raises(ValueError, match="anchor"):
        guidance.anchor_simplified_poses([])
    with pytest.raises(ValueError, match="anchor_poses"):
        guidance.nearest_anchor_objective(torch.zeros(0, 23, 3), tensors.condition())
    with pytest.raises(ValueError, match="cond"):
        guidance.field_objective(field, {"betas": tensors.betas})
    with pytest.raises(ValueError, match="n_samples"):
        guidance.guided_samples(_tiny_model(tensors), tensors.condition(), n_samples=0,
                                generator=torch.Generator())
    lift = interaction_field_config("lift", "toy")
    with pytest.raises(ValueError, match="action"):
        field_training_pairs(_tiny_model(tensors), tensors, lift)


def test_config_presets():
    assert interaction_field_config("sit") == field_module.InteractionFieldConfig()
    assert interaction_field_config("lift", "paper").lr == 5e-5  # NIFTY §4.1
    assert interaction_field_config("lift", "paper").steps == 300_000


def test_field_anchor_subset_takes_a_share_of_the_training_anchors(sit_tensors):
    from hoi_tutorial.nifty.data import SyntheticDataset, synthetic_data_config

    records, _ = sit_tensors
    anchors = [r.anchor for r in records] + [records[0].anchor.__class__(**vars(records[0].anchor))]  # one unused
    dataset = SyntheticDataset(config=synthetic_data_config("sit"), anchors=anchors, sequences=records, leaves=[],
                               all_paths=[], tree_stats=[], stats={})
    assert dataset.training_anchor_index == [0, 1, 2]  # the copy grew no sequence
    assert field_module.field_anchor_subset(dataset, _tiny_field_config()) == [0, 1, 2]
    half = field_module.field_anchor_subset(dataset, _tiny_field_config(anchor_fraction=0.5))
    assert len(half) == 2 and set(half) <= {0, 1, 2}  # ceil(0.5 x 3)
    assert len(field_module.field_anchor_subset(dataset, _tiny_field_config(anchor_fraction=0.01))) == 1
    assert half == field_module.field_anchor_subset(dataset, _tiny_field_config(anchor_fraction=0.5))
    with pytest.raises(ValueError, match="anchor_fraction"):
        _tiny_field_config(anchor_fraction=0.0)
    with pytest.raises(ValueError, match="anchor_fraction"):
        _tiny_field_config(anchor_fraction=1.5)


def test_guiding_the_last_step_changes_only_the_final_step(sit_tensors):
    # The Trace and Pace code skips guidance at k = 0; guide_last_step adds it. The steps before are the same, so
    # the samples differ, by one more guided update of the last prediction.
    _, tensors = sit_tensors
    model, field = _tiny_model_and_field(tensors)
    cond = tensors.condition()
    objective_for = functools.partial(guidance.field_objective, field)
    runs = {flag: guidance.guided_samples(model, cond, objective_for, n_samples=2, alpha=0.1, guide_last_step=flag,
                                          generator=torch.Generator().manual_seed(0)) for flag in (False, True)}
    assert not torch.allclose(runs[False].all_objectives, runs[True].all_objectives)
    # Both runs reach the last step from the same input; only its update differs.
    steps = model.config.diffusion_steps
    record = {flag: sample_motions_with_record(model, cond, generator=torch.Generator().manual_seed(0), n_samples=2,
                                               guidance=objective_for(cond, 2), alpha=0.1,
                                               guidance_steps=range(steps) if flag else None)
              for flag in (False, True)}
    torch.testing.assert_close(record[False].x_k[-1], record[True].x_k[-1], rtol=0, atol=0)  # same input to k = 0
    assert not torch.equal(record[False].sample, record[True].sample)
    with pytest.raises(ValueError, match="guide_last_step"):
        guidance.guided_samples(model, cond, objective_for, alpha=0.1, guide_last_step=1, generator=torch.Generator())


def test_each_field_variant_guides_with_its_own_step_size():
    from hoi_tutorial.nifty import guidance

    table = guidance.GUIDANCE_ALPHA
    variants = {"offset": {}, "distance": {"output": "distance"}, "human frame": {"frame": "human"},
                "5 frames": {"n_frames": 5}}
    for name, overrides in variants.items():
        config = interaction_field_config("lift", "toy", **overrides)
        assert field_module.field_variant(config) == name
        assert guidance.step_size(config) == table[name]
    # The share of anchors (Table 5) keeps the offset field's form, and its α.
    assert guidance.step_size(interaction_field_config("sit", anchor_fraction=0.5)) == table["offset"]
    # Derived by replace, a config takes its new variant's α.
    five = dataclasses.replace(interaction_field_config("sit"), n_frames=5)
    assert guidance.step_size(five) == table["5 frames"]
    assert guidance.step_size(None, "nearest_anchor") == table["nearest_anchor"]
    with pytest.raises(ValueError, match="no step size was chosen"):
        guidance.step_size(interaction_field_config("sit", n_frames=10))
    with pytest.raises(ValueError, match="field_config"):
        guidance.step_size(None, "field")
    with pytest.raises(ValueError, match="objective"):
        guidance.step_size(interaction_field_config("sit"), "random")


def test_the_guidance_step_sizes_are_outside_the_trained_fields_code():
    # A trained field's cache key hashes its module's import closure: choosing α again must not retrain a field.
    from hoi_tutorial.infra.code_closure import code_closure

    closure = code_closure(field_module)
    assert "hoi_tutorial.nifty.interaction_field" in closure
    assert "hoi_tutorial.nifty.guidance" not in closure and "hoi_tutorial.nifty.evaluation" not in closure


def test_field_training_runs_on_one_thread(sit_tensors, monkeypatch):
    # A chapter's kernel (two torch threads) and a warm_cache worker (one) must train the same field.
    _, tensors = sit_tensors
    config = _tiny_field_config(steps=2)
    pairs = field_training_pairs(_tiny_model(tensors), tensors, config)
    seen = []

    def spy(*args, **kwargs):
        seen.append(torch.get_num_threads())
        return real(*args, **kwargs)

    real = field_module.train
    monkeypatch.setattr(field_module, "train", spy)
    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        train_interaction_field(pairs, config)
    finally:
        torch.set_num_threads(threads)
    assert seen == [1]
