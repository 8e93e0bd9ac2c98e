"""The goal features of SAMP's state (Eq. 1), computed from a trajectory and a goal.

Training (scheduled sampling with recomputed inputs, ``motionnet``) and the run-time loop
(``runtime``) both recompute ``t̃^p``, ``t̃^d``, ``g^p``, ``g^d``, ``g^a`` from the state's own
trajectory samples and the current goal, so they share this module (and a trained MotionNet's cache
key includes it).

Ground-plane vectors are handled as complex numbers ``x + iy``: turning a vector by an angle ``a``
about +Z is the product with ``e^{ia}``. A heading ``h`` (0 faces +Y) has the forward vector
``f = (−sin h, cos h) = i e^{ih}``, so the frame of a unit forward ``f`` is entered by multiplying with
``e^{−ih} = i f̄``: no angle is computed. This is the run-time step's bookkeeping, called every frame
(``scripts/bench_motionnet_step.py`` times it against the decoder).
"""
from __future__ import annotations

from typing import NamedTuple, Optional

import torch

from .._validate import as_tensor, check_shape
from .motion_data import as_complex
from ..world.features import SAMP_ACTIONS, SAMP_SAMPLE_OFFSETS, SAMP_STATE_LAYOUT, SAMP_STATE_SIZE

__all__ = ["CURRENT_SAMPLE", "GOAL_FEATURES", "goal_features", "with_goal", "correct_towards_goal", "recomputed_state", "LocalGoal", "local_goal",
           "as_complex", "entering_frame", "unit"]

_NS, _NA = len(SAMP_SAMPLE_OFFSETS), len(SAMP_ACTIONS)
CURRENT_SAMPLE = SAMP_SAMPLE_OFFSETS.index(0.0)  # the trajectory sample at the current frame


def entering_frame(forward: torch.Tensor) -> torch.Tensor:
    """``(...)`` complex factors that turn world vectors into the frames facing ``forward (...)``.

    ``forward`` is complex, of length 1 or 0 (as :func:`unit` returns it): the factor is
    ``e^{−ih} = i f̄``, which swaps the real and imaginary parts; a zero forward has heading 0, the identity.
    """
    return _I * forward.conj() + (forward == 0)


def unit(z: torch.Tensor) -> torch.Tensor:
    """``z / max(|z|, 1e-6)`` for complex ``z`` (a direction, as the features normalise it)."""
    return z / z.abs().clamp_min(1e-6)


# X's trajectory block t^p, t^d, t̃^p, t̃^d (264:320) and its goal block g^p, g^d, g^a (355:432) are contiguous
_TRAJECTORY = slice(SAMP_STATE_LAYOUT["trajectory_positions"].start, SAMP_STATE_LAYOUT["goal_trajectory_directions"].stop)
_GOAL = slice(SAMP_STATE_LAYOUT["goal_positions"].start, SAMP_STATE_LAYOUT["goal_actions"].stop)
assert _TRAJECTORY.stop - _TRAJECTORY.start == 8 * _NS and _GOAL.stop - _GOAL.start == _NS * (3 + 3 + _NA)
assert SAMP_STATE_LAYOUT["trajectory_actions"] == slice(_TRAJECTORY.stop, _GOAL.start)

GOAL_FEATURES = ("goal_trajectory_positions", "goal_trajectory_directions", "goal_positions", "goal_directions",
                  "goal_actions")

# the future samples (after the current one) and their share k / 4 of the way to the goal-frame prediction
_FUTURE = (torch.arange(_NS) > CURRENT_SAMPLE).float()
_FUTURE_SHARE = (torch.arange(_NS) - CURRENT_SAMPLE).clamp_min(0).float() / (_NS - CURRENT_SAMPLE)
_ONE_HOT = torch.eye(_NA)
_I = torch.tensor(1j, dtype=torch.complex64)
# below this weight (reached beyond ~0.9 m from the goal) the correction moves a sample by less than
# float32 resolves, so it is skipped
_NEGLIGIBLE = 1e-9


class LocalGoal(NamedTuple):
    """A goal seen from the root, in the form the bookkeeping uses (see :func:`local_goal`).

    ``xy`` ``(B, 1)`` complex position (m); ``forward`` ``(B, 1)`` complex unit facing (or 0);
    ``height`` ``(B, 1)`` (m); ``action`` ``(B,)`` int64 index into ``SAMP_ACTIONS``.
    """

    xy: torch.Tensor
    forward: torch.Tensor
    height: torch.Tensor
    action: torch.Tensor


def local_goal(roots: torch.Tensor, xy: torch.Tensor, forward: torch.Tensor, height: torch.Tensor,
               action: torch.Tensor) -> LocalGoal:
    """A world goal seen from ``roots (B, 3)`` ``(x, y, heading)``: ``xy (B,)`` complex, ``forward (B,)``
    complex unit, ``height (B, 1)``, ``action (B,)``."""
    turn = torch.polar(torch.ones_like(roots[:, 2:]), -roots[:, 2:])  # e^{−ih}, (B, 1)
    return LocalGoal((xy[:, None] - as_complex(roots[:, :2])[:, None]) * turn, forward[:, None] * turn, height, action)


def _world_goal(position: torch.Tensor, direction: torch.Tensor):
    return as_complex(position[:, :2]), unit(as_complex(direction[:, :2])), position[:, 2:]


def _goal_blocks(origin, forward, goal: LocalGoal) -> list:
    """The goal features from complex ``origin, forward (B, S)`` (forward unit) and a root-frame goal:
    ``[t̃^p (B, 14), t̃^d (B, 14), g^p (B, 21), g^d (B, 21), g^a (B, 35)]``, in the state's order."""
    B, dtype = origin.shape[0], goal.height.dtype
    into_goal, into_sample = entering_frame(goal.forward), entering_frame(forward)
    in_goal = torch.view_as_real(torch.stack([origin - goal.xy, forward], 1) * into_goal[:, None])  # (B, 2, S, 2)
    seen = torch.view_as_real(torch.stack([goal.xy - origin, goal.forward.expand(B, _NS)], 1) * into_sample[:, None])
    height = goal.height[:, None].expand(B, _NS, 1)
    one_hot = _ONE_HOT.to(device=origin.device, dtype=dtype)[goal.action][:, None].expand(B, _NS, _NA)
    return [in_goal[:, 0].reshape(B, -1), in_goal[:, 1].reshape(B, -1),
            torch.cat([seen[:, 0], height], -1).reshape(B, -1),  # g^p: (x, y, goal height) per sample
            torch.cat([seen[:, 1], torch.zeros_like(height)], -1).reshape(B, -1),  # g^d: (x, y, 0)
            one_hot.reshape(B, -1)]


def goal_features(trajectory_positions: torch.Tensor, trajectory_directions: torch.Tensor,
                  goal_position: torch.Tensor, goal_direction: torch.Tensor, goal_action: torch.Tensor) -> dict:
    """The goal features of Eq. 1 from a trajectory and a goal, all in the current root frame.

    The same quantities as ``world.features.samp_pose_state`` computes from a whole clip, here from
    the state's own trajectory samples (what the run-time loop has).

    Args:
        trajectory_positions: ``(B, 14)`` ``t^p``, the 7 samples' ground positions (x, y).
        trajectory_directions: ``(B, 14)`` ``t^d``, their forward directions (normalised here).
        goal_position: ``(B, 3)`` the goal in the root frame (m).
        goal_direction: ``(B, 3)`` its facing in the root frame (the ground-plane part is used).
        goal_action: ``(B,)`` int64 index into ``SAMP_ACTIONS``.
    Returns:
        dict of ``goal_trajectory_positions (B, 14)``, ``goal_trajectory_directions (B, 14)``,
        ``goal_positions (B, 21)``, ``goal_directions (B, 21)``, ``goal_actions (B, 35)``.
    """
    B = trajectory_positions.shape[0]
    check_shape(trajectory_positions, (B, 2 * _NS), "trajectory_positions")
    check_shape(trajectory_directions, (B, 2 * _NS), "trajectory_directions")
    check_shape(goal_position, (B, 3), "goal_position")
    check_shape(goal_direction, (B, 3), "goal_direction")
    origin = as_complex(trajectory_positions.reshape(B, _NS, 2))
    forward = unit(as_complex(trajectory_directions.reshape(B, _NS, 2)))
    xy, goal_forward, height = _world_goal(goal_position.to(trajectory_positions.dtype),
                                           goal_direction.to(trajectory_positions.dtype))
    goal = LocalGoal(xy[:, None], goal_forward[:, None], height, as_tensor(goal_action, "goal_action").long())
    blocks = _goal_blocks(origin, forward, goal)
    return dict(zip(GOAL_FEATURES, blocks))


def recomputed_state(states: torch.Tensor, goal: Optional[LocalGoal] = None, correct_towards: Optional[LocalGoal] = None,
                     sharpness: float = 100.0) -> torch.Tensor:
    """``states (B, 437)`` with their trajectory corrected near a goal and/or their goal features recomputed.

    The run-time loop's bookkeeping in one pass over the state (no checks; the public functions
    :func:`with_goal` and :func:`correct_towards_goal` check their inputs and call this).

    Args:
        goal: the goal (:class:`LocalGoal`, root frame) whose features ``t̃^p, t̃^d, g^p, g^d, g^a``
            are recomputed (None keeps them).
        correct_towards: the goal (root frame) to blend the future trajectory samples towards its
            goal-frame prediction (see :func:`correct_towards_goal`), None for no correction.
        sharpness: the correction's exponent scale (per m²).
    """
    B = states.shape[0]
    trajectory = as_complex(states[:, _TRAJECTORY].reshape(B, 4, _NS, 2))  # t^p, t^d, t̃^p, t̃^d
    positions, forwards = trajectory[:, 0], trajectory[:, 1]
    unit_forwards = None
    if correct_towards is not None:
        distance = (positions - correct_towards.xy).abs()
        # (k / 4)^(sharpness d²) on the future samples, 0 on the others
        weight = _FUTURE_SHARE.to(states.device).pow(sharpness * distance.square()) * _FUTURE.to(states.device)
        if bool(weight.max() > _NEGLIGIBLE):
            leaving_goal = entering_frame(correct_towards.forward).conj()  # e^{+i goal heading}, (B, 1)
            anchored = trajectory[:, 2:] * leaving_goal[:, None]  # t̃^p, t̃^d back in the root frame
            positions = positions + weight * (anchored[:, 0] + correct_towards.xy - positions)
            forwards = forwards + weight * (anchored[:, 1] - forwards)
        forwards = unit_forwards = unit(forwards)
    pieces = [states[:, :_TRAJECTORY.start],
              torch.view_as_real(torch.stack([positions, forwards], 1)).reshape(B, 4 * _NS)]
    if goal is None:
        pieces += [states[:, SAMP_STATE_LAYOUT["goal_trajectory_positions"].start:]]
    else:
        blocks = _goal_blocks(positions, unit(forwards) if unit_forwards is None else unit_forwards, goal)
        pieces += blocks[:2] + [states[:, _TRAJECTORY.stop:_GOAL.start]] + blocks[2:] + [states[:, _GOAL.stop:]]
    return torch.cat(pieces, -1)


def correct_towards_goal(states: torch.Tensor, roots: torch.Tensor, goal_position: torch.Tensor,
                         goal_direction: torch.Tensor, sharpness: float = 100.0) -> torch.Tensor:
    """Blend the future trajectory samples towards the network's own goal-relative prediction of them.

    SAMP's public run-time code (inherited from the Neural State Machine) reads the predicted
    trajectory twice: as ``t^p, t^d`` in the root frame and as ``t̃^p, t̃^d`` in the goal's frame.
    Close to the goal it trusts the second, which is anchored on the goal: future sample ``k``
    (``k = 1 … 3`` after the current one) moves to the goal-frame prediction with weight
    ``(k / 4)^(sharpness · d_k²)``, ``d_k`` the sample's distance to the goal (m). Far from the goal
    the weight vanishes; on the goal it is ``k / 4``.

    Args:
        states: ``(B, 437)`` predicted states (root frame of ``roots``).
        roots, goal_position, goal_direction: ``(B, 3)`` world.
        sharpness: the exponent's scale (the public code's 100 per m²).
    Returns:
        ``(B, 437)`` with ``t^p, t^d`` of the future samples corrected (``t^d`` normalised).
    """
    check_shape(states, (None, SAMP_STATE_SIZE), "states")
    B = states.shape[0]
    for value, name in ((roots, "roots"), (goal_position, "goal_position"), (goal_direction, "goal_direction")):
        check_shape(value, (B, 3), name)
    goal = local_goal(roots, *_world_goal(goal_position, goal_direction), None)
    return recomputed_state(states, correct_towards=goal, sharpness=sharpness)


def with_goal(states: torch.Tensor, roots: torch.Tensor, goal_position: torch.Tensor, goal_direction: torch.Tensor,
              goal_action: torch.Tensor) -> torch.Tensor:
    """``states (B, 437)`` with their goal features recomputed for a world goal.

    Args:
        roots: ``(B, 3)`` ``(x, y, heading)`` of the states' root frames.
        goal_position, goal_direction: ``(B, 3)`` world; goal_action: ``(B,)`` ids.
    """
    check_shape(states, (None, SAMP_STATE_SIZE), "states")
    B = states.shape[0]
    check_shape(roots, (B, 3), "roots")
    check_shape(goal_position, (B, 3), "goal_position")
    check_shape(goal_direction, (B, 3), "goal_direction")
    world = _world_goal(goal_position.to(states.dtype), goal_direction.to(states.dtype))
    return recomputed_state(states, goal=local_goal(roots, *world, as_tensor(goal_action, "goal_action").long()))
