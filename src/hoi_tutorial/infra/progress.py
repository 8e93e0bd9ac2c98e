"""Progress a reader can see: training's progress bars, on where a person watches, and carried back from
``warm_cache``'s worker processes.

Where bars show (:func:`progress_enabled`):

- ``HOI_PROGRESS=1`` / ``0`` in the environment turns them on or off everywhere (CI, ``make book`` and
  ``make test`` set ``0``: a stored page shows results, not bars);
- otherwise they are on in a Jupyter kernel (a reader in Colab or JupyterLab) and off in scripts and tests;
- :func:`show_progress` overrides both for this process (and the workers it starts), and an explicit
  ``progress=True`` of a training call always shows its bar.

A worker's output reaches the terminal that started the kernel, never the notebook. So a build running in a
``warm_cache`` worker sends its bar's state (``desc``, steps done, steps in all, the last loss) through a queue,
and a thread of the notebook's process draws it there (:func:`progress_bar` in the worker, :class:`BarListener`
here); the build's printed lines still come back as text when it ends.
"""
from __future__ import annotations

import importlib.util
import os
import queue as queue_module
import sys
import threading
import time
from typing import Iterable, Optional

__all__ = ["show_progress", "progress_enabled", "progress_bar", "BarListener", "set_worker_sink"]

_ENV = "HOI_PROGRESS"
_override: Optional[bool] = None  # show_progress's choice for this process
_sink = None  # a worker's queue to the notebook's process (set by warm_cache's worker initialiser)
SEND_EVERY = 0.5  # seconds between two updates a worker sends


def show_progress(on: Optional[bool] = True) -> None:
    """Turn progress bars on (``True``) or off (``False``) for this process and the workers it starts; ``None``
    goes back to the default (:func:`progress_enabled`)."""
    global _override
    if on is not None and not isinstance(on, bool):
        raise ValueError(f"on: expected True, False or None, got {on!r}")
    _override = on


def _in_kernel() -> bool:
    """Whether this is a Jupyter kernel's process (ipykernel's shell, or a subclass of it such as Colab's)."""
    ipython, zmqshell = sys.modules.get("IPython"), sys.modules.get("ipykernel.zmqshell")
    if ipython is None or zmqshell is None:
        return False
    return isinstance(ipython.get_ipython(), zmqshell.ZMQInteractiveShell)


def _tqdm(*args, **kwargs):
    """tqdm's notebook bar where ipywidgets is installed (Colab has it), its text bar otherwise (imported here:
    ``tqdm.auto`` warns on import in a kernel that lacks ipywidgets)."""
    if _in_kernel() and importlib.util.find_spec("ipywidgets") is None:
        from tqdm.std import tqdm

        kwargs["position"] = 0  # one line: a notebook's text output does not move the cursor between bars
    else:
        from tqdm.auto import tqdm
    return tqdm(*args, **kwargs)


def progress_enabled() -> bool:
    """Whether training shows progress bars here: :func:`show_progress`'s choice, else ``HOI_PROGRESS``
    (``1``/``true``/``on`` or ``0``/``false``/``off``), else whether this is a Jupyter kernel."""
    if _override is not None:
        return _override
    value = os.environ.get(_ENV, "").strip().lower()
    if value in ("1", "true", "on", "yes"):
        return True
    if value in ("0", "false", "off", "no"):
        return False
    if value:
        raise ValueError(f"{_ENV}: expected 1 or 0 (true/false, on/off), got {os.environ[_ENV]!r}")
    return _in_kernel()


class _SentBar:
    """A worker's bar: iterates like tqdm and sends its state to the notebook's process."""

    def __init__(self, iterable, total: int, desc: str, sink):
        self.iterable, self.total, self.desc, self.sink = iterable, total, desc, sink
        self.key = (os.getpid(), id(self), desc)
        self.n, self.postfix, self._sent = 0, "", 0.0

    def _send(self, closed: bool = False):
        self._sent = time.monotonic()
        try:
            self.sink.put_nowait((self.key, self.desc, self.n, self.total, self.postfix, closed))
        except (queue_module.Full, OSError, ValueError):  # a closed or full queue: progress is best effort
            pass

    def __iter__(self):
        self._send()
        for item in self.iterable:
            yield item
            self.n += 1
            if time.monotonic() - self._sent >= SEND_EVERY:
                self._send()

    def set_postfix(self, **values):
        self.postfix = ", ".join(f"{k}={v}" for k, v in values.items())

    def close(self):
        self._send(closed=True)


def progress_bar(iterable: Iterable, total: int, desc: str, enabled: Optional[bool] = None):
    """A progress bar over ``iterable`` (``total`` items): tqdm's here, one drawn in the notebook's process when this
    is a ``warm_cache`` worker. ``enabled`` None: :func:`progress_enabled`; ``True``: always; ``False``: never."""
    show = progress_enabled() if enabled is None else enabled
    if show and _sink is not None:
        return _SentBar(iterable, total, desc, _sink)
    return _tqdm(iterable, total=total, disable=not show, leave=False, desc=desc)


def set_worker_sink(sink, enabled: Optional[bool]) -> None:
    """In a worker: send bars to ``sink``, and show them where the notebook's process does."""
    global _sink, _override
    _sink, _override = sink, enabled


class BarListener:
    """A thread of the notebook's process that draws the bars its workers send (a context manager).

    Args:
        sink: the queue the workers put ``(key, desc, n, total, postfix, closed)`` on.
    """

    def __init__(self, sink):
        self.sink = sink
        self.bars: dict = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._listen, daemon=True)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        for bar in self.bars.values():
            bar.close()
        self.bars.clear()

    def _draw(self, key, desc, n, total, postfix, closed):
        bar = self.bars.get(key)
        if bar is None:
            bar = self.bars[key] = _tqdm(total=total, desc=f"[worker] {desc}", leave=False)
        bar.update(n - bar.n)
        if postfix:
            bar.set_postfix_str(postfix, refresh=False)
        bar.refresh()
        if closed:
            bar.close()
            del self.bars[key]

    def _listen(self):
        while True:
            try:
                message = self.sink.get(timeout=0.1)
            except queue_module.Empty:
                if self._stop.is_set():
                    return
                continue
            except (OSError, EOFError, ValueError):  # the queue went away with its pool
                return
            self._draw(*message)
