"""NIFTY (Kulkarni et al. 2024) at toy scale.

Modules, in the order of the paper:

- ``toy2d``: the diffusion chapter's 2-D experiment: distributions with exact posteriors, region objectives,
  a class-conditional denoiser.
- ``trajectories``: a small diffusion model over toy walking trajectories (the guidance chapter).
- ``motion_prior``: the time-reversed HuMoR-style motion prior (§3.3, Appendix A.2).
- ``anchors``: anchor poses for sitting and lifting across toy subjects and objects (§3.3).
- ``rollout``: Algorithm 1, tree-based rollouts with PruneCheck (§3.3, Appendix A.2).
- ``data``: the synthetic-data pipeline end to end, cached: mocap, prior, anchors, trees, datasets (§3.3).
- ``motion_model``: the object-conditioned motion diffusion model, its training and sampling (§3.1, Appendix B).
- ``interaction_field``: the object interaction field F_φ, its training pairs and training (§3.2).
- ``guidance``: guidance objectives (the field, the nearest anchor) and best-of-N guided sampling (Eq. 4, §4.1).
- ``baselines``: Table 1's Cond. VAE, a conditional motion VAE on the same data and conditions (§4.3).
- ``evaluation``: test scenes and the metrics of Table 1 (§4.2, Appendix C.2).
- ``paper_numbers``: the paper's reported numbers, transcribed, for the tables set beside ours.
"""
