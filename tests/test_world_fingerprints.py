"""The toy world is what ``tests/data/world_fingerprints.json`` records, on any CPU.

The JSON holds fingerprints of toy-mocap clips, objects and scenes (see ``scripts/world_fingerprints.py``):
non-float content hashed exactly, floats summarised and compared with tolerances far above float noise and far
below a millimetre. The tests below also show that the check tells the two apart: last-bit changes pass, a
millimetre in an object's size or another clip fail. When the toy world changes on purpose, regenerate it with

    python scripts/world_fingerprints.py --write tests/data/world_fingerprints.json
"""
import importlib.util
from pathlib import Path

import numpy as np
import pytest
import torch

from hoi_tutorial.world import mocap, objects

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "world_fingerprints.json"


def _script():
    spec = importlib.util.spec_from_file_location("world_fingerprints", ROOT / "scripts" / "world_fingerprints.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


script = _script()
QUERY = np.random.default_rng(12345).uniform([-1.5, -1.5, -0.1], [1.5, 1.5, 2.1], size=(512, 3))


def _object_entries(obj, placed=True) -> dict:
    out = {}
    script._object(out, "obj", obj.placed(0.3, -0.4, 0.8, z=0.1) if placed else obj, QUERY,
                   canonical=not placed, costly=False)
    return out


def _motion_entries(motion) -> dict:
    out = {}
    script._motion(out, "clip", motion)
    return out


@pytest.mark.slow
def test_world_matches_recorded_fingerprints():
    expected = script.read(GOLDEN)
    differences = script.compare(expected, script.fingerprints())
    assert not differences, (
        f"{len(differences)} of {len(expected)} toy-world fingerprints differ from {GOLDEN.name}:\n"
        + "\n".join(differences[:50])
        + ("\n..." if len(differences) > 50 else "")
        + "\nIf the toy world changed on purpose, regenerate the file with\n"
        "    python scripts/world_fingerprints.py --write tests/data/world_fingerprints.json"
    )


def test_last_bit_changes_pass():
    # What another CPU's kernels do: every float moved by a few units in the last place, float32 and float64.
    chair = objects.make_object("chair", seed=0).placed(0.3, -0.4, 0.8, z=0.1)
    sdf32 = chair.sdf(torch.tensor(QUERY, dtype=torch.float32)).numpy()
    rng = np.random.default_rng(0)
    for values in (sdf32, chair.sdf(QUERY)):
        ulp = np.spacing(np.abs(values)).astype(values.dtype)
        for moved in (np.nextafter(values, np.inf), values + rng.integers(-4, 5, values.shape) * ulp):
            assert not np.array_equal(moved, values)
            name = "objects.chair[seed=0].placed.sdf_torch"
            assert script.deviation(name, script.fingerprint(values), script.fingerprint(moved)) is None
    # and a whole object's and clip's fingerprints, every float moved by one ulp
    clip = mocap.generate_clip("walk", seed=0)
    for name, value in {**_object_entries(objects.make_object("table", seed=1)), **_motion_entries(clip)}.items():
        moved = value
        if isinstance(value, np.ndarray) and value.dtype.kind == "f":
            moved = np.nextafter(value, -np.inf)
        assert script.deviation(name, script.fingerprint(value), script.fingerprint(moved)) is None, name


def test_the_noise_of_two_bone_ik_passes_where_it_was_measured():
    # The drawer clip's rotations moved by up to 1.0e-4 between OpenBLAS kernels (an arccos near full
    # extension): well inside the rotations' tolerance, which is still far below a changed pose.
    drawer = objects.make_object("drawer", seed=6).placed(-0.5, 0.2, -0.6)
    clip = mocap.interactions.open_drawer(drawer, hand="right", seed=1, approach=True, betas=mocap.sample_betas(7))
    rotations = np.asarray(clip.local_rotations)
    noisy = rotations + np.random.default_rng(1).uniform(-1e-4, 1e-4, rotations.shape)
    name = "interactions.open_drawer.right.local_rotations"
    assert script.deviation(name, script.fingerprint(rotations), script.fingerprint(noisy)) is None
    bent = rotations.copy()
    bent[:, 18] = bent[:, 18] @ np.array([[1, 0, 0], [0, np.cos(0.05), -np.sin(0.05)], [0, np.sin(0.05), np.cos(0.05)]])
    assert script.deviation(name, script.fingerprint(rotations), script.fingerprint(bent)) is not None


@pytest.mark.parametrize("size", ["seat_height", "seat_width", "back_thickness"])
def test_a_millimetre_in_an_objects_size_fails(size):
    chair = objects.make_object("chair", seed=0)
    bigger = chair.with_params(**{size: chair.params[size] + 0.001})
    for placed in (True, False):
        before, after = _object_entries(chair, placed), _object_entries(bigger, placed)
        differences = script.compare(before, after)
        assert differences, f"a 1 mm change of {size} went unnoticed"
    assert script.compare(_object_entries(chair), _object_entries(objects.make_object("chair", seed=0))) == []


def test_a_changed_clip_fails():
    clip = mocap.generate_clip("sit", seed=0)
    before = _motion_entries(clip)
    assert script.compare(before, _motion_entries(mocap.generate_clip("sit", seed=0))) == []
    assert script.compare(before, _motion_entries(mocap.generate_clip("sit", seed=1)))
    # one joint turned by half a degree in the second half of the clip
    turned = clip.local_rotations.clone()
    angle = np.radians(0.5)
    turn = torch.tensor([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]],
                        dtype=turned.dtype)
    half = turned.shape[0] // 2
    turned[half:, 16] = turned[half:, 16] @ turn
    entries = dict(before)
    entries["clip.local_rotations"] = script.fingerprint(turned)
    assert script.compare(before, entries) == ["differs: clip.local_rotations: " +
                                               script.deviation("clip.local_rotations", before["clip.local_rotations"],
                                                                entries["clip.local_rotations"])]
    # a label changed in one frame: non-float content, compared exactly
    labels = list(clip.actions)
    labels[3] = "idle" if labels[3] != "idle" else "walk"
    assert script.deviation("clip.actions", script.fingerprint(list(clip.actions)), script.fingerprint(labels))


def test_non_finite_values_and_float_counts_are_exact():
    a = np.array([1.0, np.inf, 2.0])
    assert script.deviation("x", script.fingerprint(a), script.fingerprint(np.array([1.0, -np.inf, 2.0])))
    assert script.deviation("x", script.fingerprint(a), script.fingerprint(np.array([1.0, np.nan, 2.0])))
    assert script.deviation("x", script.fingerprint([1.0, 2.0]), script.fingerprint([1.0, 2.0, 0.0]))
    assert script.deviation("x", script.fingerprint(a), script.fingerprint(a.copy())) is None


def test_summary_numbers_move_no_more_than_the_largest_change():
    # The property the tolerance rests on: each summary number is 1-Lipschitz in the max norm.
    rng = np.random.default_rng(3)
    for n in (1, 5, 8, 100, 1001):
        x = rng.normal(0, 2, n)
        delta = rng.uniform(-1, 1, n) * 1e-3
        moved = np.subtract(script.summarise(x + delta), script.summarise(x))
        assert np.all(np.abs(moved) <= np.abs(delta).max() + 1e-15)
    assert script.summarise(np.zeros(0)) == []


def test_the_file_format_is_checked(tmp_path):
    old = tmp_path / "old.json"
    old.write_text('{"gait.idle.actions": "adee1a59"}', encoding="utf-8")
    with pytest.raises(ValueError, match="format 2"):
        script.read(old)
    entries = {"b": script.fingerprint(np.linspace(0, 1, 30)), "a": script.fingerprint("label")}
    new = tmp_path / "new.json"
    script.write(new, entries)
    assert script.compare(script.read(new), entries) == []
