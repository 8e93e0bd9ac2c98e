"""SAMP (Hassan et al. 2021) at toy scale.

Modules, in the order of the paper:

- ``core``: the networks: the interaction encoder over 8×8×8×4 object voxels, GoalNet's cVAE (§3.1–3.2).
- ``goalnet``: goal data from toy objects, GoalNet's training (Eq. 4), sampling and evaluation (§3.2, §4.3, §5.2).
- ``planning``: A* path planning on a room's grid inflated by the body radius, and the waypoints
  where the path changes direction that the character walks to in turn (§3.3, Appendix E).
- ``paper_numbers``: the paper's reported numbers, transcribed, for the tables set beside ours.

MotionNet (§3.1), the baselines and the full pipeline follow in later chapters.
"""
