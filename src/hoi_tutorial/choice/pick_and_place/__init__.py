"""CHOICE §6: navigation and bimanual planning for pick and place, and the kitchen demo that joins them (§8.3).

Modules, in the order of the paper:

- ``environment``: a hand goal's environment feature — a 3D-CNN autoencoder over the distance field around it
  (§6.1).
- ``goal_library``: the goal keyframes of the capture and their K-nearest matching with a KD-tree (§6.1).
- ``navigation``: the 2D path to the goal by fast marching with the cost of Eq. 23, split every 3 m (§6.2).
- ``locomotion``: navigation matching — the features ``N``, a KD-tree over toy-mocap walks, and the path
  followed by stitched clips that do not collide (§6.2).
- ``scheduler``: the bimanual task scheduler (Eq. 24) and the state machine of Fig. 6 (§6.3).
- ``demo``: the kitchen demo that joins navigation, the scheduler and Fig. 6's keyframes — walk to the
  cabinet, open it with one hand, take the bottle with the other, put it on the table (§6, §8.3); its
  stance search in ``stances``, its motion pieces (walks, the plans at the cabinet and the table) in
  ``motion_pieces``, its collision checks in ``checks`` and the small types they pass each other (the
  configuration, the setting, stances and plans) in ``demo_types``; the hands' approaches to the bottle and to the
  table are planned by §4's planner (``hand_paths``). The body there is posed by IK and the toy world's body
  planner, not yet by the controller; ``controller_reaches`` measures how near the §5.1 controller brings each hand
  to its contact there (the IK correction §6.3 would leave), with Table 4's controller or one trained on the demo's
  actions.
- ``table4``: Table 4's runs (§8.3.1) — the controller (§5) driven toward goals matched by §6.1 in unseen scenes,
  with each source of the goal phase.
"""
from . import (checks, controller_reaches, demo, demo_types, environment, goal_library, hand_paths, locomotion,
               motion_pieces, navigation, scheduler, stances, table4)

__all__ = ["environment", "goal_library", "navigation", "locomotion", "scheduler", "demo", "demo_types", "stances",
           "motion_pieces", "hand_paths", "checks", "controller_reaches", "table4"]
