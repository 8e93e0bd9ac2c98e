"""The §5.1 controller at the demo's three contacts: how far it brings the working hand, and so how far IK would
have to move the wrist to close the contact (CHOICE §6.3: IK only adjusts the keyframes to the scene and closes
the last centimetres).

The demo (``demo``) poses its body by IK and the toy world's body planner. Driving it by the controller instead
needs the controller to bring each hand near its contact first; this module measures that, on the demo's own
run:

1. **The contacts** (:data:`CONTACTS`): the door hand on the handle (the first frame of ``"grasp handle"``), the
   bottle hand on the bottle's grasp point (``"grasp bottle"``) and on the spot above the table (the end of
   ``"place"``), each with the phase that approaches it (``"reach handle"``, ``"reach bottle"``, ``"place"``).
2. **The goal** of each (Fig. 6's keyframe, as the controller takes it, §5.1): the demo's key joints over the
   2 s window about the contact frame (``runtime.clip_goal``: the keyframe IK has fitted to the scene, §6.3)
   with the PAE phase there as the matched goal phase, due when the demo reaches the contact; the working hand
   is the contact's.
3. **The start**: the demo's state where the approach begins (the body, the root history and the phase up to
   that frame), the future root on the line to the goal's root (``runtime.toward_goal``: the body is at its
   stance, so the root path is short).
4. **The rollout** (``runtime.rollout``): the three contacts in one batch, with the Kalman-filtered goal phase of
   Algorithm 1 by default, for the approach's frames plus ``wait`` seconds (Fig. 6's state machine moves on
   when the hand arrives, not at a fixed time).
5. **The IK correction**: the working wrist's closest approach to the contact within the rollout, the distance
   IK would move it there; also the distance at the frame the demo reaches the contact.

:func:`demo_controller_config` is the controller trained for the demo: its toy clips of every action of the demo
the toy capture records with a hand keyframe, reach and grasp and the cabinet door (``world.mocap``'s
``"reach_grasp"`` and ``"open_door"``); Table 4's controller learns from reaches alone, as §8.3.1's runs are
reaches. The toy capture has no clip of carrying or placing, and its walks have no hand keyframe to learn a goal
from.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import torch

from ..._validate import check_choice
from ...world.mocap.body_plan import SIDES
from ...world.motion import FPS
from ..controller import features, network, runtime
from .demo import cached_controller_measure
from .demo_types import PickAndPlace, PickAndPlaceConfig

__all__ = ["CONTACTS", "DEMO_KINDS", "demo_controller_config", "controller_reaches", "cached_controller_reaches"]

# (contact, the phase that approaches it, the phase that starts at the contact, the hand's role)
CONTACTS = (("handle", "reach handle", "grasp handle", "door"),
            ("bottle", "reach bottle", "grasp bottle", "bottle"),
            ("table", "place", "release bottle", "bottle"))
DEMO_KINDS = ("reach_grasp", "open_door")  # the demo's actions that the toy capture has with a hand keyframe


def demo_controller_config(scale: str = "toy", **overrides) -> network.ControllerConfig:
    """``network.controller_config(scale)`` trained on :data:`DEMO_KINDS` (reaches and the cabinet door; ours: the
    same network, steps and budget as Table 4's controller, twice the clips)."""
    return network.controller_config(scale, **{"kinds": DEMO_KINDS, **overrides})


@torch.no_grad()
def controller_reaches(run: PickAndPlace, model: network.ControllerNet, wait: float = 1.0,
                       variant: str = "kalman") -> dict:
    """Roll the controller out from the start of each of the demo's approaches toward its contact (the module's
    algorithm box) and measure how far the working wrist stays from the contact.

    Args:
        run: a ``demo.PickAndPlace``.
        model: a trained ``network.ControllerNet``.
        wait: seconds rolled out after the frame the demo reaches the contact, ``>= 0``.
        variant: the goal-phase source (``features.VARIANTS``; Algorithm 1's ``"kalman"`` by default).
    Returns:
        ``{contact: {"hand", "start", "due"`` (frames of the run: the approach's first, the contact's),
        ``"target"`` (3,) the contact, the demo's wrist at ``due``, world metres, ``"from_start"`` (the wrist's
        distance from it at ``start``, m), ``"at_due"`` (the controller's wrist at ``due``, m), ``"correction"``
        (its closest approach within the rollout: the distance IK would move it, m), ``"closest_frame"`` (frames
        after ``start``), ``"root_error"`` (the root's ground distance from the goal's root after the last frame,
        m), ``"wrist"`` (N, 3) the controller's working wrist, ``"joints"`` (N, 22, 3) its body``}}``.
    """
    if not isinstance(run, PickAndPlace):
        raise ValueError(f"run: expected a PickAndPlace (demo.pick_and_place), got {type(run).__name__}")
    if not isinstance(model, network.ControllerNet):
        raise ValueError(f"model: expected a network.ControllerNet, got {type(model).__name__}")
    if isinstance(wait, bool) or not isinstance(wait, (int, float)) or not wait >= 0:
        raise ValueError(f"wait: expected a number of seconds >= 0, got {wait!r}")
    check_choice(variant, features.VARIANTS, "variant")
    motion = run.motion
    rows = []
    for name, approach, contact, role in CONTACTS:
        start, due = run.phase(approach)[0], run.phase(contact)[0]
        hand = run.hands[role]
        state = runtime.initial_state(model, [motion.slice(0, start + 1)], frame=start)  # sees the run up to start
        # Fig. 6's keyframe at the contact: the demo's key joints about it, fitted to the scene by IK (§6.3)
        goal = runtime.clip_goal(model, [dataclasses.replace(motion, meta={"anchor_frame": due, "hand": hand})],
                                 frame=start)  # the contact due − start frames into the rollout
        rows.append((name, start, due, hand, runtime.toward_goal(state, goal), goal))
    state = runtime.ControllerState(*(torch.cat(parts) for parts in zip(*(r[4] for r in rows))))
    goal = runtime.KeyJointGoal(*(torch.cat(parts) for parts in zip(*(r[5] for r in rows))))
    frames = max(due - start for _, start, due, *_ in rows) + int(round(wait * FPS))
    rolled = runtime.rollout(model, state, goal, frames, variant)
    out = {}
    for b, (name, start, due, hand, _, _) in enumerate(rows):
        side = SIDES.index(hand)
        target = goal.positions[b, features.WINDOW // 2, 2 + side].numpy()
        wrist = rolled.wrist[:, b, side].numpy()  # (N, 3): step k puts the body at frame start + k + 1
        n = due - start + int(round(wait * FPS))  # this contact's frames
        distance = np.linalg.norm(wrist[:n] - target, axis=-1)
        closest = int(np.argmin(distance))
        out[name] = {"hand": hand, "start": int(start), "due": int(due), "target": target,
                     "from_start": float(np.linalg.norm(motion.joints[start, features.WRIST_JOINTS[side]].numpy()
                                                        - target)),
                     "at_due": float(distance[due - start - 1]), "correction": float(distance[closest]),
                     "closest_frame": closest + 1,
                     "root_error": float(np.linalg.norm(rolled.origin[n - 1, b, :2].numpy()
                                                        - goal.positions[b, features.WINDOW // 2, 0, :2].numpy())),
                     "wrist": wrist[:n], "joints": rolled.joints[:n, b].numpy()}
    return out


def cached_controller_reaches(seed: int, config: PickAndPlaceConfig, controller: network.ControllerConfig,
                              wait: float = 1.0, variant: str = "kalman") -> dict:
    """:func:`controller_reaches` through the artifact cache (``demo.cached_controller_measure``), for the demo of
    ``seed`` and ``config`` and the controller trained with ``controller``: rolled out once, then loaded."""
    return cached_controller_measure("choice_controller_reaches", controller_reaches, seed, config, controller,
                                     wait=wait, variant=variant)
