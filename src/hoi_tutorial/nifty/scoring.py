"""NIFTY's evaluation protocol (§4.2, Appendix C.2): test scenes, the metrics of Table 1, its rows.

Test scenes are *not* made with the data pipeline (that would look too much like the training
data): NIFTY places objects at random and starts the person from a random pose. Here a scene takes
one of the training anchors (those that grew kept sequences), a *held-out instance* of its object's
category (new sizes, never seen in training) where that object stood, and a person of that
anchor's body shape standing or walking (a random frame of a toy-mocap ``idle`` or ``walk`` clip,
the prior's own kind of motion) at a random distance and heading around it.

Per generated motion (its last frame is the interaction pose):

- **foot skating** of the right toe vertex (:func:`~hoi_tutorial.metrics.foot_skating`);
- **D2O**, the distance from the final body to the object's surface (2K surface points);
- the **penetration score** of the first ``N_A`` frames, the approach
  (:func:`~hoi_tutorial.metrics.penetration_score` over 2K object points; ``N_A`` from the
  synthetic data with :func:`approach_length`);
- **skeleton distance** from the final pose to the nearest anchor pose of the training data, both
  in their object's frame, and the **contact IoU** between the final body's contacting vertices
  and the nearest anchor's (vertices inside the object);
- the **pose-only distance** (ours, not the paper's): the same sum over joints with both poses in
  their own root frame (pelvis over the origin, facing +Y), so it measures how the body is posed
  wherever it stands, where the skeleton distance mixes that with where it stands;
- the pelvis's ground-plane distance to the object's centre at the start and at the end (how far
  the person got).

:func:`table_row` condenses them as Table 1 does; :func:`paired_comparison` sets two methods' scores
of the same scenes against each other, each difference with its paired interval.

Scaled down: 500 test scenes per action -> 32; sequences of 150 frames -> the model's
``max_frames``.

``nifty.evaluation`` runs the protocol end to end on trained models (and caches the results).
"""
from __future__ import annotations

import collections
import copy
import dataclasses
import hashlib
import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
import torch

from .. import intervals, metrics
from .._validate import check_choice
from ..infra import load_or_build, single_threaded
from ..world import body
from ..world.features import canonicalize
from ..world.mocap import generate_clip
from ..world.motion import Motion, motion_from_payload, motion_payload
from ..world.objects import make_object, object_from_description
from .motion_model import anchor_skeleton_distance, final_pelvis_distance
from .paper_numbers import SUPPLEMENT_COLUMNS, TABLE1_COLUMNS

__all__ = [
    "TestScene",
    "test_scenes",
    "scene_distance_range",
    "object_centre",
    "MotionScores",
    "ScoredMotions",
    "APPROACH_QUANTILE",
    "approach_length",
    "evaluate_motions",
    "penetration_by_approach_length",
    "table_row",
    "table_counts",
    "POSE_THRESHOLD_QUANTILE",
    "pose_threshold",
    "pose_row",
    "paired_comparison",
    "BETTER",
    "comparison_table",
]

# NIFTY Appendix C.2: the median approach length for sitting, the 15th percentile for lifting.
APPROACH_QUANTILE = {"sit": 0.5, "lift": 0.15}


@dataclass
class TestScene:
    """One evaluation scene.

    Attributes:
        obj: the object, placed in the world (a held-out instance unless ``test_scenes`` was told
            otherwise).
        start: a two-frame world ``Motion``: the start pose ``X_0`` and the frame after it (its
            velocities).
        anchor: index into the anchors given to :func:`test_scenes` of the one whose object
            category, placement and body shape the scene uses.
        distance: metres, the start pelvis's ground-plane distance to the object's centre.
    """

    obj: object
    start: Motion
    anchor: int
    distance: float

@dataclass
class MotionScores:
    """NIFTY's per-sequence metrics (§4.2) of ``N`` interaction motions, one ``(N,)`` array each.

    Attributes:
        foot_skating: m/s, the right toe's skating score.
        d2o: metres, the final body's distance to the object's surface.
        penetration: metres, the approach's penetration score (NaN where D2O > 2 cm: not scored).
        skeleton_distance: metres summed over the 22 joints, final pose to the nearest anchor pose.
        nearest_anchor: int, that anchor's index in the ``anchors`` given to :func:`evaluate_motions`.
        contact_iou: IoU of the final pose's contacting vertices with the nearest anchor's.
        pose_distance: metres summed over the 22 joints, final pose to the nearest anchor pose with
            both in their own root frame (how the body is posed, wherever it stands; ours).
        start_distance, final_distance: metres, the pelvis's ground distance to the object's centre
            at the first and the last frame.
        final_distance_positions: metres, ``final_distance`` with the root read from the predicted
            positions ``t^p`` instead of integrated velocities (generated motions only; else None).
    """

    foot_skating: np.ndarray
    d2o: np.ndarray
    penetration: np.ndarray
    skeleton_distance: np.ndarray
    nearest_anchor: np.ndarray
    contact_iou: np.ndarray
    pose_distance: np.ndarray
    start_distance: np.ndarray
    final_distance: np.ndarray
    final_distance_positions: Optional[np.ndarray] = None

    def __len__(self) -> int:
        return int(len(self.d2o))

    def as_dict(self) -> dict:
        """The arrays by name (those that are set), e.g. for the artifact cache or a DataFrame."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if getattr(self, f.name) is not None}


@dataclass
class ScoredMotions:
    """A set of motions with their metrics.

    Attributes:
        motions: ``N`` world-frame ``Motion``.
        metrics: their :class:`MotionScores`.
    """

    motions: list
    metrics: MotionScores

_PLACEMENT_TRIES = 100
_START_CLEARANCE = 0.05  # metres between the start body and the object
# Scenes made in this process, by what they are made from (``_scenes_key``): every evaluation of a chapter asks for the
# same scenes, and making them (toy-mocap clips, bodies) takes seconds. A copy is handed out each time.
_SCENES_MADE: "collections.OrderedDict[bytes, list]" = collections.OrderedDict()
_SCENES_KEPT = 8


def _scenes_key(anchors, n_scenes, distance_range, seed, kinds) -> bytes:
    """What held-out test scenes are made from: each anchor's object category, placement and body shape, and the
    arguments."""
    parts = [repr((int(n_scenes), tuple(float(v) for v in distance_range), int(seed), tuple(kinds))).encode()]
    for anchor in anchors:
        parts += [anchor.obj.category.encode(), np.asarray(anchor.obj.pose, dtype=np.float64).tobytes(),
                  np.asarray(anchor.betas, dtype=np.float64).tobytes()]
    return hashlib.sha256(b"\0".join(parts)).digest()


def object_centre(obj) -> np.ndarray:
    """``(2,)`` metres: where the object stands on the ground (its frame's origin)."""
    return np.asarray(obj.pose, dtype=np.float64)[:2, 3]


@single_threaded
def test_scenes(anchors: Sequence, n_scenes: int, distance_range: tuple[float, float], seed: int = 0,
                kinds: tuple[str, ...] = ("idle", "walk"), held_out: bool = True) -> list[TestScene]:
    """Random test scenes around the anchors' objects (NIFTY §4.2, "test scenes").

    Scene ``i`` uses anchor ``i mod len(anchors)``: its body shape, and a new instance of its
    object's category (``held_out``, sizes drawn afresh, so the model meets an object it never saw)
    or the anchor's own object, placed where the anchor's object stands. The start pose is a random frame of a toy-mocap clip of a kind drawn from ``kinds``, moved so
    that its pelvis stands ``d ~ U(distance_range)`` metres from the object's centre in a random
    direction, facing a random heading (uniform over the circle: the person may start with the
    object behind them); placements where the body would come within 5 cm of the object are
    drawn again.

    Args:
        anchors: ``nifty.anchors.Anchor`` records (``obj``, ``betas``).
        n_scenes: number of scenes.
        distance_range: ``(low, high)`` metres, ``0 < low ≤ high``.
        seed: seeds everything random here.
        kinds: toy-mocap kinds the start pose comes from.
        held_out: a new instance of each anchor's object category (True) or the anchor's object.
    Returns:
        ``n_scenes`` :class:`TestScene`.
    """
    anchors = list(anchors)
    if not anchors:
        raise ValueError("anchors: expected at least one anchor")
    if not isinstance(n_scenes, (int, np.integer)) or n_scenes < 1:
        raise ValueError(f"n_scenes: expected a positive int, got {n_scenes!r}")
    low, high = (float(v) for v in distance_range)
    if not 0.0 < low <= high:
        raise ValueError(f"distance_range: expected 0 < low <= high metres, got {distance_range!r}")
    for kind in kinds:
        check_choice(kind, ("idle", "walk", "turn", "side_step"), "kinds")
    # held-out scenes depend on the anchors only through their objects' categories and placements and their body
    # shapes, so scenes made before from the same are the same: a copy of those made in this process, else the cached
    if not held_out:  # the anchors' own objects: made here each time (they are not keyed)
        return _make_scenes(anchors, int(n_scenes), low, high, seed, kinds, held_out)
    key = _scenes_key(anchors, n_scenes, (low, high), seed, kinds)
    if key in _SCENES_MADE:
        _SCENES_MADE.move_to_end(key)
        return copy.deepcopy(_SCENES_MADE[key])

    def build():
        return [{"object": {"category": s.obj.category, "params": dict(s.obj.params), "pose": np.asarray(s.obj.pose)},
                 "start": motion_payload(s.start), "anchor": int(s.anchor), "distance": float(s.distance)}
                for s in _make_scenes(anchors, int(n_scenes), low, high, seed, kinds, held_out)]

    # Made once, then from the cache (the objects rebuilt from their sizes and poses, the starts field by field):
    # the same scenes whether just made or loaded.
    made = load_or_build("nifty_test_scenes", {"scenes": key.hex()}, build)
    scenes = [TestScene(object_from_description(m["object"]), motion_from_payload(m["start"]), int(m["anchor"]),
                        float(m["distance"])) for m in made]
    _SCENES_MADE[key] = copy.deepcopy(scenes)
    while len(_SCENES_MADE) > _SCENES_KEPT:
        _SCENES_MADE.popitem(last=False)
    return scenes


def _make_scenes(anchors, n_scenes: int, low: float, high: float, seed: int, kinds, held_out: bool) -> list:
    rng = np.random.default_rng([int(seed), 4242])
    scenes = []
    for i in range(n_scenes):
        a = i % len(anchors)
        anchor = anchors[a]
        obj = make_object(anchor.obj.category, seed=rng).with_pose(anchor.obj.pose) if held_out else anchor.obj
        kind = str(rng.choice(kinds))
        clip = generate_clip(kind, seed=int(rng.integers(2**31)), betas=anchor.betas)
        t = int(rng.integers(0, len(clip) - 1))
        pose = canonicalize(clip.slice(t, t + 2))  # pelvis over the origin, facing +Y
        for _ in range(_PLACEMENT_TRIES):
            distance = float(rng.uniform(low, high))
            direction = float(rng.uniform(0.0, 2.0 * math.pi))
            heading = float(rng.uniform(0.0, 2.0 * math.pi))
            where = object_centre(obj) + distance * np.array([math.cos(direction), math.sin(direction)])
            translation = torch.tensor([where[0], where[1], 0.0], dtype=pose.root_position.dtype)
            start = pose.transformed(heading, translation)
            # The person must start clear of the object (a wide sofa reaches past the nearest starts).
            vertices = body.body_from_motion(start, frames=[0])[0]
            if float(np.min(obj.sdf(vertices.detach().double().numpy()))) > _START_CLEARANCE:
                break
        else:
            raise RuntimeError(f"test_scenes: no start {low}-{high} m from the {obj.category} clears it")
        scenes.append(TestScene(obj, start, a, distance))
    return scenes


def scene_distance_range(dataset, low: float = 5.0, high: float = 95.0) -> tuple[float, float]:
    """The ``(low, high)`` percentiles of the training sequences' start distances (metres)."""
    starts = [final_pelvis_distance(s.motion, s.obj)[1] for s in dataset.sequences]
    if not starts:
        raise ValueError("dataset: expected at least one training sequence")
    return float(np.percentile(starts, low)), float(np.percentile(starts, high))

def _penetration_per_frame(motion: Motion, object_points: torch.Tensor, frames=None) -> np.ndarray:
    """``(T', P)`` body SDF of every frame at the object points, exact where it is negative (inside the body).

    Only the points inside a frame's bounding box of the body (its capsules' boxes, radius
    included) can be inside the body; the SDF is evaluated for those, and the others get ``+inf``.
    Every use takes ``max(-sdf, 0)``, the penetration depth, which this leaves exact. Float32:
    millimetre precision is plenty for a 2 cm threshold.
    """
    rot, pos = motion.global_rotations, motion.joints
    if frames is not None:
        rot, pos = rot[frames], pos[frames]
    rot, pos, betas = rot.float(), pos.float(), motion.betas.float()
    points = object_points.float()
    a, b, radius = body.capsule_segments(rot, pos, betas)  # (T', C, 3), (T', C)
    low = (torch.minimum(a, b) - radius[..., None]).amin(dim=-2)  # (T', 3)
    high = (torch.maximum(a, b) + radius[..., None]).amax(dim=-2)
    near = ((points[None] >= low[:, None]) & (points[None] <= high[:, None])).all(dim=-1)  # (T', P)
    sdf = torch.full(near.shape, math.inf)
    t, p = torch.nonzero(near, as_tuple=True)
    sdf[t, p] = body.capsule_sdf(points[p, None], a[t], b[t], radius[t])[:, 0]
    return sdf.numpy()


def _world_object_points(obj, n_points: int, seed: int) -> torch.Tensor:
    return torch.as_tensor(np.asarray(obj.surface_points(n_points, seed=seed), dtype=np.float64))


@single_threaded
def approach_length(motions: Sequence[Motion], objects: Sequence, action: str, max_frames: Optional[int] = None,
                    n_object_points: int = 2000, seed: int = 0) -> int:
    """``N_A``, the approach length of the synthetic data (NIFTY Appendix C.2).

    For each data sequence the per-frame penetration (summed depth of the object's surface points
    inside the body) is computed, its approach length is the frame from which that curve only
    grows (:func:`~hoi_tutorial.metrics.approach_frames`), and ``N_A`` is the median over the
    data for sitting and the 15th percentile for lifting (:data:`APPROACH_QUANTILE`).

    Args:
        motions: data sequences (world frame), each ending in its interaction pose.
        objects: the object of each sequence.
        action: ``"sit"`` or ``"lift"``.
        max_frames: pad each sequence with its last frame (or keep its last ``max_frames``) to
            this length first, as the motion model sees it; ``None`` leaves them as they are.
        n_object_points: surface points per object (NIFTY: 2K).
        seed: seed of the point sampling.
    Returns:
        ``N_A`` (frames).
    """
    check_choice(action, tuple(APPROACH_QUANTILE), "action")
    motions, objects = list(motions), list(objects)
    if not motions or len(motions) != len(objects):
        raise ValueError(f"motions, objects: expected equal, non-zero lengths, got {len(motions)}, {len(objects)}")
    curves = []
    clouds = {}
    for motion, obj in zip(motions, objects):
        if id(obj) not in clouds:
            clouds[id(obj)] = _world_object_points(obj, n_object_points, seed)
        depth = np.clip(-_penetration_per_frame(motion, clouds[id(obj)]), 0.0, None).sum(-1)
        if max_frames is not None:
            depth = depth[-int(max_frames):]
            depth = np.concatenate([depth, np.full(int(max_frames) - len(depth), depth[-1])])
        curves.append(depth)
    return metrics.approach_length_quantile(curves, APPROACH_QUANTILE[action])


@single_threaded
def evaluate_motions(motions: Sequence[Motion], objects: Sequence, anchors: Sequence, n_approach: int,
                     n_object_points: int = 2000, seed: int = 0, reach: float = 0.02) -> MotionScores:
    """NIFTY's per-sequence metrics (§4.2) for generated (or data) interaction motions.

    Args:
        motions: ``N`` world-frame motions; the last frame is the interaction pose.
        objects: the object of each motion (placed in the world).
        anchors: the training anchors (``nifty.anchors.Anchor``), for skeleton distance and IoU.
        n_approach: ``N_A`` frames of approach for the penetration score (clamped to each length).
        n_object_points: object surface points for D2O and penetration (NIFTY: 2K).
        seed: seed of the point sampling.
        reach: metres, the D2O below which a sequence counts as reaching the object.
    Returns:
        :class:`MotionScores` (``final_distance_positions`` unset).
    """
    motions, objects, anchors = list(motions), list(objects), list(anchors)
    if not motions or len(motions) != len(objects):
        raise ValueError(f"motions, objects: expected equal, non-zero lengths, got {len(motions)}, {len(objects)}")
    if not anchors:
        raise ValueError("anchors: expected at least one anchor")
    if not isinstance(n_approach, (int, np.integer)) or n_approach < 1:
        raise ValueError(f"n_approach: expected a positive int, got {n_approach!r}")
    # Contacting vertices of every anchor with its own object, computed once.
    anchor_contacts = []
    anchor_joints = torch.stack([torch.as_tensor(a.pose.joints, dtype=torch.float64) for a in anchors])
    for anchor in anchors:
        pose = anchor.pose
        motion = Motion(pose.local_rotations[None], pose.root_position[None], anchor.betas)
        vertices = body.body_from_motion(motion)[0]
        anchor_contacts.append(body.object_contact_vertices(vertices, anchor.obj.sdf))
    clouds = {}
    out = {name: [] for name in ("foot_skating", "d2o", "penetration", "skeleton_distance", "nearest_anchor",
                                 "contact_iou", "pose_distance", "start_distance", "final_distance")}
    for motion, obj in zip(motions, objects):
        if not isinstance(motion, Motion):
            raise TypeError(f"motions: expected Motion records, got {type(motion).__name__}")
        if id(obj) not in clouds:
            clouds[id(obj)] = _world_object_points(obj, n_object_points, seed)
        points = clouds[id(obj)]
        final_vertices = body.body_from_motion(motion, frames=[len(motion) - 1])[0]
        n = min(int(n_approach), len(motion))
        distance, nearest = anchor_skeleton_distance(motion, anchors, obj)
        last, first = final_pelvis_distance(motion, obj)
        out["foot_skating"].append(float(metrics.foot_skating(body.toe_positions(motion), fps=motion.fps)))
        d2o = float(metrics.distance_to_object(final_vertices, points))
        out["d2o"].append(d2o)
        out["penetration"].append(float(metrics.penetration_score(
            _penetration_per_frame(motion, points, frames=slice(0, n)))) if d2o <= reach else math.nan)
        out["skeleton_distance"].append(float(distance))
        out["nearest_anchor"].append(int(nearest))
        contacts = body.object_contact_vertices(final_vertices, obj.sdf)
        out["contact_iou"].append(float(metrics.contact_iou(contacts, anchor_contacts[nearest])))
        out["pose_distance"].append(float(anchor_skeleton_distance(motion, anchor_joints)[0]))
        out["start_distance"].append(first)
        out["final_distance"].append(last)
    return MotionScores(**{name: np.asarray(values) for name, values in out.items()})


@single_threaded
def penetration_by_approach_length(motions: Sequence[Motion], objects: Sequence, d2o, n_approach_values,
                                   n_object_points: int = 2000, seed: int = 0, reach: float = 0.02,
                                   threshold: float = 0.02) -> dict:
    """% Pen. ≤ 2 cm as a function of ``N_A`` (NIFTY Appendix C.2, Figs. 10 and 11).

    Only the motions that reach the object (``d2o ≤ reach``) are scored, as in Table 1. For each, the
    per-frame penetration (summed depth of the object's surface points inside the body) is computed
    once; the penetration score for ``N_A`` is its mean over the first ``N_A`` frames
    (:func:`~hoi_tutorial.metrics.penetration_score`), clamped to each motion's length.

    Args:
        motions: ``N`` world-frame motions.
        objects: the object of each.
        d2o: ``(N,)`` metres, their final distance to the object (``MotionScores.d2o``).
        n_approach_values: the ``N_A`` values (frames, positive ints).
        n_object_points, seed: the object's surface points (as :func:`evaluate_motions`).
        reach: metres, the D2O below which a motion is scored.
        threshold: metres, the penetration score that counts as "no penetration".
    Returns:
        ``{"n_approach": (V,) int, "pct": (V,) % of the scored motions with penetration ≤ threshold
        (NaN when none is scored), "n_scored": int}``.
    """
    motions, objects = list(motions), list(objects)
    d2o = np.asarray(d2o, dtype=np.float64)
    if not motions or len(motions) != len(objects) or d2o.shape != (len(motions),):
        raise ValueError(f"motions, objects, d2o: expected equal, non-zero lengths, got {len(motions)}, "
                         f"{len(objects)}, {d2o.shape}")
    values = np.asarray([int(v) for v in n_approach_values], dtype=np.int64)
    if values.size == 0 or values.min() < 1:
        raise ValueError(f"n_approach_values: expected positive ints, got {list(n_approach_values)!r}")
    clouds, scores = {}, []
    for motion, obj, distance in zip(motions, objects, d2o):
        if distance > reach:
            continue
        if id(obj) not in clouds:
            clouds[id(obj)] = _world_object_points(obj, n_object_points, seed)
        depth = np.clip(-_penetration_per_frame(motion, clouds[id(obj)]), 0.0, None).sum(-1)  # (T,)
        mean_upto = np.cumsum(depth) / np.arange(1, len(depth) + 1)
        scores.append(mean_upto[np.minimum(values, len(depth)) - 1])
    if not scores:
        return {"n_approach": values, "pct": np.full(len(values), np.nan), "n_scored": 0}
    scores = np.stack(scores)  # (scored, V)
    return {"n_approach": values, "pct": 100.0 * (scores <= threshold).mean(axis=0), "n_scored": len(scores)}


def table_row(results: MotionScores, d2o_threshold: float = 0.02, penetration_threshold: float = 0.02,
              skeleton_threshold: float = 0.25, columns=TABLE1_COLUMNS) -> dict:
    """One row of NIFTY's tables from :class:`MotionScores` (:func:`evaluate_motions`).

    Columns (any of :data:`~hoi_tutorial.nifty.paper_numbers.SUPPLEMENT_COLUMNS`, default Table 1's):
    mean foot skating, % of sequences with D2O ≤ 2 cm, the 95th percentile of D2O (metres), mean
    skeleton distance (metres), % of sequences with skeleton distance ≤ 25 cm (Appendix D.1), mean
    contact IoU, and the % of sequences with penetration ≤ 2 cm among those with D2O ≤ 2 cm (NaN when
    none reaches the object). :func:`table_counts` gives the counts behind the percentages.
    """
    if not isinstance(results, MotionScores):
        raise TypeError(f"results: expected MotionScores (the output of evaluate_motions), "
                        f"got {type(results).__name__}")
    unknown = [c for c in columns if c not in SUPPLEMENT_COLUMNS]
    if unknown:
        raise ValueError(f"columns: unknown {unknown}; expected some of {list(SUPPLEMENT_COLUMNS)}")
    d2o = metrics.d2o_summary(results.d2o, threshold=d2o_threshold)
    values = {
        "Foot Skating ↓": float(np.mean(results.foot_skating)),
        "% D2O ≤ 2cm ↑": d2o["pct_within"],
        "D2O 95th % ↓": d2o["p95"],
        "Skel. Dist. ↓": float(np.mean(results.skeleton_distance)),
        "% Skel. Dist. ≤ 25cm ↑": float(100.0 * np.mean(np.asarray(results.skeleton_distance) <= skeleton_threshold)),
        "Contact IoU ↑": float(np.mean(results.contact_iou)),
        "% Pen. ≤ 2cm ↑": metrics.penetration_pass_rate(results.penetration, results.d2o,
                                                       threshold=penetration_threshold, d2o_threshold=d2o_threshold),
    }
    return {column: values[column] for column in columns}


def table_counts(results: MotionScores, d2o_threshold: float = 0.02, penetration_threshold: float = 0.02,
                 skeleton_threshold: float = 0.25) -> dict:
    """The counts behind :func:`table_row`'s percentages, as ``"k / n"`` strings.

    Returns ``{"D2O ≤ 2cm": reached / all, "Skel. Dist. ≤ 25cm": within / all,
    "Pen. ≤ 2cm": passed / reached}``.
    """
    if not isinstance(results, MotionScores):
        raise TypeError(f"results: expected MotionScores, got {type(results).__name__}")
    d2o, pen = np.asarray(results.d2o), np.asarray(results.penetration)
    reached = d2o <= d2o_threshold
    n = len(d2o)
    return {"D2O ≤ 2cm": f"{int(reached.sum())} / {n}",
            "Skel. Dist. ≤ 25cm": f"{int((np.asarray(results.skeleton_distance) <= skeleton_threshold).sum())} / {n}",
            "Pen. ≤ 2cm": f"{int((pen[reached] <= penetration_threshold).sum())} / {int(reached.sum())}"}


# The share of samples on their own training conditions a pose-only threshold lets pass (pose_threshold).
POSE_THRESHOLD_QUANTILE = 0.5


def pose_threshold(training: MotionScores, quantile: float = POSE_THRESHOLD_QUANTILE) -> float:
    """The pose-only distance under which a final pose counts as posed like the data (ours).

    Chosen on *training* conditions, never on the test scenes: the ``quantile`` (default the median)
    of the pose-only distances of a model's samples of its own training conditions
    (``nifty.evaluation.evaluate_motion_model(...).training``), rounded to the centimetre. At the
    median half of those samples pass, so the share under it can separate methods either way; NIFTY's
    own 25 cm skeleton-distance threshold is passed by none of our samples.

    Args:
        training: :class:`MotionScores` of samples on training conditions.
        quantile: in (0, 1).
    Returns:
        metres (summed over the 22 joints).
    """
    if not isinstance(training, MotionScores):
        raise TypeError(f"training: expected MotionScores, got {type(training).__name__}")
    if not 0.0 < float(quantile) < 1.0:
        raise ValueError(f"quantile: expected a value in (0, 1), got {quantile!r}")
    return round(float(np.quantile(np.asarray(training.pose_distance, dtype=np.float64), quantile)), 2)


def pose_row(results: MotionScores, threshold: float) -> dict:
    """The pose-only columns beside a Table 1 row: the mean pose-only distance (m), the % of final
    poses within ``threshold`` of an anchor pose (:func:`pose_threshold`) and the count behind it."""
    if not isinstance(results, MotionScores):
        raise TypeError(f"results: expected MotionScores, got {type(results).__name__}")
    within = np.asarray(results.pose_distance) <= float(threshold)
    return {"Pose Dist. ↓": float(np.mean(results.pose_distance)),
            f"% Pose Dist. ≤ {100 * float(threshold):.0f}cm ↑": float(100.0 * within.mean()),
            "count": f"{int(within.sum())} / {len(within)}"}


# The side of zero on which "ours is better" lies, for each difference :func:`paired_comparison` returns.
BETTER = {"reach": "above", "d2o": "below", "skel": "below", "pose": "below", "contact_iou": "above"}
_COMPARISON_LABELS = {"reach": ("% D2O ≤ 2cm (points)", 100.0), "d2o": ("D2O, median difference (m)", 1.0),
                      "skel": ("mean Skel. Dist. (m)", 1.0), "pose": ("mean Pose Dist. (m)", 1.0),
                      "contact_iou": ("contact IoU", 1.0)}


def paired_comparison(ours: MotionScores, theirs: MotionScores, n_scenes: Optional[int] = None,
                      d2o_threshold: float = 0.02) -> dict:
    """Two methods' scores of the same test scenes, ours minus theirs, each with a paired 95 % interval.

    Args:
        ours, theirs: per-scene :class:`MotionScores`; scene ``i`` of both must be the same scene (the
            evaluations of one ``evaluation_config`` share their scenes, in order).
        n_scenes: compare the first ``n_scenes`` of each (a guided run of the first scenes against a
            full evaluation); ``None`` requires the two to have the same length.
        d2o_threshold: metres, "reaches the object" (Table 1: 2 cm).

    Returns:
        ``{"reach": ..., "d2o": ..., "skel": ..., "pose": ..., "contact_iou": ...}``, each an
        :class:`~hoi_tutorial.intervals.Interval` of ours minus theirs, paired scene by scene
        (:func:`~hoi_tutorial.intervals.paired_difference`): the share of scenes with D2O at most the
        threshold (0-1), the median of the scenes' D2O differences (m), the mean skeleton distance (m),
        the mean pose-only distance (m) and the mean contact IoU. "Ours is better" reads ``verdict("above")``
        for reach and contact IoU, ``verdict("below")`` for D2O and the two distances (:data:`BETTER`).
    """
    if n_scenes is None:
        if len(ours) != len(theirs):
            raise ValueError(f"ours, theirs: expected scores of the same scenes, got {len(ours)} and {len(theirs)} "
                             "(give n_scenes to compare the first scenes of each)")
        n_scenes = len(ours)
    if not isinstance(n_scenes, int) or not 2 <= n_scenes <= min(len(ours), len(theirs)):
        raise ValueError(f"n_scenes: expected an int from 2 to {min(len(ours), len(theirs))} (the scenes both "
                         f"score), got {n_scenes!r}")

    def first(m: MotionScores, name: str) -> np.ndarray:
        return np.asarray(getattr(m, name), dtype=np.float64)[:n_scenes]

    return {
        "reach": intervals.paired_difference(first(ours, "d2o") <= d2o_threshold,
                                             first(theirs, "d2o") <= d2o_threshold),
        "d2o": intervals.paired_difference(first(ours, "d2o"), first(theirs, "d2o"), statistic="median"),
        "skel": intervals.paired_difference(first(ours, "skeleton_distance"), first(theirs, "skeleton_distance")),
        "pose": intervals.paired_difference(first(ours, "pose_distance"), first(theirs, "pose_distance")),
        "contact_iou": intervals.paired_difference(first(ours, "contact_iou"), first(theirs, "contact_iou")),
    }


def comparison_table(comparisons, columns: Sequence[str] = ("reach", "d2o", "skel")):
    """A DataFrame of :func:`paired_comparison` results, one row per comparison.

    comparisons: ``{row label: paired_comparison(...)}``. columns: which differences to show. Each
    difference appears as ``"estimate [low, high]"`` (the share in percentage points), followed by its
    verdict on "ours is better" (:data:`BETTER`): "held", "inconclusive" or "not held".
    """
    import pandas as pd

    for c in columns:
        if c not in BETTER:
            raise ValueError(f"columns: expected names among {tuple(BETTER)}, got {c!r}")
    rows = {}
    for label, found in comparisons.items():
        row = {}
        for c in columns:
            name, scale = _COMPARISON_LABELS[c]
            row[name] = found[c].format(scale=scale)
            row[f"{name}: better"] = found[c].verdict(BETTER[c])
        rows[label] = row
    return pd.DataFrame(rows).T
