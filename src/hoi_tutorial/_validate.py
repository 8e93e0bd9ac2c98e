"""Input checks shared by the public functions: every failure names what was expected."""
from __future__ import annotations

from typing import Iterable, Sequence

import numpy as np
import torch

__all__ = ["check_shape", "check_choice", "as_tensor", "check_finite", "check_positive_ints", "check_numbers"]


def _fmt(shape: Sequence) -> str:
    parts = ["..." if s is Ellipsis else ("*" if s is None else str(s)) for s in shape]
    return "(" + ", ".join(parts) + ")"


def check_shape(x, shape: Sequence, name: str) -> None:
    """Raise ``ValueError`` unless ``x.shape`` matches ``shape``.

    ``shape`` is a sequence of ints, ``None`` (any size) and at most one leading ``...``
    (any number of batch dimensions), e.g. ``(..., 22, 3)``.
    """
    if not hasattr(x, "shape"):
        raise TypeError(f"{name}: expected an array or tensor of shape {_fmt(shape)}, got {type(x).__name__}")
    actual = tuple(x.shape)
    shape = tuple(shape)
    if shape and shape[0] is Ellipsis:
        tail = shape[1:]
        ok = len(actual) >= len(tail) and all(
            s is None or s == a for s, a in zip(tail, actual[len(actual) - len(tail):])
        )
    else:
        ok = len(actual) == len(shape) and all(s is None or s == a for s, a in zip(shape, actual))
    if not ok:
        raise ValueError(f"{name}: expected shape {_fmt(shape)}, got {actual}")


def check_choice(value, choices: Iterable, name: str) -> None:
    """Raise ``ValueError`` unless ``value`` is one of ``choices``."""
    choices = list(choices)
    if value not in choices:
        raise ValueError(f"{name}: expected one of {choices}, got {value!r}")


def check_finite(x, name: str) -> None:
    """Raise ``ValueError`` when ``x`` holds NaN or infinity."""
    arr = x.detach().cpu().numpy() if isinstance(x, torch.Tensor) else np.asarray(x)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite values, found NaN or inf")


def as_tensor(x, name: str, dtype=None) -> torch.Tensor:
    """Convert an array-like to a float tensor (keeps an existing tensor's device).

    A floating tensor keeps its dtype unless ``dtype`` is given; anything else becomes ``dtype``
    (default float32).
    """
    if isinstance(x, torch.Tensor):
        if dtype is None:
            return x if x.is_floating_point() else x.to(torch.float32)
        return x if x.dtype == dtype else x.to(dtype)
    dtype = dtype or torch.float32
    try:
        return torch.as_tensor(np.asarray(x), dtype=dtype)
    except Exception as exc:  # pragma: no cover - message path
        raise TypeError(f"{name}: expected an array-like of numbers, got {type(x).__name__}") from exc


def check_positive_ints(owner, names: Iterable[str]) -> None:
    """Raise ``ValueError`` naming the first of ``owner``'s attributes ``names`` that is not an int ≥ 1
    (a bool is not an int here): the shared check of the configuration dataclasses."""
    for name in names:
        value = getattr(owner, name)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ValueError(f"{name}: expected a positive int, got {value!r}")


def _range_text(above, at_least, below, at_most) -> str:
    low = f"> {above}" if above is not None else f">= {at_least}" if at_least is not None else None
    high = f"< {below}" if below is not None else f"<= {at_most}" if at_most is not None else None
    if low and high:
        left = "(" if above is not None else "["
        right = ")" if below is not None else "]"
        lo = above if above is not None else at_least
        hi = below if below is not None else at_most
        return f"a number in {left}{lo}, {hi}{right}"
    return "a finite number" + (f" {low or high}" if (low or high) else "")


def check_numbers(owner, names: Iterable[str], *, above=None, at_least=None, below=None, at_most=None,
                  allow_none: bool = False) -> None:
    """Raise ``ValueError`` naming the first of ``owner``'s attributes ``names`` that is not a finite real
    number in the range (``above`` / ``at_least`` bound it below, ``below`` / ``at_most`` above; a bool is not
    a number here); ``None`` passes where ``allow_none``. The configuration dataclasses' range check, so a
    learning rate of -1 or a dropout of 1.5 is refused where it is written, not minutes into training.
    """
    text = _range_text(above, at_least, below, at_most) + (" or None" if allow_none else "")
    for name in names:
        value = getattr(owner, name)
        if value is None and allow_none:
            continue
        ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
        ok = ok and bool(np.isfinite(value))
        ok = ok and (above is None or value > above) and (at_least is None or value >= at_least)
        ok = ok and (below is None or value < below) and (at_most is None or value <= at_most)
        if not ok:
            raise ValueError(f"{name}: expected {text}, got {value!r}")
