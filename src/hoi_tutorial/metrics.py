"""Every metric that NIFTY, SAMP and CHOICE report, one function each.

Inputs may be numpy arrays, torch tensors (detached and moved to the CPU here: metrics are
never differentiated) or nested lists. Outputs are python floats for a single value and numpy
arrays where a leading batch of sequences gives one value per sequence. Units are metres,
seconds and degrees; the tables of the papers print centimetres, which the book converts.

Direction of each metric (↑ higher is better, ↓ lower is better) is given in its docstring.

NIFTY (§4.2, Appendix C.2): :func:`foot_skating`, :func:`distance_to_object`,
:func:`d2o_summary`, :func:`penetration_score`, :func:`penetration_pass_rate`,
:func:`approach_frames`, :func:`approach_length_quantile`, :func:`skeleton_distance`,
:func:`contact_set`, :func:`contact_iou`.

SAMP (§5.2): :func:`average_pairwise_distance`, :func:`goal_apd`,
:func:`goal_reconstruction_error`, :func:`penetration_frame_rate`, :func:`execution_time`,
:func:`goal_precision`, :func:`frechet_distance`.

CHOICE (Tables 3 and 4): :func:`unsmoothness`, :func:`foot_sliding`, :func:`foot_slide_speed`,
:func:`rms_curvature`, :func:`safety_distance`, :func:`near_endpoint_mask`,
:func:`success_rate`, :func:`frechet_distance` with :func:`sliding_windows`.
"""
from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg
import torch
from scipy.spatial import cKDTree

from ._validate import check_shape

__all__ = [
    "foot_skating",
    "distance_to_object",
    "d2o_summary",
    "penetration_score",
    "penetration_pass_rate",
    "approach_frames",
    "approach_length_quantile",
    "skeleton_distance",
    "contact_set",
    "contact_iou",
    "average_pairwise_distance",
    "goal_apd",
    "goal_reconstruction_error",
    "penetration_frame_rate",
    "execution_time",
    "goal_precision",
    "frechet_distance",
    "sliding_windows",
    "unsmoothness",
    "foot_sliding",
    "foot_slide_speed",
    "rms_curvature",
    "safety_distance",
    "near_endpoint_mask",
    "success_rate",
]


# ----------------------------------------------------------------------------- helpers


def _to_numpy(x, name: str, dtype=np.float64) -> np.ndarray:
    """Convert an array, tensor or nested list to a numpy array (``dtype=None`` keeps it)."""
    if isinstance(x, torch.Tensor):
        x = x.detach().cpu().numpy()
    try:
        arr = np.asarray(x)
        return arr.astype(dtype, copy=False) if dtype is not None else arr
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an array-like of numbers, got {type(x).__name__}") from exc


def _to_bool(x, name: str) -> np.ndarray:
    arr = _to_numpy(x, name, dtype=None)
    if arr.dtype != bool:
        if not np.issubdtype(arr.dtype, np.number):
            raise TypeError(f"{name}: expected booleans, got dtype {arr.dtype}")
        arr = arr != 0
    return arr


def _out(x):
    """A 0-d result becomes a python float, anything else a float numpy array."""
    x = np.asarray(x, dtype=np.float64)
    return float(x) if x.ndim == 0 else x


def _check_min_length(n: int, minimum: int, name: str, what: str) -> None:
    if n < minimum:
        raise ValueError(f"{name}: expected at least {minimum} {what}, got {n}")


def _check_same_shape(a: np.ndarray, b: np.ndarray, name_a: str, name_b: str) -> None:
    if a.shape != b.shape:
        raise ValueError(f"{name_b}: expected the shape of {name_a} {a.shape}, got {b.shape}")


def _masked_mean(values: np.ndarray, mask: np.ndarray, axes) -> np.ndarray:
    """Mean of ``values`` where ``mask`` over ``axes``; NaN where the mask is empty."""
    count = mask.sum(axis=axes)
    total = np.where(mask, values, 0.0).sum(axis=axes)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _unit(v: np.ndarray, name: str) -> np.ndarray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise ValueError(f"{name}: expected non-zero direction vectors, found a zero vector")
    return v / norm


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle in degrees between unit vectors along the last axis."""
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


# ----------------------------------------------------------------------------- NIFTY


def foot_skating(toe_positions, fps: float = 30.0, height_threshold: float = 0.025):
    """Foot-skating score of the right-toe vertex (NIFTY §4.2), ↓.

    ``(1/N) Σ_i v_i (2 − 2^{h_i/H}) · 1[h_i ≤ H]`` with ``H = height_threshold``: the mean
    horizontal toe speed while the toe is near the ground, weighted more the closer it is.

    Args:
        toe_positions: ``(..., T, 3)`` metres, the right-toe vertex per frame, T ≥ 2.
        fps: frames per second.
        height_threshold: ``H`` in metres (NIFTY: 2.5 cm).

    Returns:
        ``(...)`` m/s. ``v_i`` is the horizontal (xy) speed from the forward difference
        between frames ``i`` and ``i+1`` (T−1 velocities, averaged); ``h_i`` is the z height of
        frame ``i``, clamped at 0 so a toe below the ground gets the full weight 1.
    """
    toe = _to_numpy(toe_positions, "toe_positions")
    check_shape(toe, (..., None, 3), "toe_positions")
    _check_min_length(toe.shape[-2], 2, "toe_positions", "frames")
    speed = np.linalg.norm(np.diff(toe[..., :2], axis=-2), axis=-1) * fps
    height = np.clip(toe[..., :-1, 2], 0.0, None)
    weight = np.where(height <= height_threshold, 2.0 - np.power(2.0, height / height_threshold), 0.0)
    return _out(np.mean(speed * weight, axis=-1))


def distance_to_object(body_points, object_points, chunk_size: int = 65536):
    """D2O: minimum distance from the body to the object's surface (NIFTY §4.2), ↓.

    Pass the body's surface vertices in the LAST frame of each sequence, e.g.
    ``vertices[..., -1, :, :]``; NIFTY measures the final interaction pose.

    Args:
        body_points: ``(..., V, 3)`` metres, body surface vertices (one set per sequence).
        object_points: ``(P, 3)`` metres, points sampled on the object's surface.
        chunk_size: body points queried against the object's KD-tree at a time.

    Returns:
        ``(...)`` metres, ``min_{v, p} ||body_v − object_p||``. Points sampled on the surface
        only: a body vertex inside the object still reports its distance to the nearest
        sampled surface point.
    """
    body = _to_numpy(body_points, "body_points")
    obj = _to_numpy(object_points, "object_points")
    check_shape(body, (..., None, 3), "body_points")
    check_shape(obj, (None, 3), "object_points")
    _check_min_length(body.shape[-2], 1, "body_points", "vertices")
    _check_min_length(obj.shape[0], 1, "object_points", "points")
    tree = cKDTree(obj)
    flat = body.reshape(-1, 3)
    dist = np.empty(len(flat))
    for start in range(0, len(flat), chunk_size):
        dist[start:start + chunk_size], _ = tree.query(flat[start:start + chunk_size])
    return _out(dist.reshape(body.shape[:-1]).min(axis=-1))


def d2o_summary(d2o, threshold: float = 0.02) -> dict:
    """Table summary of D2O values (NIFTY Table 1).

    Args:
        d2o: ``(N,)`` (any shape, flattened) metres, one D2O per sequence.
        threshold: metres (NIFTY: 2 cm).

    Returns:
        ``{"pct_within": % of sequences with D2O ≤ threshold (↑),
        "p95": 95th percentile of D2O in metres (↓)}``.
    """
    values = _to_numpy(d2o, "d2o").reshape(-1)
    _check_min_length(values.size, 1, "d2o", "values")
    return {
        "pct_within": float(100.0 * np.mean(values <= threshold)),
        "p95": float(np.percentile(values, 95)),
    }


def penetration_score(body_sdf_at_object_points, n_approach: int | None = None):
    """Penetration score of the approach (NIFTY §4.2 and Appendix C.2), ↓.

    ``(1/N_A) Σ_v Σ_{i ≤ N_A} depth_i(v)``: the depth of every object surface point inside
    the body, summed over points, averaged over the first ``N_A`` frames. The body SDF in this
    library is NEGATIVE inside the body, so ``depth = max(−sdf, 0)`` (NIFTY writes the same
    with its positive-inside convention).

    Args:
        body_sdf_at_object_points: ``(..., T, P)`` metres, the body's SDF evaluated at the
            ``P`` object surface points in each frame.
        n_approach: ``N_A``, the number of approach frames (1 ≤ N_A ≤ T); ``None`` uses all T.

    Returns:
        ``(...)`` metres. It is a sum over points, so it grows with ``P`` (NIFTY uses 2K
        points); compare scores only at equal ``P``.
    """
    sdf = _to_numpy(body_sdf_at_object_points, "body_sdf_at_object_points")
    check_shape(sdf, (..., None, None), "body_sdf_at_object_points")
    n_frames = sdf.shape[-2]
    n = n_frames if n_approach is None else int(n_approach)
    if not 1 <= n <= n_frames:
        raise ValueError(f"n_approach: expected an integer in [1, {n_frames}], got {n_approach}")
    depth = np.clip(-sdf[..., :n, :], 0.0, None)
    return _out(depth.sum(axis=(-2, -1)) / n)


def penetration_pass_rate(pen_scores, d2o, threshold: float = 0.02,
                          d2o_threshold: float | None = None) -> float:
    """% Pen. ≤ 2 cm (NIFTY Table 1), ↑.

    The percentage of sequences with penetration score ≤ ``threshold`` among the sequences
    that reach the object (D2O ≤ ``d2o_threshold``); sequences that never reach the object
    avoid penetration trivially, so NIFTY leaves them out.

    Args:
        pen_scores: ``(N,)`` metres, :func:`penetration_score` per sequence.
        d2o: ``(N,)`` metres, :func:`distance_to_object` per sequence.
        threshold: penetration threshold in metres (NIFTY: 2 cm).
        d2o_threshold: reach threshold in metres; ``None`` uses ``threshold``.

    Returns:
        A percentage, or NaN when no sequence reaches the object (the rate is undefined).
    """
    pen = _to_numpy(pen_scores, "pen_scores").reshape(-1)
    dist = _to_numpy(d2o, "d2o").reshape(-1)
    _check_same_shape(pen, dist, "pen_scores", "d2o")
    reach = dist <= (threshold if d2o_threshold is None else d2o_threshold)
    if not reach.any():
        return float("nan")
    return float(100.0 * np.mean(pen[reach] <= threshold))


def approach_frames(penetration_per_frame, tolerance: float = 0.0) -> int:
    """Length ``N_A`` of the approach: the frame where the penetration starts to only grow
    (NIFTY Appendix C.2).

    Finds the final run of the curve that never decreases (a drop larger than ``tolerance``
    ends a run), then the first frame of that run from which the curve actually rises: a flat
    stretch at the start of the run (e.g. zero penetration while walking up) still belongs to
    the approach. Frames ``0 .. N_A − 1`` are the approach.

    Args:
        penetration_per_frame: ``(T,)`` metres, the per-frame penetration (e.g. the summed
            depth of object points inside the body in each frame).
        tolerance: metres; changes this small count as flat (ignores numerical noise).

    Returns:
        ``N_A`` in ``[0, T]`` (an int); ``T`` when the curve never rises at its end.
    """
    curve = _to_numpy(penetration_per_frame, "penetration_per_frame")
    check_shape(curve, (None,), "penetration_per_frame")
    n_frames = curve.shape[0]
    if n_frames < 2:
        return n_frames
    step = np.diff(curve)
    drops = np.flatnonzero(step < -tolerance)
    onset = int(drops[-1]) + 1 if drops.size else 0
    rises = np.flatnonzero(step[onset:] > tolerance)
    return onset + int(rises[0]) if rises.size else n_frames


def approach_length_quantile(list_of_per_frame_curves, q: float) -> int:
    """A quantile of :func:`approach_frames` over a data set (NIFTY Appendix C.2).

    NIFTY uses the median (``q = 0.5``) for sitting and the 15th percentile (``q = 0.15``)
    for lifting.

    Args:
        list_of_per_frame_curves: a sequence of ``(T_k,)`` per-frame penetration curves, or a
            ``(K, T)`` array.
        q: quantile in [0, 1].

    Returns:
        The quantile, taken as an observed length (numpy's ``method="lower"``) so it can be
        used directly as ``n_approach``.
    """
    if not 0.0 <= q <= 1.0:
        raise ValueError(f"q: expected a quantile in [0, 1], got {q}")
    curves = list(list_of_per_frame_curves)
    _check_min_length(len(curves), 1, "list_of_per_frame_curves", "curves")
    lengths = [approach_frames(c) for c in curves]
    return int(np.quantile(lengths, q, method="lower"))


def skeleton_distance(joints, anchor_joints):
    """Skeleton distance to the nearest anchor pose (NIFTY §4.2 and Appendix C.2), ↓.

    ``min_a Σ_j ||joints_j − anchor_{a,j}||``: the sum over joints (22 in NIFTY) of the
    per-joint Euclidean error to the anchor pose that is nearest under that same sum.

    Args:
        joints: ``(..., J, 3)`` metres, the final pose of each generated sequence.
        anchor_joints: ``(A, J, 3)`` metres, the anchor poses of the training data.

    Returns:
        ``(distances, nearest_index)``: ``(...)`` metres (↓) and ``(...)`` ints indexing
        ``anchor_joints`` (a float and an int for a single pose).
    """
    pose = _to_numpy(joints, "joints")
    check_shape(pose, (..., None, 3), "joints")
    n_joints = pose.shape[-2]
    anchors = _to_numpy(anchor_joints, "anchor_joints")
    check_shape(anchors, (None, n_joints, 3), "anchor_joints")
    _check_min_length(anchors.shape[0], 1, "anchor_joints", "anchor poses")
    flat = pose.reshape(-1, n_joints, 3)
    best = np.empty(len(flat))
    index = np.empty(len(flat), dtype=np.int64)
    # bound the (chunk, A, J, 3) difference array to a few million numbers
    chunk_size = max(1, 4_000_000 // anchors.size)
    for start in range(0, len(flat), chunk_size):
        part = flat[start:start + chunk_size, None]  # (B, 1, J, 3) against (A, J, 3)
        dist = np.linalg.norm(part - anchors[None], axis=-1).sum(axis=-1)
        index[start:start + chunk_size] = dist.argmin(axis=1)
        best[start:start + chunk_size] = dist.min(axis=1)
    batch = pose.shape[:-2]
    if not batch:
        return float(best[0]), int(index[0])
    return best.reshape(batch), index.reshape(batch)


def contact_set(object_sdf_at_body_vertices, threshold: float = 0.0) -> np.ndarray:
    """Contacting body vertices: those that penetrate the object (NIFTY §4.2).

    Args:
        object_sdf_at_body_vertices: ``(..., V)`` metres, the object's SDF (negative inside
            the object) at each body vertex.
        threshold: metres; a vertex is in contact when the SDF is ≤ ``threshold``.

    Returns:
        ``(..., V)`` bool.
    """
    sdf = _to_numpy(object_sdf_at_body_vertices, "object_sdf_at_body_vertices")
    check_shape(sdf, (..., None), "object_sdf_at_body_vertices")
    return sdf <= threshold


def contact_iou(contacts_a, contacts_b):
    """Contact IoU between two per-vertex contact sets (NIFTY §4.2), ↑.

    Args:
        contacts_a: ``(..., V)`` bool, e.g. :func:`contact_set` of the generated final pose.
        contacts_b: ``(..., V)`` bool, e.g. that of the nearest anchor pose.

    Returns:
        ``(...)`` ``|a ∩ b| / |a ∪ b|``. Two empty sets agree perfectly, so their IoU is 1.0.
    """
    a = _to_bool(contacts_a, "contacts_a")
    b = _to_bool(contacts_b, "contacts_b")
    check_shape(a, (..., None), "contacts_a")
    _check_same_shape(a, b, "contacts_a", "contacts_b")
    inter = np.logical_and(a, b).sum(axis=-1)
    union = np.logical_or(a, b).sum(axis=-1)
    return _out(np.where(union > 0, inter / np.maximum(union, 1), 1.0))


# ----------------------------------------------------------------------------- SAMP


def average_pairwise_distance(features):
    """Average pairwise distance, APD (SAMP Eq. 6), ↑ for diversity (compare with GT).

    ``(1/(N(N−1))) Σ_{i≠j} ||X_i − X_j||²₂`` — the SQUARED L2 distance, as Eq. 6 is written.
    Computed in O(ND) with ``Σ_{i≠j} ||x_i − x_j||² = 2N Σ||x_i||² − 2||Σ x_i||²`` after
    centring (the sum is translation invariant, and centring avoids cancellation).

    Args:
        features: ``(..., N, D)``, N ≥ 2 feature vectors (SAMP: local pose features of all
            frames of all runs).

    Returns:
        ``(...)`` in squared feature units.
    """
    x = _to_numpy(features, "features")
    check_shape(x, (..., None, None), "features")
    n = x.shape[-2]
    _check_min_length(n, 2, "features", "feature vectors")
    x = x - x.mean(axis=-2, keepdims=True)
    total = 2.0 * n * np.sum(x * x, axis=(-2, -1)) - 2.0 * np.sum(x.sum(axis=-2) ** 2, axis=-1)
    return _out(np.clip(total, 0.0, None) / (n * (n - 1)))


def goal_apd(positions, directions) -> dict:
    """Diversity of GoalNet's goals: APD-Pos and APD-Rot (SAMP Eq. 7–8), ↑.

    Args:
        positions: ``(L, N, 3)`` metres, N ≥ 2 goal positions for each of L objects.
        directions: ``(L, N, 3)`` goal directions (normalised here).

    Returns:
        ``{"apd_pos": metres, mean over objects of (1/(N(N−1))) Σ_{i≠j} ||g_i^p − g_j^p||₂
        (the Euclidean norm; the paper writes |·|), "apd_rot": degrees, the same mean of
        arccos(g_i^d · g_j^d)}``.
    """
    pos = _to_numpy(positions, "positions")
    check_shape(pos, (None, None, 3), "positions")
    n_obj, n = pos.shape[:2]
    _check_min_length(n, 2, "positions", "goals per object")
    dirs = _to_numpy(directions, "directions")
    check_shape(dirs, (n_obj, n, 3), "directions")
    dirs = _unit(dirs, "directions")
    off_diagonal = ~np.eye(n, dtype=bool)
    pair_dist = np.linalg.norm(pos[:, :, None] - pos[:, None, :], axis=-1)
    pair_angle = _angle_deg(dirs[:, :, None], dirs[:, None, :])
    return {
        "apd_pos": float(pair_dist[:, off_diagonal].mean()),
        "apd_rot": float(pair_angle[:, off_diagonal].mean()),
    }


def goal_reconstruction_error(pred_pos, pred_dir, true_pos, true_dir) -> dict:
    """GoalNet reconstruction error (SAMP §5.2), ↓.

    Args:
        pred_pos: ``(..., 3)`` metres, reconstructed goal positions.
        pred_dir: ``(..., 3)`` reconstructed goal directions (normalised here).
        true_pos: ``(..., 3)`` metres, ground-truth goal positions.
        true_dir: ``(..., 3)`` ground-truth goal directions (normalised here).

    Returns:
        ``{"position_error": mean Euclidean error in metres,
        "angle_error": mean angle between directions in degrees}``.
    """
    arrays = {}
    for name, value in (("pred_pos", pred_pos), ("pred_dir", pred_dir),
                        ("true_pos", true_pos), ("true_dir", true_dir)):
        arrays[name] = _to_numpy(value, name)
        check_shape(arrays[name], (..., 3), name)
    for name in ("pred_dir", "true_pos", "true_dir"):
        _check_same_shape(arrays["pred_pos"], arrays[name], "pred_pos", name)
    angle = _angle_deg(_unit(arrays["pred_dir"], "pred_dir"), _unit(arrays["true_dir"], "true_dir"))
    return {
        "position_error": float(np.mean(np.linalg.norm(arrays["pred_pos"] - arrays["true_pos"], axis=-1))),
        "angle_error": float(np.mean(angle)),
    }


def penetration_frame_rate(min_body_sdf_per_frame, threshold: float = 0.0):
    """Percentage of frames in which the body penetrates the scene (SAMP §5.2), ↓.

    Args:
        min_body_sdf_per_frame: ``(..., T)`` metres, per frame the minimum over the body's
            vertices of the scene SDF (negative inside an object).
        threshold: metres; a frame penetrates when that minimum is < −threshold.

    Returns:
        ``(...)`` percent.
    """
    sdf = _to_numpy(min_body_sdf_per_frame, "min_body_sdf_per_frame")
    check_shape(sdf, (..., None), "min_body_sdf_per_frame")
    _check_min_length(sdf.shape[-1], 1, "min_body_sdf_per_frame", "frames")
    return _out(100.0 * np.mean(sdf < -threshold, axis=-1))


def execution_time(action_labels, target_action, fps: float = 30.0) -> float:
    """Execution time (SAMP Table 2), ↓.

    Seconds from the first frame until the character's action label first equals
    ``target_action``: a label switching at frame 45 at 30 fps gives 1.5 s.

    Args:
        action_labels: ``(T,)`` per-frame action labels (ints or strings).
        target_action: the label of the requested action.
        fps: frames per second.

    Returns:
        Seconds, or ``inf`` when the label never switches (SAMP prints ∞ for a run that fails
        within its time limit; average with care).
    """
    labels = _to_numpy(action_labels, "action_labels", dtype=None)
    check_shape(labels, (None,), "action_labels")
    hits = np.flatnonzero(labels == target_action)
    return float(hits[0]) / fps if hits.size else float("inf")


def goal_precision(root_position, root_forward, goal_position, goal_direction,
                   horizontal: bool = True) -> dict:
    """Precision at the goal: positional (PE) and rotational (RE) error (SAMP Table 3), ↓.

    Args:
        root_position: ``(..., 3)`` metres, the character's root when the action executes.
        root_forward: ``(..., 3)`` the character's forward (local +Y) direction then.
        goal_position: ``(..., 3)`` metres, the goal position.
        goal_direction: ``(..., 3)`` the goal direction.
        horizontal: measure on the ground plane (xy), which is how a goal on a seat is
            reached by a root at hip height; ``False`` uses full 3-D vectors.

    Returns:
        ``{"position_error": (...) metres, "rotation_error": (...) degrees}`` per sample
        (floats for a single sample).
    """
    arrays = {}
    for name, value in (("root_position", root_position), ("root_forward", root_forward),
                        ("goal_position", goal_position), ("goal_direction", goal_direction)):
        arrays[name] = _to_numpy(value, name)
        check_shape(arrays[name], (..., 3), name)
    for name in ("root_forward", "goal_position", "goal_direction"):
        _check_same_shape(arrays["root_position"], arrays[name], "root_position", name)
    dims = slice(0, 2) if horizontal else slice(0, 3)
    offset = arrays["goal_position"][..., dims] - arrays["root_position"][..., dims]
    part = " (horizontal part)" if horizontal else ""
    forward = _unit(arrays["root_forward"][..., dims], "root_forward" + part)
    goal_dir = _unit(arrays["goal_direction"][..., dims], "goal_direction" + part)
    return {
        "position_error": _out(np.linalg.norm(offset, axis=-1)),
        "rotation_error": _out(_angle_deg(forward, goal_dir)),
    }


def frechet_distance(features_a, features_b, eps: float = 1e-6) -> float:
    """Fréchet distance between Gaussians fitted to two feature sets (SAMP Table 4 on the
    features of Eq. 9; CHOICE Table 4 on 2 s windows), ↓.

    ``||μ_a − μ_b||² + Tr(Σ_a + Σ_b − 2 (Σ_a Σ_b)^{1/2})``. The matrix square root is
    retried with ``eps·I`` added to both covariances when it is not finite; its real part is
    used, and tiny negative results from round-off are clipped to 0.

    Args:
        features_a: ``(N, D)``, N ≥ 2 feature vectors.
        features_b: ``(M, D)``, M ≥ 2 feature vectors.
        eps: the ridge added on retry.

    Returns:
        Squared feature units (it is the squared 2-Wasserstein distance of the Gaussians).
    """
    a = _to_numpy(features_a, "features_a")
    check_shape(a, (None, None), "features_a")
    b = _to_numpy(features_b, "features_b")
    check_shape(b, (None, a.shape[1]), "features_b")
    _check_min_length(a.shape[0], 2, "features_a", "feature vectors")
    _check_min_length(b.shape[0], 2, "features_b", "feature vectors")
    mu_a, mu_b = a.mean(axis=0), b.mean(axis=0)
    cov_a = np.atleast_2d(np.cov(a, rowvar=False))
    cov_b = np.atleast_2d(np.cov(b, rowvar=False))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)
        covmean = scipy.linalg.sqrtm(cov_a @ cov_b)
        if not np.all(np.isfinite(covmean)):
            ridge = eps * np.eye(cov_a.shape[0])
            covmean = scipy.linalg.sqrtm((cov_a + ridge) @ (cov_b + ridge))
    covmean = np.real(covmean)
    diff = mu_a - mu_b
    value = diff @ diff + np.trace(cov_a) + np.trace(cov_b) - 2.0 * np.trace(covmean)
    return float(max(value, 0.0))


def sliding_windows(x, window: int, stride: int = 1) -> np.ndarray:
    """Stack ``window`` consecutive frames into one feature vector (CHOICE Table 4's 2 s
    windows: ``window = 60`` at 30 fps).

    Args:
        x: ``(..., T, D)`` per-frame features (flatten per-frame joint arrays first).
        window: frames per window, 1 ≤ window ≤ T.
        stride: frames between window starts.

    Returns:
        ``(..., n_windows, window * D)`` with ``n_windows = (T − window) // stride + 1``; each
        row concatenates frames ``t, t+1, …, t+window−1`` in order.
    """
    arr = _to_numpy(x, "x")
    check_shape(arr, (..., None, None), "x")
    n_frames, dim = arr.shape[-2:]
    if not 1 <= window <= n_frames:
        raise ValueError(f"window: expected an integer in [1, {n_frames}], got {window}")
    if stride < 1:
        raise ValueError(f"stride: expected a positive integer, got {stride}")
    view = np.lib.stride_tricks.sliding_window_view(arr, window, axis=-2)  # (..., n, D, window)
    view = np.swapaxes(view, -1, -2)[..., ::stride, :, :]
    return view.reshape(*view.shape[:-2], window * dim)


# ----------------------------------------------------------------------------- CHOICE


def _acceleration(positions: np.ndarray, fps: float, time_axis: int) -> np.ndarray:
    """Central second differences along ``time_axis`` times fps², frames 1 .. T−2."""
    return np.diff(positions, n=2, axis=time_axis) * fps * fps


def unsmoothness(positions, fps: float = 30.0, has_joint_axis: bool = True):
    """Unsmoothness: mean acceleration magnitude (CHOICE Tables 3 and 4), ↓.

    Args:
        positions: ``(..., T, J, 3)`` metres (all joints; mean over joints and frames) when
            ``has_joint_axis``; ``(..., T, 3)`` metres (one tracked point, e.g. the hand or the
            object of a planned trajectory) otherwise. A 2-D ``(T, 3)`` array is always one
            track. T ≥ 3.
        fps: frames per second.
        has_joint_axis: whether the axis before the last is a joint axis.

    Returns:
        ``(...)`` m/s² (CHOICE's tables print cm/s²: multiply by 100).
    """
    pos = _to_numpy(positions, "positions")
    if has_joint_axis and pos.ndim != 2:
        check_shape(pos, (..., None, None, 3), "positions")
        time_axis, reduce = -3, (-2, -1)
    else:
        check_shape(pos, (..., None, 3), "positions")
        time_axis, reduce = -2, -1
    _check_min_length(pos.shape[time_axis], 3, "positions", "frames")
    accel = np.linalg.norm(_acceleration(pos, fps, time_axis), axis=-1)
    return _out(accel.mean(axis=reduce))


def _check_feet(foot_positions, contacts):
    feet = _to_numpy(foot_positions, "foot_positions")
    check_shape(feet, (..., None, None, 3), "foot_positions")
    contact = _to_bool(contacts, "contacts")
    check_shape(contact, feet.shape[:-1], "contacts")
    return feet, contact


def foot_sliding(foot_positions, contacts, fps: float = 30.0):
    """Foot sliding: mean foot acceleration during ground contact (CHOICE Table 4), ↓.

    CHOICE's caption "sums up the feet' acceleration during ground contact" in cm/s²; this
    returns the mean magnitude in m/s² (×100 for the table). A frame counts when the foot is
    in contact at that frame and both neighbours: the acceleration at a touch-down or lift-off
    frame measures the swing, not sliding, so a planted foot scores exactly 0.

    Args:
        foot_positions: ``(..., T, F, 3)`` metres, F foot points (e.g. heels and toes), T ≥ 3.
        contacts: ``(..., T, F)`` bool ground-contact labels.
        fps: frames per second.

    Returns:
        ``(...)`` m/s², NaN where no foot is in contact for three consecutive frames.
    """
    feet, contact = _check_feet(foot_positions, contacts)
    _check_min_length(feet.shape[-3], 3, "foot_positions", "frames")
    accel = np.linalg.norm(_acceleration(feet, fps, -3), axis=-1)  # (..., T-2, F)
    planted = contact[..., :-2, :] & contact[..., 1:-1, :] & contact[..., 2:, :]
    return _out(_masked_mean(accel, planted, (-2, -1)))


def foot_slide_speed(foot_positions, contacts, fps: float = 30.0):
    """Mean horizontal foot speed while in ground contact (CHOICE Fig. 12 "mean sliding
    during stepping"), ↓.

    Args:
        foot_positions: ``(..., T, F, 3)`` metres, T ≥ 2.
        contacts: ``(..., T, F)`` bool ground-contact labels; a forward difference between
            frames ``t`` and ``t+1`` counts when the foot is in contact at both.
        fps: frames per second.

    Returns:
        ``(...)`` m/s (Fig. 12 prints cm/s), NaN where the feet are never in contact.
    """
    feet, contact = _check_feet(foot_positions, contacts)
    _check_min_length(feet.shape[-3], 2, "foot_positions", "frames")
    speed = np.linalg.norm(np.diff(feet[..., :2], axis=-3), axis=-1) * fps  # (..., T-1, F)
    planted = contact[..., :-1, :] & contact[..., 1:, :]
    return _out(_masked_mean(speed, planted, (-2, -1)))


def rms_curvature(path, fps: float = 30.0, min_speed: float = 1e-3):
    """Root-mean-square curvature of a trajectory, e.g. the wrist (CHOICE Table 4 RMSC), ↓.

    ``κ = |v × a| / |v|³`` with central differences at frames 1 .. T−2 (κ does not depend on
    the time parametrisation; ``fps`` only sets the units of ``min_speed``).

    Args:
        path: ``(..., T, 3)`` metres, T ≥ 3.
        fps: frames per second.
        min_speed: m/s; slower frames are left out (the curvature of a resting point is
            undefined).

    Returns:
        ``(...)`` 1/m (CHOICE prints cm⁻¹: divide by 100), NaN where no frame is fast enough.
    """
    pos = _to_numpy(path, "path")
    check_shape(pos, (..., None, 3), "path")
    _check_min_length(pos.shape[-2], 3, "path", "frames")
    vel = (pos[..., 2:, :] - pos[..., :-2, :]) * (fps / 2.0)
    acc = _acceleration(pos, fps, -2)
    speed = np.linalg.norm(vel, axis=-1)
    moving = speed >= min_speed
    with np.errstate(invalid="ignore", divide="ignore"):
        kappa = np.linalg.norm(np.cross(vel, acc), axis=-1) / np.where(moving, speed, 1.0) ** 3
    return _out(np.sqrt(_masked_mean(kappa ** 2, moving, -1)))


def safety_distance(clearance, mask=None):
    """Spare safety distance (CHOICE Table 3), ↑.

    The distance from the hand and the carried object to the nearest obstacle, averaged over
    frames; CHOICE counts the frames within 20 cm of the touch/release position (see
    :func:`near_endpoint_mask`) of collision-free successful runs.

    Args:
        clearance: ``(..., T)`` metres, per-frame distance to the nearest obstacle.
        mask: ``(..., T)`` bool frames to count; ``None`` counts all.

    Returns:
        ``(...)`` metres, NaN where the mask is empty.
    """
    dist = _to_numpy(clearance, "clearance")
    check_shape(dist, (..., None), "clearance")
    if mask is None:
        keep = np.ones(dist.shape, dtype=bool)
    else:
        keep = _to_bool(mask, "mask")
        _check_same_shape(dist, keep, "clearance", "mask")
    return _out(_masked_mean(dist, keep, -1))


def near_endpoint_mask(path, endpoint, radius: float = 0.2) -> np.ndarray:
    """Frames of a trajectory within ``radius`` of an end point (CHOICE Table 3: 20 cm around
    the touch/release position). Combine touch and release masks with ``|``.

    Args:
        path: ``(..., T, 3)`` metres.
        endpoint: ``(..., 3)`` metres, one point per trajectory.
        radius: metres.

    Returns:
        ``(..., T)`` bool.
    """
    pos = _to_numpy(path, "path")
    check_shape(pos, (..., None, 3), "path")
    end = _to_numpy(endpoint, "endpoint")
    check_shape(end, (*pos.shape[:-2], 3), "endpoint")
    return np.linalg.norm(pos - end[..., None, :], axis=-1) <= radius


def success_rate(successes) -> float:
    """Success rate (CHOICE Table 3), ↑.

    Args:
        successes: ``(N,)`` (any shape, flattened) bool, one per run.

    Returns:
        Percent of True; NaN for no runs.
    """
    ok = _to_bool(successes, "successes").reshape(-1)
    return float(100.0 * ok.mean()) if ok.size else float("nan")
