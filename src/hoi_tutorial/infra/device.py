"""Device choice: the GPU when there is one, the CPU otherwise, and clear errors in between."""
from __future__ import annotations

import contextlib
import functools
import re

import torch

__all__ = ["choose_device", "one_thread", "single_threaded", "threads_allowed"]

# Set by threads_allowed: while > 1, one_thread leaves the pool as the caller set it.
_ALLOWED_THREADS = 1

_PATTERN = re.compile(r"^(auto|cpu|mps|cuda(:\d+)?)$")


def _mps_available() -> bool:
    backend = getattr(torch.backends, "mps", None)
    return bool(backend is not None and backend.is_available())


def choose_device(device="auto") -> torch.device:
    """Turn ``"auto"``, ``"cpu"``, ``"cuda"``, ``"cuda:N"`` or ``"mps"`` into a ``torch.device``.

    ``"auto"`` picks CUDA when it is available, else the CPU (MPS is used only when asked
    for: some of its kernels are not deterministic). A ``torch.device`` is accepted as well.

    Raises:
        ValueError: for a string that names no device.
        RuntimeError: when the requested device is not available on this machine.
    """
    if isinstance(device, torch.device):
        device = str(device)
    if not isinstance(device, str) or not _PATTERN.match(device.strip().lower()):
        raise ValueError(
            f"device: expected 'auto', 'cpu', 'cuda', 'cuda:N' or 'mps', got {device!r}"
        )
    device = device.strip().lower()
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if device.startswith("cuda"):
        if not torch.cuda.is_available():
            raise RuntimeError(
                f"device {device!r} was requested but CUDA is not available on this machine; "
                "use device='auto' (falls back to the CPU) or device='cpu'"
            )
        index = int(device.split(":")[1]) if ":" in device else None
        if index is not None and index >= torch.cuda.device_count():
            raise RuntimeError(
                f"device {device!r} was requested but this machine has "
                f"{torch.cuda.device_count()} CUDA device(s); use 'cuda:0' or device='auto'"
            )
    if device == "mps" and not _mps_available():
        raise RuntimeError(
            "device 'mps' was requested but MPS is not available on this machine; "
            "use device='auto' or device='cpu'"
        )
    return torch.device(device)


@contextlib.contextmanager
def one_thread():
    """Run torch on one CPU thread inside the block, restoring the pool size after.

    Workloads made of many small ops (forward kinematics over a few hundred frames, small MLPs,
    autoregressive rollouts) gain nothing from a second thread, and on a busy two-core machine a
    two-thread pool makes them several times slower; one thread never does.
    """
    threads = torch.get_num_threads()
    if _ALLOWED_THREADS > 1:  # inside threads_allowed: the caller owns the cores
        yield
        return
    if threads > 1:
        torch.set_num_threads(1)
    try:
        yield
    finally:
        if threads > 1:
            torch.set_num_threads(threads)


@contextlib.contextmanager
def threads_allowed(n: int):
    """Let the library's one-thread sections use ``n`` torch threads inside the block.

    The library samples and rolls out on one thread because its builds often run two at a time,
    one per core (:func:`~hoi_tutorial.infra.warm_cache`). A caller that has the machine to
    itself, e.g. one interactive sampling call on two cores, can lend it every core::

        with threads_allowed(2):
            guidance.guided_samples(...)

    Raises:
        ValueError: unless ``n`` is a positive int.
    """
    global _ALLOWED_THREADS
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        raise ValueError(f"n: expected a positive int (torch threads), got {n!r}")
    allowed, threads = _ALLOWED_THREADS, torch.get_num_threads()
    _ALLOWED_THREADS = n
    torch.set_num_threads(n)
    try:
        yield
    finally:
        _ALLOWED_THREADS = allowed
        torch.set_num_threads(threads)


def single_threaded(function):
    """Decorator: run ``function`` inside :func:`one_thread`."""
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with one_thread():
            return function(*args, **kwargs)
    return wrapper
