"""Size ranges of the object categories: how each parameter of a category is drawn
(:class:`SizeRange`), the table of them (``CATEGORY_SIZES``) and a printable listing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SizeRange", "CATEGORY_SIZES", "size_table"]


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
