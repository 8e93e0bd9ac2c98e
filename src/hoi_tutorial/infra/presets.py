"""Scale presets: one switch, ``SCALE``, that every chapter and paper package reads.

``toy`` runs on a 2-core CPU in minutes (CI and Colab), ``small`` gives better numbers in an
hour on a CPU or minutes on a GPU, ``paper`` uses the papers' own hyper-parameters (a GPU and
days; recorded, never run in CI).

Every component has one frozen configuration dataclass and one factory, written the same way:
the class defaults *are* the ``toy`` preset, a module-level dict holds only what ``small`` and
``paper`` change, and the factory ``xxx_config(scale="toy", **overrides)`` (the action first
where there is one) hands both to :func:`scaled_config`::

    @dataclass(frozen=True)
    class SitModelConfig:
        width: int = 64          # toy
        layers: int = 2
        pointnet_hidden: tuple = (64, 128)   # tuples, never lists: configs are hashable cache keys
        seed: int = 0

    # What the larger scales change (SAMP / CHOICE: the paper's values go under "paper").
    SIT_MODEL_SCALES = {
        "small": {"width": 256, "layers": 4},
        "paper": {"width": 512, "layers": 8, "pointnet_hidden": (64, 128, 1024)},
    }

    def sit_model_config(scale: str = "toy", **overrides) -> SitModelConfig:
        return scaled_config(SitModelConfig, scale, SIT_MODEL_SCALES, overrides,
                             factory="sit_model_config")

    sit_model_config("paper", seed=3)   # paper sizes, seed 3
    sit_model_config("toy") == SitModelConfig()
    sit_model_config("toy", widht=8)    # TypeError: ... unknown field 'widht'; expected one of ...

A configuration that contains another one (a data set's ``prior``, say) builds the nested one
with that component's own factory for the same scale, passed in ``fixed``; a caller replaces it
by passing a whole nested configuration (``prior=prior_config("small", steps=50)``).
"""
from __future__ import annotations

import dataclasses
from typing import Any, Mapping, Optional, TypeVar

from .._validate import check_choice

__all__ = ["SCALES", "check_scale", "by_scale", "scaled_config"]

SCALES = ("toy", "small", "paper")

T = TypeVar("T")


def check_scale(scale, name: str = "scale") -> str:
    """Return ``scale`` unchanged when it is one of :data:`SCALES`, else raise ``ValueError``
    (its message starts with ``name`` and lists the scales).

    >>> check_scale("toy")
    'toy'
    """
    check_choice(scale, SCALES, name)
    return scale


def by_scale(scale: str, *, toy: T, small: T, paper: T) -> T:
    """Pick the value that belongs to ``scale`` (``"toy"``, ``"small"`` or ``"paper"``).

    For a single number in a chapter; a component's configuration uses :func:`scaled_config`.

    >>> by_scale("small", toy=1, small=10, paper=100)
    10
    """
    return {"toy": toy, "small": small, "paper": paper}[check_scale(scale)]


def _frozen(value):
    """Lists (a caller's ``pointnet_hidden=[64, 128]``) become tuples, so the config stays hashable."""
    if isinstance(value, list):
        return tuple(_frozen(v) for v in value)
    return value


def scaled_config(cls: type[T], scale: str, changes: Mapping[str, Mapping[str, Any]],
                  overrides: Mapping[str, Any], *, factory: str,
                  fixed: Optional[Mapping[str, Any]] = None) -> T:
    """The configuration ``cls`` at ``scale``: class defaults (the ``toy`` preset), then
    ``changes[scale]``, then ``fixed``, then ``overrides``.

    Args:
        cls: a (frozen) configuration dataclass whose defaults are the ``toy`` preset.
        scale: one of :data:`SCALES`.
        changes: ``{"small": {field: value}, "paper": {...}}``, only the fields that differ from
            the class defaults (a scale may be missing: nothing changes).
        overrides: the caller's ``**overrides``, field by field (lists become tuples).
        factory: the factory's name, for error messages.
        fixed: values the factory works out itself: the action, a value that depends on the
            action, nested configurations built for the same scale.
    Raises:
        ValueError: ``scale`` is not one of :data:`SCALES` (the message lists them).
        TypeError: an override names no field of ``cls`` (the message lists the fields).

    >>> @dataclasses.dataclass(frozen=True)
    ... class Demo:
    ...     width: int = 64
    ...     seed: int = 0
    >>> scaled_config(Demo, "paper", {"paper": {"width": 512}}, {"seed": 3}, factory="demo_config")
    Demo(width=512, seed=3)
    """
    check_scale(scale, f"{factory}: scale")
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    for source in (*(changes.get(s, {}) for s in SCALES), fixed or {}, overrides):
        for key in source:
            if key not in names:
                raise TypeError(f"{factory}: unknown field {key!r}; expected one of {', '.join(names)}")
    unknown_scales = [s for s in changes if s not in SCALES]
    if unknown_scales:
        raise ValueError(f"{factory}: changes for unknown scale {unknown_scales[0]!r}; expected one of {list(SCALES)}")
    values = {**changes.get(scale, {}), **(fixed or {}), **{k: _frozen(v) for k, v in overrides.items()}}
    return cls(**values)
