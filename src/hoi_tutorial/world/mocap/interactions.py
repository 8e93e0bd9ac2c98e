"""Procedural interaction clips for the toy mocap: sit, lie down, lift, reach and grasp, open a door or drawer.

These clips stand in for the interaction captures the three papers learn from: BEHAVE's sitting
and lifting (NIFTY §3.3 picks its *anchor poses* there: "the moment a person settles in a chair"
and the moment a person "contacts an object before lifting"), the SAMP capture (§4.1: walk to an
object, sit or lie down in several styles, get up, walk away) and the CHOICE capture (reaching,
grasping, opening cabinet doors and drawers).

Every clip is built the way a procedural animation system builds one:

1. an *approach*: ``gait.walk_path`` from a start at least 1.5 m away to a standing spot chosen
   from the object's geometry (in front of a seat, facing a box, a handle or a small prop); a
   sitter's last steps turn it round so it arrives with its back to the seat;
2. a *plan* of the interaction, frame by frame: the pelvis position and orientation follow smooth
   (minimum-jerk) curves between key poses, the spine leans, the feet stay planted where the
   approach left them (or step along a footstep plan), and the hands get targets: object contact
   points (lift contacts, grasp points, handles), or spots on the body (knees, thighs);
3. the *pose*: the legs and arms are solved with exact analytic two-bone IK
   (``kinematics.solve_limb_ik``) with the knees bending forward and the elbows backward, so a
   planted foot never slides and a hand on an object is exactly on its contact point.

Labels follow ``motion.ACTIONS`` and ``motion.CONTACT_JOINTS``: feet are in contact while planted,
the pelvis while seated or lying, a wrist while it holds the object. ``meta`` records the kind,
style, seed, a description of the object, ``anchor_frame`` (NIFTY's anchor: the settle frame of a
sit or lie, the first hand-contact frame of a lift, grasp, door or drawer), and for moving objects
``object_poses`` ``(T, 4, 4)`` world_from_object per frame and ``articulation`` ``(T,)`` (door
angle in radians or drawer opening in metres).

All randomness comes from ``seed`` (an int or a ``numpy.random.Generator``): the same seed gives
identical arrays; different seeds change the style, timing, speeds, the goal among an object's sit
goals, the hand used and the start of the approach.

This module is the front door; the clips live in ``sitting`` (:func:`sit`), ``lying``
(:func:`lie`), ``lifting`` (:func:`lift`), ``grasping`` (:func:`reach_grasp`) and ``handles``
(:func:`open_door`, :func:`open_drawer`), on shared machinery: ``body_plan`` (the plan and its IK
solve), ``standing`` (standing, stepping and bending), ``approach`` (the walks to and from the
object) and ``motion_math``.
"""
from __future__ import annotations

from .body_plan import SIDES  # noqa: F401 (the hands' names, for callers)
from .grasping import reach_grasp
from .handles import open_door, open_drawer
from .lifting import LIFT_STYLES, lift
from .lying import LIE_STYLES, lie
from .sitting import SIT_STYLES, sit

__all__ = [
    "SIT_STYLES",
    "LIE_STYLES",
    "LIFT_STYLES",
    "sit",
    "lie",
    "lift",
    "reach_grasp",
    "open_door",
    "open_drawer",
]
