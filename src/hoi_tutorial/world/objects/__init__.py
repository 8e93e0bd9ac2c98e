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

from .builders import LIE_PELVIS_HEIGHT, PELVIS_FROM_BACKREST, SEAT_PELVIS_HEIGHT  # noqa: F401
from .categories import (  # noqa: F401 (HANDLED, SMALL)
    CATEGORIES,
    CONTAINERS,
    GRASPABLE,
    HANDLED,
    LIFTABLE,
    LYING,
    SITTABLE,
    SMALL,
    SUPPORTING,
)
from .sizes import CATEGORY_SIZES, SizeRange, size_table
from .toy_object import ToyObject, as_rng, make_object, object_from_description  # noqa: F401 (as_rng)

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
    "object_from_description",
]
