"""CHOICE (Lu et al. 2024) at toy scale.

Modules, in the order of the paper:

- ``fields``: the object-centric grid and the three fields of Eq. 1 — target and obstacle
  distances (Eqs. 2–4) and the time of arrival of a demonstrated wrist trajectory (Eqs. 5–6) — by
  fast marching (scikit-fmm), and the descent along ``−∇φ`` that turns a time field into a path.

The implicit trajectory planner (§4.2), its baselines and Table 3, and the controller half of the
paper (§5–6, Table 4) are still to come.
"""
from . import fields

__all__ = ["fields"]
