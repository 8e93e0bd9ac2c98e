"""Reference poses shared by the toy-mocap generators."""
from __future__ import annotations

import math

import torch

from ..rotations import axis_angle_to_matrix, rotation_about_z
from ..skeleton import NUM_JOINTS, joint_index, rest_pelvis_height

__all__ = ["standing_pose", "ARM_DOWN_ANGLE"]

# How far the arms hang from the T-pose towards the body, radians (75 degrees).
ARM_DOWN_ANGLE = math.radians(75.0)


def standing_pose(betas=None, position=(0.0, 0.0), heading: float = 0.0, arm_angle: float = ARM_DOWN_ANGLE,
                  elbow_bend: float = math.radians(10.0)):
    """A relaxed standing pose: straight legs, flat feet on the ground, arms hanging.

    Args:
        betas: ``(10,)`` body shape or ``None``.
        position: ``(2,)`` ground position of the pelvis, metres.
        heading: yaw in radians; 0 faces +Y.
        arm_angle: how far the arms drop from the T-pose, radians.
        elbow_bend: elbow flexion, radians.
    Returns:
        ``(local_rotations (22, 3, 3), root_position (3,))``.
    """
    local = torch.eye(3).repeat(NUM_JOINTS, 1, 1)
    local[0] = rotation_about_z(torch.tensor(float(heading)))
    # Rotation about +Y lowers the right arm (+X) for a positive angle and the left arm for a negative one.
    local[joint_index("left_shoulder")] = axis_angle_to_matrix(torch.tensor([0.0, -arm_angle, 0.0]))
    local[joint_index("right_shoulder")] = axis_angle_to_matrix(torch.tensor([0.0, arm_angle, 0.0]))
    # Elbows flex forward: about the arm's local axis that turns the forearm towards +Y.
    local[joint_index("left_elbow")] = axis_angle_to_matrix(torch.tensor([0.0, 0.0, -elbow_bend]))
    local[joint_index("right_elbow")] = axis_angle_to_matrix(torch.tensor([0.0, 0.0, elbow_bend]))
    height = float(rest_pelvis_height(betas))
    root = torch.tensor([float(position[0]), float(position[1]), height])
    return local, root

