"""SHA-256 fingerprints of the toy world: mocap clips, objects and scenes.

The fingerprints pin down what the procedural generators produce, so a change that is meant to
leave the toy world alone (a refactoring, a speed-up) can be checked to be bit-for-bit neutral.
Float arrays are rounded to 6 decimals and hashed as float64 bytes; integers, booleans, labels
and metadata are hashed as they are.

Usage::

    python scripts/world_fingerprints.py --write tests/data/world_fingerprints.json
    python scripts/world_fingerprints.py --check tests/data/world_fingerprints.json

``--check`` exits with status 1 and lists every entry that differs. The package is imported
normally, so ``PYTHONPATH`` decides which code is fingerprinted.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import math
import struct
import sys
from typing import Callable

import numpy as np
import torch

from hoi_tutorial.world import mocap, objects, scenes
from hoi_tutorial.world.mocap import gait, interactions

SEEDS = (0, 1, 2)
DECIMALS = 6


# ----------------------------------------------------------------------------- hashing


def _feed(h, value) -> None:
    """Feed a canonical byte encoding of ``value`` into the hash ``h``."""
    if value is None:
        h.update(b"N")
    elif isinstance(value, (bool, np.bool_)):
        h.update(b"B1" if value else b"B0")
    elif isinstance(value, (int, np.integer)):
        h.update(b"I" + str(int(value)).encode() + b";")
    elif isinstance(value, (float, np.floating)):
        x = float(value)
        x = round(x, DECIMALS) + 0.0 if math.isfinite(x) else x
        h.update(b"F" + struct.pack("<d", x))
    elif isinstance(value, str):
        data = value.encode("utf-8")
        h.update(b"S" + str(len(data)).encode() + b":" + data)
    elif isinstance(value, dict):
        h.update(b"D" + str(len(value)).encode() + b"{")
        for key in sorted(value, key=str):
            _feed(h, str(key))
            _feed(h, value[key])
        h.update(b"}")
    elif isinstance(value, (list, tuple)):
        h.update(b"L" + str(len(value)).encode() + b"[")
        for item in value:
            _feed(h, item)
        h.update(b"]")
    elif isinstance(value, (np.ndarray, torch.Tensor)):
        a = value.detach().cpu().numpy() if isinstance(value, torch.Tensor) else value
        h.update(b"A" + a.dtype.kind.encode() + str(a.shape).encode())
        if a.dtype.kind == "f":
            a = np.round(a.astype(np.float64), DECIMALS) + 0.0  # + 0.0 turns -0.0 into 0.0
            h.update(np.ascontiguousarray(a, dtype="<f8").tobytes())
        elif a.dtype.kind in "iu":
            h.update(np.ascontiguousarray(a, dtype="<i8").tobytes())
        elif a.dtype.kind == "b":
            h.update(np.ascontiguousarray(a, dtype=np.uint8).tobytes())
        elif a.dtype.kind in "UO":
            _feed(h, a.tolist())
        else:
            raise TypeError(f"cannot fingerprint an array of dtype {a.dtype}")
    elif isinstance(value, objects.ToyObject):
        _feed(h, {"category": value.category, "params": value.params, "pose": value.pose,
                  "annotations": value.annotations})
    else:
        raise TypeError(f"cannot fingerprint a {type(value).__name__}")


def digest(value) -> str:
    h = hashlib.sha256()
    _feed(h, value)
    return h.hexdigest()


def _outcome(function: Callable):
    """The value of ``function()``, or a description of the exception it raises."""
    try:
        return function()
    except Exception as error:  # noqa: BLE001 - the error itself is part of the behaviour
        return f"raises {type(error).__name__}: {error}"


# ----------------------------------------------------------------------------- parts


def _motion(out: dict, name: str, motion) -> None:
    out[f"{name}.frames"] = digest(int(motion.local_rotations.shape[0]))
    out[f"{name}.local_rotations"] = digest(motion.local_rotations)
    out[f"{name}.root_position"] = digest(motion.root_position)
    out[f"{name}.betas"] = digest(motion.betas)
    out[f"{name}.fps"] = digest(float(motion.fps))
    out[f"{name}.actions"] = digest(motion.actions)
    out[f"{name}.contacts"] = digest(motion.contacts)
    for key in sorted(motion.meta):
        out[f"{name}.meta.{key}"] = digest(motion.meta[key])
    out[f"{name}.meta_keys"] = digest(sorted(motion.meta))


def _mocap(out: dict) -> None:
    for seed in SEEDS:
        clips = mocap.generate_dataset(2, seed=seed, subjects=3)
        out[f"mocap.dataset[seed={seed}].count"] = digest(len(clips))
        for motion in clips:
            _motion(out, f"mocap.dataset[seed={seed}].{motion.meta['kind']}[{motion.meta['index']}]", motion)
        for kind in mocap.ACTION_GENERATORS:
            _motion(out, f"mocap.clip[seed={seed}].{kind}", mocap.generate_clip(kind, seed=seed))
        out[f"mocap.sample_betas[seed={seed}]"] = digest(mocap.sample_betas(seed))
        out[f"mocap.random_path[seed={seed}]"] = digest(mocap.random_path(seed))


def _interaction(out: dict, name: str, function: Callable) -> None:
    result = _outcome(function)
    if isinstance(result, str):
        out[f"{name}.error"] = digest(result)
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
    out["gait.path_from_waypoints"] = digest([path.length, path.at(np.linspace(0.0, path.length, 50))])


def _object(out: dict, name: str, obj, query: np.ndarray, *, canonical: bool, costly: bool) -> None:
    """Fingerprints of one object: world-frame geometry and affordances, plus the canonical-frame
    ones when ``canonical`` (a placed copy shares them) and the Monte-Carlo ones when ``costly``."""
    out[f"{name}.pose"] = digest(obj.pose)
    out[f"{name}.bounds"] = digest([obj.canonical_bounds, obj.bounds])
    out[f"{name}.mesh.vertices"] = digest(np.asarray(obj.mesh.vertices))
    out[f"{name}.mesh.faces"] = digest(np.asarray(obj.mesh.faces))
    out[f"{name}.sdf"] = digest(obj.sdf(query))
    out[f"{name}.surface_points"] = digest(obj.surface_points(128, seed=1))
    out[f"{name}.voxel_centres"] = digest(obj.voxel_centres(8))
    for prop in ("sit_goals", "lie_goals", "lift_contacts", "lift_approach", "grasp_points", "handle_point",
                 "support_surfaces"):
        out[f"{name}.{prop}"] = digest(_outcome(lambda: getattr(obj, prop)))
    if canonical:
        out[f"{name}.params"] = digest(obj.params)
        out[f"{name}.annotations"] = digest(obj.annotations)
        out[f"{name}.point_cloud"] = digest(obj.point_cloud(256, seed=0))
        out[f"{name}.interaction_voxels"] = digest(obj.interaction_voxels(np.eye(4)))
    else:
        out[f"{name}.sdf_torch"] = digest(obj.sdf(torch.tensor(query, dtype=torch.float32)))
        out[f"{name}.interaction_voxels_frame"] = digest(obj.interaction_voxels(np.linalg.inv(obj.centre_frame)))
    if costly:
        out[f"{name}.volume"] = digest(obj.volume)
        out[f"{name}.occupancy_grid"] = digest(obj.occupancy_grid(8))


def _objects(out: dict) -> None:
    query = np.random.default_rng(12345).uniform([-1.5, -1.5, -0.1], [1.5, 1.5, 2.1], size=(512, 3))
    for category in objects.CATEGORIES:
        for seed in SEEDS:
            obj = objects.make_object(category, seed=seed)
            _object(out, f"objects.{category}[seed={seed}]", obj, query, canonical=True, costly=seed == 0)
            placed = obj.placed(0.3, -0.4, 0.8 + seed, z=0.1)
            _object(out, f"objects.{category}[seed={seed}].placed", placed, query, canonical=False, costly=False)
        scaled = objects.make_object(category, seed=9, size_scale=(1.2, 0.9, 1.1))
        out[f"objects.{category}.scaled.params"] = digest(scaled.params)
        out[f"objects.{category}.scaled.annotations"] = digest(scaled.annotations)
        out[f"objects.{category}.scaled.sdf"] = digest(scaled.sdf(query))
    for category, key, value in (("cabinet", "door_angle", 1.1), ("drawer", "drawer_open", 0.2),
                                 ("chair", "seat_height", 0.5)):
        obj = objects.make_object(category, seed=1, **{key: value}).placed(0.1, 0.2, 0.3)
        out[f"objects.{category}.override.annotations"] = digest(obj.annotations)
        out[f"objects.{category}.override.sdf"] = digest(obj.sdf(query))
        rebuilt = obj.with_params(**{key: value / 2})
        out[f"objects.{category}.with_params.annotations"] = digest(rebuilt.annotations)
        out[f"objects.{category}.with_params.sdf"] = digest(rebuilt.sdf(query))
    out["objects.override.unknown"] = digest(_outcome(lambda: objects.make_object("chair", 0, height=1.0)))
    out["objects.size_table"] = digest([list(row) for row in objects.size_table()])
    out["objects.category_sizes"] = digest(
        {c: {n: [r.low, r.high, r.axis, r.kind, r.unit, r.description] for n, r in spec.items()}
         for c, spec in objects.CATEGORY_SIZES.items()})
    out["objects.constants"] = digest({name: getattr(objects, name) for name in objects.__all__
                                       if name.isupper() and name != "CATEGORY_SIZES"})


def _scene_objects(objs) -> list:
    return [{"category": o.category, "params": o.params, "pose": o.pose} for o in objs]


def _scenes(out: dict) -> None:
    query = np.random.default_rng(54321).uniform([0.0, 0.0, 0.0], [6.0, 6.0, 2.0], size=(256, 3))
    for seed in SEEDS:
        room = scenes.make_room(seed)
        name = f"scenes.room[seed={seed}]"
        out[f"{name}.objects"] = digest(_scene_objects(room.objects))
        out[f"{name}.layout"] = digest([room.size, room.target_index, room.shape])
        out[f"{name}.occupancy"] = digest(room.occupancy)
        out[f"{name}.clearance"] = digest(room.clearance)
        out[f"{name}.sdf"] = digest(room.sdf(query))
        out[f"{name}.approach_point"] = digest(_outcome(room.approach_point))
        out[f"{name}.reachable_fraction"] = digest(_outcome(room.reachable_fraction))
        out[f"{name}.start_positions"] = digest(_outcome(lambda: room.start_positions(4, seed=seed)))

        kitchen = scenes.make_kitchen(seed)
        name = f"scenes.kitchen[seed={seed}]"
        out[f"{name}.furniture"] = digest(_scene_objects(kitchen.furniture))
        out[f"{name}.items"] = digest(_scene_objects(kitchen.items))
        out[f"{name}.obstacles"] = digest(_scene_objects(kitchen.obstacles))
        out[f"{name}.holders"] = digest(list(kitchen.holders))
        out[f"{name}.occupancy"] = digest(kitchen.occupancy)
        out[f"{name}.clearance"] = digest(kitchen.clearance)
        out[f"{name}.sdf"] = digest(kitchen.sdf(query[:, :3] * np.array([5 / 6, 5 / 6, 1.0])))
        out[f"{name}.start_positions"] = digest(_outcome(lambda: kitchen.start_positions(4, seed=seed)))


SECTIONS = {"mocap": _mocap, "interactions": _interactions, "gait": _gait, "objects": _objects, "scenes": _scenes}


def fingerprints(sections=tuple(SECTIONS)) -> dict[str, str]:
    """Entry name → SHA-256 hex digest, for the named sections (default: all)."""
    out: dict[str, str] = {}
    for section in sections:
        SECTIONS[section](out)
    return dict(sorted(out.items()))


def compare(expected: dict[str, str], actual: dict[str, str]) -> list[str]:
    """Readable lines, one per entry that differs, is missing or is new; empty when all match."""
    lines = []
    for key in sorted(set(expected) | set(actual)):
        if key not in actual:
            lines.append(f"missing: {key}")
        elif key not in expected:
            lines.append(f"new:     {key}")
        elif expected[key] != actual[key]:
            lines.append(f"differs: {key}")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", metavar="PATH", help="write the fingerprints to a JSON file")
    group.add_argument("--check", metavar="PATH", help="compare against a JSON file; exit 1 on differences")
    args = parser.parse_args(argv)
    actual = fingerprints()
    if args.write:
        with open(args.write, "w", encoding="utf-8") as f:
            json.dump(actual, f, indent=1, sort_keys=True)
            f.write("\n")
        print(f"wrote {len(actual)} fingerprints to {args.write}")
        return 0
    with open(args.check, encoding="utf-8") as f:
        expected = json.load(f)
    differences = compare(expected, actual)
    if differences:
        print(f"{len(differences)} of {len(expected)} fingerprints differ:")
        print("\n".join(differences))
        return 1
    print(f"all {len(expected)} fingerprints match")
    return 0


if __name__ == "__main__":
    sys.exit(main())
