"""The procedural object (:class:`ToyObject`: a union of primitives with a pose, its exact SDF,
meshes, surface samples, voxels and affordances in the world frame) and :func:`make_object`,
which samples an instance of a category from its size ranges and builds it.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
import torch

from ..._validate import check_choice, check_shape
from ..primitives import (
    Footprint,
    Primitive,
    PrimitiveSet,
    footprint,
    primitive_bounds,
    primitive_mesh,
    rigid_transform,
    rotation_z,
    sample_surface,
    surface_area,
)
from .builders import BUILDERS, DERIVED_PARAMS, recentre
from .categories import CATEGORIES, GRASPABLE, HANDLED, LIFTABLE, LYING, SITTABLE, SMALL, SUPPORTING
from .sizes import CATEGORY_SIZES

__all__ = ["as_rng", "ToyObject", "make_object", "object_from_description"]


# ----------------------------------------------------------------------------- the object


def as_rng(seed) -> np.random.Generator:
    """``seed`` itself when it is a ``numpy.random.Generator``, else a new one seeded with the int."""
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        return np.random.default_rng(int(seed))
    raise TypeError(f"seed: expected an int or a numpy.random.Generator, got {type(seed).__name__}")


_ADJECTIVES = {"sit": "sittable", "lie": "lying", "lift": "liftable", "grasp": "graspable", "handle": "handled", "support": "supporting"}


@dataclass(eq=False)
class ToyObject:
    """A procedural object: a union of primitives with a pose in the world.

    Attributes:
        category: one of ``CATEGORIES``.
        params: the sampled sizes and states (see ``CATEGORY_SIZES``), plus derived counts.
        primitives: the parts in the object's canonical frame.
        pose: (4, 4) float64 ``world_from_object``.
        annotations: canonical-frame affordances (read them through the properties).
    """

    category: str
    params: dict
    primitives: list
    pose: np.ndarray = field(default_factory=lambda: np.eye(4))
    annotations: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        check_choice(self.category, CATEGORIES, "category")
        self.pose = np.asarray(self.pose, dtype=np.float64)
        check_shape(self.pose, (4, 4), "pose")
        self._canonical = PrimitiveSet(self.primitives)
        self._volume = None
        self._mesh = None
        self._footprints = {}

    # ------------------------------------------------------------------ frames

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) world_from_object rotation."""
        return self.pose[:3, :3]

    @property
    def translation(self) -> np.ndarray:
        """(3,) world position of the canonical origin, metres."""
        return self.pose[:3, 3]

    def to_world(self, points) -> np.ndarray:
        """Canonical points (..., 3) metres → world frame (..., 3)."""
        return np.asarray(points, dtype=np.float64) @ self.rotation.T + self.translation

    def to_canonical(self, points):
        """World points (..., 3) metres → canonical frame (..., 3); torch or numpy in, same out."""
        check_shape(points, (..., 3), "points")
        if isinstance(points, torch.Tensor):
            R = torch.as_tensor(self.rotation, dtype=points.dtype, device=points.device)
            t = torch.as_tensor(self.translation, dtype=points.dtype, device=points.device)
            return (points - t) @ R
        return (np.asarray(points, dtype=np.float64) - self.translation) @ self.rotation

    def placed(self, x: float, y: float, yaw: float, z: float = 0.0) -> "ToyObject":
        """A copy standing at (x, y, z) metres turned by ``yaw`` radians about +Z (front +Y → yaw)."""
        return self.with_pose(rigid_transform(rotation_z(yaw), (x, y, z)))

    def with_pose(self, pose) -> "ToyObject":
        """A copy with ``pose`` (4, 4) world_from_object; canonical caches are shared."""
        out = copy.copy(self)
        out.params = dict(self.params)
        out.pose = np.asarray(pose, dtype=np.float64).copy()
        check_shape(out.pose, (4, 4), "pose")
        out._mesh = None
        out._footprints = {}
        return out

    def with_params(self, **overrides) -> "ToyObject":
        """The same instance rebuilt with some parameters changed (e.g. ``door_angle``), same pose."""
        params = {k: v for k, v in self.params.items() if k not in DERIVED_PARAMS}
        _check_override_names(self.category, overrides)
        params.update(overrides)
        return _build(self.category, params).with_pose(self.pose)

    # ------------------------------------------------------------------ geometry

    def sdf(self, points):
        """Exact signed distance to the object, negative inside.

        Args:
            points: (..., 3) metres in the WORLD frame; torch (differentiable, device and dtype
                kept) or numpy (float64 numpy returned).
        Returns:
            (...) metres. The union's distance is the min over primitives: exact outside,
            exact in sign inside.
        """
        return self._canonical.sdf(self.to_canonical(points))

    def canonical_sdf(self, points):
        """Signed distance for points (..., 3) metres given in the CANONICAL frame → (...)."""
        return self._canonical.sdf(points)

    def world_primitives(self) -> list[Primitive]:
        """The parts moved into the world frame by ``pose``."""
        return [q.transformed(self.pose) for q in self.primitives]

    def footprints(self, z_band=(-np.inf, np.inf)) -> list[Footprint]:
        """The world parts' vertical projections for heights in ``z_band`` (low, high) metres
        (``primitives.footprint``), prepared once for this pose: a scene asks for distances to them
        thousands of times."""
        key = (float(z_band[0]), float(z_band[1]), self.pose.tobytes())
        prepared = self._footprints.get(key)
        if prepared is None:
            prepared = self._footprints[key] = [footprint(q, z_band) for q in self.world_primitives()]
        return prepared

    def primitive_meshes(self) -> list:
        """One closed ``trimesh.Trimesh`` per primitive, world frame."""
        return [primitive_mesh(q) for q in self.world_primitives()]

    @property
    def mesh(self):
        """The concatenated primitive meshes (``trimesh.Trimesh``), world frame."""
        if self._mesh is None:
            import trimesh

            self._mesh = trimesh.util.concatenate(self.primitive_meshes())
        return self._mesh

    def contains(self, points) -> np.ndarray:
        """Mesh containment, tested per primitive mesh and OR-ed: points (N, 3) metres → (N,) bool.

        This is trimesh's ray test, independent of the analytic SDF (the reference cross-check).
        """
        points = np.asarray(points, dtype=np.float64)
        check_shape(points, (None, 3), "points")
        inside = np.zeros(len(points), dtype=bool)
        for mesh in self.primitive_meshes():
            inside |= mesh.contains(points)
        return inside

    @property
    def canonical_bounds(self) -> np.ndarray:
        """(2, 3) metres: the axis-aligned box of the object in its canonical frame."""
        b = np.stack([primitive_bounds(q) for q in self.primitives])
        return np.stack([b[:, 0].min(0), b[:, 1].max(0)])

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3) metres: the world axis-aligned bounding box."""
        b = np.stack([primitive_bounds(q) for q in self.world_primitives()])
        return np.stack([b[:, 0].min(0), b[:, 1].max(0)])

    @property
    def volume(self) -> float:
        """Volume in m³: fixed-seed Monte-Carlo estimate (200k points in the canonical box), cached."""
        if self._volume is None:
            lo, hi = self.canonical_bounds
            pts = np.random.default_rng(0).uniform(lo, hi, size=(200_000, 3))
            self._volume = float(np.mean(self._canonical.sdf(pts) < 0) * np.prod(hi - lo))
        return self._volume

    def _canonical_surface_points(self, n: int, rng: np.random.Generator) -> np.ndarray:
        areas = np.array([surface_area(q) for q in self.primitives])
        chunks, have = [], 0
        while have < n:
            counts = rng.multinomial(max(2 * (n - have), 64), areas / areas.sum())
            cand = np.concatenate([sample_surface(q, c, rng) for q, c in zip(self.primitives, counts) if c > 0])
            cand = cand[rng.permutation(len(cand))]
            # keep points on the union's surface (not buried inside another part)
            keep = cand[np.abs(self._canonical.sdf(cand)) < 1e-4]
            chunks.append(keep)
            have += len(keep)
        return np.concatenate(chunks)[:n]

    def surface_points(self, n: int, seed=0) -> np.ndarray:
        """``n`` points on the object's surface, area-weighted, world frame: (n, 3) metres."""
        return self.to_world(self._canonical_surface_points(int(n), as_rng(seed)))

    def point_cloud(self, n: int, seed=0) -> np.ndarray:
        """``n`` surface points in the CANONICAL frame, (n, 3) metres (NIFTY's object condition P_o, §3.1)."""
        return self._canonical_surface_points(int(n), as_rng(seed))

    # ------------------------------------------------------------------ voxels

    def _cell_geometry(self, resolution: int):
        lo, hi = self.canonical_bounds
        cell = (hi - lo) / resolution
        return lo, cell

    def canonical_voxel_centres(self, resolution: int = 8) -> np.ndarray:
        """Centres (r, r, r, 3) metres of the cells splitting the canonical box, index [ix, iy, iz]."""
        lo, cell = self._cell_geometry(resolution)
        idx = np.arange(resolution) + 0.5
        grid = np.stack(np.meshgrid(idx, idx, idx, indexing="ij"), axis=-1)
        return lo + grid * cell

    def voxel_centres(self, resolution: int = 8) -> np.ndarray:
        """World-frame centres (r, r, r, 3) metres of the object's voxel cells (they turn with the object)."""
        return self.to_world(self.canonical_voxel_centres(resolution))

    def occupancy_grid(self, resolution: int = 8, samples_per_axis: int = 4) -> np.ndarray:
        """Fraction of each cell of the canonical box inside the object: (r, r, r) in [0, 1], [ix, iy, iz].

        Each cell is sub-sampled on a jittered ``samples_per_axis``³ grid (fixed seed), so
        ``occupancy.sum() * cell_volume`` is an unbiased estimate of ``volume`` even for boards
        thinner than the sub-sample spacing.
        """
        lo, cell = self._cell_geometry(resolution)
        s = samples_per_axis
        n = resolution * s
        jitter = np.random.default_rng(0).uniform(size=(n, n, n, 3))
        idx = np.arange(n)
        grid = np.stack(np.meshgrid(idx, idx, idx, indexing="ij"), axis=-1)
        pts = lo + (grid + jitter) * (cell / s)
        inside = (self._canonical.sdf(pts.reshape(-1, 3)) < 0).reshape(resolution, s, resolution, s, resolution, s)
        return inside.mean(axis=(1, 3, 5)).astype(np.float64)

    def interaction_voxels(self, frame, resolution: int = 8):
        """SAMP's interaction representation I (SAMP §3.1, Interaction Encoder; §3.2 for GoalNet).

        The object's canonical bounding box is split into ``resolution``³ cells that move with
        the object. Per cell: its centre expressed in ``frame`` (3 numbers) and a real-valued
        occupancy ``clip(1 − max(sdf(centre), 0) / cell_size, 0, 1)`` (1 inside or on the
        surface, 0 one cell away), with ``cell_size`` the largest cell edge.
        Flattened, 8×8×8×4 gives SAMP's 2048 numbers.

        Args:
            frame: (..., 4, 4) world_from_frame, e.g. the character root (MotionNet) or
                ``centre_frame`` (GoalNet); numpy or torch.
        Returns:
            (..., r, r, r, 4): metres for the centres, occupancy in [0, 1]; torch if ``frame``
            is torch (its dtype and device), else float64 numpy.
        """
        check_shape(frame, (..., 4, 4), "frame")
        is_torch = isinstance(frame, torch.Tensor)
        F = frame.detach().cpu().double().numpy() if is_torch else np.asarray(frame, dtype=np.float64)
        _, cell = self._cell_geometry(resolution)
        canonical = self.canonical_voxel_centres(resolution)
        occupancy = np.clip(1.0 - np.maximum(self._canonical.sdf(canonical), 0.0) / cell.max(), 0.0, 1.0)
        world = self.to_world(canonical)
        R, t = F[..., :3, :3], F[..., :3, 3]
        # frame coordinates: R^T (x - t), batched over the frame's leading dimensions
        flat = world.reshape(-1, 3)
        local = np.einsum("...ji,...nj->...ni", R, flat - t[..., None, :])
        local = local.reshape(F.shape[:-2] + (resolution,) * 3 + (3,))
        occ = np.broadcast_to(occupancy[..., None], local.shape[:-1] + (1,))
        out = np.concatenate([local, occ], axis=-1)
        if is_torch:
            return torch.as_tensor(out, dtype=frame.dtype, device=frame.device)
        return out

    @property
    def centre_frame(self) -> np.ndarray:
        """(4, 4) world_from_centre: the object's axes with the origin at its canonical box centre (GoalNet's frame)."""
        lo, hi = self.canonical_bounds
        return self.pose @ rigid_transform(translation=(lo + hi) / 2)

    # ------------------------------------------------------------------ affordances (world frame)

    def _require_affordance(self, name: str, kind: str, allowed: tuple) -> None:
        """Raise ``ValueError`` for the property ``name`` unless the category is among ``allowed``,
        the categories with the ``kind`` affordance."""
        if self.category not in allowed:
            raise ValueError(f"{name}: category {self.category!r} has no {kind} affordance; "
                             f"{_ADJECTIVES[kind]} categories are {list(allowed)}")

    def _points(self, key):
        return self.to_world(self.annotations[key])

    def _directions(self, key):
        return np.asarray(self.annotations[key], dtype=np.float64) @ self.rotation.T

    @property
    def sit_goals(self) -> tuple[np.ndarray, np.ndarray]:
        """Sitting goals (SAMP §3.2 g^p, g^d): positions (K, 3) metres of the seated pelvis
        (``SEAT_PELVIS_HEIGHT`` above the seat) and the sitter's forward (K, 3), horizontal unit."""
        self._require_affordance("sit_goals", "sit", SITTABLE)
        return self._points("sit_positions"), self._directions("sit_directions")

    @property
    def lie_goals(self) -> tuple[np.ndarray, np.ndarray]:
        """Lying goals on sofas: pelvis positions (K, 3) metres and head directions (K, 3), unit, along the cushion."""
        self._require_affordance("lie_goals", "lie", LYING)
        return self._points("lie_positions"), self._directions("lie_directions")

    @property
    def lift_contacts(self) -> np.ndarray:
        """(2, 3) metres: left and right hand contacts on opposite sides of the object (NIFTY lifting)."""
        self._require_affordance("lift_contacts", "lift", LIFTABLE)
        return self._points("lift_contacts")

    @property
    def lift_approach(self) -> np.ndarray:
        """(3,) horizontal unit vector: the direction the lifter FACES while holding the object."""
        self._require_affordance("lift_approach", "lift", LIFTABLE)
        return self._directions("lift_approach")

    @property
    def grasp_points(self) -> np.ndarray:
        """(K, 3) metres: where a hand grasps (handle or body of a prop, handle of a door or drawer)."""
        self._require_affordance("grasp_points", "grasp", GRASPABLE + HANDLED)
        return self._points("grasp_points")

    @property
    def handle_point(self) -> np.ndarray:
        """(3,) metres: the front of the door or drawer handle; it moves with ``door_angle`` / ``drawer_open``."""
        self._require_affordance("handle_point", "handle", HANDLED)
        return self._points("handle_point")

    @property
    def support_surfaces(self) -> np.ndarray:
        """(K, 6) in the CANONICAL frame: ``[z, x_min, x_max, y_min, y_max, free_height]`` metres,
        the horizontal surfaces (boards, tray bottom, table top) small objects can stand on."""
        self._require_affordance("support_surfaces", "support", SUPPORTING)
        return np.array(self.annotations["supports"], dtype=np.float64)


def _check_override_names(category, overrides):
    unknown = sorted(set(overrides) - set(CATEGORY_SIZES[category]))
    if unknown:
        raise ValueError(
            f"overrides: expected parameters of {category!r} among {sorted(CATEGORY_SIZES[category])}, got {unknown}"
        )


def _build(category: str, params: dict) -> ToyObject:
    params = dict(params)
    parts, ann = BUILDERS[category](params)
    if category not in SMALL + HANDLED:
        parts, ann = recentre(parts, ann)
    ann = {k: np.asarray(v, dtype=np.float64) for k, v in ann.items()}
    return ToyObject(category, params, parts, np.eye(4), ann)


def _scale_factors(size_scale) -> np.ndarray:
    if size_scale is None:
        return np.ones(3)
    s = np.asarray(size_scale, dtype=np.float64).reshape(-1)
    if s.shape == (1,):
        s = np.repeat(s, 3)
    if s.shape != (3,) or np.any(s <= 0):
        raise ValueError(f"size_scale: expected a positive number or 3 positive numbers (x, y, z), got {size_scale!r}")
    return s


def make_object(category: str, seed=0, *, size_scale=None, **overrides) -> ToyObject:
    """Sample one instance of ``category`` from its size ranges (``CATEGORY_SIZES``).

    Args:
        category: one of ``CATEGORIES``.
        seed: int or ``numpy.random.Generator``; same seed → same instance.
        size_scale: None, a number, or (3,) factors along x, y, z applied to the sampled
            lengths (SAMP §4.3 augments goal data by random xyz scaling; CHOICE reshapes
            containers); radii use the geometric mean of the axes they span.
        **overrides: exact values for named parameters (e.g. ``seat_height=0.45``,
            ``door_angle=1.2``); applied after sampling and scaling, so the other sizes
            stay those of the seed.
    Returns:
        A ``ToyObject`` at the identity pose (canonical frame = world frame).
    """
    check_choice(category, CATEGORIES, "category")
    rng = as_rng(seed)
    scale = _scale_factors(size_scale)
    axis_factor = {
        "x": scale[0], "y": scale[1], "z": scale[2],
        "xy": np.sqrt(scale[0] * scale[1]), "xyz": np.cbrt(np.prod(scale)),
    }
    spec = CATEGORY_SIZES[category]
    params = {}
    for name, r in spec.items():
        value = r.sample(rng)
        if r.axis is not None:
            value = float(value * axis_factor[r.axis])
        params[name] = value
    _check_override_names(category, overrides)
    params.update(overrides)
    return _build(category, params)


def object_from_description(description: dict) -> ToyObject:
    """Rebuild the object a clip recorded (``{"category", "params", "pose"}``, as toy-mocap clips
    store their object and support in ``motion.meta``): same category, sizes and world pose."""
    if not isinstance(description, dict) or not {"category", "params", "pose"} <= set(description):
        raise ValueError("description: expected a dict with 'category', 'params' and 'pose' (a clip's meta['object'])")
    params = {k: v for k, v in description["params"].items() if k not in DERIVED_PARAMS}
    check_choice(description["category"], CATEGORIES, "description['category']")
    pose = np.asarray(description["pose"], dtype=np.float64)
    if pose.shape != (4, 4):
        raise ValueError(f"description['pose']: expected a (4, 4) matrix, got shape {pose.shape}")
    return _build(description["category"], params).with_pose(pose)
