"""Geometric primitives of the toy world: exact signed distances, surface samples, meshes.

Every procedural object (``hoi_tutorial.world.objects``) is a union of four primitive kinds,
each placed by a centre and a rotation (``object_from_primitive``) in the object's frame:

=========  ============================================  =====================================
kind       local shape                                   ``size``
=========  ============================================  =====================================
box        ``|x| <= hx, |y| <= hy, |z| <= hz``            ``(hx, hy, hz)`` half extents
cylinder   axis along local z, ``|z| <= h``                ``(radius, half_height)``
capsule    segment ``z in [-h, h]`` swept by a sphere      ``(radius, half_length)``
sphere     ball at the centre                            ``(radius,)``
=========  ============================================  =====================================

The signed distance is negative inside and exact for each primitive; the distance of a union
is the minimum over its parts (exact outside, exact in sign inside). All distance functions
are batched and accept torch tensors (differentiable, device and dtype kept) or numpy arrays
(computed in float64, numpy returned).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import torch

from .._validate import check_choice, check_shape

__all__ = [
    "PRIMITIVE_KINDS",
    "Primitive",
    "box",
    "cylinder",
    "capsule_between",
    "sphere",
    "rotation_x",
    "rotation_y",
    "rotation_z",
    "rotation_from_z",
    "rigid_transform",
    "transform_points",
    "box_sdf",
    "cylinder_sdf",
    "capsule_sdf",
    "sphere_sdf",
    "PrimitiveSet",
    "union_sdf",
    "surface_area",
    "sample_surface",
    "primitive_bounds",
    "primitive_mesh",
    "Footprint",
    "footprint",
    "footprint_distance",
]

PRIMITIVE_KINDS = ("box", "cylinder", "capsule", "sphere")


# ----------------------------------------------------------------------------- rotations


def rotation_x(angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) about +X by ``angle`` radians (right-handed)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rotation_y(angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) about +Y by ``angle`` radians (right-handed)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rotation_z(angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) about +Z (yaw) by ``angle`` radians; yaw > 0 turns +X toward +Y."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_from_z(direction) -> np.ndarray:
    """A rotation (3, 3) whose third column (the local z axis) is ``direction`` (3,), normalised."""
    z = np.asarray(direction, dtype=np.float64)
    z = z / np.linalg.norm(z)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)


def rigid_transform(rotation=None, translation=None) -> np.ndarray:
    """A 4×4 homogeneous transform from a rotation (3, 3) and a translation (3,) in metres."""
    out = np.eye(4)
    if rotation is not None:
        out[:3, :3] = rotation
    if translation is not None:
        out[:3, 3] = translation
    return out


def transform_points(transform, points):
    """Apply a 4×4 rigid ``transform`` to ``points`` (..., 3) metres; torch or numpy in, same out."""
    check_shape(points, (..., 3), "points")
    if isinstance(points, torch.Tensor):
        t = torch.as_tensor(np.asarray(transform), dtype=points.dtype, device=points.device)
        return points @ t[:3, :3].T + t[:3, 3]
    transform = np.asarray(transform, dtype=np.float64)
    return np.asarray(points, dtype=np.float64) @ transform[:3, :3].T + transform[:3, 3]


# ----------------------------------------------------------------------------- records


@dataclass(frozen=True)
class Primitive:
    """One solid primitive of an object, placed in the object's canonical frame.

    Attributes:
        kind: one of ``PRIMITIVE_KINDS``.
        centre: (3,) metres, the primitive's centre in the object frame.
        rotation: (3, 3) ``object_from_primitive`` rotation.
        size: the kind's size numbers in metres (see the module table).
        name: the part it models (``"seat"``, ``"door"``, ``"handle"``...).
    """

    kind: str
    centre: np.ndarray
    rotation: np.ndarray
    size: np.ndarray
    name: str = ""

    def __post_init__(self):
        check_choice(self.kind, PRIMITIVE_KINDS, "kind")
        object.__setattr__(self, "centre", np.asarray(self.centre, dtype=np.float64).reshape(3))
        object.__setattr__(self, "rotation", np.asarray(self.rotation, dtype=np.float64).reshape(3, 3))
        expected = {"box": 3, "cylinder": 2, "capsule": 2, "sphere": 1}[self.kind]
        size = np.asarray(self.size, dtype=np.float64).reshape(-1)
        if size.shape != (expected,) or np.any(size <= 0):
            raise ValueError(f"size: expected {expected} positive numbers for a {self.kind}, got {size.tolist()}")
        object.__setattr__(self, "size", size)

    def transformed(self, transform) -> "Primitive":
        """This primitive moved by a 4×4 rigid ``transform`` (new frame from the current frame)."""
        transform = np.asarray(transform, dtype=np.float64)
        return Primitive(
            self.kind,
            transform[:3, :3] @ self.centre + transform[:3, 3],
            transform[:3, :3] @ self.rotation,
            self.size,
            self.name,
        )


def box(centre, half_extents, rotation=None, *, yaw: float | None = None, name: str = "") -> Primitive:
    """A box with ``half_extents`` (3,) metres at ``centre`` (3,), rotated by ``rotation`` (3, 3) or ``yaw``."""
    if rotation is None:
        rotation = rotation_z(yaw) if yaw is not None else np.eye(3)
    return Primitive("box", centre, rotation, half_extents, name)


def cylinder(centre, radius: float, half_height: float, rotation=None, *, name: str = "") -> Primitive:
    """A solid cylinder (axis along z unless ``rotation`` turns it) of ``radius`` and ``half_height`` metres."""
    return Primitive("cylinder", centre, np.eye(3) if rotation is None else rotation, (radius, half_height), name)


def capsule_between(start, end, radius: float, *, name: str = "") -> Primitive:
    """A capsule whose axis runs from ``start`` (3,) to ``end`` (3,) metres, of ``radius`` metres."""
    start, end = np.asarray(start, dtype=np.float64), np.asarray(end, dtype=np.float64)
    axis = end - start
    length = float(np.linalg.norm(axis))
    if length <= 0:
        raise ValueError("capsule_between: expected distinct start and end points")
    return Primitive("capsule", (start + end) / 2, rotation_from_z(axis), (radius, length / 2), name)


def sphere(centre, radius: float, *, name: str = "") -> Primitive:
    """A ball of ``radius`` metres at ``centre`` (3,)."""
    return Primitive("sphere", centre, np.eye(3), (radius,), name)


# ----------------------------------------------------------------------------- exact SDFs (local frames)
# Each takes points already in the primitive's local frame, shape (..., 3), and sizes that
# broadcast against the leading dimensions; torch only (the numpy entry points convert).


def _length(x: torch.Tensor) -> torch.Tensor:
    return torch.linalg.vector_norm(x, dim=-1)


def box_sdf(local_points: torch.Tensor, half_extents: torch.Tensor) -> torch.Tensor:
    """Exact SDF of a centred axis-aligned box.

    Args:
        local_points: (..., 3) metres in the box frame.
        half_extents: (..., 3) metres, broadcasting with ``local_points``.
    Returns:
        (...) signed distance in metres, negative inside.
    """
    q = local_points.abs() - half_extents
    outside = _length(q.clamp(min=0.0))
    inside = q.max(dim=-1).values.clamp(max=0.0)
    return outside + inside


def cylinder_sdf(local_points: torch.Tensor, radius: torch.Tensor, half_height: torch.Tensor) -> torch.Tensor:
    """Exact SDF of a centred solid cylinder with its axis on local z.

    Args:
        local_points: (..., 3) metres; radius, half_height: (...) metres, broadcasting.
    Returns:
        (...) signed distance in metres, negative inside.
    """
    d = torch.stack([_length(local_points[..., :2]) - radius, local_points[..., 2].abs() - half_height], dim=-1)
    return d.max(dim=-1).values.clamp(max=0.0) + _length(d.clamp(min=0.0))


def capsule_sdf(local_points: torch.Tensor, radius: torch.Tensor, half_length: torch.Tensor) -> torch.Tensor:
    """Exact SDF of a capsule around the segment ``z in [-half_length, half_length]`` of local z.

    Args:
        local_points: (..., 3) metres; radius, half_length: (...) metres, broadcasting.
    Returns:
        (...) signed distance in metres, negative inside.
    """
    z = local_points[..., 2]
    clamped = torch.maximum(torch.minimum(z, half_length), -half_length)
    offset = torch.stack([local_points[..., 0], local_points[..., 1], z - clamped], dim=-1)
    return _length(offset) - radius


def sphere_sdf(local_points: torch.Tensor, radius: torch.Tensor) -> torch.Tensor:
    """Exact SDF of a centred ball: ``|p| - radius``; local_points (..., 3), returns (...) metres."""
    return _length(local_points) - radius


# ----------------------------------------------------------------------------- batched unions


class PrimitiveSet:
    """Primitives stacked per kind for batched distance queries.

    Args:
        primitives: the parts of one union, in one frame.
    """

    def __init__(self, primitives: Sequence[Primitive]):
        if len(primitives) == 0:
            raise ValueError("primitives: expected at least one primitive")
        self.primitives = list(primitives)
        self._groups = {}
        for kind in PRIMITIVE_KINDS:
            members = [p for p in self.primitives if p.kind == kind]
            if members:
                self._groups[kind] = (
                    np.stack([p.centre for p in members]),
                    np.stack([p.rotation for p in members]),
                    np.stack([p.size for p in members]),
                )
        self._cache = {}

    def _tensors(self, device, dtype):
        key = (str(device), dtype)
        if key not in self._cache:
            self._cache[key] = {
                kind: tuple(torch.as_tensor(a, dtype=dtype, device=device) for a in arrays)
                for kind, arrays in self._groups.items()
            }
        return self._cache[key]

    def per_primitive_sdf(self, points):
        """Signed distance to each primitive.

        Args:
            points: (..., 3) metres, torch or numpy.
        Returns:
            (..., P) metres, columns grouped by kind in ``PRIMITIVE_KINDS`` order (see ``order``).
        """
        check_shape(points, (..., 3), "points")
        is_numpy = not isinstance(points, torch.Tensor)
        pts = torch.as_tensor(np.asarray(points, dtype=np.float64)) if is_numpy else points
        if not pts.is_floating_point():
            pts = pts.to(torch.get_default_dtype())
        groups = self._tensors(pts.device, pts.dtype)
        columns = []
        for kind, (centre, rotation, size) in groups.items():
            # local = R^T (p - c), for every primitive of this kind: (..., K, 3)
            local = torch.einsum("kji,...kj->...ki", rotation, pts[..., None, :] - centre)
            if kind == "box":
                columns.append(box_sdf(local, size))
            elif kind == "cylinder":
                columns.append(cylinder_sdf(local, size[:, 0], size[:, 1]))
            elif kind == "capsule":
                columns.append(capsule_sdf(local, size[:, 0], size[:, 1]))
            else:
                columns.append(sphere_sdf(local, size[:, 0]))
        out = torch.cat(columns, dim=-1)
        return out.numpy() if is_numpy else out

    @property
    def order(self) -> list[Primitive]:
        """The primitives in the column order of ``per_primitive_sdf``."""
        return [p for kind in self._groups for p in self.primitives if p.kind == kind]

    def sdf(self, points):
        """Signed distance to the union (min over parts): points (..., 3) metres → (...) metres."""
        per = self.per_primitive_sdf(points)
        if isinstance(per, torch.Tensor):
            return per.min(dim=-1).values
        return per.min(axis=-1)


def union_sdf(points, primitives: Sequence[Primitive]):
    """Signed distance (negative inside) to the union of ``primitives``.

    Args:
        points: (..., 3) metres in the primitives' frame; torch (differentiable) or numpy.
        primitives: the parts.
    Returns:
        (...) metres, same library as ``points``.
    """
    return PrimitiveSet(primitives).sdf(points)


# ----------------------------------------------------------------------------- surfaces, bounds, meshes


def surface_area(prim: Primitive) -> float:
    """Exact surface area of a primitive in square metres."""
    if prim.kind == "box":
        hx, hy, hz = prim.size
        return 8.0 * (hx * hy + hy * hz + hx * hz)
    if prim.kind == "cylinder":
        r, h = prim.size
        return 2.0 * np.pi * r * (2.0 * h) + 2.0 * np.pi * r * r
    if prim.kind == "capsule":
        r, h = prim.size
        return 2.0 * np.pi * r * (2.0 * h) + 4.0 * np.pi * r * r
    return 4.0 * np.pi * prim.size[0] ** 2


def _unit_vectors(n: int, rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def sample_surface(prim: Primitive, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points uniformly distributed (by area) on the exact surface of ``prim``.

    Returns:
        (n, 3) metres in the frame the primitive is placed in.
    """
    if prim.kind == "box":
        h = prim.size
        areas = np.array([h[1] * h[2], h[0] * h[2], h[0] * h[1]])  # faces normal to x, y, z
        axis = rng.choice(3, size=n, p=areas / areas.sum())
        local = rng.uniform(-1.0, 1.0, size=(n, 3)) * h
        sign = rng.choice([-1.0, 1.0], size=n)
        local[np.arange(n), axis] = sign * h[axis]
    elif prim.kind in ("cylinder", "capsule"):
        r, h = prim.size
        side_area = 2.0 * np.pi * r * 2.0 * h
        cap_area = 2.0 * np.pi * r * r if prim.kind == "cylinder" else 4.0 * np.pi * r * r
        on_side = rng.uniform(size=n) < side_area / (side_area + cap_area)
        local = np.empty((n, 3))
        theta = rng.uniform(0.0, 2.0 * np.pi, size=n)
        local[:, 0] = r * np.cos(theta)
        local[:, 1] = r * np.sin(theta)
        local[:, 2] = rng.uniform(-h, h, size=n)
        caps = ~on_side
        m = int(caps.sum())
        if prim.kind == "cylinder":
            radius = r * np.sqrt(rng.uniform(size=m))
            phi = rng.uniform(0.0, 2.0 * np.pi, size=m)
            local[caps] = np.stack(
                [radius * np.cos(phi), radius * np.sin(phi), rng.choice([-h, h], size=m)], axis=1
            )
        else:
            u = _unit_vectors(m, rng) * r
            u[:, 2] += np.where(u[:, 2] >= 0, h, -h)
            local[caps] = u
    else:
        local = _unit_vectors(n, rng) * prim.size[0]
    return local @ prim.rotation.T + prim.centre


def primitive_bounds(prim: Primitive) -> np.ndarray:
    """Exact axis-aligned bounds (2, 3) metres of a primitive in the frame it is placed in."""
    R = prim.rotation
    if prim.kind == "box":
        half = np.abs(R) @ prim.size
    elif prim.kind == "cylinder":
        r, h = prim.size
        axis = R[:, 2]
        half = np.abs(axis) * h + r * np.sqrt(np.clip(1.0 - axis**2, 0.0, None))
    elif prim.kind == "capsule":
        r, h = prim.size
        half = np.abs(R[:, 2]) * h + r
    else:
        half = np.full(3, prim.size[0])
    return np.stack([prim.centre - half, prim.centre + half])


def primitive_mesh(prim: Primitive, *, sections: int = 64, subdivisions: int = 4):
    """A closed ``trimesh.Trimesh`` of the primitive (curved parts as inscribed polygons).

    The deviation from the exact surface is at most ``r·(1 − cos(π/sections))`` for cylinders
    and capsules, about ``r·3e-4`` for spheres at ``subdivisions = 4``.
    """
    import trimesh

    transform = rigid_transform(prim.rotation, prim.centre)
    if prim.kind == "box":
        mesh = trimesh.creation.box(extents=2.0 * prim.size)
    elif prim.kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=prim.size[0], height=2.0 * prim.size[1], sections=sections)
    elif prim.kind == "capsule":
        mesh = trimesh.creation.capsule(height=2.0 * prim.size[1], radius=prim.size[0], count=[sections // 2, sections])
    else:
        mesh = trimesh.creation.icosphere(subdivisions=subdivisions, radius=prim.size[0])
    mesh = trimesh.Trimesh(vertices=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces), process=True)
    mesh.apply_transform(transform)
    return mesh


# ----------------------------------------------------------------------------- 2D footprints


def _row_norms(d: np.ndarray) -> np.ndarray:
    """``np.linalg.norm(d, axis=1)`` for real ``d`` (N, 2), computed as it computes it (the same bits) without its
    checks: these distances are taken many thousand times on a few points each."""
    return np.sqrt(np.add.reduce(d * d, axis=1))


@dataclass(frozen=True)
class _Segment:
    """A 2D segment from ``a`` along ``ab``, with ``denom = ab·ab``, prepared once for many distance queries."""

    a: np.ndarray
    ab: np.ndarray
    denom: float

    @classmethod
    def between(cls, a: np.ndarray, b: np.ndarray) -> "_Segment":
        ab = b - a
        return cls(a, ab, float(ab @ ab))

    def distance(self, xy: np.ndarray) -> np.ndarray:
        """(N,) metres from ``xy`` (N, 2) to the segment."""
        t = np.zeros(len(xy)) if self.denom == 0 else np.clip((xy - self.a) @ self.ab / self.denom, 0.0, 1.0)
        return _row_norms(xy - (self.a + t[:, None] * self.ab))


def _convex_hull_2d(points: np.ndarray) -> np.ndarray:
    """Counter-clockwise hull vertices (K, 2) of a few 2D points (Andrew's monotone chain)."""
    pts = sorted(set(map(tuple, np.round(points, 12))))
    if len(pts) <= 2:
        return np.array(pts)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


@dataclass(frozen=True)
class Footprint:
    """The vertical projection of a primitive inside a height band (:func:`footprint`), prepared once so that the
    distance to it can be taken for many points at a time (a scene's grid, a planner's queries).

    ``kind`` is ``"disc"`` (``centre`` (2,), ``radius``: spheres and upright cylinders), ``"stadium"`` (one segment
    and ``radius``: capsules and tilted cylinders), ``"polygon"`` (the convex hull ``polygon`` (K, 2),
    counter-clockwise, and its edges: boxes) or ``"empty"`` (the primitive lies outside the band).
    """

    kind: str
    centre: np.ndarray = None
    radius: float = 0.0
    segments: tuple = ()
    polygon: np.ndarray = None

    def distance(self, xy) -> np.ndarray:
        """Horizontal distance (N,) metres from ``xy`` (N, 2) to the footprint (0 inside, ``inf`` if empty)."""
        xy = np.asarray(xy, dtype=np.float64)
        if self.kind == "empty":
            return np.full(len(xy), np.inf)
        if self.kind == "disc":
            return np.clip(_row_norms(xy - self.centre) - self.radius, 0.0, None)
        if self.kind == "stadium":
            return np.clip(self.segments[0].distance(xy) - self.radius, 0.0, None)
        dist = np.full(len(xy), np.inf)
        for segment in self.segments:
            dist = np.minimum(dist, segment.distance(xy))
        polygon = self.polygon
        if len(polygon) >= 3:
            inside = np.ones(len(xy), dtype=bool)
            # hull vertices are counter-clockwise: inside is left of every edge
            for k in range(len(polygon)):
                a, b = polygon[k], polygon[(k + 1) % len(polygon)]
                cross = (b[0] - a[0]) * (xy[:, 1] - a[1]) - (b[1] - a[1]) * (xy[:, 0] - a[0])
                inside &= cross >= 0
            dist[inside] = 0.0
        return dist


def footprint(prim: Primitive, z_band=(-np.inf, np.inf)) -> Footprint:
    """The vertical projection of ``prim`` (in the frame of the floor, z up) for heights in ``z_band`` (low, high)
    metres: a primitive entirely outside the band has none. Exact for every kind: a box projects to a convex polygon,
    a capsule to a stadium, cylinders and spheres to discs (a tilted cylinder projects to the hull of two ellipses; it
    is bounded here by the stadium of its axis, a slight over-estimate)."""
    lo, hi = primitive_bounds(prim)[:, 2]
    if hi < z_band[0] or lo > z_band[1]:
        return Footprint("empty")
    if prim.kind == "sphere" or (prim.kind == "cylinder" and abs(prim.rotation[2, 2]) > 1 - 1e-12):
        return Footprint("disc", centre=prim.centre[:2], radius=prim.size[0])
    if prim.kind in ("capsule", "cylinder"):
        r, h = prim.size
        a = prim.centre - prim.rotation[:, 2] * h
        b = prim.centre + prim.rotation[:, 2] * h
        return Footprint("stadium", radius=r, segments=(_Segment.between(a[:2], b[:2]),))
    # box: convex hull of the 8 projected corners
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    corners = (signs * prim.size) @ prim.rotation.T + prim.centre
    polygon = _convex_hull_2d(corners[:, :2])
    return Footprint("polygon", polygon=polygon,
                     segments=tuple(_Segment.between(polygon[k], polygon[(k + 1) % len(polygon)])
                                    for k in range(len(polygon))))


def footprint_distance(prim: Primitive, xy, z_band=(-np.inf, np.inf)) -> np.ndarray:
    """Horizontal distance from ``xy`` to the vertical projection of ``prim`` (0 inside it).

    Args:
        prim: a primitive in the frame of ``xy`` (z up).
        xy: (N, 2) metres.
        z_band: (low, high) metres; a primitive entirely outside the band has no footprint
            and gives ``inf``.
    Returns:
        (N,) metres (:func:`footprint`; for many queries on one primitive, prepare it once with that).
    """
    xy = np.asarray(xy, dtype=np.float64)
    check_shape(xy, (None, 2), "xy")
    return footprint(prim, z_band).distance(xy)
