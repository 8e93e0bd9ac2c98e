"""The toy world every chapter builds on (see the book's "Conventions" page).

- ``skeleton``: SMPL-22 joint names, parents, rest offsets and the toy body shape ``b``.
- ``rotations``: matrices, axis-angle, quaternions and the 6D representation (batched torch).
- ``kinematics``: forward kinematics and analytic two-bone IK.
- ``body``: capsule body surface, index-stable vertices, analytic body SDF, the right-toe vertex.
- ``mocap``: the procedural toy motion-capture generator (30 fps, labelled).
- ``objects``: procedural furniture and props with SDFs, voxels and affordances.
- ``scenes``: cluttered rooms and kitchens.
- ``features``: pose-state features (NIFTY Eq. 1, SAMP Eq. 1) and canonicalisation.
"""
from . import kinematics, rotations, skeleton  # noqa: F401
