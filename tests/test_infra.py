"""Tests for hoi_tutorial.infra: presets, seeding, device, artifact cache, trainer, tables."""
from __future__ import annotations

import dataclasses
import importlib.util
import os
import random
import subprocess
import sys
import time

import numpy as np
import pytest
import torch

from hoi_tutorial.infra import cache as cache_module
from hoi_tutorial.infra import (
    SCALES,
    CorruptArtifactWarning,
    TrainerConfig,
    trainer_config,
    artifact_key,
    by_scale,
    cache_dir,
    check_scale,
    choose_device,
    clear_cache,
    format_seconds,
    learning_rate_factor,
    load_or_build,
    rng,
    seed_everything,
    side_by_side,
    state_dict_to_cpu,
    train,
)

from helpers import counting


# ---------------------------------------------------------------------------------- presets


def test_check_scale_accepts_the_three_scales_and_names_them_in_the_error():
    assert [check_scale(s) for s in SCALES] == ["toy", "small", "paper"]
    with pytest.raises(ValueError) as err:
        check_scale("huge")
    assert str(err.value) == "scale: expected one of ['toy', 'small', 'paper'], got 'huge'"


def test_by_scale_picks_the_matching_value():
    assert [by_scale(s, toy=1, small=2, paper=3) for s in SCALES] == [1, 2, 3]
    with pytest.raises(ValueError, match="scale"):
        by_scale("tiny", toy=1, small=2, paper=3)


# ---------------------------------------------------------------------------------- seeding


@pytest.fixture
def restore_determinism():
    enabled = torch.are_deterministic_algorithms_enabled()
    warn_only = torch.is_deterministic_algorithms_warn_only_enabled()
    yield
    torch.use_deterministic_algorithms(enabled, warn_only=warn_only)


def _global_draws():
    return random.random(), np.random.rand(3), torch.rand(3)


def test_seed_everything_repeats_every_global_draw(restore_determinism):
    g1 = seed_everything(7)
    first = _global_draws()
    a = torch.rand(4, generator=g1)
    g2 = seed_everything(7)
    second = _global_draws()
    b = torch.rand(4, generator=g2)
    assert first[0] == second[0]
    np.testing.assert_array_equal(first[1], second[1])
    assert torch.equal(first[2], second[2]) and torch.equal(a, b)
    assert torch.are_deterministic_algorithms_enabled()
    seed_everything(8)
    assert not np.array_equal(np.random.rand(3), first[1])


def test_seed_everything_sets_the_kernels_switch_without_loading_the_compiler():
    # a fresh interpreter: the compiler is loaded nowhere yet, and seed_everything leaves it so; where it is
    # loaded, torch's own call sets its switch too
    code = ("import sys, torch; from hoi_tutorial.infra import seed_everything; seed_everything(0); "
            "a = (torch.are_deterministic_algorithms_enabled(), torch.is_deterministic_algorithms_warn_only_enabled(), "
            "'torch._inductor.config' in sys.modules); import torch._inductor.config as c; c.deterministic = False; "
            "seed_everything(0); print(a, c.deterministic)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["(True,", "True,", "False)", "True"]


def test_seed_validation(restore_determinism):
    with pytest.raises(ValueError, match="seed"):
        seed_everything(-1)
    with pytest.raises(TypeError, match="seed"):
        seed_everything(1.5)
    with pytest.raises(TypeError, match="seed"):
        seed_everything(True)
    assert isinstance(seed_everything(np.int64(3)), torch.Generator)


def test_rng_is_repeatable_and_passes_generators_through():
    assert np.array_equal(rng(3).random(5), rng(3).random(5))
    g = np.random.default_rng(0)
    assert rng(g) is g
    with pytest.raises(ValueError):
        rng(-2)


# ---------------------------------------------------------------------------------- device


def test_choose_device(monkeypatch):
    assert choose_device("cpu") == torch.device("cpu")
    expected = "cuda" if torch.cuda.is_available() else "cpu"
    assert choose_device().type == expected
    with pytest.raises(ValueError, match="'gpu'"):
        choose_device("gpu")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert choose_device("auto") == torch.device("cpu")
    for name in ("cuda", "cuda:0"):
        with pytest.raises(RuntimeError, match="device='auto'"):
            choose_device(name)
    monkeypatch.setattr(torch.backends.mps, "is_available", lambda: False)
    with pytest.raises(RuntimeError, match="mps"):
        choose_device("mps")


# ---------------------------------------------------------------------------------- cache


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("HOI_CACHE", str(folder))
    return folder


@dataclasses.dataclass
class _Config:
    size: int = 3
    scale: float = 0.5
    shape: tuple = (2, 3)


def _rich_artifact():
    return {
        "bool": np.array([True, False]),
        "int64": np.arange(6, dtype=np.int64).reshape(2, 3),
        "float32": np.linspace(0, 1, 5, dtype=np.float32),
        "float64": np.full((2, 0, 3), 1.5),
        "uint16": np.array([1, 65535], dtype=np.uint16),
        "scalar": np.float32(2.5),
        "text": np.array(["sit", "lift"]),
        "tensor": torch.arange(12.0).reshape(3, 4)[1:],  # a view of a larger storage
        "nested": [({"a": 1, "b": None}, torch.tensor([True])), ("x", 2.5, False)],
    }


def _assert_same(a, b):
    assert type(a) is type(b), (type(a), type(b))
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape
        np.testing.assert_array_equal(a, b)
    elif isinstance(a, np.generic):
        assert a.dtype == b.dtype and a == b
    elif isinstance(a, torch.Tensor):
        assert a.dtype == b.dtype and torch.equal(a, b)
    elif isinstance(a, dict):
        assert list(a) == list(b)
        for key in a:
            _assert_same(a[key], b[key])
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b)
        for x, y in zip(a, b):
            _assert_same(x, y)
    else:
        assert a == b


def test_build_then_load_gives_identical_content(isolated_cache, capsys):
    build, calls = counting(_rich_artifact)
    built = load_or_build("rich", _Config(), build)
    assert "[cache] building rich" in capsys.readouterr().out
    loaded = load_or_build("rich", _Config(), build)
    assert "[cache] loaded rich" in capsys.readouterr().out
    assert len(calls) == 1
    _assert_same(built, loaded)
    _assert_same(_rich_artifact(), loaded)
    files = list(isolated_cache.glob("rich-*.pt"))
    assert len(files) == 1 and len(files[0].stem.split("-")[1]) == 16
    # the stored tensor holds only the view's 8 elements, not the 12 of its base
    assert loaded["tensor"].untyped_storage().nbytes() == 8 * 4
    load_or_build("rich", _Config(), build, verbose=False)
    assert capsys.readouterr().out == ""


def test_an_artifact_loaded_again_in_a_process_is_a_copy_of_the_first_load(isolated_cache, monkeypatch, capsys):
    net = torch.nn.Linear(3, 2)
    build, calls = counting(lambda: {**_rich_artifact(), "state": state_dict_to_cpu(net)})
    built = load_or_build("again", _Config(), build)
    real, read = cache_module._load_verified, []
    monkeypatch.setattr(cache_module, "_load_verified", lambda *args: read.append(args) or real(*args))
    first = load_or_build("again", _Config(), build)  # read from the file
    capsys.readouterr()
    second = load_or_build("again", _Config(), build)  # a copy of what was read before
    assert "[cache] loaded again" in capsys.readouterr().out
    assert len(read) == 1 and len(calls) == 1
    _assert_same(built, second)
    assert second["state"]._metadata == built["state"]._metadata  # a state dict's version information kept
    torch.nn.Linear(3, 2).load_state_dict(second["state"])
    first["tensor"].add_(1.0)  # what one caller changes, another does not get
    first["nested"].append("changed")
    first["int64"][0, 0] = 99
    third = load_or_build("again", _Config(), build)
    _assert_same(built, third)
    assert third["tensor"] is not second["tensor"] and len(read) == 1
    # a file written since (another process built it again) is read again
    (path,) = isolated_cache.glob("again-*.pt")
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 10**9))
    _assert_same(built, load_or_build("again", _Config(), build))
    assert len(read) == 2 and len(calls) == 1


def test_hoi_cache_and_xdg_are_honoured(tmp_path, monkeypatch):
    target = tmp_path / "elsewhere"
    monkeypatch.setenv("HOI_CACHE", str(target))
    assert cache_dir() == target and target.is_dir()
    load_or_build("small_thing", {"n": 1}, lambda: {"x": torch.ones(2)}, verbose=False)
    assert len(list(target.glob("small_thing-*.pt"))) == 1
    monkeypatch.delenv("HOI_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "hoi_tutorial"


def test_changed_config_gives_a_new_key_and_a_rebuild():
    def make():
        return np.zeros(2)

    key = artifact_key("thing", _Config(), (make,))
    assert key == artifact_key("thing", _Config(), (make,))
    assert key != artifact_key("thing", _Config(size=4), (make,))
    assert key != artifact_key("thing", _Config(shape=(2, 4)), (make,))
    assert key != artifact_key("other", _Config(), (make,))
    # numpy scalars hash like the python numbers they hold, tuples like lists
    assert artifact_key("thing", {"n": np.int64(3), "s": (1, 2)}, ()) == \
        artifact_key("thing", {"n": 3, "s": [1, 2]}, ())
    build, calls = counting(make)
    load_or_build("thing", _Config(), build, verbose=False)
    load_or_build("thing", _Config(size=4), build, verbose=False)
    load_or_build("thing", _Config(), build, verbose=False)
    assert len(calls) == 2


def test_key_rejects_unsupported_config_and_bad_names():
    with pytest.raises(TypeError, match="set"):
        artifact_key("thing", {"values": {1, 2}}, ())
    with pytest.raises(TypeError, match="object"):
        artifact_key("thing", {"handle": object()}, ())
    for bad in ("has space", "../escape", "", "9lives", 3):
        with pytest.raises(ValueError, match="name"):
            artifact_key(bad, {}, ())


def _producer_a():
    return {"value": np.array([1.0])}


def _producer_b():
    return {"value": np.array([2.0])}


def test_a_changed_producer_function_changes_the_key():
    assert artifact_key("p", {}, (_producer_a,)) != artifact_key("p", {}, (_producer_b,))
    assert load_or_build("p", {}, _producer_a, verbose=False)["value"][0] == 1.0
    assert load_or_build("p", {}, _producer_b, verbose=False)["value"][0] == 2.0


def _import_from(path, name):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_an_edited_module_rebuilds(tmp_path):
    source = tmp_path / "toy_producer.py"
    source.write_text("import numpy as np\n\ndef make():\n    return np.arange(3)\n")
    module = _import_from(source, "toy_producer_v1")
    calls = []

    def build():
        calls.append(1)
        return module.make()

    first = load_or_build("produced", {"n": 3}, build, code=(module,), verbose=False)
    again = load_or_build("produced", {"n": 3}, build, code=(module,), verbose=False)
    np.testing.assert_array_equal(first, again)
    assert len(calls) == 1
    # comments, docstrings and blank lines are not code: the artifact is loaded, not built again
    source.write_text('"""Makes a range."""\nimport numpy as np\n\n\ndef make():\n    """Three numbers."""\n'
                      "    return np.arange(3)  # 0, 1, 2\n\n")
    module = _import_from(source, "toy_producer_v1_prose")
    np.testing.assert_array_equal(load_or_build("produced", {"n": 3}, build, code=(module,), verbose=False), first)
    assert len(calls) == 1
    source.write_text("import numpy as np\n\ndef make():\n    return np.arange(3) * 10\n")
    module = _import_from(source, "toy_producer_v2")
    edited = load_or_build("produced", {"n": 3}, build, code=(module,), verbose=False)
    assert len(calls) == 2
    np.testing.assert_array_equal(edited, [0, 10, 20])


def test_the_caches_own_modules_are_left_out_of_every_key():
    # Every builder imports the cache, which decides how an artifact is stored, not what it holds: mending it (a
    # full disk, a lock) must rebuild nothing. A real builder's import closure reaches it; its key does not.
    from hoi_tutorial.choice.planner import latent_map
    from hoi_tutorial.infra.code_closure import code_closure

    reached = set(code_closure(latent_map.__name__))
    assert cache_module.STORAGE_MODULES <= reached
    hashed = set(cache_module.derived_code([latent_map]))
    assert hashed == reached - cache_module.STORAGE_MODULES and latent_map.__name__ in hashed


@pytest.mark.parametrize("damage", ["truncate", "garbage", "empty"])
def test_a_corrupt_file_is_detected_and_rebuilt(isolated_cache, damage):
    build, calls = counting(lambda: {"w": torch.randn(50, generator=torch.Generator().manual_seed(0))})
    original = load_or_build("fragile", {}, build, verbose=False)
    (path,) = isolated_cache.glob("fragile-*.pt")
    data = path.read_bytes()
    path.write_bytes({"truncate": data[: len(data) // 2], "garbage": b"not a zip file" * 10,
                      "empty": b""}[damage])
    with pytest.warns(CorruptArtifactWarning, match="rebuilding corrupt artifact"):
        rebuilt = load_or_build("fragile", {}, build, verbose=False)
    assert len(calls) == 2 and torch.equal(rebuilt["w"], original["w"])
    assert torch.equal(load_or_build("fragile", {}, build, verbose=False)["w"], original["w"])
    assert len(calls) == 2


def test_checksum_and_key_mismatches_are_rebuilt(isolated_cache):
    build, calls = counting(lambda: {"w": torch.zeros(4)})
    load_or_build("checked", {}, build, verbose=False)
    (path,) = isolated_cache.glob("checked-*.pt")
    blob = torch.load(path, weights_only=True)
    blob["payload"]["w"] = torch.ones(4)  # the stored checksum no longer matches
    torch.save(blob, path)
    with pytest.warns(CorruptArtifactWarning, match="checksum"):
        assert torch.equal(load_or_build("checked", {}, build, verbose=False)["w"], torch.zeros(4))
    blob = torch.load(path, weights_only=True)
    blob["key"] = "0" * 64
    torch.save(blob, path)
    with pytest.warns(CorruptArtifactWarning, match="key"):
        load_or_build("checked", {}, build, verbose=False)
    assert len(calls) == 3


def test_a_new_cache_format_gives_new_keys_and_an_earlier_formats_file_is_rebuilt(isolated_cache, monkeypatch):
    # A format bump (what a key hashes changed its meaning) must rebuild every artifact once, never reuse one.
    key = artifact_key("formatted", {"n": 1}, (_producer_a,))
    with monkeypatch.context() as patch:
        patch.setattr(cache_module, "FORMAT", cache_module.FORMAT - 1)
        assert artifact_key("formatted", {"n": 1}, (_producer_a,)) != key
    build, calls = counting(lambda: {"w": torch.zeros(2)})
    load_or_build("formatted", {}, build, verbose=False)
    (path,) = isolated_cache.glob("formatted-*.pt")
    blob = torch.load(path, weights_only=True)
    blob["format"] = cache_module.FORMAT - 1  # a file written by the library before the bump, under the same name
    torch.save(blob, path)
    with pytest.warns(CorruptArtifactWarning, match="unknown file format"):
        load_or_build("formatted", {}, build, verbose=False)
    assert len(calls) == 2


_EXECUTED = []


def _record_execution(marker):
    _EXECUTED.append(marker)
    return marker


class _Exploit:
    def __reduce__(self):
        return (_record_execution, ("pwned",))


def test_an_arbitrary_pickle_is_rejected_not_executed(isolated_cache):
    build, calls = counting(lambda: {"safe": torch.arange(3)})
    load_or_build("guarded", {}, build, verbose=False)
    (path,) = isolated_cache.glob("guarded-*.pt")
    blob = torch.load(path, weights_only=True)
    blob["payload"] = {"safe": _Exploit()}
    torch.save(blob, path)
    with pytest.warns(CorruptArtifactWarning):
        result = load_or_build("guarded", {}, build, verbose=False)
    assert _EXECUTED == []
    assert torch.equal(result["safe"], torch.arange(3)) and len(calls) == 2


def test_unsupported_artifacts_raise_before_saving(isolated_cache):
    with pytest.raises(TypeError, match="set"):
        load_or_build("bad", {}, lambda: {"items": {1, 2}}, verbose=False)
    with pytest.raises(TypeError, match="object"):
        load_or_build("bad", {}, lambda: np.array([object()]), verbose=False)
    assert list(isolated_cache.glob("bad-*")) == []


def test_clear_cache_removes_only_the_named_artifacts(isolated_cache):
    load_or_build("first", {}, lambda: 1, verbose=False)
    load_or_build("first_more", {}, lambda: 2, verbose=False)
    (isolated_cache / "notes.txt").write_text("keep me")
    assert clear_cache("first") == 1
    assert [p.name.split("-")[0] for p in isolated_cache.glob("*.pt")] == ["first_more"]
    assert clear_cache() == 1
    assert (isolated_cache / "notes.txt").exists()


def test_model_state_round_trip():
    torch.manual_seed(0)
    model = torch.nn.Sequential(torch.nn.Linear(3, 4), torch.nn.BatchNorm1d(4))
    state = load_or_build("tiny_model", {"width": 4}, lambda: state_dict_to_cpu(model),
                          verbose=False)
    state = load_or_build("tiny_model", {"width": 4}, lambda: state_dict_to_cpu(model),
                          verbose=False)
    fresh = torch.nn.Sequential(torch.nn.Linear(3, 4), torch.nn.BatchNorm1d(4))
    fresh.load_state_dict(state)
    for a, b in zip(model.state_dict().values(), fresh.state_dict().values()):
        assert torch.equal(a, b)
    assert state._metadata == model.state_dict()._metadata


# ---------------------------------------------------------------------------------- trainer


def _regression_problem():
    true_w = torch.tensor([[1.5, -2.0, 0.5]])

    def sample_batch(step, generator):
        x = torch.randn(32, 3, generator=generator)
        return {"x": x, "y": x @ true_w.T + 0.3}

    def loss_fn(model, batch):
        loss = torch.nn.functional.mse_loss(model(batch["x"]), batch["y"])
        return loss, {"abs_bias_error": abs(model.bias.item() - 0.3)}

    return sample_batch, loss_fn


def _fresh_linear():
    return torch.nn.Linear(3, 1).requires_grad_(True), torch.Generator().manual_seed(1)


def _init(model, generator):
    with torch.no_grad():
        for p in model.parameters():
            p.copy_(torch.randn(p.shape, generator=generator))
    return model


def test_linear_regression_converges_and_repeats_bit_for_bit():
    sample_batch, loss_fn = _regression_problem()
    config = TrainerConfig(steps=150, lr=0.05, lr_schedule="cosine", warmup_steps=10,
                           device="cpu", progress=False, seed=3, grad_clip=10.0)
    models, results = [], []
    for _ in range(2):
        model = _init(*_fresh_linear())
        results.append(train(model, sample_batch, loss_fn, config))
        models.append(model)
    first = results[0]
    assert len(first.losses) == 150 and first.seconds > 0
    assert np.mean(first.losses[-10:]) < np.mean(first.losses[:10]) / 10
    assert len(first.extra["abs_bias_error"]) == 150
    assert first.losses == results[1].losses
    for a, b in zip(models[0].parameters(), models[1].parameters()):
        assert torch.equal(a, b)


@pytest.mark.parametrize("optimizer, weight_decay", [("adamw", 0.01), ("adam", 0.0), ("adam", 0.01)])
def test_the_trainers_one_update_over_all_parameters_gives_the_loops_bits(monkeypatch, optimizer, weight_decay):
    """The trainer's Adam(W) updates every parameter in one call (``foreach``); torch's loop over them, its
    CPU default, must give the same weights to the last bit, so the switch changed no trained model."""
    from hoi_tutorial.infra import training

    sample_batch, _ = _regression_problem()

    def loss_fn(model, batch):
        return torch.nn.functional.mse_loss(model(batch["x"]), batch["y"])

    def make():
        torch.manual_seed(0)
        return torch.nn.Sequential(torch.nn.Linear(3, 16), torch.nn.Tanh(), torch.nn.Linear(16, 16),
                                   torch.nn.Tanh(), torch.nn.Linear(16, 1))

    config = TrainerConfig(steps=40, device="cpu", progress=False, optimizer=optimizer, weight_decay=weight_decay,
                           grad_clip=0.5, lr_schedule="cosine", warmup_steps=5)
    one_call = make()
    train(one_call, sample_batch, loss_fn, config)
    made, one_call_optimizer = [], training._make_optimizer

    def loop_optimizer(parameters, config):
        made.append(one_call_optimizer(parameters, config, foreach=False))
        return made[-1]

    looped = make()
    monkeypatch.setattr(training, "_make_optimizer", loop_optimizer)
    train(looped, sample_batch, loss_fn, config)
    assert made and made[0].defaults["foreach"] is False
    assert any(not torch.equal(p, q) for p, q in zip(make().parameters(), one_call.parameters()))  # it trained
    for p, q in zip(one_call.parameters(), looped.parameters()):
        assert torch.equal(p, q)


def test_trainer_seeds_dropout_and_restores_global_rng():
    sample_batch, _ = _regression_problem()

    def loss_fn(model, batch):
        return torch.nn.functional.mse_loss(model(batch["x"]), batch["y"])

    def make():
        torch.manual_seed(0)
        return torch.nn.Sequential(torch.nn.Linear(3, 16), torch.nn.Dropout(0.5),
                                   torch.nn.Linear(16, 1))

    config = TrainerConfig(steps=20, device="cpu", progress=False, optimizer="adam")
    a, b = make(), make()
    state_before = torch.random.get_rng_state()
    train(a, sample_batch, loss_fn, config)
    assert torch.equal(torch.random.get_rng_state(), state_before)
    train(b, sample_batch, loss_fn, config)
    for p, q in zip(a.parameters(), b.parameters()):
        assert torch.equal(p, q)
    assert a.training


def test_trainer_errors_and_callbacks():
    sample_batch, _ = _regression_problem()
    config = TrainerConfig(steps=30, device="cpu", progress=False)
    with pytest.raises(ValueError, match="scalar"):
        train(torch.nn.Linear(3, 1), sample_batch,
              lambda m, b: (m(b["x"]) - b["y"]) ** 2, config)
    with pytest.raises(FloatingPointError, match="step 0"):
        train(torch.nn.Linear(3, 1), sample_batch,
              lambda m, b: m(b["x"]).sum() * float("nan"), config)
    seen = []
    result = train(torch.nn.Linear(3, 1), sample_batch,
                   lambda m, b: torch.nn.functional.mse_loss(m(b["x"]), b["y"]), config,
                   callbacks=[lambda step, model, loss, logs: seen.append(step) or step == 4])
    assert seen == [0, 1, 2, 3, 4] and len(result.losses) == 5
    with pytest.raises(ValueError, match="lr_schedule"):
        TrainerConfig(lr_schedule="linear")
    with pytest.raises(ValueError, match="optimizer"):
        TrainerConfig(optimizer="sgd")
    with pytest.raises(ValueError, match="steps"):
        TrainerConfig(steps=0)


def test_losses_read_back_at_an_interval_are_the_per_step_losses():
    sample_batch, loss_fn = _regression_problem()
    runs = []
    for log_every in (1, 10):
        torch.manual_seed(0)
        runs.append(train(torch.nn.Linear(3, 1), sample_batch, loss_fn,
                          TrainerConfig(steps=23, device="cpu", progress=False, log_every=log_every)))
    every, interval = runs
    assert len(interval.losses) == 23 and interval.losses == every.losses
    assert interval.extra["abs_bias_error"] == every.extra["abs_bias_error"]


def test_trainer_config_reads_a_component_config():
    import dataclasses

    @dataclasses.dataclass(frozen=True)
    class Component:
        width: int = 8
        steps: int = 40
        lr: float = 5e-3
        warmup_steps: int = 100
        lr_schedule: str = "cosine"
        seed: int = 7

    config = trainer_config(Component(), device="cpu")
    assert (config.steps, config.lr, config.lr_schedule, config.seed) == (40, 5e-3, "cosine", 7)
    assert config.warmup_steps == 40  # cut to the run's length
    assert config.batch_size == TrainerConfig().batch_size and not config.progress
    assert trainer_config(Component(), batch_size=4).batch_size == 4
    with pytest.raises(TypeError, match="steps"):
        trainer_config({"steps": 3})


def test_learning_rate_schedules():
    assert learning_rate_factor("constant", 50, 100) == 1.0
    assert learning_rate_factor("constant", 0, 100, warmup_steps=10) == pytest.approx(0.1)
    assert learning_rate_factor("cosine", 10, 110, warmup_steps=10) == pytest.approx(1.0)
    assert learning_rate_factor("cosine", 110, 110, warmup_steps=10) == pytest.approx(0.0)
    one = [learning_rate_factor("onecycle", s, 100) for s in range(101)]
    assert one[0] == pytest.approx(1 / 25) and max(one) == pytest.approx(1.0)
    assert int(np.argmax(one)) == 29 and one[99] < 1e-4  # the peak at 0.3 · steps − 1, as in torch


@pytest.mark.parametrize("steps, warmup", [(100, 0), (57, 0), (40, 10)])
def test_onecycle_matches_torch(steps, warmup):
    """The "onecycle" schedule is PyTorch's OneCycleLR (cosine phases, its default divisors)."""
    optimizer = torch.optim.SGD([torch.nn.Parameter(torch.zeros(1))], lr=1.0)
    pct_start = warmup / steps if warmup else 0.3
    scheduler = torch.optim.lr_scheduler.OneCycleLR(optimizer, max_lr=1.0, total_steps=steps, pct_start=pct_start)
    for step in range(steps):
        assert learning_rate_factor("onecycle", step, steps, warmup) == pytest.approx(
            optimizer.param_groups[0]["lr"], rel=1e-9, abs=1e-12)
        optimizer.step()
        scheduler.step()


def test_train_result_plot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sample_batch, loss_fn = _regression_problem()
    result = train(torch.nn.Linear(3, 1), sample_batch, loss_fn,
                   TrainerConfig(steps=60, device="cpu", progress=False))
    ax = result.plot()
    assert ax.get_yscale() == "log" and len(ax.lines) == 2
    plt.close(ax.figure)


# ---------------------------------------------------------------------------------- tables


def test_side_by_side_shape_and_missing_entries():
    pytest.importorskip("pandas")
    paper = {"Cond. VAE": {"D2O": 0.31, "IoU": 0.12}, "NIFTY": {"D2O": 0.08, "IoU": "0.35*"}}
    ours = {"NIFTY": {"D2O": 0.1234, "IoU": 0.3, "Skating": 0.02}, "MLP": {"D2O": 0.5}}
    table = side_by_side(paper, ours, decimals=3, higher_is_better={"IoU": True, "D2O": False})
    assert table.shape == (3, 6)
    assert list(table.index) == ["Cond. VAE", "NIFTY", "MLP"]
    assert list(table.columns.get_level_values("source")[:2]) == ["paper", "ours"]
    assert table.loc["NIFTY", ("D2O ↓", "ours")] == "0.123"
    assert table.loc["NIFTY", ("IoU ↑", "paper")] == "0.35*"
    assert table.loc["Cond. VAE", ("D2O ↓", "ours")] == "—"
    assert table.loc["MLP", ("Skating", "paper")] == "—"
    only = side_by_side(paper, ours, columns=["IoU"])
    assert only.shape == (3, 2)


def test_format_seconds():
    assert format_seconds(0.4234) == "0.42 s"
    assert format_seconds(12.34) == "12.3 s"
    assert format_seconds(125) == "2 min 05 s"
    assert format_seconds(3720) == "1 h 02 min"
    with pytest.raises(ValueError):
        format_seconds(-1)


def _build_square(name, value):
    # Module-level so that a worker process can unpickle it.
    return load_or_build(name, {"value": value}, lambda: torch.tensor(value) ** 2, verbose=False)


def test_cache_only_loads_or_raises(isolated_cache):
    from hoi_tutorial.infra import NotCachedError, cache_only

    with cache_only():
        with pytest.raises(NotCachedError, match="square"):
            _build_square("square", 3.0)
    assert not list(isolated_cache.glob("square-*.pt")) if isolated_cache.exists() else True
    _build_square("square", 3.0)
    with cache_only():
        assert float(_build_square("square", 3.0)) == 9.0


def test_warm_cache_builds_missing_artifacts_in_parallel(isolated_cache):
    import functools

    from hoi_tutorial.infra import warm_cache

    calls = [functools.partial(_build_square, f"square{i}", float(i)) for i in range(3)]
    warm_cache(calls, workers=2)
    for i in range(3):
        assert len(list(isolated_cache.glob(f"square{i}-*.pt"))) == 1
        # What a worker cached is what this process builds.
        assert float(_build_square(f"square{i}", float(i))) == float(i) ** 2
    # Everything cached: nothing is built again (the files are untouched).
    stamps = {p: p.stat().st_mtime_ns for p in isolated_cache.glob("*.pt")}
    warm_cache(calls, workers=2)
    assert {p: p.stat().st_mtime_ns for p in isolated_cache.glob("*.pt")} == stamps


def test_in_order_runs_a_chain_in_one_worker_after_each_other(isolated_cache):
    import functools
    import pickle

    from hoi_tutorial.infra import in_order, warm_cache

    # Two chains of two one-second builds each on two cores: each chain's builds in one process, in order.
    chains = [in_order(functools.partial(_build_slow_pid, f"chain{c}a"), functools.partial(_build_slow_pid, f"chain{c}b"))
              for c in range(2)]
    pickle.dumps(chains[0])  # a worker receives it by pickle
    warm_cache(chains, workers=2)
    pids = {c: [int(_build_slow_pid(f"chain{c}{part}")) for part in "ab"] for c in range(2)}
    assert all(len(set(p)) == 1 for p in pids.values()), pids      # a chain stays in its process
    assert pids[0][0] != pids[1][0], pids                            # and the two chains ran side by side
    first, second = (isolated_cache.glob(f"chain0{part}-*.pt") for part in "ab")
    assert next(first).stat().st_mtime_ns <= next(second).stat().st_mtime_ns   # a before b
    # A chain whose first part is cached and second is not is still missing: it runs (and loads its first part).
    for path in isolated_cache.glob("chain1b-*.pt"):
        path.unlink()
    warm_cache(chains, workers=2)
    assert len(list(isolated_cache.glob("chain1b-*.pt"))) == 1


def test_in_order_refuses_what_it_cannot_run():
    from hoi_tutorial.infra import in_order

    with pytest.raises(ValueError, match="at least one"):
        in_order()
    with pytest.raises(TypeError, match=r"calls\[1\]: expected a callable, got int"):
        in_order(print, 3)


def _build_slow_pid(name):
    # A build that takes a second and records which process made it.
    def build():
        time.sleep(1.0)
        return torch.tensor(os.getpid())

    return load_or_build(name, {}, build, verbose=False)


def _build_failing(name):
    def build():
        raise RuntimeError(f"{name} cannot be built")

    return load_or_build(name, {}, build, verbose=False)


def test_warm_cache_shares_the_queue_between_processes(isolated_cache):
    import functools

    from hoi_tutorial.infra import warm_cache

    # Four one-second builds on two cores: this process must take more than the first one (a
    # worker needs seconds to start, so it cannot have taken the other three by then).
    calls = [functools.partial(_build_slow_pid, f"slow{i}") for i in range(4)]
    warm_cache(calls, workers=2)
    pids = [int(_build_slow_pid(f"slow{i}")) for i in range(4)]
    assert pids.count(os.getpid()) >= 2, pids
    assert len(set(pids)) == 2, pids


def _build_threads(name):
    # A build that records how many torch threads it ran with, and in which process.
    def build():
        time.sleep(0.5)
        return torch.tensor([torch.get_num_threads(), os.getpid()])

    return load_or_build(name, {}, build, verbose=False)


def test_warm_cache_builds_on_one_thread_in_every_process(isolated_cache):
    import functools

    from hoi_tutorial.infra import warm_cache

    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        calls = [functools.partial(_build_threads, f"threads{i}") for i in range(4)]
        warm_cache(calls, workers=2)
        assert torch.get_num_threads() == 2  # restored after
        built = [_build_threads(f"threads{i}").tolist() for i in range(4)]
        assert os.getpid() in [pid for _, pid in built], built  # this process built some too ...
        assert all(threads == 1 for threads, _ in built), built  # ... on one thread, as the workers did
    finally:
        torch.set_num_threads(before)


def _build_talking(name):
    # A one-second build that says what it does, and records which process made it.
    def build():
        print(f"{name}: building in process", os.getpid())
        time.sleep(1.0)
        return torch.tensor(os.getpid())

    return load_or_build(name, {}, build, verbose=False)


def test_warm_cache_shows_what_the_workers_print(isolated_cache, capsys):
    import functools

    from hoi_tutorial.infra import warm_cache

    calls = [functools.partial(_build_talking, f"talk{i}") for i in range(4)]
    warm_cache(calls, workers=2)
    out = capsys.readouterr().out
    by_worker = [i for i in range(4) if int(_build_talking(f"talk{i}")) != os.getpid()]
    assert by_worker, "no build ran in a worker"
    for i in range(4):  # a worker's lines reach this process's output, as this process's own do
        assert f"talk{i}: building in process" in out, out
    assert out.count("[worker] test_infra._build_talking done in") == len(by_worker), out


def test_warm_cache_reraises_a_failed_build(isolated_cache):
    import functools

    from hoi_tutorial.infra import warm_cache

    calls = [functools.partial(_build_square, "fine", 2.0), functools.partial(_build_failing, "broken")]
    with pytest.raises(RuntimeError, match="broken cannot be built"):
        warm_cache(calls, workers=2)


def test_warm_cache_rejects_what_it_cannot_run(isolated_cache):
    from hoi_tutorial.infra import warm_cache

    with pytest.raises(TypeError, match="callable"):
        warm_cache([3])
    with pytest.raises(ValueError, match="workers"):
        warm_cache([], workers=0)
    local = [lambda: _build_square("a", 1.0), lambda: _build_square("b", 2.0)]
    with pytest.raises(TypeError, match="picklable"):
        warm_cache(local, workers=2)


def test_threads_allowed_lends_cores_to_one_thread_sections():
    from hoi_tutorial.infra import one_thread, threads_allowed

    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        with one_thread():
            assert torch.get_num_threads() == 1
        with threads_allowed(2):
            with one_thread():
                assert torch.get_num_threads() == 2
        assert torch.get_num_threads() == 2
        with one_thread():
            assert torch.get_num_threads() == 1
        with pytest.raises(ValueError, match="positive int"):
            with threads_allowed(0):
                pass
    finally:
        torch.set_num_threads(before)


# ----------------------------------------------------------------------------- keys derived from imports


def test_an_edit_reached_only_through_imports_changes_the_key_and_nothing_else(tmp_path, derived_package):
    from hoi_tutorial.infra.code_closure import code_closure

    derived_package("derivedpkg", {
        "derivedpkg/__init__.py": "",
        "derivedpkg/tools/__init__.py": "from .deep import scale\n",  # a re-export, as infra/__init__ does
        "derivedpkg/tools/deep.py": "def scale(x):\n    return 2 * x\n",
        "derivedpkg/middle.py": "def twice(x):\n    from .tools import scale  # imported inside a function\n"
                                "    return scale(x)\n",
        "derivedpkg/builder.py": "from . import middle\n\n\ndef build():\n    return {'v': middle.twice(1)}\n",
        "derivedpkg/other.py": "def build():\n    return {'v': 0}\n",
        "derivedpkg/unrelated.py": "VALUE = 1\n",
    })
    builder = importlib.import_module("derivedpkg.builder")
    other = importlib.import_module("derivedpkg.other")
    # the builder's module, what it imports, and the module that defines the re-exported name; not the rest
    assert code_closure("derivedpkg.builder") == ["derivedpkg.builder", "derivedpkg.middle", "derivedpkg.tools.deep"]
    before = artifact_key("t", {}, (builder.build,)), artifact_key("t", {}, (other.build,))
    (tmp_path / "derivedpkg/tools/deep.py").write_text("def scale(x):\n    return 3 * x\n")
    after = artifact_key("t", {}, (builder.build,)), artifact_key("t", {}, (other.build,))
    assert after[0] != before[0]  # two imports away, one of them inside a function: still a new key
    assert after[1] == before[1]  # an artifact that never reaches it keeps its key
    (tmp_path / "derivedpkg/unrelated.py").write_text("VALUE = 2\n")
    assert artifact_key("t", {}, (builder.build,)) == after[0]


def test_library_keys_follow_the_library_imports():
    from hoi_tutorial.choice.pick_and_place import table4
    from hoi_tutorial.choice.planner import intp
    from hoi_tutorial.infra.cache import derived_code

    table4_code = derived_code([table4.table4_runs])
    # Table 4's "w/ KF + cuRobo" row calls the minimum-jerk planner, reached from table4 only by its import
    assert "hoi_tutorial.choice.planner.baselines" in table4_code
    assert "hoi_tutorial.world.rotations" in table4_code  # through the controller's features
    assert {"hoi_tutorial.choice.controller.runtime", "hoi_tutorial.choice.pick_and_place.goal_library"} <= set(table4_code)
    assert not any(m.startswith(("hoi_tutorial.samp", "hoi_tutorial.nifty", "hoi_tutorial.choice.pick_and_place.demo"))
                   for m in table4_code)
    planner_code = derived_code([intp.trained_planner])
    assert "hoi_tutorial.choice.planner.fields" in planner_code
    assert not any(m.startswith("hoi_tutorial.choice.controller") for m in planner_code)
    # a function defined outside the library (a test, a notebook cell) adds no module
    assert derived_code([_producer_a]) == []


def _library_code_arguments():
    """Every ``code=`` the library passes to ``load_or_build``: ``(where, the module, the expression, its items)``."""
    import ast
    import importlib
    import pathlib

    import hoi_tutorial

    root = pathlib.Path(hoi_tutorial.__file__).parent
    found = []
    for path in sorted(root.rglob("*.py")):
        source = path.read_text()
        if "load_or_build(" not in source:
            continue
        parts = path.relative_to(root.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        for node in ast.walk(ast.parse(source)):
            called = getattr(node, "func", None)
            if not isinstance(node, ast.Call) or getattr(called, "id", getattr(called, "attr", None)) != "load_or_build":
                continue
            for keyword in node.keywords:
                if keyword.arg != "code":
                    continue
                module = importlib.import_module(name)
                items = eval(compile(ast.Expression(keyword.value), str(path), "eval"), dict(vars(module)))  # noqa: S307
                found.append((f"{name}:{node.lineno}", name, keyword.value, tuple(items)))
    return found


def test_the_library_lists_by_hand_only_code_its_imports_do_not_show():
    """A builder's key already holds its module and every library module that module imports (``code_closure``):
    a ``code=`` passed to ``load_or_build`` must add what imports cannot show (the code that made the data a model
    is trained on, say), and a tuple written out must not list a module the imports already bring."""
    import ast

    from hoi_tutorial.infra.cache import derived_code
    from hoi_tutorial.infra.code_closure import code_closure

    found = _library_code_arguments()
    assert found, "expected the library's builders to pass some code= (the NIFTY motion model's data, at least)"
    for where, module, expression, items in found:
        own = set(code_closure(module))
        assert set(derived_code(items)) - own, f"{where}: code= adds nothing to what {module} imports; drop it"
        if isinstance(expression, ast.Tuple):
            for item, element in zip(items, expression.elts):
                assert set(derived_code([item])) - own, \
                    f"{where}: {ast.unparse(element)} in code= is already imported by {module}; drop it"


def _build_trained(name):
    # A build that trains a small model for a second or so (its bar is what the test watches).
    from hoi_tutorial.infra import TrainerConfig, train

    def build():
        model = torch.nn.Linear(4, 1)
        x = torch.randn(64, 4, generator=torch.Generator().manual_seed(0))

        def loss_fn(m, batch):
            time.sleep(0.004)
            return (m(batch) - 1.0).pow(2).mean()

        train(model, lambda step, g: x, loss_fn, TrainerConfig(steps=300, log_every=10, device="cpu", progress=False))
        return model.weight.detach()

    return load_or_build(name, {}, build, verbose=False)


def test_progress_shows_in_a_kernel_or_where_asked(monkeypatch):
    from hoi_tutorial.infra import progress

    monkeypatch.setattr(progress, "_override", None)
    monkeypatch.delenv("HOI_PROGRESS", raising=False)
    assert not progress.progress_enabled()  # a test run is no Jupyter kernel
    for value, expected in (("1", True), ("on", True), ("0", False), ("false", False)):
        monkeypatch.setenv("HOI_PROGRESS", value)
        assert progress.progress_enabled() is expected
    monkeypatch.setenv("HOI_PROGRESS", "sometimes")
    with pytest.raises(ValueError, match="HOI_PROGRESS: expected 1 or 0"):
        progress.progress_enabled()
    monkeypatch.setenv("HOI_PROGRESS", "0")
    progress.show_progress(True)  # the call wins over the environment
    assert progress.progress_enabled()
    progress.show_progress(None)
    assert not progress.progress_enabled()
    with pytest.raises(ValueError, match="on: expected True, False or None"):
        progress.show_progress("yes")
    # a bar asked for shows; one not asked for follows the default
    assert not progress.progress_bar(range(3), 3, "x", enabled=True).disable
    assert progress.progress_bar(range(3), 3, "x").disable
    # in a kernel's shell, or one derived from it (Colab's), bars show by default
    zmqshell = pytest.importorskip("ipykernel.zmqshell")
    import IPython

    class ColabLikeShell(zmqshell.ZMQInteractiveShell):
        pass

    monkeypatch.delenv("HOI_PROGRESS")
    monkeypatch.setattr(IPython, "get_ipython", lambda: object.__new__(ColabLikeShell))
    assert progress.progress_enabled()
    monkeypatch.setenv("HOI_PROGRESS", "0")  # the book build's setting wins over the kernel
    assert not progress.progress_enabled()


def test_a_workers_training_bar_is_drawn_in_this_process(isolated_cache, monkeypatch):
    """A build in a ``warm_cache`` worker sends its bar; this process's listener draws it, up to the last step."""
    import functools

    from hoi_tutorial.infra import progress, warm_cache

    drawn = []
    draw = progress.BarListener._draw

    def record(self, key, desc, n, total, postfix, closed):
        drawn.append((key[0], desc, n, total, postfix, closed))
        draw(self, key, desc, n, total, postfix, closed)

    monkeypatch.setattr(progress.BarListener, "_draw", record)
    monkeypatch.setattr(progress, "_override", True)
    calls = [functools.partial(_build_trained, f"trained{i}") for i in range(3)]
    warm_cache(calls, workers=2)
    from_workers = [d for d in drawn if d[0] != os.getpid()]
    assert from_workers, drawn  # a worker built something, and its bar came here
    assert {d[1] for d in from_workers} == {"Linear"} and all(d[3] == 300 for d in from_workers)
    closed = [d for d in from_workers if d[5]]
    assert closed and all(d[2] == 300 for d in closed)  # each worker's bar ends at its last step
    assert any("loss=" in d[4] for d in from_workers)
    # off: no queue, nothing drawn
    drawn.clear()
    monkeypatch.setattr(progress, "_override", False)
    warm_cache([functools.partial(_build_trained, f"quiet{i}") for i in range(3)], workers=2)
    assert drawn == []
