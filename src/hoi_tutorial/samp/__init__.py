"""SAMP (Hassan et al. 2021) at toy scale.

Modules, in the order of the paper:

- ``planning``: A* path planning on a room's grid inflated by the body radius, and the waypoints
  where the path changes direction that the character walks to in turn (§3.3, Appendix E).
"""
