"""Scale presets: one switch, ``SCALE``, that every chapter and paper package reads.

``toy`` runs on a 2-core CPU in minutes (CI and Colab), ``small`` gives better numbers in an
hour on a CPU or minutes on a GPU, ``paper`` uses the papers' own hyper-parameters (a GPU and
days; recorded, never run in CI).

Each paper package builds its own configuration dataclass with :func:`by_scale`::

    @dataclass(frozen=True)
    class SitModelConfig:
        width: int
        layers: int

    def sit_model_config(scale: str) -> SitModelConfig:
        return by_scale(scale,
                        toy=SitModelConfig(width=64, layers=2),
                        small=SitModelConfig(width=256, layers=4),
                        paper=SitModelConfig(width=512, layers=8))

and :func:`preset` gives the knobs the whole book shares.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar

from .._validate import check_choice

__all__ = ["SCALES", "check_scale", "by_scale", "ScalePreset", "preset"]

SCALES = ("toy", "small", "paper")

T = TypeVar("T")


def check_scale(scale) -> str:
    """Return ``scale`` unchanged when it is one of :data:`SCALES`, else raise ``ValueError``.

    >>> check_scale("toy")
    'toy'
    """
    check_choice(scale, SCALES, "scale")
    return scale


def by_scale(scale: str, *, toy: T, small: T, paper: T) -> T:
    """Pick the value that belongs to ``scale`` (``"toy"``, ``"small"`` or ``"paper"``).

    >>> by_scale("small", toy=1, small=10, paper=100)
    10
    """
    return {"toy": toy, "small": small, "paper": paper}[check_scale(scale)]


@dataclass(frozen=True)
class ScalePreset:
    """Knobs shared by every chapter; the ``paper`` values are the papers' own.

    Attributes:
        name: the scale, one of :data:`SCALES`.
        n_mocap_clips_per_action: toy-mocap clips generated per action. The papers train on
            200K (NIFTY sit) / 110K (NIFTY lift) sequences grown from 174 / 72 anchors; ``paper``
            stands in with 400 clips per action, from which the data pipelines grow more.
        train_steps_factor: multiplier on each model's toy number of optimiser steps. NIFTY
            trains the diffusion model 600K iterations and the field 300K; ``paper`` (x100) is
            as close as a chapter's own step count gets to that.
        model_width: hidden width of transformers and MLPs (NIFTY / MDM: 512).
        model_layers: transformer layers (NIFTY / MDM: 8).
        diffusion_steps: diffusion steps K (NIFTY: K = 1000).
        max_frames: frames per motion at 30 fps (NIFTY: 150 frames, 5 s).
        eval_scenes: test scenes per action (NIFTY: 500 test scenes per action).
        batch_size: training batch size (NIFTY: 32).
    """

    name: str
    n_mocap_clips_per_action: int
    train_steps_factor: float
    model_width: int
    model_layers: int
    diffusion_steps: int
    max_frames: int
    eval_scenes: int
    batch_size: int


_PRESETS = {
    "toy": ScalePreset(
        name="toy", n_mocap_clips_per_action=6, train_steps_factor=1.0, model_width=64,
        model_layers=2, diffusion_steps=100, max_frames=60, eval_scenes=16, batch_size=32,
    ),
    "small": ScalePreset(
        name="small", n_mocap_clips_per_action=40, train_steps_factor=10.0, model_width=256,
        model_layers=4, diffusion_steps=1000, max_frames=120, eval_scenes=100, batch_size=64,
    ),
    "paper": ScalePreset(
        name="paper", n_mocap_clips_per_action=400, train_steps_factor=100.0, model_width=512,
        model_layers=8, diffusion_steps=1000, max_frames=150, eval_scenes=500, batch_size=32,
    ),
}


def preset(scale: str) -> ScalePreset:
    """The shared knobs for ``scale`` (see :class:`ScalePreset` for what each one means).

    >>> preset("paper").model_width
    512
    """
    return _PRESETS[check_scale(scale)]
