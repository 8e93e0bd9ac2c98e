"""Style parameters of the gaits: the ranges each gait draws its style from (:class:`GaitParams`,
``GAITS`` for walking and running, and the slow stepping gaits for turning on the spot, side
steps and standing), and the style one clip draws from them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["GaitParams", "GAITS", "TURN_GAIT", "SIDE_GAIT", "IDLE_GAIT", "GaitStyle", "sample_style"]


@dataclass(frozen=True)
class GaitParams:
    """Ranges of one gait's style parameters; each clip draws its style from them.

    Lengths in metres, angles in radians, speeds in m/s. ``step_ratio`` gives the step length
    as a fraction of the hip height ``l``: ``L = l * (a + b * speed)``.
    """

    speed: tuple[float, float]
    step_ratio: tuple[float, float]
    duty: float                      # fraction of a stride each foot spends on the ground
    over_foot: float                 # fraction of stance at which the root passes over its standing spot
    half_width: float                # lateral ankle offset from the root while moving
    swing_height: tuple[float, float]
    heel_off: tuple[float, float]    # heel pitch at lift-off
    heel_off_fraction: float         # last fraction of stance spent rolling the heel up
    arm_swing: tuple[float, float]
    elbow: tuple[float, float]
    bob: tuple[float, float]
    drop: tuple[float, float]        # mean pelvis lowering at cruise speed
    lean: tuple[float, float]
    sway: tuple[float, float]        # share of the stance foot's lateral offset the pelvis takes
    pelvis_twist: tuple[float, float]
    accel_time: float                # seconds to reach 1 m/s (ramps scale with speed)
    spring: bool                     # True: pelvis lowest at mid-stance (running)
    lateral_accel: float = 1.5       # m/s² allowed in bends (sets the cornering speed)
    min_turn_speed: float = 0.3      # m/s, the slowest a bend makes the walker


GAITS: dict[str, GaitParams] = {
    "walk": GaitParams(
        speed=(0.9, 1.5), step_ratio=(0.27, 0.38), duty=0.62, over_foot=0.47, half_width=0.075,
        swing_height=(0.05, 0.09), heel_off=(math.radians(26), math.radians(32)), heel_off_fraction=0.4,
        arm_swing=(math.radians(12), math.radians(22)), elbow=(math.radians(12), math.radians(25)),
        bob=(0.012, 0.022), drop=(0.01, 0.02), lean=(math.radians(1), math.radians(4)),
        sway=(0.25, 0.4), pelvis_twist=(math.radians(3), math.radians(6)), accel_time=0.55, spring=False,
    ),
    "run": GaitParams(
        speed=(2.4, 3.4), step_ratio=(0.23, 0.32), duty=0.36, over_foot=0.5, half_width=0.05,
        swing_height=(0.16, 0.24), heel_off=(math.radians(25), math.radians(32)), heel_off_fraction=0.5,
        arm_swing=(math.radians(30), math.radians(45)), elbow=(math.radians(75), math.radians(95)),
        bob=(0.02, 0.035), drop=(0.03, 0.05), lean=(math.radians(6), math.radians(11)),
        sway=(0.15, 0.25), pelvis_twist=(math.radians(5), math.radians(9)), accel_time=0.45, spring=True,
        lateral_accel=4.0, min_turn_speed=1.0,
    ),
}

# Slow stepping gaits (no root speed range: the root plan sets the motion).
TURN_GAIT = GaitParams(
    speed=(0.0, 0.0), step_ratio=(0.0, 0.0), duty=0.7, over_foot=0.5, half_width=0.09,
    swing_height=(0.04, 0.07), heel_off=(0.0, 0.0), heel_off_fraction=0.0,
    arm_swing=(math.radians(3), math.radians(6)), elbow=(math.radians(10), math.radians(18)),
    bob=(0.0, 0.0), drop=(0.005, 0.015), lean=(0.0, math.radians(2)),
    sway=(0.25, 0.4), pelvis_twist=(0.0, 0.0), accel_time=0.0, spring=False,
)
SIDE_GAIT = GaitParams(
    speed=(0.25, 0.35), step_ratio=(0.0, 0.0), duty=0.7, over_foot=0.5, half_width=0.14,
    swing_height=(0.04, 0.07), heel_off=(0.0, 0.0), heel_off_fraction=0.0,
    arm_swing=(math.radians(2), math.radians(5)), elbow=(math.radians(10), math.radians(18)),
    bob=(0.0, 0.0), drop=(0.01, 0.02), lean=(0.0, math.radians(2)),
    sway=(0.3, 0.45), pelvis_twist=(0.0, 0.0), accel_time=1.2, spring=False,
)
IDLE_GAIT = GaitParams(
    speed=(0.0, 0.0), step_ratio=(0.0, 0.0), duty=1.0, over_foot=0.5, half_width=0.09,
    swing_height=(0.0, 0.0), heel_off=(0.0, 0.0), heel_off_fraction=0.0,
    arm_swing=(0.0, 0.0), elbow=(math.radians(8), math.radians(18)),
    bob=(0.0, 0.0), drop=(0.0, 0.0), lean=(0.0, math.radians(1.5)),
    sway=(0.0, 0.0), pelvis_twist=(0.0, 0.0), accel_time=0.0, spring=False,
)


# --------------------------------------------------------------------------- style

@dataclass
class GaitStyle:
    """The style of one clip, drawn from a gait's ranges by :func:`sample_style`; ``noise`` holds
    the idle drift signals (breathing, head yaw, arms) when there are any."""

    swing_height: float
    heel_off: float
    arm_swing: float
    elbow: float
    bob: float
    drop: float
    lean: float
    sway: float
    pelvis_twist: float
    shoulder_twist: float
    head_pitch: float
    toe_up: float
    noise: dict = field(default_factory=dict)


def sample_style(rng: np.random.Generator, params: GaitParams) -> GaitStyle:
    """Draw a clip's style from the ranges of ``params``."""
    u = lambda r: float(rng.uniform(*r))  # noqa: E731
    twist = u(params.pelvis_twist)
    return GaitStyle(
        swing_height=u(params.swing_height), heel_off=u(params.heel_off), arm_swing=u(params.arm_swing),
        elbow=u(params.elbow), bob=u(params.bob), drop=u(params.drop), lean=u(params.lean), sway=u(params.sway),
        pelvis_twist=twist, shoulder_twist=twist * rng.uniform(0.8, 1.3),
        head_pitch=float(rng.uniform(math.radians(2), math.radians(8))),
        toe_up=math.radians(6.0) if params.swing_height[1] > 0 else 0.0,
    )
