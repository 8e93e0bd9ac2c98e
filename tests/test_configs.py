"""Every component configuration follows one pattern (``infra.presets``): a frozen, hashable
dataclass whose defaults are the ``toy`` preset, and a factory ``xxx_config(scale, **overrides)``
(the action first where there is one) that names what it rejects."""
from __future__ import annotations

import dataclasses
import json
import os
import re
import subprocess
import sys

import pytest
import torch

from hoi_tutorial.infra import SCALES, artifact_key, scaled_config
from hoi_tutorial.nifty import (baselines, data, evaluation, interaction_field, motion_model, motion_prior, rollout,
                                toy2d, trajectories)
from hoi_tutorial.samp import goalnet, motion_data, motionnet
from hoi_tutorial.choice.controller import network, phase
from hoi_tutorial.choice.pick_and_place import demo, environment, goal_library, navigation, scheduler
from hoi_tutorial.choice.planner import baselines as choice_baselines, fields, interactions as choice_interactions, intp

ACTIONS = ("sit", "lift")

# (module, factory name, configuration class, takes an action first)
FACTORIES = [
    (motion_model, "motion_model_config", motion_model.MotionModelConfig, True),
    (data, "synthetic_data_config", data.SyntheticDataConfig, True),
    (motion_prior, "prior_config", motion_prior.PriorConfig, False),
    (rollout, "tree_config", rollout.TreeConfig, False),
    (rollout, "prune_config", rollout.PruneConfig, False),
    (trajectories, "walk_data_config", trajectories.WalkDataConfig, False),
    (trajectories, "trajectory_model_config", trajectories.TrajectoryModelConfig, False),
    (toy2d, "toy2d_config", toy2d.Toy2DConfig, False),
    (evaluation, "evaluation_config", evaluation.EvaluationConfig, False),
    (interaction_field, "interaction_field_config", interaction_field.InteractionFieldConfig, True),
    (baselines, "cond_vae_config", baselines.CondVAEConfig, True),
    (goalnet, "goal_data_config", goalnet.GoalDataConfig, False),
    (goalnet, "goalnet_config", goalnet.GoalNetConfig, False),
    (motion_data, "motion_data_config", motion_data.MotionDataConfig, False),
    (motionnet, "motionnet_config", motionnet.MotionNetConfig, False),
    (fields, "field_config", fields.FieldConfig, False),
    (choice_interactions, "planner_data_config", choice_interactions.PlannerDataConfig, False),
    (intp, "planner_config", intp.PlannerConfig, False),
    (choice_baselines, "diffusion_policy_config", choice_baselines.DiffusionPolicyConfig, False),
    (phase, "phase_config", phase.PhaseConfig, False),
    (environment, "environment_config", environment.EnvironmentConfig, False),
    (goal_library, "library_config", goal_library.LibraryConfig, False),
    (scheduler, "scheduler_config", scheduler.SchedulerConfig, False),
    (navigation, "navigation_config", navigation.NavigationConfig, False),
    (network, "controller_config", network.ControllerConfig, False),
    (demo, "pick_and_place_config", demo.PickAndPlaceConfig, False),
]

CASES = [(module, name, cls, scale, action)
         for module, name, cls, has_action in FACTORIES
         for scale in SCALES
         for action in (ACTIONS if has_action else (None,))]


def _id(case) -> str:
    _, name, _, scale, action = case
    return f"{name}-{scale}" + (f"-{action}" if action else "")


def make(module, name, scale, action, **overrides):
    factory = getattr(module, name)
    return factory(action, scale, **overrides) if action else factory(scale, **overrides)


@pytest.fixture(params=CASES, ids=[_id(c) for c in CASES])
def case(request):
    return request.param


def _nested(config):
    """``(path, configuration)`` for the configuration itself and every configuration inside it."""
    out = [("", config)]
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            out += [(f"{f.name}.{path}".rstrip("."), inner) for path, inner in _nested(value)]
    return out


def test_the_preset_is_a_frozen_hashable_dataclass(case):
    module, name, cls, scale, action = case
    config = make(module, name, scale, action)
    assert type(config) is cls
    assert hash(config) == hash(make(module, name, scale, action))
    for path, inner in _nested(config):
        for f in dataclasses.fields(inner):
            assert not isinstance(getattr(inner, f.name), (list, dict, set, torch.Tensor)), f"{path}.{f.name}"
            with pytest.raises(dataclasses.FrozenInstanceError):
                setattr(inner, f.name, getattr(inner, f.name))


def test_nested_fields_cannot_be_assigned():
    config = data.synthetic_data_config("sit", "toy")
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.prior.steps = 5
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.tree.max_depth = 2
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.prune.penetration = 0.5


@pytest.mark.parametrize("toy_case", [c for c in CASES if c[3] == "toy"], ids=_id)
def test_class_defaults_are_the_toy_preset(toy_case):
    module, name, cls, scale, action = toy_case
    expected = cls() if action is None else dataclasses.replace(cls(), action=action)
    assert make(module, name, "toy", action) == expected


def test_overrides_replace_only_their_field(case):
    module, name, cls, scale, action = case
    preset = make(module, name, scale, action)
    field = next(f.name for f in dataclasses.fields(cls)
                 if type(getattr(preset, f.name)) in (int, float) and f.name != "seed")
    changed = make(module, name, scale, action, **{field: getattr(preset, field) + 1})
    assert getattr(changed, field) == getattr(preset, field) + 1
    assert dataclasses.replace(changed, **{field: getattr(preset, field)}) == preset


def test_an_unknown_field_is_named_with_the_valid_ones(case):
    module, name, cls, scale, action = case
    with pytest.raises(TypeError) as err:
        make(module, name, scale, action, stpes=5)
    message = str(err.value)
    assert message.startswith(f"{name}: unknown field 'stpes'; expected one of ")
    assert all(f.name in message for f in dataclasses.fields(cls))


def test_an_unknown_scale_is_named_with_the_valid_ones(case):
    module, name, cls, scale, action = case
    with pytest.raises(ValueError) as err:
        make(module, name, "huge", action)
    message = str(err.value)
    assert name in message and "'huge'" in message and all(f"'{s}'" in message for s in SCALES)


def test_the_seed_reaches_the_prior_unless_a_whole_prior_is_given():
    for scale in SCALES:
        config = data.synthetic_data_config("lift", scale, seed=3)
        assert config.seed == 3 and config.prior == motion_prior.prior_config(scale, seed=3)
        assert config.tree == rollout.tree_config(scale)
    own = motion_prior.prior_config("small", steps=50)
    config = data.synthetic_data_config("sit", "toy", seed=3, prior=own)
    assert config.prior is own and config.seed == 3 and config.tree == rollout.tree_config("toy")


def test_preset_values_of_the_nested_and_action_dependent_fields():
    assert [motion_prior.prior_config(s).steps for s in SCALES] == [800, 10000, 100000]
    assert [rollout.tree_config(s).max_depth for s in SCALES] == [4, 5, 7]
    assert [data.synthetic_data_config(a, "paper").anchors_per_subject for a in ACTIONS] == [25, 10]
    assert [evaluation.evaluation_config(s).n_scenes for s in SCALES] == [32, 100, 500]


def test_lists_and_tensors_are_stored_as_tuples():
    config = motion_model.motion_model_config("sit", "toy", pointnet_hidden=[32, 64])
    assert config.pointnet_hidden == (32, 64) and hash(config)
    limits = torch.linspace(0.5, 3.0, 22, dtype=torch.float64)
    prune = rollout.prune_config("toy", joint_limits=limits)
    assert prune.joint_limits == tuple(limits.tolist()) and hash(prune)
    with pytest.raises(ValueError, match="joint_limits"):
        rollout.PruneConfig(joint_limits=(1.0, 2.0))


def test_scaled_config_layers_defaults_scale_fixed_and_overrides():
    @dataclasses.dataclass(frozen=True)
    class Demo:
        width: int = 64
        layers: int = 2
        tag: str = "a"

    changes = {"paper": {"width": 512, "layers": 8}}
    assert scaled_config(Demo, "toy", changes, {}, factory="demo_config") == Demo()
    assert scaled_config(Demo, "paper", changes, {"layers": 4}, factory="demo_config",
                         fixed={"tag": "b"}) == Demo(512, 4, "b")
    with pytest.raises(TypeError, match="demo_config: unknown field 'widht'; expected one of width, layers, tag"):
        scaled_config(Demo, "toy", changes, {"widht": 3}, factory="demo_config")


_KEYS_SCRIPT = """
import json, sys
sys.path[:0] = {path!r}
import test_configs as t
print(json.dumps(t.artifact_keys()))
"""


def artifact_keys() -> dict:
    """The artifact-cache key of every preset (configuration and its class's source)."""
    keys = {}
    for module, name, cls, scale, action in CASES:
        config = make(module, name, scale, action)
        keys[_id((module, name, cls, scale, action))] = artifact_key(name, config, code=(cls,))
    return keys


def test_artifact_keys_are_the_same_in_a_fresh_process():
    here = os.path.dirname(os.path.abspath(__file__))
    env = {**os.environ, "PYTHONHASHSEED": "12345"}  # a different str-hash seed than this process's
    out = subprocess.run([sys.executable, "-c", _KEYS_SCRIPT.format(path=[here] + sys.path)],
                         capture_output=True, text=True, env=env, check=True)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == artifact_keys()


# Ranges checked where a configuration is made (Readers III): a bad rate, probability or scale is refused with its
# name, the range expected and the value given, not minutes later inside training (or never); by the configuration's
# own check where it has one, else by _validate.check_numbers.
RANGE_CASES = [
    (motion_model, "motion_model_config", "lr", -1.0),
    (motion_model, "motion_model_config", "dropout", 1.5),
    (motion_model, "motion_model_config", "guidance_scale", float("nan")),
    (motion_model, "motion_model_config", "grad_clip", 0.0),
    (interaction_field, "interaction_field_config", "weight_decay", -0.1),
    (interaction_field, "interaction_field_config", "dropout", 1.0),
    (baselines, "cond_vae_config", "kl_weight", float("inf")),
    (motion_prior, "prior_config", "own_prediction_max", 1.5),
    (trajectories, "trajectory_model_config", "lr", 0.0),
    (toy2d, "toy2d_config", "p_uncond", -0.1),
    (goalnet, "goalnet_config", "lr", "1e-3"),
    (motionnet, "motionnet_config", "kl_weight", -1.0),
    (intp, "planner_config", "near_share", 2.0),
    (choice_baselines, "diffusion_policy_config", "reach", 0.0),
    (environment, "environment_config", "truncation", -0.4),
    (phase, "phase_config", "weight_decay", -1e-4),
    (network, "controller_config", "phase_dropout", 1.0),
    (network, "controller_config", "lr", True),
]


@pytest.mark.parametrize("module, factory, field, value", RANGE_CASES,
                         ids=[f"{factory}-{field}" for _, factory, field, _ in RANGE_CASES])
def test_a_value_out_of_range_is_refused_by_name(module, factory, field, value):
    make = getattr(module, factory)
    args = ("sit",) if factory in ("motion_model_config", "interaction_field_config", "cond_vae_config") else ()
    make(*args, "toy")  # the preset itself passes
    with pytest.raises(ValueError, match=rf"^{field}: expected .*, got {re.escape(repr(value))}$"):
        make(*args, "toy", **{field: value})


def test_the_trainer_and_the_phase_filter_check_their_ranges():
    from hoi_tutorial.choice.controller import kalman
    from hoi_tutorial.infra import TrainerConfig

    for bad in (-1, float("inf"), "1e-3"):  # an infinite rate passed the trainer's own check before
        with pytest.raises(ValueError, match=rf"^lr: expected .*, got {re.escape(repr(bad))}$"):
            TrainerConfig(steps=1, batch_size=1, lr=bad)
    with pytest.raises(ValueError, match=r"^phase_blend: expected .*, got 1.5$"):
        kalman.PhaseFilterConfig(phase_blend=1.5)
    with pytest.raises(ValueError, match=r"^body_width: expected .*, got inf$"):
        kalman.PhaseFilterConfig(body_width=float("inf"))
    kalman.PhaseFilterConfig(body_width=None)
