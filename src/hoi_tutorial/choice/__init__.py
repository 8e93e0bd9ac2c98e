"""CHOICE (Lu et al. 2024) at toy scale.

Modules, in the order of the paper:

- ``fields``: the object-centric grid and the three fields of Eq. 1 — target and obstacle
  distances (Eqs. 2–4) and the time of arrival of a demonstrated wrist trajectory (Eqs. 5–6) — by
  fast marching (scikit-fmm), and the descent along ``−∇φ`` that turns a time field into a path.
- ``data``: the planner's interactions — toy-mocap reaches onto items on shelves and tables, with
  clutter, their fields and conditions ``c`` (§4.2, §7, §8.1).
- ``core``: the auto-decoder's network ``f_θ(x, z; c)`` (§4.2, Fig. 3).
- ``planner``: training (Eqs. 7–8), the run-time latent fit (Eq. 9), the start point (Eq. 11), the
  integration (Eq. 10) and the orientation transfer (Eq. 12).
- ``baselines``: the collision-penalised minimum-jerk planner standing in for cuRobo, and the diffusion
  policy of Chi et al. on ``nn.diffusion`` (§8.2.1).
- ``evaluation``: Table 3's protocol — unseen layouts, reshaped containers, unsmoothness, safety
  distance, success (§8.2.2).
- ``paper_numbers``: the paper's reported numbers, transcribed, for the tables set beside ours.
- ``phase``: the DeepPhase periodic autoencoder whose phase manifold the controller works in (§5, §7).
- ``kalman``: the phase linear dynamical system (Eqs. 15–17) and the goal-phase Kalman filter
  (Eqs. 18–22, Algorithm 1).
- ``navigation``: the 2D path to the goal by fast marching with the cost of Eq. 23, split every 3 m (§6.2).
- ``locomotion``: navigation matching — the features ``N``, a KD-tree over toy-mocap walks, and the path
  followed by stitched clips that do not collide (§6.2).
- ``environment``: the goal's environment features (a 3D-CNN autoencoder over its distance field) and
  K-nearest goal matching with a KD-tree (§6.1).
- ``scheduler``: the bimanual task scheduler (Eq. 24) and the state machine of Fig. 6 (§6.3).
- ``controller``: the goal-driven MoE controller on phase features, with the four goal-phase sources of
  Table 4 (none, matched, predicted, Kalman-filtered) (§5.1); ``evaluation.table4_runs`` measures them (§8.3.1).
- ``pick_and_place``: the kitchen demo that joins navigation, the scheduler and Fig. 6's keyframes — walk to the
  cabinet, open it with one hand, take the bottle with the other, put it on the table (§6, §8.3); its stance
  search in ``pick_and_place_stances``, its motion pieces (walks, the plans at the cabinet and the table) in
  ``pick_and_place_motion`` and its collision checks in ``pick_and_place_checks``. The body there is posed by IK
  and the toy world's body planner, not yet by the controller.
"""
from . import (baselines, controller, core, data, environment, evaluation, fields, kalman, locomotion, navigation,
               paper_numbers, phase, pick_and_place, pick_and_place_checks, pick_and_place_motion, pick_and_place_stances,
               planner, scheduler)

__all__ = ["baselines", "controller", "core", "data", "environment", "evaluation", "fields", "kalman", "locomotion",
           "navigation", "paper_numbers", "phase", "pick_and_place", "pick_and_place_checks", "pick_and_place_motion",
           "pick_and_place_stances", "planner", "scheduler"]
