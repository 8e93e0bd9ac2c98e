"""CHOICE (Lu et al. 2024) at toy scale, in three sub-packages laid out by the paper's sections:

- ``planner`` (§4, §8.2): the fields of Eq. 1, the neural implicit trajectory planner (INTP), its baselines
  and Table 3.
- ``controller`` (§5, §8.3.1): the DeepPhase autoencoder, the goal-phase Kalman filter, the goal-driven
  controller and Table 4.
- ``pick_and_place`` (§6, §8.3): environment features and the goal library, navigation and its matching, the
  bimanual scheduler and the kitchen demo.

``paper_numbers`` holds the paper's reported numbers, transcribed, for the tables set beside ours. A later
sub-package imports an earlier one (the demo uses the planner's fields and the controller), never the reverse.
"""
from . import controller, paper_numbers, pick_and_place, planner

__all__ = ["planner", "controller", "pick_and_place", "paper_numbers"]
