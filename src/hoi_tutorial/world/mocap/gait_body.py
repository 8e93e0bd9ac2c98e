"""Rest geometry of a body shape for locomotion: hips, leg lengths, the ankle-to-ball vector of
each foot and where the ankles stand, with the per-side joint indices the gait modules share.
"""
from __future__ import annotations

import numpy as np
import torch

from ..._validate import as_tensor, check_finite, check_shape
from ..skeleton import FOOT_JOINT_HEIGHT, NUM_BETAS, bone_offsets, joint_index, rest_pelvis_height
from .motion_math import rot_x, rot_z

__all__ = ["SIDES", "SIDE_JOINTS", "SIDE_SIGN", "GaitBody"]

SIDES = ("left", "right")
# Joint index of each side's hip, knee, ankle, foot, shoulder and elbow.
SIDE_JOINTS = {side: {part: joint_index(f"{side}_{part}")
                      for part in ("hip", "knee", "ankle", "foot", "shoulder", "elbow")}
               for side in SIDES}
SIDE_SIGN = {"left": -1.0, "right": 1.0}  # +X is the character's right


class GaitBody:
    """Rest geometry of one body shape, in numpy float64."""

    def __init__(self, betas):
        self.betas = torch.zeros(NUM_BETAS) if betas is None else as_tensor(betas, "betas").clone()
        check_shape(self.betas, (NUM_BETAS,), "betas")
        check_finite(self.betas, "betas")
        self.offsets_torch = bone_offsets(self.betas)
        off = self.offsets_torch.double().numpy()
        self.offsets = off
        self.stand_height = float(rest_pelvis_height(self.betas))
        self.hip, self.leg_length, self.foot, self.stand_ankle, self.flat_ankle_height = {}, {}, {}, {}, {}
        for side in SIDES:
            j = SIDE_JOINTS[side]
            self.hip[side] = off[j["hip"]]
            self.leg_length[side] = float(np.linalg.norm(off[j["knee"]]) + np.linalg.norm(off[j["ankle"]]))
            self.foot[side] = off[j["foot"]]  # ankle -> ball with a flat foot facing +Y
            chain = off[j["hip"]] + off[j["knee"]] + off[j["ankle"]]
            self.stand_ankle[side] = chain[:2]
            self.flat_ankle_height[side] = FOOT_JOINT_HEIGHT - off[j["foot"], 2]
        self.stand_ankle_forward = 0.5 * float(self.stand_ankle["left"][1] + self.stand_ankle["right"][1])
        self.hip_height = self.stand_height + 0.5 * (self.hip["left"][2] + self.hip["right"][2])

    def ankle_from_ball(self, side, ball, yaw, pitch):
        """Ankle position ``(..., 3)`` and orientation ``(..., 3, 3)`` for a foot whose ball is at ``ball``."""
        rot = rot_z(yaw) @ rot_x(-np.asarray(pitch))  # positive pitch lifts the heel
        return ball - rot @ self.foot[side], rot

    def ball_from_ankle_xy(self, side, ankle_xy, yaw):
        """Ball ground position ``(2,)`` of a flat foot whose ankle is above ``ankle_xy``."""
        return ankle_xy + (rot_z(yaw) @ self.foot[side])[:2]
