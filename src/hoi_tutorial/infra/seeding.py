"""Seeding: one call at the top of a notebook makes every random draw repeatable.

Library functions never read global random state; they take ``seed: int`` or a
``numpy.random.Generator`` (see :func:`rng`) or a ``torch.Generator``. :func:`seed_everything`
is for notebook code and third-party code that does read the global state (e.g. dropout).
"""
from __future__ import annotations

import operator
import os
import random
import sys

import numpy as np
import torch

__all__ = ["seed_everything", "deterministic_kernels", "rng", "check_seed"]

# numpy's legacy global seeder accepts only 32-bit seeds.
_MAX_SEED = 2**32 - 1


def check_seed(seed, name: str = "seed") -> int:
    """Return ``seed`` as a python int; raise unless it is an integer in [0, 2**32 - 1]."""
    if isinstance(seed, bool):
        raise TypeError(f"{name}: expected a non-negative int, got bool")
    try:
        value = operator.index(seed)
    except TypeError:
        raise TypeError(f"{name}: expected a non-negative int, got {type(seed).__name__}") from None
    if not 0 <= value <= _MAX_SEED:
        raise ValueError(f"{name}: expected an int in [0, {_MAX_SEED}], got {value}")
    return value


def seed_everything(seed: int) -> torch.Generator:
    """Seed python ``random``, numpy's global generator and torch (CPU and every CUDA device).

    Also asks torch for deterministic kernels (``warn_only=True``: an op without a
    deterministic version warns instead of failing). CUDA runs can still differ from CPU runs
    in the last digits. The number of CPU threads is left as it is.

    The switch is torch's own (``torch.use_deterministic_algorithms`` sets it and the compiler's
    ``torch._inductor.config.deterministic``); where the compiler is not loaded, only the kernels'
    switch is set: loading the compiler for a flag takes about a second per process, and the library
    never compiles (:func:`deterministic_kernels`).

    Returns:
        a CPU ``torch.Generator`` seeded with ``seed``, to pass to sampling functions.
    """
    seed = check_seed(seed)
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)  # also seeds every CUDA device
    # cuBLAS needs this before its first use to be deterministic; a value set by the user wins.
    os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    deterministic_kernels()
    generator = torch.Generator()
    generator.manual_seed(seed)
    return generator


def deterministic_kernels() -> None:
    """``torch.use_deterministic_algorithms(True, warn_only=True)``, without loading torch's compiler for it.

    Where ``torch._inductor`` is already loaded (or torch lacks the kernels' switch), torch's own call
    sets both switches; otherwise only the kernels' switch is set, which is all eager code reads
    (``torch.are_deterministic_algorithms_enabled()`` is True either way).
    """
    set_kernels = getattr(torch._C, "_set_deterministic_algorithms", None)
    if "torch._inductor.config" in sys.modules or set_kernels is None:
        torch.use_deterministic_algorithms(True, warn_only=True)
    else:
        set_kernels(True, warn_only=True)


def rng(seed) -> np.random.Generator:
    """A numpy ``Generator`` from ``seed`` (an int), or ``seed`` itself when it is already one.

    >>> float(rng(0).random()) == float(rng(0).random())
    True
    """
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(check_seed(seed))
