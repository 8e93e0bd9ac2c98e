"""The toy motion capture: a procedural, stochastic generator of clean, labelled motion at 30 fps.

It stands in for AMASS, BEHAVE and the SAMP and CHOICE captures. Feet are planted while in
contact (ground-truth foot skating ≈ 0), hand contacts with objects are exact (IK), and every clip
carries per-frame action labels (``motion.ACTIONS``) and contact labels (``motion.CONTACT_JOINTS``).

- ``gait``: locomotion — :func:`~.gait.idle`, :func:`~.gait.walk_path` (walk or run along a path),
  :func:`~.gait.turn_in_place`, :func:`~.gait.side_step`; built from ``paths`` (ground paths and
  speed profiles), ``footsteps`` (footstep plans and foot tracks), ``gait_params`` (style ranges),
  ``gait_body`` (leg geometry) and ``gait_synthesis`` (the posed body).
- ``interactions``: sit, lie down, lift, reach and grasp, open a door or drawer — one module per
  family (``sitting``, ``lying``, ``lifting``, ``grasping``, ``handles``) on ``body_plan`` (the
  per-frame plan and its IK solve), ``standing`` (standing, stepping, bending) and ``approach``
  (walking to the object and away).
- ``poses``: reference poses (:func:`~.poses.standing_pose`).
- ``motion_math``: the small math they share (easing curves, axis rotations, seeded generators).

The front door is :func:`generate_clip` (one clip of a named kind from a seed) and
:func:`generate_dataset` (a reproducible set of clips, optionally over several toy subjects whose
body shapes come from :func:`sample_betas`).
"""
from __future__ import annotations

import importlib.util
import math
import zlib
from typing import Callable, Optional, Sequence

import numpy as np
import torch

from ...infra.cache import load_or_build
from ...infra.device import single_threaded
from ..motion import Motion, motion_from_payload, motion_payload
from ..objects import make_object
from ..skeleton import NUM_BETAS
from . import gait
from .gait import GAITS, Footstep, footstep_plan, idle, path_from_waypoints, side_step, turn_in_place, walk_path
from .motion_math import seeded_rng
from .poses import standing_pose

__all__ = [
    "ACTION_GENERATORS",
    "LOCOMOTION_KINDS",
    "INTERACTION_KINDS",
    "INTERACTION_OBJECTS",
    "generate_clip",
    "generate_dataset",
    "sample_betas",
    "random_path",
    "standing_pose",
    "walk_path",
    "idle",
    "turn_in_place",
    "side_step",
    "footstep_plan",
    "Footstep",
    "path_from_waypoints",
    "GAITS",
]

LOCOMOTION_KINDS: tuple[str, ...] = ("idle", "walk", "run", "turn", "side_step")
INTERACTION_KINDS: tuple[str, ...] = ("sit", "lie", "lift", "reach_grasp", "open_door", "open_drawer")

# Object categories each interaction kind is generated with in ``generate_dataset``.
INTERACTION_OBJECTS: dict[str, tuple[str, ...]] = {
    "sit": ("chair", "armchair", "stool", "sofa"),
    "lie": ("sofa",),
    "lift": ("box", "suitcase"),
    "reach_grasp": ("bottle", "mug", "teapot"),
    "open_door": ("cabinet",),
    "open_drawer": ("drawer",),
}

# Toy room used for random paths: a square of this side, centred on the origin, metres.
ROOM_SIZE = 6.0


def sample_betas(rng_or_seed, scale: float = 1.0) -> torch.Tensor:
    """Body shape of a toy "subject": standard normal times ``scale``, clipped to ±2.5.

    Args:
        rng_or_seed: int or ``numpy.random.Generator``.
        scale: standard deviation of each entry (0 gives the mean body).
    Returns:
        ``(10,)`` float32 tensor of toy betas (see ``skeleton``).
    """
    if not (isinstance(scale, (int, float, np.floating, np.integer)) and 0.0 <= float(scale) <= 5.0):
        raise ValueError(f"scale: expected a number in [0, 5], got {scale!r}")
    rng = seeded_rng(rng_or_seed)
    betas = np.clip(rng.normal(size=NUM_BETAS) * float(scale), -2.5, 2.5)
    return torch.tensor(betas, dtype=torch.float32)


def random_path(rng_or_seed, n_points: Optional[int] = None, *, room: float = ROOM_SIZE, min_leg: float = 1.0,
                max_turn: float = math.radians(120.0), min_length: float = 0.0) -> np.ndarray:
    """Random ground waypoints inside a square room, without sharp reversals.

    Args:
        rng_or_seed: int or ``numpy.random.Generator``.
        n_points: number of waypoints (default: 2 to 4 at random).
        room: side of the square room centred on the origin, metres.
        min_leg: shortest distance between consecutive waypoints, metres.
        max_turn: largest change of direction at a waypoint, radians.
        min_length: shortest total polyline length, metres (the first leg stretches to reach it).
    Returns:
        ``(n_points, 2)`` metres.
    """
    rng = seeded_rng(rng_or_seed)
    n = int(rng.integers(2, 5)) if n_points is None else int(n_points)
    if n < 2:
        raise ValueError(f"n_points: expected at least 2, got {n}")
    half = 0.5 * room - 0.3
    for _ in range(200):
        pts = [rng.uniform(-half, half, size=2)]
        direction = None
        ok = True
        for k in range(1, n):
            for _ in range(50):
                angle = rng.uniform(-math.pi, math.pi)
                if direction is not None and abs((angle - direction + math.pi) % (2 * math.pi) - math.pi) > max_turn:
                    continue
                extra = max(min_length - _polyline_length(pts), 0.0) if k == n - 1 else 0.0
                leg = rng.uniform(min_leg, max(min_leg, 0.8 * room)) + extra
                cand = pts[-1] + leg * np.array([-math.sin(angle), math.cos(angle)])
                if np.all(np.abs(cand) <= half):
                    pts.append(cand)
                    direction = angle
                    break
            else:
                ok = False
                break
        if ok and _polyline_length(pts) >= min_length:
            return np.stack(pts)
    raise ValueError(f"random_path: could not fit {n} waypoints of length >= {min_length} m in a {room} m room")


def _polyline_length(pts) -> float:
    return float(sum(np.linalg.norm(b - a) for a, b in zip(pts[:-1], pts[1:])))


# --------------------------------------------------------------------------- locomotion kinds

def _walk_clip(*, seed, betas=None, waypoints=None, gait: str = "walk", **kwargs) -> Motion:
    rng = seeded_rng(seed)
    if waypoints is None:
        # Runs need room to speed up and slow down: 3-4 waypoints, at least 5 m of path.
        waypoints = random_path(rng, int(rng.integers(3, 5)), min_length=5.0) if gait == "run" else random_path(rng)
    return walk_path(waypoints, betas=betas, seed=rng, gait=gait, **kwargs)


def _run_clip(*, seed, betas=None, **kwargs) -> Motion:
    return _walk_clip(seed=seed, betas=betas, gait="run", **kwargs)


def _idle_clip(*, seed, betas=None, duration=None, **kwargs) -> Motion:
    rng = seeded_rng(seed)
    duration = float(rng.uniform(2.0, 4.0)) if duration is None else duration
    return idle(duration, betas=betas, seed=rng, **kwargs)


def _turn_clip(*, seed, betas=None, angle=None, **kwargs) -> Motion:
    rng = seeded_rng(seed)
    if angle is None:
        angle = float(rng.choice([-1.0, 1.0]) * rng.uniform(math.radians(45), math.radians(180)))
    return turn_in_place(angle, betas=betas, seed=rng, **kwargs)


def _side_step_clip(*, seed, betas=None, distance=None, **kwargs) -> Motion:
    rng = seeded_rng(seed)
    if distance is None:
        distance = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 1.0))
    return side_step(distance, betas=betas, seed=rng, **kwargs)


ACTION_GENERATORS: dict[str, Callable[..., Motion]] = {
    "idle": _idle_clip,
    "walk": _walk_clip,
    "run": _run_clip,
    "turn": _turn_clip,
    "side_step": _side_step_clip,
}


def _with_object(kind: str, function: Callable[..., Motion]) -> Callable[..., Motion]:
    """Adapt an interaction generator ``function(obj, *, seed, betas, ...)`` to the registry's
    keyword form; without ``obj`` an object of a category from ``INTERACTION_OBJECTS[kind]`` is
    made from the seed."""

    def generate(*, seed, betas=None, obj=None, **kwargs) -> Motion:
        rng = seeded_rng(seed)
        if obj is None:
            categories = INTERACTION_OBJECTS[kind]
            obj = make_object(categories[int(rng.integers(len(categories)))], seed=rng)
        return function(obj, seed=rng, betas=betas, **kwargs)

    generate.__name__ = f"generate_{kind}"
    generate.__doc__ = f"``interactions.{function.__name__}`` with the object passed as ``obj``."
    return generate


# Interaction clips come from ``interactions.py``; registered whenever that module is present.
if importlib.util.find_spec(f"{__name__}.interactions") is not None:
    from . import interactions  # noqa: E402

    for _kind in INTERACTION_KINDS:
        ACTION_GENERATORS[_kind] = _with_object(_kind, getattr(interactions, _kind))


def generate_clip(kind: str, *, seed, betas=None, **kwargs) -> Motion:
    """One clip of a named kind.

    Locomotion kinds sample what they are not given from ``seed``: "idle" a 2–4 s duration,
    "walk" / "run" a random path in a 6 m room (runs at least 5 m long), "turn" an angle of
    45–180° either way, "side_step" 0.3–1 m either way. Interaction kinds take the object as
    ``obj`` (a ``world.objects.ToyObject``; one of ``INTERACTION_OBJECTS[kind]`` is made from the
    seed when it is missing) and the options of the matching function in ``interactions``.

    Args:
        kind: one of ``ACTION_GENERATORS`` ("idle", "walk", "run", "turn", "side_step" and the
            interaction kinds "sit", "lie", "lift", "reach_grasp", "open_door", "open_drawer").
        seed: int or ``numpy.random.Generator``.
        betas: ``(10,)`` toy body shape, None for the mean body.
        **kwargs: passed to the generator (e.g. ``waypoints``, ``speed``, ``angle``, ``distance``,
            ``obj``, ``style``).
    Returns:
        ``Motion`` with ``meta["kind"]`` set.
    """
    if kind not in ACTION_GENERATORS:
        raise ValueError(f"kind: expected one of {sorted(ACTION_GENERATORS)}, got {kind!r}")
    motion = ACTION_GENERATORS[kind](seed=seed, betas=betas, **kwargs)
    motion.meta = {**motion.meta, "kind": kind}
    if isinstance(seed, (int, np.integer)):
        motion.meta["seed"] = int(seed)
    return motion


def _clip_seed(seed: int, kind: str, index: int) -> int:
    """Seed of clip ``index`` of ``kind``: stable across runs and independent of the other kinds."""
    sequence = np.random.SeedSequence([int(seed), zlib.crc32(kind.encode("utf-8")), int(index)])
    return int(sequence.generate_state(1, dtype=np.uint32)[0])


def _subject_betas(seed: int, subjects) -> Optional[list[torch.Tensor]]:
    if subjects is None:
        return None
    if isinstance(subjects, (int, np.integer)) and not isinstance(subjects, bool):
        if subjects < 1:
            raise ValueError(f"subjects: expected a positive count, got {subjects}")
        root = np.random.SeedSequence([int(seed), zlib.crc32(b"subjects")])
        return [sample_betas(np.random.default_rng(child)) for child in root.spawn(int(subjects))]
    betas = [torch.as_tensor(np.asarray(b, dtype=np.float32)) for b in subjects]
    if not betas or any(tuple(b.shape) != (NUM_BETAS,) for b in betas):
        raise ValueError(f"subjects: expected None, a positive int or a sequence of ({NUM_BETAS},) betas")
    return betas


@single_threaded
def generate_dataset(n_per_kind: int, *, seed: int, kinds: Optional[Sequence[str]] = None,
                     subjects=None, cache: bool = False) -> list[Motion]:
    """A reproducible toy-mocap data set: ``n_per_kind`` clips of each kind.

    Clip ``i`` of ``kind`` uses the seed derived from ``(seed, kind, i)`` by
    ``numpy.random.SeedSequence``, so adding kinds or clips never changes the others.
    Interaction kinds get an object from ``world.objects.make_object`` (category drawn from
    ``INTERACTION_OBJECTS[kind]``, instance from the clip's seed).

    Args:
        n_per_kind: clips per kind (>= 0).
        seed: int.
        kinds: kinds to generate (default: every registered kind, ``ACTION_GENERATORS``).
        subjects: None (mean body), an int ``n`` (``n`` toy subjects from :func:`sample_betas`,
            clip ``i`` performed by subject ``i % n``), or a sequence of ``(10,)`` betas.
        cache: make the clips once, then load them from the artifact cache (``infra.load_or_build``, keyed by the
            arguments, the subjects' body shapes and the generators' code): the same clips, bit for bit, for a
            chapter that shows a data set it does not train on (a builder's own clips are part of what it builds).
    Returns:
        list of ``Motion``, grouped by kind in the order of ``kinds``; ``meta`` records kind,
        seed, index and subject.
    """
    if isinstance(n_per_kind, bool) or not isinstance(n_per_kind, (int, np.integer)) or n_per_kind < 0:
        raise ValueError(f"n_per_kind: expected a non-negative int, got {n_per_kind!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed: expected a non-negative int, got {seed!r}")
    if isinstance(kinds, str):  # list("sit") would be its letters
        raise ValueError(f"kinds: expected a sequence of kind names such as ({kinds!r},), got the string {kinds!r}")
    kinds = list(ACTION_GENERATORS) if kinds is None else list(kinds)
    for kind in kinds:
        if kind not in ACTION_GENERATORS:
            raise ValueError(f"kinds: expected names from {sorted(ACTION_GENERATORS)}, got {kind!r}")
    if not isinstance(cache, bool):
        raise ValueError(f"cache: expected a bool, got {cache!r}")
    betas_list = _subject_betas(seed, subjects)
    if cache:
        key = {"n_per_kind": int(n_per_kind), "seed": int(seed), "kinds": kinds,
               "betas": None if betas_list is None else [np.asarray(b, dtype=np.float64) for b in betas_list]}
        made = load_or_build("mocap_dataset", key, lambda: [motion_payload(m) for m in
                                                            _generate_dataset(n_per_kind, seed, kinds, betas_list)])
        return [motion_from_payload(m) for m in made]
    return _generate_dataset(n_per_kind, seed, kinds, betas_list)


def _generate_dataset(n_per_kind: int, seed: int, kinds: list, betas_list) -> list[Motion]:
    clips = []
    for kind in kinds:
        for index in range(int(n_per_kind)):
            clip_seed = _clip_seed(seed, kind, index)
            subject = None if betas_list is None else index % len(betas_list)
            betas = None if subject is None else betas_list[subject]
            kwargs = {}
            if kind in INTERACTION_KINDS:
                rng = np.random.default_rng(clip_seed)
                categories = INTERACTION_OBJECTS[kind]
                kwargs["obj"] = make_object(categories[int(rng.integers(len(categories)))], seed=rng)
                clip_seed = int(rng.integers(2**32 - 1))
            motion = generate_clip(kind, seed=clip_seed, betas=betas, **kwargs)
            motion.meta = {**motion.meta, "index": index, "subject": subject, "dataset_seed": int(seed)}
            clips.append(motion)
    return clips
