"""Object categories of the toy world and the affordance groups they fall into (sittable,
liftable, graspable, containers, lying, handled, supporting, small). Both ``world.objects`` and
the toy mocap read these, so they live apart from the object code.
"""
from __future__ import annotations

__all__ = ["CATEGORIES", "SITTABLE", "LIFTABLE", "GRASPABLE", "CONTAINERS", "LYING", "HANDLED", "SUPPORTING",
           "SMALL"]

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
