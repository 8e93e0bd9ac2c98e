"""Fingerprints of the toy world: mocap clips, objects and scenes, compared with tolerances.

The fingerprints pin down what the procedural generators produce, so that a change meant to leave the toy
world alone (a refactoring, a speed-up) can be checked to be neutral, on any CPU. Each entry has two parts:

* ``digest``: SHA-256 (its first 64 bits) of everything that is not a float, hashed exactly: integers, booleans, labels, metadata
  keys, array shapes and dtypes, where a float is NaN or infinite, and how many floats there are;
* ``floats``: a summary of the entry's floats, in order: the smallest, the largest, and the mean and the
  root mean square of each of up to :data:`CHUNKS` consecutive chunks.

A check compares the digests exactly and each summary number within ``atol + rtol * |expected|``
(:func:`tolerance`). No summary number moves by more than the largest change of any one float (a chunk's
mean and RMS, the minimum and the maximum are all 1-Lipschitz in the max norm), and a chunk's mean and RMS
move by far less when only a few floats change: values that differ in their last bits -- another CPU's BLAS
or vector kernels -- pass, and there is no rounding boundary to fall across. A real change (a millimetre in an
object's size, a joint turned by half a degree, another clip) moves a chunk's mean or RMS beyond 1e-5 and fails.

Usage::

    python scripts/world_fingerprints.py --write tests/data/world_fingerprints.json
    python scripts/world_fingerprints.py --check tests/data/world_fingerprints.json

``--check`` exits with status 1 and lists every entry that differs, with its largest deviation. The package is
imported normally, so ``PYTHONPATH`` decides which code is fingerprinted.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from typing import Callable

import numpy as np
import torch

from hoi_tutorial.world import mocap, objects, scenes
from hoi_tutorial.world.mocap import gait, interactions

SEEDS = (0, 1, 2)
CHUNKS = 8
FORMAT = 2

# Tolerances. Each summary number may differ from the recorded one by ``atol + rtol * |recorded|``. The chunk
# means and RMS average thousands of floats: between OpenBLAS's SkylakeX and Haswell kernels (and MKL's
# compatible mode) they moved by at most 4.5e-7, so (1e-5, 1e-5) is a wide margin and still far below a
# millimetre. The smallest and the largest value follow single floats, so their tolerance is the largest
# difference one float may show (EXTREMES, by the last part of the entry's name).
CHUNK_TOLERANCE = (1e-5, 1e-5)
# Joint rotations come from two-bone IK, whose elbow and knee angles are an arccos near full extension: there a
# last-bit change in the target moves an angle by about its square root (measured: 1.0e-4 in one rotation-matrix
# entry of the drawer clip between the two kernels). 2e-3 is about 0.1 degree. Root positions inherit a little of
# it (measured: 4.4e-6 m). Everything else: float32's last bits (the objects' float32 SDF: up to 4.8e-7 m).
EXTREMES = {"local_rotations": (2e-3, 0.0), "root_position": (1e-4, 0.0)}
DEFAULT_EXTREMES = (1e-5, 1e-5)


def tolerance(name: str) -> tuple:
    """``((atol, rtol) of the smallest and largest value, (atol, rtol) of the chunk means and RMS)`` for the entry
    ``name``: see :data:`EXTREMES` and :data:`CHUNK_TOLERANCE`."""
    return EXTREMES.get(name.rsplit(".", 1)[-1], DEFAULT_EXTREMES), CHUNK_TOLERANCE


# ----------------------------------------------------------------------------- fingerprinting


def _feed(h, floats: list, value) -> None:
    """Feed a canonical byte encoding of ``value``'s non-float content into the hash ``h``, and append its floats
    (as float64 arrays, in order) to ``floats``."""
    if value is None:
        h.update(b"N")
    elif isinstance(value, (bool, np.bool_)):
        h.update(b"B1" if value else b"B0")
    elif isinstance(value, (int, np.integer)):
        h.update(b"I" + str(int(value)).encode() + b";")
    elif isinstance(value, (float, np.floating)):
        h.update(b"F")
        _feed_floats(h, floats, np.array([float(value)]))
    elif isinstance(value, str):
        data = value.encode("utf-8")
        h.update(b"S" + str(len(data)).encode() + b":" + data)
    elif isinstance(value, dict):
        h.update(b"D" + str(len(value)).encode() + b"{")
        for key in sorted(value, key=str):
            _feed(h, floats, str(key))
            _feed(h, floats, value[key])
        h.update(b"}")
    elif isinstance(value, (list, tuple)):
        h.update(b"L" + str(len(value)).encode() + b"[")
        for item in value:
            _feed(h, floats, item)
        h.update(b"]")
    elif isinstance(value, (np.ndarray, torch.Tensor)):
        a = value.detach().cpu().numpy() if isinstance(value, torch.Tensor) else value
        h.update(b"A" + a.dtype.kind.encode() + str(a.shape).encode())
        if a.dtype.kind == "f":
            _feed_floats(h, floats, a)
        elif a.dtype.kind in "iu":
            h.update(np.ascontiguousarray(a, dtype="<i8").tobytes())
        elif a.dtype.kind == "b":
            h.update(np.ascontiguousarray(a, dtype=np.uint8).tobytes())
        elif a.dtype.kind in "UO":
            _feed(h, floats, a.tolist())
        else:
            raise TypeError(f"cannot fingerprint an array of dtype {a.dtype}")
    elif isinstance(value, objects.ToyObject):
        _feed(h, floats, {"category": value.category, "params": value.params, "pose": value.pose,
                          "annotations": value.annotations})
    else:
        raise TypeError(f"cannot fingerprint a {type(value).__name__}")


def _feed_floats(h, floats: list, a: np.ndarray) -> None:
    """Hash where ``a`` is not finite (exactly), and keep its finite values (NaN and inf read as 0) for the summary."""
    a = np.asarray(a, dtype=np.float64).reshape(-1)
    finite = np.isfinite(a)
    if not finite.all():
        h.update(b"X" + np.packbits(~finite).tobytes() + np.sign(np.where(finite, 0.0, np.nan_to_num(a))).tobytes())
    floats.append(np.where(finite, a, 0.0))


def summarise(floats: np.ndarray) -> list:
    """The summary of a float vector: ``[min, max]`` then each chunk's ``mean, rms`` (up to :data:`CHUNKS`
    consecutive chunks of nearly equal size); ``[]`` for no floats."""
    x = np.asarray(floats, dtype=np.float64).reshape(-1)
    if x.size == 0:
        return []
    out = [float(x.min()), float(x.max())]
    for chunk in np.array_split(x, min(CHUNKS, x.size)):
        out += [float(chunk.mean()), float(np.sqrt(np.mean(chunk * chunk)))]
    return out


def fingerprint(value) -> dict:
    """``{"digest": SHA-256 of the non-float content (16 hex digits), "floats": summary of the floats}`` of
    ``value``."""
    h, floats = hashlib.sha256(), []
    _feed(h, floats, value)
    x = np.concatenate(floats) if floats else np.zeros(0)
    h.update(b"n" + str(x.size).encode())
    return {"digest": h.hexdigest()[:16], "floats": summarise(x)}   # 64 bits: a change is never missed by chance


def _outcome(function: Callable):
    """The value of ``function()``, or a description of the exception it raises."""
    try:
        return function()
    except Exception as error:  # noqa: BLE001 - the error itself is part of the behaviour
        return f"raises {type(error).__name__}: {error}"


# ----------------------------------------------------------------------------- parts


def _motion(out: dict, name: str, motion) -> None:
    out[f"{name}.frames"] = fingerprint(int(motion.local_rotations.shape[0]))
    out[f"{name}.local_rotations"] = fingerprint(motion.local_rotations)
    out[f"{name}.root_position"] = fingerprint(motion.root_position)
    out[f"{name}.betas"] = fingerprint(motion.betas)
    out[f"{name}.fps"] = fingerprint(float(motion.fps))
    out[f"{name}.actions"] = fingerprint(motion.actions)
    out[f"{name}.contacts"] = fingerprint(motion.contacts)
    for key in sorted(motion.meta):
        out[f"{name}.meta.{key}"] = fingerprint(motion.meta[key])
    out[f"{name}.meta_keys"] = fingerprint(sorted(motion.meta))


def _mocap(out: dict) -> None:
    for seed in SEEDS:
        clips = mocap.generate_dataset(2, seed=seed, subjects=3)
        out[f"mocap.dataset[seed={seed}].count"] = fingerprint(len(clips))
        for motion in clips:
            _motion(out, f"mocap.dataset[seed={seed}].{motion.meta['kind']}[{motion.meta['index']}]", motion)
        for kind in mocap.ACTION_GENERATORS:
            _motion(out, f"mocap.clip[seed={seed}].{kind}", mocap.generate_clip(kind, seed=seed))
        out[f"mocap.sample_betas[seed={seed}]"] = fingerprint(mocap.sample_betas(seed))
        out[f"mocap.random_path[seed={seed}]"] = fingerprint(mocap.random_path(seed))


def _interaction(out: dict, name: str, function: Callable) -> None:
    result = _outcome(function)
    if isinstance(result, str):
        out[f"{name}.error"] = fingerprint(result)
    else:
        _motion(out, name, result)


def _interactions(out: dict) -> None:
    """The interaction generators called directly over their styles and options."""
    betas = mocap.sample_betas(7)
    I = interactions
    for i, category in enumerate(objects.SITTABLE):
        obj = objects.make_object(category, seed=i).placed(0.3, -0.2, 0.4)
        style = I.SIT_STYLES[i % len(I.SIT_STYLES)]
        _interaction(out, f"interactions.sit.{category}.{style}",
                     lambda: I.sit(obj, seed=i, style=style, betas=betas if i % 2 else None))
    chair = objects.make_object("chair", seed=5)
    for style in I.SIT_STYLES:
        _interaction(out, f"interactions.sit.chair.{style}.no_approach",
                     lambda: I.sit(chair, seed=3, style=style, approach=False, stand_up=False))
    for category in objects.LYING:
        obj = objects.make_object(category, seed=4)
        for j, style in enumerate(I.LIE_STYLES):
            _interaction(out, f"interactions.lie.{category}.{style}",
                         lambda: I.lie(obj, seed=j, style=style, stand_up=bool(j % 2), betas=betas if j else None))
    for category in objects.LIFTABLE:
        obj = objects.make_object(category, seed=2).placed(-0.4, 0.5, -1.1)
        for j, style in enumerate(I.LIFT_STYLES):
            _interaction(out, f"interactions.lift.{category}.{style}",
                         lambda: I.lift(obj, seed=j, style=style, approach=bool(j), betas=betas))
    for category in objects.GRASPABLE:
        obj = objects.make_object(category, seed=3)
        for j, hand in enumerate(I.SIDES):
            _interaction(out, f"interactions.reach_grasp.{category}.{hand}",
                         lambda: I.reach_grasp(obj, hand=hand, seed=j, pick_up=bool(j), approach=bool(j)))
        raised = obj.placed(0.2, 0.6, 0.3, z=0.9)
        _interaction(out, f"interactions.reach_grasp.{category}.raised",
                     lambda: I.reach_grasp(raised, seed=5, start_position=(1.5, -1.0)))
    cabinet = objects.make_object("cabinet", seed=6).placed(0.5, 0.5, 2.0)
    drawer = objects.make_object("drawer", seed=6).placed(-0.5, 0.2, -0.6)
    for j, hand in enumerate(I.SIDES):
        _interaction(out, f"interactions.open_door.{hand}",
                     lambda: I.open_door(cabinet, hand=hand, seed=j, approach=bool(j), betas=betas))
        _interaction(out, f"interactions.open_drawer.{hand}",
                     lambda: I.open_drawer(drawer, hand=hand, seed=j, approach=bool(j), betas=betas))
    _interaction(out, "interactions.sit.wrong_object", lambda: I.sit(objects.make_object("mug"), seed=0))
    # Rarer branches: feet hanging off a high seat, a start boxed in by an L-sofa (grid route),
    # goals chosen by index (and refused).
    _interaction(out, "interactions.sit.yoga_ball.hanging", lambda: I.sit(objects.make_object("yoga_ball", 10), seed=10))
    l_sofa = objects.make_object("l_sofa", seed=1)
    _interaction(out, "interactions.sit.l_sofa.grid_route",
                 lambda: I.sit(l_sofa, seed=0, start_position=(-1.5, -1.5), stand_up=False))
    for k in range(len(l_sofa.sit_goals[0])):
        _interaction(out, f"interactions.sit.l_sofa.goal{k}", lambda: I.sit(l_sofa, seed=1, goal_index=k))
    _interaction(out, "interactions.sit.goal_out_of_range", lambda: I.sit(chair, seed=1, goal_index=7))
    sofa = objects.make_object("sofa", seed=2)
    _interaction(out, "interactions.lie.sofa.goal1", lambda: I.lie(sofa, seed=3, goal_index=1, stand_up=True))


def _gait(out: dict) -> None:
    waypoints = np.array([[0.0, 0.0], [1.5, 0.4], [2.0, 2.2], [0.5, 3.0]])
    betas = mocap.sample_betas(3)
    for name in gait.GAITS:
        _motion(out, f"gait.walk_path.{name}", gait.walk_path(waypoints, seed=4, gait=name, betas=betas))
    _motion(out, "gait.walk_path.slow_heading", gait.walk_path(waypoints[:2], seed=5, speed=0.8, end_heading=1.0))
    _motion(out, "gait.idle", gait.idle(2.5, seed=6, position=(0.5, -0.3), heading=0.7))
    _motion(out, "gait.turn_in_place", gait.turn_in_place(-2.4, seed=7, heading=0.3, betas=betas))
    _motion(out, "gait.side_step", gait.side_step(-0.7, seed=8, heading=-1.2))
    path = gait.path_from_waypoints(waypoints)
    out["gait.path_from_waypoints"] = fingerprint([path.length, path.at(np.linspace(0.0, path.length, 50))])


def _object(out: dict, name: str, obj, query: np.ndarray, *, canonical: bool, costly: bool) -> None:
    """Fingerprints of one object: world-frame geometry and affordances, plus the canonical-frame
    ones when ``canonical`` (a placed copy shares them) and the Monte-Carlo ones when ``costly``."""
    out[f"{name}.pose"] = fingerprint(obj.pose)
    out[f"{name}.bounds"] = fingerprint([obj.canonical_bounds, obj.bounds])
    out[f"{name}.mesh.vertices"] = fingerprint(np.asarray(obj.mesh.vertices))
    out[f"{name}.mesh.faces"] = fingerprint(np.asarray(obj.mesh.faces))
    out[f"{name}.sdf"] = fingerprint(obj.sdf(query))
    out[f"{name}.surface_points"] = fingerprint(obj.surface_points(128, seed=1))
    out[f"{name}.voxel_centres"] = fingerprint(obj.voxel_centres(8))
    for prop in ("sit_goals", "lie_goals", "lift_contacts", "lift_approach", "grasp_points", "handle_point",
                 "support_surfaces"):
        out[f"{name}.{prop}"] = fingerprint(_outcome(lambda: getattr(obj, prop)))
    if canonical:
        out[f"{name}.params"] = fingerprint(obj.params)
        out[f"{name}.annotations"] = fingerprint(obj.annotations)
        out[f"{name}.point_cloud"] = fingerprint(obj.point_cloud(256, seed=0))
        out[f"{name}.interaction_voxels"] = fingerprint(obj.interaction_voxels(np.eye(4)))
    else:
        out[f"{name}.sdf_torch"] = fingerprint(obj.sdf(torch.tensor(query, dtype=torch.float32)))
        out[f"{name}.interaction_voxels_frame"] = fingerprint(obj.interaction_voxels(np.linalg.inv(obj.centre_frame)))
    if costly:
        out[f"{name}.volume"] = fingerprint(obj.volume)
        out[f"{name}.occupancy_grid"] = fingerprint(obj.occupancy_grid(8))


def _objects(out: dict) -> None:
    query = np.random.default_rng(12345).uniform([-1.5, -1.5, -0.1], [1.5, 1.5, 2.1], size=(512, 3))
    for category in objects.CATEGORIES:
        for seed in SEEDS:
            obj = objects.make_object(category, seed=seed)
            _object(out, f"objects.{category}[seed={seed}]", obj, query, canonical=True, costly=seed == 0)
            placed = obj.placed(0.3, -0.4, 0.8 + seed, z=0.1)
            _object(out, f"objects.{category}[seed={seed}].placed", placed, query, canonical=False, costly=False)
        scaled = objects.make_object(category, seed=9, size_scale=(1.2, 0.9, 1.1))
        out[f"objects.{category}.scaled.params"] = fingerprint(scaled.params)
        out[f"objects.{category}.scaled.annotations"] = fingerprint(scaled.annotations)
        out[f"objects.{category}.scaled.sdf"] = fingerprint(scaled.sdf(query))
    for category, key, value in (("cabinet", "door_angle", 1.1), ("drawer", "drawer_open", 0.2),
                                 ("chair", "seat_height", 0.5)):
        obj = objects.make_object(category, seed=1, **{key: value}).placed(0.1, 0.2, 0.3)
        out[f"objects.{category}.override.annotations"] = fingerprint(obj.annotations)
        out[f"objects.{category}.override.sdf"] = fingerprint(obj.sdf(query))
        rebuilt = obj.with_params(**{key: value / 2})
        out[f"objects.{category}.with_params.annotations"] = fingerprint(rebuilt.annotations)
        out[f"objects.{category}.with_params.sdf"] = fingerprint(rebuilt.sdf(query))
    out["objects.override.unknown"] = fingerprint(_outcome(lambda: objects.make_object("chair", 0, height=1.0)))
    out["objects.size_table"] = fingerprint([list(row) for row in objects.size_table()])
    out["objects.category_sizes"] = fingerprint(
        {c: {n: [r.low, r.high, r.axis, r.kind, r.unit, r.description] for n, r in spec.items()}
         for c, spec in objects.CATEGORY_SIZES.items()})
    out["objects.constants"] = fingerprint({name: getattr(objects, name) for name in objects.__all__
                                       if name.isupper() and name != "CATEGORY_SIZES"})


def _scene_objects(objs) -> list:
    return [{"category": o.category, "params": o.params, "pose": o.pose} for o in objs]


def _scenes(out: dict) -> None:
    query = np.random.default_rng(54321).uniform([0.0, 0.0, 0.0], [6.0, 6.0, 2.0], size=(256, 3))
    for seed in SEEDS:
        room = scenes.make_room(seed)
        name = f"scenes.room[seed={seed}]"
        out[f"{name}.objects"] = fingerprint(_scene_objects(room.objects))
        out[f"{name}.layout"] = fingerprint([room.size, room.target_index, room.shape])
        out[f"{name}.occupancy"] = fingerprint(room.occupancy)
        out[f"{name}.clearance"] = fingerprint(room.clearance)
        out[f"{name}.sdf"] = fingerprint(room.sdf(query))
        out[f"{name}.approach_point"] = fingerprint(_outcome(room.approach_point))
        out[f"{name}.reachable_fraction"] = fingerprint(_outcome(room.reachable_fraction))
        out[f"{name}.start_positions"] = fingerprint(_outcome(lambda: room.start_positions(4, seed=seed)))

        kitchen = scenes.make_kitchen(seed)
        name = f"scenes.kitchen[seed={seed}]"
        out[f"{name}.furniture"] = fingerprint(_scene_objects(kitchen.furniture))
        out[f"{name}.items"] = fingerprint(_scene_objects(kitchen.items))
        out[f"{name}.obstacles"] = fingerprint(_scene_objects(kitchen.obstacles))
        out[f"{name}.holders"] = fingerprint(list(kitchen.holders))
        out[f"{name}.occupancy"] = fingerprint(kitchen.occupancy)
        out[f"{name}.clearance"] = fingerprint(kitchen.clearance)
        out[f"{name}.sdf"] = fingerprint(kitchen.sdf(query[:, :3] * np.array([5 / 6, 5 / 6, 1.0])))
        out[f"{name}.start_positions"] = fingerprint(_outcome(lambda: kitchen.start_positions(4, seed=seed)))


SECTIONS = {"mocap": _mocap, "interactions": _interactions, "gait": _gait, "objects": _objects, "scenes": _scenes}


def fingerprints(sections=tuple(SECTIONS)) -> dict[str, dict]:
    """Entry name -> :func:`fingerprint`, for the named sections (default: all)."""
    out: dict[str, dict] = {}
    for section in sections:
        SECTIONS[section](out)
    return dict(sorted(out.items()))


def deviation(name: str, expected: dict, actual: dict) -> str | None:
    """Why ``actual`` differs from ``expected`` for the entry ``name`` (in words), or ``None`` when they agree:
    the same digest and every summary number within :func:`tolerance`."""
    if expected["digest"] != actual["digest"]:
        return "its non-float content (integers, booleans, labels, shapes, how many floats) changed"
    e, a = np.asarray(expected["floats"], float), np.asarray(actual["floats"], float)
    if e.shape != a.shape:
        return f"{len(a)} summary numbers against {len(e)} recorded"
    if e.size == 0:
        return None
    extremes, chunks = tolerance(name)
    atol = np.array([extremes[0]] * 2 + [chunks[0]] * (e.size - 2))
    rtol = np.array([extremes[1]] * 2 + [chunks[1]] * (e.size - 2))
    excess = np.abs(a - e) - (atol + rtol * np.abs(e))
    if np.all(excess <= 0):
        return None
    i = int(np.argmax(excess))
    what = ("the smallest value", "the largest value")[i] if i < 2 else \
        f"chunk {(i - 2) // 2 + 1}'s {('mean', 'RMS')[(i - 2) % 2]}"
    return (f"{what} is {a[i]:.9g} against {e[i]:.9g} recorded (differs by {abs(a[i] - e[i]):.3g}; "
            f"tolerance {atol[i]:g} + {rtol[i]:g} x |recorded|)")


def compare(expected: dict[str, dict], actual: dict[str, dict]) -> list[str]:
    """Readable lines, one per entry that differs beyond its tolerance, is missing or is new; empty when all match."""
    lines = []
    for key in sorted(set(expected) | set(actual)):
        if key not in actual:
            lines.append(f"missing: {key}")
        elif key not in expected:
            lines.append(f"new:     {key}")
        else:
            reason = deviation(key, expected[key], actual[key])
            if reason:
                lines.append(f"differs: {key}: {reason}")
    return lines


def _stored(entries: dict) -> dict:
    """Entries as the JSON file stores them: summary numbers to 10 significant digits (a rounding of at most
    5e-10 relative, far below every tolerance), so that a fresh run compares the same numbers as the file."""
    return {name: {"digest": e["digest"], "floats": [float(f"{v:.10g}") for v in e["floats"]]}
            for name, e in entries.items()}


def read(path) -> dict[str, dict]:
    """The recorded fingerprints in ``path``; a clear error for a file in the old, exact-hash format."""
    with open(path, encoding="utf-8") as f:
        payload = json.load(f)
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise ValueError(f"{path}: expected world fingerprints of format {FORMAT} (written by "
                         "scripts/world_fingerprints.py --write); regenerate the file")
    return payload["entries"]


def write(path, entries: dict) -> None:
    """Write ``entries`` to ``path``: one entry a line, so that a change reads as a diff of the entries it moved."""
    lines = [json.dumps(name) + ": " + json.dumps(entry, separators=(",", ":"))
             for name, entry in sorted(_stored(entries).items())]
    with open(path, "w", encoding="utf-8") as f:
        f.write('{"format": %d, "chunks": %d, "entries": {\n' % (FORMAT, CHUNKS) + ",\n".join(lines) + "\n}}\n")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", metavar="PATH", help="write the fingerprints to a JSON file")
    group.add_argument("--check", metavar="PATH", help="compare against a JSON file; exit 1 on differences")
    args = parser.parse_args(argv)
    actual = fingerprints()
    if args.write:
        write(args.write, actual)
        print(f"wrote {len(actual)} fingerprints to {args.write}")
        return 0
    expected = read(args.check)
    differences = compare(expected, actual)
    if differences:
        print(f"{len(differences)} of {len(expected)} fingerprints differ:")
        print("\n".join(differences))
        return 1
    print(f"all {len(expected)} fingerprints match within their tolerances")
    return 0


if __name__ == "__main__":
    sys.exit(main())
