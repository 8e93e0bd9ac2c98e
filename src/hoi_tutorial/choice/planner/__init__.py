"""CHOICE §4 and §8.2: the neural implicit trajectory planner (INTP) and its evaluation (Table 3).

Modules, in the order of the paper:

- ``fields``: the object-centric grid and the three fields of Eq. 1 — target and obstacle distances
  (Eqs. 2–4) and the time of arrival of a demonstrated wrist trajectory (Eqs. 5–6) — by fast marching
  (scikit-fmm), and the descent along ``−∇φ`` that turns a time field into a path.
- ``interactions``: the planner's interactions — toy-mocap reaches onto items on shelves and tables, with
  clutter, their fields and conditions ``c`` (§4.2, §7, §8.1).
- ``decoder``: the auto-decoder's network ``f_θ(x, z; c)`` (§4.2, Fig. 3).
- ``intp``: training (Eqs. 7–8), the run-time latent fit (Eq. 9), the start point (Eq. 11), the integration
  (Eq. 10) and the orientation transfer (Eq. 12).
- ``baselines``: the collision-penalised minimum-jerk planner standing in for cuRobo, and the diffusion policy
  of Chi et al. on ``nn.diffusion`` (§8.2.1).
- ``table3``: Table 3's protocol — unseen layouts, reshaped containers, unsmoothness, safety distance,
  success (§8.2.2).
- ``latent_map``: Fig. 11, the codes fitted in unseen layouts among the training codes (t-SNE).
"""
from . import baselines, decoder, fields, interactions, intp, latent_map, table3

__all__ = ["fields", "interactions", "decoder", "intp", "baselines", "table3", "latent_map"]
