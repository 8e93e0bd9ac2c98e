"""Build independent artifacts at the same time, one per CPU core.

A chapter often needs the same pipeline for two actions (sitting and lifting), each step of it on
one thread (see :func:`~hoi_tutorial.infra.device.one_thread`). On a two-core machine the second
core is idle. :func:`warm_cache` runs such independent builds at the same time, the extra ones in
worker processes: each worker stores its artifacts in the cache and exits, and the caller then
loads them as usual. Workers are fresh interpreters (spawned, never forked from a process that
already runs torch threads), and every build seeds itself from its configuration, so the artifacts
are the ones a sequential run in one process makes.
"""
from __future__ import annotations

import collections
import concurrent.futures
import contextlib
import io
import multiprocessing
import os
import pickle
import threading
import time
from typing import Callable, Optional, Sequence

from . import progress
from .cache import NotCachedError, cache_only

__all__ = ["available_cores", "in_order", "warm_cache"]


def available_cores() -> int:
    """CPU cores this process may run on (its affinity where the system reports it)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # macOS and Windows have no affinity call
        return os.cpu_count() or 1


class in_order:  # noqa: N801 - read as a function: ``warm_cache([in_order(train, use), ...])``
    """Several builds as one call, run one after the other: for :func:`warm_cache`, where a build needs
    another's artifact (runs that use a field after the field's training).

    Without it a chapter waits until every call of one :func:`warm_cache` is done before it starts the calls
    that depend on them, so a core that finished early idles; with one ``in_order`` per chain (one per action,
    say) each core goes on with its own chain.

    Args:
        *calls: zero-argument callables (picklable, as :func:`warm_cache` asks), run in this order.
    """

    def __init__(self, *calls: Callable[[], object]):
        if not calls:
            raise ValueError("calls: expected at least one callable")
        for index, call in enumerate(calls):
            if not callable(call):
                raise TypeError(f"calls[{index}]: expected a callable, got {type(call).__name__}")
        self.calls = calls

    def __call__(self) -> None:
        for call in self.calls:
            call()

    def __repr__(self) -> str:
        return f"in_order({', '.join(_describe(call) for call in self.calls)})"


def _run(call: Callable[[], object]) -> tuple[str, float]:
    # In the worker: one torch thread; the return value stays here (only the cache matters), and what the
    # build prints goes back as text with its seconds: a worker's own output would reach the terminal that
    # started the notebook's kernel, never the notebook (its progress bars are sent on: ``progress``).
    import torch

    torch.set_num_threads(1)
    text = io.StringIO()
    start = time.perf_counter()
    with contextlib.redirect_stdout(text), contextlib.redirect_stderr(text):
        call()
    return text.getvalue(), time.perf_counter() - start


def _describe(call: Callable[[], object]) -> str:
    """A build's name for progress lines: ``module.function`` of the call (of a partial's function)."""
    if isinstance(call, in_order):
        return " then ".join(_describe(part) for part in call.calls)
    function = getattr(call, "func", call)
    name = getattr(function, "__name__", type(function).__name__)
    return f"{(function.__module__ or '').rsplit('.', 1)[-1]}.{name}"


def warm_cache(calls: Sequence[Callable[[], object]], workers: Optional[int] = None) -> None:
    """Make sure the artifacts of independent builds are cached, building the missing ones in parallel.

    Each call is first run here with :func:`~hoi_tutorial.infra.cache.cache_only`: if everything
    it needs is cached it just loads, and is done. The calls that would build something run in
    parallel, at most ``workers`` at a time: this process and ``workers - 1`` worker processes (a
    fresh interpreter each) take the next missing call from one queue whenever they are free. Each
    runs torch on one thread while they build in parallel (this process too), so the cores are not
    oversubscribed and a build's numbers do not depend on which process ran it.

    Args:
        calls: zero-argument callables that build (or load) cached artifacts, e.g.
            ``functools.partial(data.synthesize, config)``. They must be picklable: module-level
            functions and partials of them, with picklable arguments. Their return values are
            discarded; call them again afterwards to load what they cached.
        workers: builds at once (default: the available cores). With one, the calls that build
            run here, one after the other.

    Calls must not depend on each other's artifacts (build shared ones first), and must not
    build the same artifact (two workers would both build it).

    Raises:
        TypeError: when ``calls`` holds something that is not callable or cannot be pickled.
        Whatever a call raises, re-raised here.
    """
    calls = list(calls)
    for index, call in enumerate(calls):
        if not callable(call):
            raise TypeError(f"calls[{index}]: expected a callable, got {type(call).__name__}")
    if workers is None:
        workers = available_cores()
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers: expected a positive int, got {workers!r}")
    missing = []
    for call in calls:
        try:
            with cache_only():
                call()
        except NotCachedError:
            missing.append(call)
    if workers == 1 or len(missing) <= 1:
        for call in missing:
            call()
        return
    for call in missing:
        try:
            pickle.dumps(call)
        except Exception as exc:  # noqa: BLE001 - any pickling failure means the same thing
            raise TypeError(f"calls: expected picklable callables (module-level functions or "
                            f"functools.partial of them), got {call!r}: {exc}") from exc
    # A shared queue: this process and each worker slot take the next build as soon as they are
    # free, so a long build on one core never leaves the other waiting with work still queued.
    pending = collections.deque(missing)
    lock = threading.Lock()
    errors: list = []

    def next_call():
        with lock:
            return pending.popleft() if pending and not errors else None

    def feed(pool):
        # One thread per worker slot: hand the worker the next build, wait for it, repeat.
        while (call := next_call()) is not None:
            print(f"[worker] {_describe(call)} ...", flush=True)
            try:
                text, seconds = pool.submit(_run, call).result()
            except BaseException as exc:  # noqa: BLE001 - re-raised in the caller below
                with lock:
                    errors.append(exc)
                continue
            with lock:  # one build's lines together
                if text.strip():
                    print(text.rstrip("\n"))
                print(f"[worker] {_describe(call)} done in {seconds:.1f} s", flush=True)

    import torch

    # "spawn": a fresh interpreter, never a fork of a process that already runs torch threads.
    context = multiprocessing.get_context("spawn")
    # where this process shows progress, the workers send their bars here, and a thread draws them
    shown = progress.progress_enabled()
    sink = context.Queue() if shown else None
    listener = progress.BarListener(sink) if shown else contextlib.nullcontext()
    with concurrent.futures.ProcessPoolExecutor(max_workers=workers - 1, mp_context=context,
                                                initializer=progress.set_worker_sink,
                                                initargs=(sink, shown)) as pool, listener:
        feeders = [threading.Thread(target=feed, args=(pool,), daemon=True) for _ in range(workers - 1)]
        for thread in feeders:
            thread.start()
        threads = torch.get_num_threads()
        torch.set_num_threads(1)  # this process is one of the workers: one core each, and a build's numbers
        try:                      # do not depend on which process ran it
            while (call := next_call()) is not None:
                call()
        except BaseException as exc:
            with lock:
                errors.insert(0, exc)
        finally:
            torch.set_num_threads(threads)
        for thread in feeders:
            thread.join()
    if errors:
        raise errors[0]
