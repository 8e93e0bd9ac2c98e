"""SAMP (Hassan et al. 2021) at toy scale.

Modules, in the order of the paper:

- ``core``: the networks: the interaction encoder over 8×8×8×4 object voxels, GoalNet's cVAE, MotionNet's
  cVAE with its mixture-of-experts decoder, and the MLP, MoE and NSM-like baselines (§3.1–3.2, Supp. C, Table 5).
- ``sensor``: the NSM-like baseline's environment sensor, an 8×8×8 grid moving with the character (Table 5).
- ``motion_data``: toy clips of the five actions as states (Eq. 1), roots, goals and voxels (§4.1).
- ``augmentation``: a clip moved onto another object with its contacts kept, by projection and IK (§4.2, Supp. F).
- ``motionnet``: MotionNet's training with scheduled sampling (Eq. 3, Eq. 5; Supp. D, G ablations).
- ``goal_frame``: the state's goal features (Eq. 1) and the near-goal correction, recomputed from a
  trajectory and a goal, shared by training (recomputed inputs) and the run-time loop.
- ``runtime``: the decoder stepping characters from goal to goal (§3, §3.3).
- ``evaluation``: goal tasks on unseen objects, execution time and precision (§5.2, Tables 2–3).
- ``pipeline``: the whole pipeline in a cluttered room, handed over as SAMP's demo does — the path to the goal,
  MotionNet steered along it, then the action's goal (Fig. 2, §3.3, §5.2).
- ``penetration``: how far the body's capsules reach into the room's furniture, the target apart (§5.2).
- ``goalnet``: goal data from toy objects, GoalNet's training (Eq. 4), sampling and evaluation (§3.2, §4.3, §5.2).
- ``planning``: A* path planning on a room's grid inflated by the body radius, the waypoints where the path
  changes direction, and the walkable point nearest a goal on furniture (§3.3, Appendix E).
- ``paper_numbers``: the paper's reported numbers, transcribed, for the tables set beside ours.

``motion_data`` applies the augmentation to the training clips when ``MotionDataConfig.augmented`` asks for
copies; the presets train on the captured clips alone, and the baselines chapter measures one copy against none.
"""
