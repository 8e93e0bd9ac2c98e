"""Procedural objects of the toy world: furniture, containers and small props.

Each object is a union of primitives (``hoi_tutorial.world.primitives``) sampled from realistic
size ranges (``CATEGORY_SIZES``), with an exact signed distance, a trimesh mesh, surface point
samples, SAMP's 8×8×8 interaction voxels and annotated affordances:

* sit goals (pelvis position + forward direction, SAMP §3.2 / §4.3: 1–5 per instance),
* lie goals on sofas,
* lift contacts for both hands (NIFTY §4.2 lifting),
* grasp points and the moving handles of cabinet doors and drawers (CHOICE).

Canonical frame: furniture stands on the floor (min z = 0) centred in x/y at the origin (the
carcass for cabinets and drawer units, whose door or drawer moves); small objects (bottle, mug,
teapot) have their base at z = 0 and their body axis on the z axis. The object's *front* faces
+Y: a person sitting on a chair faces +Y, and doors and drawers open towards +Y.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np
import torch

from hoi_tutorial._validate import check_choice, check_shape
from hoi_tutorial.world.primitives import (
    Primitive,
    PrimitiveSet,
    box,
    capsule_between,
    cylinder,
    primitive_bounds,
    primitive_mesh,
    rigid_transform,
    rotation_x,
    rotation_z,
    sample_surface,
    sphere,
    surface_area,
)

__all__ = [
    "CATEGORIES",
    "SITTABLE",
    "LIFTABLE",
    "GRASPABLE",
    "CONTAINERS",
    "LYING",
    "SUPPORTING",
    "SEAT_PELVIS_HEIGHT",
    "LIE_PELVIS_HEIGHT",
    "SizeRange",
    "CATEGORY_SIZES",
    "size_table",
    "ToyObject",
    "make_object",
]

CATEGORIES = (
    "chair", "armchair", "stool", "table", "sofa", "l_sofa", "yoga_ball", "suitcase", "box",
    "shelf", "cabinet", "drawer", "bottle", "mug", "teapot",
)
SITTABLE = ("chair", "armchair", "stool", "sofa", "l_sofa", "yoga_ball", "table", "box")
LIFTABLE = ("box", "suitcase", "yoga_ball", "chair", "stool")
GRASPABLE = ("bottle", "mug", "teapot")
CONTAINERS = ("shelf", "cabinet", "drawer")
LYING = ("sofa", "l_sofa")
HANDLED = ("cabinet", "drawer")
SUPPORTING = CONTAINERS + ("table",)
SMALL = GRASPABLE

SEAT_PELVIS_HEIGHT = 0.09  # pelvis joint above the seat top when seated, metres
LIE_PELVIS_HEIGHT = 0.10  # pelvis joint above the cushion when lying, metres
PELVIS_FROM_BACKREST = 0.20  # seated pelvis in front of the backrest, metres
_JOIN = 0.005  # parts that touch overlap by this much, so shared faces are interior


# ----------------------------------------------------------------------------- size ranges


@dataclass(frozen=True)
class SizeRange:
    """How one parameter of a category is drawn.

    Attributes:
        low, high: the range (inclusive for integers).
        axis: which component of ``size_scale`` scales it (``"x"``, ``"y"``, ``"z"``, ``"xy"``
            geometric mean of x and y, ``"xyz"`` of all three) or ``None`` (not a length).
        kind: ``"float"`` uniform, ``"int"`` uniform integer, ``"sign"`` ±1, ``"state"`` not
            sampled: defaults to ``low`` and may be overridden within [low, high].
        unit: ``"m"``, ``"rad"``, ``"count"``, ``"fraction"`` or ``"sign"``.
        description: what it measures.
    """

    low: float
    high: float
    axis: str | None = None
    kind: str = "float"
    unit: str = "m"
    description: str = ""

    def sample(self, rng: np.random.Generator):
        if self.kind == "float":
            return float(rng.uniform(self.low, self.high))
        if self.kind == "int":
            return int(rng.integers(int(self.low), int(self.high) + 1))
        if self.kind == "sign":
            return int(rng.choice([-1, 1]))
        return float(self.low)


def _m(low, high, axis, description):
    return SizeRange(low, high, axis, "float", "m", description)


def _rad(low, high, description):
    return SizeRange(low, high, None, "float", "rad", description)


def _count(low, high, description):
    return SizeRange(low, high, None, "int", "count", description)


_SIT_DIRECTIONS = {
    "n_sit_directions": _count(1, 4, "sitting directions offered (any direction is valid)"),
    "sit_yaw": _rad(-np.pi, np.pi, "yaw of the first sitting direction"),
}
_UPHOLSTERY = {
    "seat_height": _m(0.40, 0.47, "z", "top of the seat cushion"),
    "back_height": _m(0.30, 0.45, "z", "backrest above the seat"),
    "back_thickness": _m(0.15, 0.25, "y", "backrest thickness"),
    "arm_width": _m(0.12, 0.22, "x", "armrest width"),
    "arm_height": _m(0.15, 0.25, "z", "armrest above the seat"),
}

CATEGORY_SIZES: dict[str, dict[str, SizeRange]] = {
    "chair": {
        "seat_height": _m(0.40, 0.50, "z", "top of the seat"),
        "seat_width": _m(0.40, 0.50, "x", "seat width"),
        "seat_depth": _m(0.40, 0.48, "y", "seat depth"),
        "seat_thickness": _m(0.03, 0.05, "z", "seat board thickness"),
        "leg_width": _m(0.03, 0.045, "xy", "square leg side"),
        "back_height": _m(0.35, 0.50, "z", "backrest above the seat"),
        "back_thickness": _m(0.02, 0.04, "y", "backrest thickness"),
        "back_tilt": _rad(0.0, 0.20, "backward tilt of the backrest"),
        "sit_yaw": _rad(-0.25, 0.25, "sitting direction relative to +Y"),
    },
    "armchair": {
        "seat_height": _m(0.40, 0.48, "z", "top of the seat cushion"),
        "seat_width": _m(0.50, 0.60, "x", "seat width between the arms"),
        "seat_depth": _m(0.48, 0.58, "y", "seat depth in front of the back"),
        "arm_width": _m(0.08, 0.15, "x", "armrest width"),
        "arm_height": _m(0.18, 0.26, "z", "armrest above the seat"),
        "back_height": _m(0.35, 0.50, "z", "backrest above the seat"),
        "back_thickness": _m(0.12, 0.20, "y", "backrest thickness"),
        "leg_height": _m(0.05, 0.12, "z", "short legs under the base"),
    },
    "stool": {
        "seat_height": _m(0.45, 0.75, "z", "top of the seat (bar stools above 0.6)"),
        "seat_radius": _m(0.15, 0.20, "xy", "round seat radius"),
        "seat_thickness": _m(0.03, 0.05, "z", "seat thickness"),
        "leg_radius": _m(0.012, 0.020, "xy", "leg radius"),
        "leg_splay": _m(0.03, 0.08, "xy", "outward offset of a foot from its top"),
        "n_legs": _count(3, 4, "legs"),
        **_SIT_DIRECTIONS,
    },
    "table": {
        "height": _m(0.70, 0.78, "z", "top surface height"),
        "width": _m(1.0, 1.6, "x", "length along x"),
        "depth": _m(0.6, 0.9, "y", "depth along y"),
        "top_thickness": _m(0.03, 0.05, "z", "table top thickness"),
        "leg_width": _m(0.05, 0.07, "xy", "square leg side"),
        "n_sit_edges": _count(1, 2, "edges one may sit on (front, then back)"),
        "sit_offset": SizeRange(-0.3, 0.3, None, "float", "fraction", "sitting place along the edge, fraction of half width"),
    },
    "sofa": {
        "width": _m(1.6, 2.2, "x", "overall width"),
        "depth": _m(0.80, 1.00, "y", "overall depth"),
        **_UPHOLSTERY,
    },
    "l_sofa": {
        "width": _m(2.0, 2.8, "x", "main part length along x"),
        "depth": _m(0.80, 1.00, "y", "depth of the main part and width of the L part"),
        "chaise_length": _m(1.7, 2.2, "y", "overall length of the L part along y"),
        **_UPHOLSTERY,
        "l_side": SizeRange(-1, 1, None, "sign", "sign", "side of the L part (+1 at +x)"),
    },
    "yoga_ball": {
        "radius": _m(0.27, 0.38, "xyz", "ball radius"),
        **_SIT_DIRECTIONS,
    },
    "suitcase": {
        "width": _m(0.38, 0.48, "x", "body width"),
        "depth": _m(0.22, 0.28, "y", "body depth"),
        "height": _m(0.55, 0.70, "z", "body height"),
        "wheel_radius": _m(0.02, 0.03, "xyz", "wheel radius"),
        "handle_height": _m(0.03, 0.04, "z", "carry handle height"),
    },
    "box": {
        "width": _m(0.3, 0.6, "x", "side along x"),
        "depth": _m(0.3, 0.6, "y", "side along y"),
        "height": _m(0.3, 0.6, "z", "side along z"),
        **_SIT_DIRECTIONS,
    },
    "shelf": {
        "width": _m(0.8, 1.2, "x", "overall width"),
        "depth": _m(0.28, 0.40, "y", "overall depth"),
        "height": _m(1.2, 1.9, "z", "overall height"),
        "board_thickness": _m(0.018, 0.025, "z", "wall and board thickness"),
        "plinth_height": _m(0.04, 0.08, "z", "plinth under the bottom board"),
        "n_boards": _count(2, 4, "inner boards"),
    },
    "cabinet": {
        "width": _m(0.5, 0.7, "x", "carcass width"),
        "depth": _m(0.45, 0.60, "y", "carcass depth"),
        "height": _m(0.70, 0.95, "z", "carcass height"),
        "wall_thickness": _m(0.018, 0.025, "xyz", "wall thickness"),
        "door_thickness": _m(0.018, 0.025, "y", "door thickness"),
        "plinth_height": _m(0.06, 0.10, "z", "plinth under the bottom"),
        "board_fraction": SizeRange(0.45, 0.6, None, "float", "fraction", "inner board height, fraction of the interior"),
        "hinge_side": SizeRange(-1, 1, None, "sign", "sign", "hinge on the +x (+1) or -x (-1) side"),
        "door_angle": SizeRange(0.0, 2.0, None, "state", "rad", "door opening, 0 = closed, opens towards +Y"),
    },
    "drawer": {
        "width": _m(0.5, 0.8, "x", "carcass width"),
        "depth": _m(0.45, 0.55, "y", "carcass depth"),
        "height": _m(0.70, 0.90, "z", "carcass height"),
        "wall_thickness": _m(0.018, 0.025, "xyz", "wall thickness"),
        "front_thickness": _m(0.018, 0.025, "y", "drawer front thickness"),
        "plinth_height": _m(0.05, 0.10, "z", "plinth under the bottom"),
        "n_drawers": _count(2, 3, "drawer slots; the top one slides"),
        "drawer_open": SizeRange(0.0, 0.35, None, "state", "m", "top drawer pulled out towards +Y, metres"),
    },
    "bottle": {
        "body_radius": _m(0.030, 0.045, "xy", "body radius"),
        "body_height": _m(0.12, 0.20, "z", "body height"),
        "neck_radius": _m(0.011, 0.016, "xy", "neck radius"),
        "neck_height": _m(0.04, 0.07, "z", "neck height"),
    },
    "mug": {
        "radius": _m(0.035, 0.045, "xy", "body radius"),
        "height": _m(0.08, 0.11, "z", "body height"),
        "handle_thickness": _m(0.008, 0.012, "xyz", "handle bar thickness"),
        "handle_reach": _m(0.025, 0.035, "x", "handle reach beyond the body"),
    },
    "teapot": {
        "body_radius": _m(0.07, 0.10, "xyz", "body sphere radius"),
        "spout_length": _m(0.06, 0.10, "xyz", "spout length"),
        "handle_reach": _m(0.03, 0.05, "x", "handle reach beyond the body"),
        "knob_radius": _m(0.012, 0.018, "xyz", "lid knob radius"),
    },
}


def size_table() -> list[tuple]:
    """Rows ``(category, parameter, low, high, unit, description)`` of ``CATEGORY_SIZES``, for printing."""
    return [
        (category, name, r.low, r.high, r.unit, r.description)
        for category, spec in CATEGORY_SIZES.items()
        for name, r in spec.items()
    ]


# ----------------------------------------------------------------------------- builders (canonical frame)


def _slab(lo, hi, name=""):
    """An axis-aligned box from its min corner ``lo`` (3,) to its max corner ``hi`` (3,)."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return box((lo + hi) / 2, (hi - lo) / 2, name=name)


def _heading(yaw):
    """Horizontal unit vector(s) (..., 3): +Y turned by ``yaw`` radians about +Z."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([-np.sin(yaw), np.cos(yaw), np.zeros_like(yaw)], axis=-1)


def _sit_fan(position, n, yaw0):
    """``n`` goals at one seat: positions (n, 3), directions (n, 3) evenly spread from ``yaw0``."""
    yaws = yaw0 + 2.0 * np.pi * np.arange(n) / n
    return np.repeat(np.asarray(position, dtype=np.float64)[None], n, axis=0), _heading(yaws)


def _lift_pair(half_width, height, y=0.0):
    """Hand contacts on the ±x sides; the lifter stands at +Y facing −Y, so the left hand is at +x."""
    return {
        "lift_contacts": np.array([[half_width, y, height], [-half_width, y, height]]),
        "lift_approach": np.array([0.0, -1.0, 0.0]),
    }


def _build_chair(p):
    h, w, d = p["seat_height"], p["seat_width"], p["seat_depth"]
    ts, lw, bt = p["seat_thickness"], p["leg_width"], p["back_thickness"]
    parts = [_slab((-w / 2, -d / 2, h - ts), (w / 2, d / 2, h), "seat")]
    for sx in (-1, 1):
        for sy in (-1, 1):
            cx, cy = sx * (w / 2 - lw / 2 - 0.01), sy * (d / 2 - lw / 2 - 0.01)
            parts.append(_slab((cx - lw / 2, cy - lw / 2, 0.0), (cx + lw / 2, cy + lw / 2, h - ts + _JOIN), "leg"))
    # backrest tilted about its bottom edge so that its top leans towards -Y
    tilt = rotation_x(p["back_tilt"])
    half_back = np.array([w / 2, bt / 2, (p["back_height"] + ts) / 2])
    pivot = np.array([0.0, -d / 2 + bt / 2, h - ts])
    parts.append(box(pivot + tilt @ np.array([0.0, 0.0, half_back[2]]), half_back, tilt, name="back"))
    seat_y = min(-d / 2 + bt + PELVIS_FROM_BACKREST, 0.0)
    ann = {
        "sit_positions": np.array([[0.0, seat_y, h + SEAT_PELVIS_HEIGHT]]),
        "sit_directions": _heading(np.array([p["sit_yaw"]])),
        **_lift_pair(w / 2, h - ts / 2),
    }
    return parts, ann


def _build_armchair(p):
    h, sw, sd = p["seat_height"], p["seat_width"], p["seat_depth"]
    aw, bt, lh = p["arm_width"], p["back_thickness"], p["leg_height"]
    W, D = sw + 2 * aw, sd + bt
    parts = [_slab((-W / 2, -D / 2, lh), (W / 2, D / 2, h), "base")]
    for s in (-1, 1):
        x0, x1 = sorted((s * W / 2, s * (W / 2 - aw)))
        parts.append(_slab((x0, -D / 2, lh), (x1, D / 2, h + p["arm_height"]), "arm"))
    parts.append(_slab((-W / 2, -D / 2, lh), (W / 2, -D / 2 + bt, h + p["back_height"]), "back"))
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(cylinder((sx * (W / 2 - 0.05), sy * (D / 2 - 0.05), (lh + _JOIN) / 2), 0.025, (lh + _JOIN) / 2, name="leg"))
    seat_y = min(-D / 2 + bt + PELVIS_FROM_BACKREST, (-D / 2 + bt + D / 2) / 2)
    ann = {
        "sit_positions": np.array([[0.0, seat_y, h + SEAT_PELVIS_HEIGHT]]),
        "sit_directions": np.array([[0.0, 1.0, 0.0]]),  # an armchair allows one direction (SAMP Fig. 7)
    }
    return parts, ann


def _build_stool(p):
    h, R, ts = p["seat_height"], p["seat_radius"], p["seat_thickness"]
    lr, n = p["leg_radius"], p["n_legs"]
    parts = [cylinder((0.0, 0.0, h - ts / 2), R, ts / 2, name="seat")]
    for k in range(n):
        phi = 2 * np.pi * (k + 0.5) / n
        radial = np.array([np.cos(phi), np.sin(phi), 0.0])
        top = 0.65 * R * radial + np.array([0.0, 0.0, h - ts])
        foot = (0.65 * R + p["leg_splay"]) * radial + np.array([0.0, 0.0, lr])
        parts.append(capsule_between(foot, top, lr, name="leg"))
    positions, directions = _sit_fan((0.0, 0.0, h + SEAT_PELVIS_HEIGHT), p["n_sit_directions"], p["sit_yaw"])
    ann = {"sit_positions": positions, "sit_directions": directions, **_lift_pair(R, h - ts / 2)}
    return parts, ann


def _build_table(p):
    H, W, D, tt, lw = p["height"], p["width"], p["depth"], p["top_thickness"], p["leg_width"]
    parts = [_slab((-W / 2, -D / 2, H - tt), (W / 2, D / 2, H), "top")]
    for sx in (-1, 1):
        for sy in (-1, 1):
            cx, cy = sx * (W / 2 - lw / 2 - 0.04), sy * (D / 2 - lw / 2 - 0.04)
            parts.append(_slab((cx - lw / 2, cy - lw / 2, 0.0), (cx + lw / 2, cy + lw / 2, H - tt + _JOIN), "leg"))
    x = p["sit_offset"] * W / 2
    edge_y = D / 2 - 0.15  # pelvis 15 cm in from the edge one sits on
    positions = [[x, edge_y, H + SEAT_PELVIS_HEIGHT], [-x, -edge_y, H + SEAT_PELVIS_HEIGHT]]
    directions = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]
    n = p["n_sit_edges"]
    ann = {
        "sit_positions": np.array(positions[:n]),
        "sit_directions": np.array(directions[:n]),
        "supports": np.array([[H, -W / 2, W / 2, -D / 2, D / 2, 1.0]]),
    }
    return parts, ann


def _seat_row(x0, x1, n):
    """Centres of ``n`` equal seats along the interval [x0, x1]."""
    return x0 + (np.arange(n) + 0.5) * (x1 - x0) / n


def _build_sofa(p):
    W, D, h = p["width"], p["depth"], p["seat_height"]
    bt, aw = p["back_thickness"], p["arm_width"]
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (W / 2, D / 2, h), "base"),
        _slab((-W / 2, -D / 2, 0.0), (W / 2, -D / 2 + bt, h + p["back_height"]), "back"),
        _slab((-W / 2, -D / 2, 0.0), (-W / 2 + aw, D / 2, h + p["arm_height"]), "arm"),
        _slab((W / 2 - aw, -D / 2, 0.0), (W / 2, D / 2, h + p["arm_height"]), "arm"),
    ]
    inner = W - 2 * aw
    n = 2 if inner < 1.45 else 3
    p["n_seats"] = n
    seat_y = min(-D / 2 + bt + PELVIS_FROM_BACKREST, bt / 2)
    xs = _seat_row(-inner / 2, inner / 2, n)
    ann = {
        "sit_positions": np.stack([xs, np.full(n, seat_y), np.full(n, h + SEAT_PELVIS_HEIGHT)], axis=1),
        "sit_directions": np.repeat([[0.0, 1.0, 0.0]], n, axis=0),
        "lie_positions": np.array([[0.0, bt / 2, h + LIE_PELVIS_HEIGHT]] * 2),
        "lie_directions": np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]),
    }
    return parts, ann


def _build_l_sofa(p):
    W, D, C, h = p["width"], p["depth"], p["chaise_length"], p["seat_height"]
    bt, aw, s = p["back_thickness"], p["arm_width"], p["l_side"]
    top_back, top_arm = h + p["back_height"], h + p["arm_height"]
    y0 = -C / 2  # back of the main part; the L part reaches to y0 + C

    def xs(a, b):  # an x interval written for s = +1, mirrored for s = -1
        return sorted((s * a, s * b))

    (mx0, mx1), (cx0, cx1) = xs(-W / 2, W / 2), xs(W / 2 - D, W / 2)
    (bx0, bx1), (ax0, ax1) = xs(W / 2 - bt, W / 2), xs(-W / 2, -W / 2 + aw)
    parts = [
        _slab((mx0, y0, 0.0), (mx1, y0 + D, h), "base"),
        _slab((cx0, y0, 0.0), (cx1, y0 + C, h), "chaise"),
        _slab((mx0, y0, 0.0), (mx1, y0 + bt, top_back), "back"),
        _slab((bx0, y0, 0.0), (bx1, y0 + C, top_back), "side_back"),
        _slab((ax0, y0, 0.0), (ax1, y0 + D, top_arm), "arm"),
        _slab((cx0, y0 + C - aw, 0.0), (cx1, y0 + C, top_arm), "arm"),
    ]
    seat_z = h + SEAT_PELVIS_HEIGHT
    # main part: seats facing +Y from the arm to the side back (the corner seat included)
    main_len = W - aw - bt
    n_main = int(np.clip(round(main_len / 0.7), 2, 3))
    main_x = s * _seat_row(-W / 2 + aw, W / 2 - bt, n_main)
    main_y = min(y0 + bt + PELVIS_FROM_BACKREST, y0 + (bt + D) / 2)
    # L part: seats facing sideways (towards the inside of the L), beyond the main part's depth
    chaise_len = C - D - aw
    n_side = int(np.clip(np.floor(chaise_len / 0.55), 1, 2))
    side_y = _seat_row(y0 + D, y0 + C - aw, n_side)
    side_x = s * min(W / 2 - bt - PELVIS_FROM_BACKREST, W / 2 - (D + bt) / 2)
    p["n_seats"] = n_main + n_side
    positions = np.concatenate(
        [
            np.stack([main_x, np.full(n_main, main_y), np.full(n_main, seat_z)], axis=1),
            np.stack([np.full(n_side, side_x), side_y, np.full(n_side, seat_z)], axis=1),
        ]
    )
    directions = np.concatenate([np.repeat([[0.0, 1.0, 0.0]], n_main, 0), np.repeat([[-s, 0.0, 0.0]], n_side, 0)])
    lie_z = h + LIE_PELVIS_HEIGHT
    main_mid = s * (-W / 2 + aw + W / 2 - bt) / 2
    ann = {
        "sit_positions": positions,
        "sit_directions": directions.astype(np.float64),
        "lie_positions": np.array(
            [[main_mid, y0 + (bt + D) / 2, lie_z]] * 2 + [[s * (W / 2 - (D + bt) / 2), y0 + (D + C - aw) / 2, lie_z]]
        ),
        "lie_directions": np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),
    }
    return parts, ann


def _build_yoga_ball(p):
    r = p["radius"]
    positions, directions = _sit_fan((0.0, 0.0, 2 * r + SEAT_PELVIS_HEIGHT), p["n_sit_directions"], p["sit_yaw"])
    ann = {"sit_positions": positions, "sit_directions": directions, **_lift_pair(r, r)}
    return [sphere((0.0, 0.0, r), r, name="ball")], ann


def _build_suitcase(p):
    W, D, H, wr = p["width"], p["depth"], p["height"], p["wheel_radius"]
    z0 = 1.6 * wr  # body bottom: wheels poke 0.4 r into it
    parts = [_slab((-W / 2, -D / 2, z0), (W / 2, D / 2, z0 + H), "body")]
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(sphere((sx * (W / 2 - wr - 0.01), sy * (D / 2 - wr - 0.01), wr), wr, name="wheel"))
    hh = p["handle_height"]
    parts.append(_slab((-0.06, -0.012, z0 + H - _JOIN), (0.06, 0.012, z0 + H + hh), "handle"))
    return parts, _lift_pair(W / 2, z0 + 0.6 * H)


def _build_box(p):
    W, D, H = p["width"], p["depth"], p["height"]
    positions, directions = _sit_fan((0.0, 0.0, H + SEAT_PELVIS_HEIGHT), p["n_sit_directions"], p["sit_yaw"])
    ann = {"sit_positions": positions, "sit_directions": directions, **_lift_pair(W / 2, H / 2)}
    return [_slab((-W / 2, -D / 2, 0.0), (W / 2, D / 2, H), "box")], ann


def _build_shelf(p):
    W, D, H, t = p["width"], p["depth"], p["height"], p["board_thickness"]
    ph, n = p["plinth_height"], p["n_boards"]
    back_t = 0.012
    xi = W / 2 - t  # inner half width
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (-xi, D / 2, H), "side"),
        _slab((xi, -D / 2, 0.0), (W / 2, D / 2, H), "side"),
        _slab((-xi - _JOIN, -D / 2, 0.0), (xi + _JOIN, -D / 2 + back_t, H - t), "back"),
        _slab((-xi - _JOIN, D / 2 - 0.03, 0.0), (xi + _JOIN, D / 2 - 0.01, ph), "plinth"),
        _slab((-xi - _JOIN, -D / 2 + back_t - _JOIN, ph), (xi + _JOIN, D / 2, ph + t), "board"),
        _slab((-xi - _JOIN, -D / 2, H - t), (xi + _JOIN, D / 2, H), "top"),
    ]
    floor_z, ceil_z = ph + t, H - t
    gap = (ceil_z - floor_z - n * t) / (n + 1)
    surfaces = [floor_z]
    for k in range(n):
        z = floor_z + (k + 1) * gap + k * t
        parts.append(_slab((-xi - _JOIN, -D / 2 + back_t - _JOIN, z), (xi + _JOIN, D / 2, z + t), "board"))
        surfaces.append(z + t)
    supports = [[z, -xi, xi, -D / 2 + back_t, D / 2, gap] for z in surfaces]
    supports.append([H, -W / 2, W / 2, -D / 2, D / 2, 0.5])
    return parts, {"supports": np.array(supports)}


def _check_state(p, name, category):
    r = CATEGORY_SIZES[category][name]
    if not (r.low <= p[name] <= r.high):
        raise ValueError(f"{name}: expected a value in [{r.low}, {r.high}] {r.unit}, got {p[name]}")


def _build_cabinet(p):
    _check_state(p, "door_angle", "cabinet")
    W, D, H, t = p["width"], p["depth"], p["height"], p["wall_thickness"]
    ph, dt, s = p["plinth_height"], p["door_thickness"], p["hinge_side"]
    back_t = 0.012
    xi = W / 2 - t
    floor_z, ceil_z = ph + t, H - t
    board_z = floor_z + p["board_fraction"] * (ceil_z - floor_z - t)
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (-xi, D / 2, H), "side"),
        _slab((xi, -D / 2, 0.0), (W / 2, D / 2, H), "side"),
        _slab((-xi - _JOIN, -D / 2, H - t), (xi + _JOIN, D / 2, H), "top"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, D / 2, ph + t), "bottom"),
        _slab((-xi - _JOIN, -D / 2 + 0.03, 0.0), (xi + _JOIN, D / 2 - 0.03, ph + _JOIN), "plinth"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, -D / 2 + back_t, H - t + _JOIN), "back"),
        _slab((-xi - _JOIN, -D / 2 + back_t - _JOIN, board_z), (xi + _JOIN, D / 2 - 0.02, board_z + t), "board"),
    ]
    # door: hinged on a vertical axis at the front edge of the side ``s``; the free edge swings to +Y
    hinge = np.array([s * W / 2, D / 2 - _JOIN, 0.0])
    swing = rotation_z(-s * p["door_angle"])
    door_lo, door_hi = np.array([-W / 2, D / 2 - _JOIN, ph]), np.array([W / 2, D / 2 - _JOIN + dt, H])
    door_centre = swing @ ((door_lo + door_hi) / 2 - hinge) + hinge
    parts.append(box(door_centre, (door_hi - door_lo) / 2, swing, name="door"))
    handle_z = ph + 0.7 * (H - ph)
    handle_closed = np.array([-s * (W / 2 - 0.05), D / 2 - _JOIN + dt + 0.015, handle_z])
    handle_centre = swing @ (handle_closed - hinge) + hinge
    parts.append(box(handle_centre, (0.01, 0.015 + _JOIN, 0.06), swing, name="handle"))
    handle_point = swing @ (handle_closed + np.array([0.0, 0.015 + _JOIN, 0.0]) - hinge) + hinge
    ann = {
        "handle_point": handle_point,
        "grasp_points": handle_point[None],
        "supports": np.array(
            [
                [floor_z, -xi, xi, -D / 2 + back_t, D / 2 - 0.02, board_z - floor_z],
                [board_z + t, -xi, xi, -D / 2 + back_t, D / 2 - 0.02, ceil_z - board_z - t],
            ]
        ),
    }
    return parts, ann


def _build_drawer(p):
    _check_state(p, "drawer_open", "drawer")
    W, D, H, t = p["width"], p["depth"], p["height"], p["wall_thickness"]
    ph, ft, n, pull = p["plinth_height"], p["front_thickness"], p["n_drawers"], p["drawer_open"]
    back_t = 0.012
    xi = W / 2 - t
    floor_z, ceil_z = ph + t, H - t
    slot = (ceil_z - floor_z - (n - 1) * t) / n
    parts = [
        _slab((-W / 2, -D / 2, 0.0), (-xi, D / 2, H), "side"),
        _slab((xi, -D / 2, 0.0), (W / 2, D / 2, H), "side"),
        _slab((-xi - _JOIN, -D / 2, H - t), (xi + _JOIN, D / 2, H), "top"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, D / 2, ph + t), "bottom"),
        _slab((-xi - _JOIN, -D / 2 + 0.03, 0.0), (xi + _JOIN, D / 2 - 0.03, ph + _JOIN), "plinth"),
        _slab((-xi - _JOIN, -D / 2, ph), (xi + _JOIN, -D / 2 + back_t, H - t + _JOIN), "back"),
    ]
    slot_bottoms = [floor_z + k * (slot + t) for k in range(n)]
    for z in slot_bottoms[1:]:
        parts.append(_slab((-xi - _JOIN, -D / 2, z - t), (xi + _JOIN, D / 2, z), "divider"))
    gap = 0.004  # clearance of a drawer inside its slot
    for z in slot_bottoms[:-1]:  # closed lower drawers: fronts only
        parts.append(_slab((-xi + gap, D / 2 - ft, z + gap), (xi - gap, D / 2, z + slot - gap), "front"))
    # the top drawer: a tray (bottom, sides, back) behind a front, all shifted by ``pull`` towards +Y
    z = slot_bottoms[-1]
    tray_t, tray_top = 0.012, z + 0.75 * slot
    y_back, y_front = -D / 2 + back_t + 0.02 + pull, D / 2 - ft + pull
    x_out = xi - gap
    parts += [
        _slab((-x_out, y_front, z + gap), (x_out, y_front + ft, z + slot - gap), "front"),
        _slab((-x_out, y_back, z + gap), (x_out, y_front + _JOIN, z + gap + tray_t), "tray_bottom"),
        _slab((-x_out, y_back, z + gap), (-x_out + tray_t, y_front + _JOIN, tray_top), "tray_side"),
        _slab((x_out - tray_t, y_back, z + gap), (x_out, y_front + _JOIN, tray_top), "tray_side"),
        _slab((-x_out, y_back, z + gap), (x_out, y_back + tray_t, tray_top), "tray_back"),
    ]
    handle_z = z + slot / 2
    handle_y = y_front + ft + 0.015
    parts.append(_slab((-0.06, y_front + ft - _JOIN, handle_z - 0.01), (0.06, handle_y, handle_z + 0.01), "handle"))
    handle_point = np.array([0.0, handle_y, handle_z])
    inner_floor = z + gap + tray_t
    ann = {
        "handle_point": handle_point,
        "grasp_points": handle_point[None],
        "supports": np.array(
            [[inner_floor, -x_out + tray_t, x_out - tray_t, y_back + tray_t, y_front, z + slot - gap - inner_floor]]
        ),
    }
    return parts, ann


def _build_bottle(p):
    r, bh, nr, nh = p["body_radius"], p["body_height"], p["neck_radius"], p["neck_height"]
    cap_h = 0.015
    parts = [
        cylinder((0.0, 0.0, bh / 2), r, bh / 2, name="body"),
        cylinder((0.0, 0.0, bh + nh / 2 - _JOIN / 2), nr, nh / 2 + _JOIN / 2, name="neck"),
        cylinder((0.0, 0.0, bh + nh + cap_h / 2 - _JOIN / 2), nr + 0.003, cap_h / 2 + _JOIN / 2, name="cap"),
    ]
    ann = {"grasp_points": np.array([[0.0, r, 0.55 * bh], [0.0, nr, bh + nh / 2]])}
    return parts, ann


def _build_mug(p):
    r, h, th, reach = p["radius"], p["height"], p["handle_thickness"], p["handle_reach"]
    x_in, x_out = r - 2 * _JOIN, r + reach
    parts = [
        cylinder((0.0, 0.0, h / 2), r, h / 2, name="body"),
        _slab((x_in, -th / 2, 0.8 * h - th / 2), (x_out, th / 2, 0.8 * h + th / 2), "handle"),
        _slab((x_in, -th / 2, 0.3 * h - th / 2), (x_out, th / 2, 0.3 * h + th / 2), "handle"),
        _slab((x_out - th, -th / 2, 0.3 * h - th / 2), (x_out, th / 2, 0.8 * h + th / 2), "handle"),
    ]
    ann = {"grasp_points": np.array([[x_out, 0.0, 0.55 * h], [0.0, r, 0.5 * h]])}
    return parts, ann


def _build_teapot(p):
    R, ls, reach, kr = p["body_radius"], p["spout_length"], p["handle_reach"], p["knob_radius"]
    th = 0.012
    spout_start = np.array([0.5 * R, 0.0, 0.8 * R])
    spout_end = np.array([R + 0.7 * ls, 0.0, 0.8 * R + 0.7 * ls])
    x_in, x_out = -0.8 * R, -(R + reach)
    parts = [
        sphere((0.0, 0.0, R), R, name="body"),
        cylinder((0.0, 0.0, 0.01), 0.55 * R, 0.01, name="base"),
        capsule_between(spout_start, spout_end, 0.012, name="spout"),
        _slab((x_out, -th / 2, 1.5 * R - th / 2), (x_in, th / 2, 1.5 * R + th / 2), "handle"),
        _slab((x_out, -th / 2, 0.7 * R - th / 2), (x_in, th / 2, 0.7 * R + th / 2), "handle"),
        _slab((x_out, -th / 2, 0.7 * R - th / 2), (x_out + th, th / 2, 1.5 * R + th / 2), "handle"),
        sphere((0.0, 0.0, 2 * R + 0.5 * kr), kr, name="knob"),
    ]
    ann = {"grasp_points": np.array([[x_out, 0.0, 1.1 * R], [0.0, 0.0, 2 * R + 1.5 * kr]])}
    return parts, ann


_BUILDERS = {
    "chair": _build_chair, "armchair": _build_armchair, "stool": _build_stool, "table": _build_table,
    "sofa": _build_sofa, "l_sofa": _build_l_sofa, "yoga_ball": _build_yoga_ball,
    "suitcase": _build_suitcase, "box": _build_box, "shelf": _build_shelf, "cabinet": _build_cabinet,
    "drawer": _build_drawer, "bottle": _build_bottle, "mug": _build_mug, "teapot": _build_teapot,
}
# annotation entries that are points (moved with the object) and directions (rotated only)
_POINT_KEYS = ("sit_positions", "lie_positions", "lift_contacts", "grasp_points", "handle_point")
_DIRECTION_KEYS = ("sit_directions", "lie_directions", "lift_approach")
_DERIVED_PARAMS = ("n_seats",)


def _recentre(parts, ann):
    """Shift parts and annotations so the x/y bounding box is centred on the origin."""
    bounds = np.stack([primitive_bounds(q) for q in parts])
    lo, hi = bounds[:, 0].min(0), bounds[:, 1].max(0)
    offset = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, 0.0])
    if np.allclose(offset, 0.0):
        return parts, ann
    shift = rigid_transform(translation=offset)
    ann = dict(ann)
    for key in _POINT_KEYS:
        if key in ann:
            ann[key] = ann[key] + offset
    if "supports" in ann:
        s = ann["supports"].copy()
        s[:, 1:3] += offset[0]
        s[:, 3:5] += offset[1]
        ann["supports"] = s
    return [q.transformed(shift) for q in parts], ann


# ----------------------------------------------------------------------------- the object


def _as_rng(seed) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        return np.random.default_rng(int(seed))
    raise TypeError(f"seed: expected an int or a numpy.random.Generator, got {type(seed).__name__}")


_ADJECTIVES = {"sit": "sittable", "lie": "lying", "lift": "liftable", "grasp": "graspable", "handle": "handled", "support": "supporting"}


def _affordance_error(name, category, kind, allowed):
    return ValueError(
        f"{name}: category {category!r} has no {kind} affordance; {_ADJECTIVES[kind]} categories are {list(allowed)}"
    )


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
        return out

    def with_params(self, **overrides) -> "ToyObject":
        """The same instance rebuilt with some parameters changed (e.g. ``door_angle``), same pose."""
        params = {k: v for k, v in self.params.items() if k not in _DERIVED_PARAMS}
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
        return self.to_world(self._canonical_surface_points(int(n), _as_rng(seed)))

    def point_cloud(self, n: int, seed=0) -> np.ndarray:
        """``n`` surface points in the CANONICAL frame, (n, 3) metres (NIFTY's object condition P_o, §3.1)."""
        return self._canonical_surface_points(int(n), _as_rng(seed))

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

    def _points(self, key):
        return self.to_world(self.annotations[key])

    def _directions(self, key):
        return np.asarray(self.annotations[key], dtype=np.float64) @ self.rotation.T

    @property
    def sit_goals(self) -> tuple[np.ndarray, np.ndarray]:
        """Sitting goals (SAMP §3.2 g^p, g^d): positions (K, 3) metres of the seated pelvis
        (``SEAT_PELVIS_HEIGHT`` above the seat) and the sitter's forward (K, 3), horizontal unit."""
        if self.category not in SITTABLE:
            raise _affordance_error("sit_goals", self.category, "sit", SITTABLE)
        return self._points("sit_positions"), self._directions("sit_directions")

    @property
    def lie_goals(self) -> tuple[np.ndarray, np.ndarray]:
        """Lying goals on sofas: pelvis positions (K, 3) metres and head directions (K, 3), unit, along the cushion."""
        if self.category not in LYING:
            raise _affordance_error("lie_goals", self.category, "lie", LYING)
        return self._points("lie_positions"), self._directions("lie_directions")

    @property
    def lift_contacts(self) -> np.ndarray:
        """(2, 3) metres: left and right hand contacts on opposite sides of the object (NIFTY lifting)."""
        if self.category not in LIFTABLE:
            raise _affordance_error("lift_contacts", self.category, "lift", LIFTABLE)
        return self._points("lift_contacts")

    @property
    def lift_approach(self) -> np.ndarray:
        """(3,) horizontal unit vector: the direction the lifter FACES while holding the object."""
        if self.category not in LIFTABLE:
            raise _affordance_error("lift_approach", self.category, "lift", LIFTABLE)
        return self._directions("lift_approach")

    @property
    def grasp_points(self) -> np.ndarray:
        """(K, 3) metres: where a hand grasps (handle or body of a prop, handle of a door or drawer)."""
        if self.category not in GRASPABLE + HANDLED:
            raise _affordance_error("grasp_points", self.category, "grasp", GRASPABLE + HANDLED)
        return self._points("grasp_points")

    @property
    def handle_point(self) -> np.ndarray:
        """(3,) metres: the front of the door or drawer handle; it moves with ``door_angle`` / ``drawer_open``."""
        if self.category not in HANDLED:
            raise _affordance_error("handle_point", self.category, "handle", HANDLED)
        return self._points("handle_point")

    @property
    def support_surfaces(self) -> np.ndarray:
        """(K, 6) in the CANONICAL frame: ``[z, x_min, x_max, y_min, y_max, free_height]`` metres,
        the horizontal surfaces (boards, tray bottom, table top) small objects can stand on."""
        if self.category not in SUPPORTING:
            raise _affordance_error("support_surfaces", self.category, "support", SUPPORTING)
        return np.array(self.annotations["supports"], dtype=np.float64)


def _check_override_names(category, overrides):
    unknown = sorted(set(overrides) - set(CATEGORY_SIZES[category]))
    if unknown:
        raise ValueError(
            f"overrides: expected parameters of {category!r} among {sorted(CATEGORY_SIZES[category])}, got {unknown}"
        )


def _build(category: str, params: dict) -> ToyObject:
    params = dict(params)
    parts, ann = _BUILDERS[category](params)
    if category not in SMALL + HANDLED:
        parts, ann = _recentre(parts, ann)
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
    rng = _as_rng(seed)
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
