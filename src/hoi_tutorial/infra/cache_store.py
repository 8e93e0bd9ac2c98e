"""How the artifact cache writes a file: atomically, under a lock per artifact, and never at the cost of a build.

Storing can fail where building did not: a full disk (``torch.save`` then raises ``RuntimeError``, not
``OSError``), a read-only folder, a failed ``fsync`` or ``os.replace``. An artifact may have taken minutes to
build, so :func:`~hoi_tutorial.infra.cache.load_or_build` keeps it in memory for the rest of the process and
:func:`warn_store_failed` says so once per process: a full disk fails every later store for the same reason, and
one warning is what a reader can act on.

Two processes that need the same artifact (two chapters run at once, ``make artifacts`` beside a notebook) would
both build it. :func:`artifact_lock` holds ``<name>-<key16>.lock`` beside the artifact (``fcntl.flock``): the
first process builds and stores, the second waits, then finds the stored file and loads it. Where ``fcntl`` does
not exist (Windows) there is no lock: both build, and the last atomic store wins.

The cache's own machinery (``cache.STORAGE_MODULES``): it is left out of every artifact key, so it imports nothing
of the library.
"""
from __future__ import annotations

import contextlib
import dataclasses
import os
import pathlib
import re
import shutil
import tempfile
import threading
import warnings
from typing import Callable, Iterator, Optional

import torch

try:
    import fcntl
except ImportError:  # Windows: no advisory file locks, so two processes may both build one artifact
    fcntl = None

__all__ = ["CacheStoreWarning", "LockState", "artifact_lock", "cache_files", "describe_failure", "leftovers",
           "lock_is_free", "lock_path", "remove_files", "remove_lock_file", "remove_stale_temporaries", "save_atomic",
           "temporaries_of", "warn_store_failed"]

STORE_FAILURES = (OSError, RuntimeError)  # what storing raises: OSError of any errno; torch.save's RuntimeError
# The cache's own file names: an artifact, its lock, its temporaries (save_atomic's, and a pack's unpacking's:
# ".<name>-<key16>.pt.*.tmp"), and a pack as pooch names a download ("<md5 of the URL>-<file name>").
_STEM = r"[A-Za-z_][A-Za-z0-9_]{0,99}-[0-9a-f]{16}"
_ARTIFACT_FILE = re.compile(rf"^({_STEM})\.pt$")
_LOCK_FILE = re.compile(rf"^({_STEM})\.lock$")
_TEMPORARY_FILE = re.compile(rf"^\.({_STEM})\..*\.tmp$")
PACK_FILE = re.compile(r"^[0-9a-f]{32}-[^/\\]+\.zip$")


class CacheStoreWarning(UserWarning):
    """The cache could not store an artifact or take its lock: what was built is kept in memory for this process."""


# Whether this process has warned about a failed store (one warning per process, whatever the artifact or reason).
_STORE_WARNED = False
_STORE_WARNED_LOCK = threading.Lock()


def describe_failure(exc: BaseException) -> str:
    """``"<type>: <first line of the message>"``, at most 200 characters of the message."""
    first_line = (str(exc).strip().splitlines() or [""])[0][:200]
    return f"{type(exc).__name__}: {first_line}"


def warn_store_failed(folder: pathlib.Path, what: str, exc: BaseException, stacklevel: int = 2) -> bool:
    """Warn (:class:`CacheStoreWarning`) that the cache in ``folder`` could not do ``what``, the first time in this
    process only; returns whether it warned. ``stacklevel`` is what the caller would give ``warnings.warn``."""
    global _STORE_WARNED
    with _STORE_WARNED_LOCK:
        if _STORE_WARNED:
            return False
        _STORE_WARNED = True
    try:  # torch.save's message on a full disk names no cause ("unexpected pos 960 vs 854"): the free space does
        free = f"; {shutil.disk_usage(folder).free / 1e6:.1f} MB free there"
    except OSError:
        free = ""
    warnings.warn(
        f"the artifact cache in {folder} could not {what} ({describe_failure(exc)}{free}). What is built is kept in "
        "memory until this process ends, and built again by the next one: free disk space, or set HOI_CACHE to a "
        "writable folder. Later failures in this process are not reported again.",
        CacheStoreWarning, stacklevel=stacklevel + 1)
    return True


# ----------------------------------------------------------------------------------------------
# writing


def save_atomic(blob, path: pathlib.Path) -> int:
    """Write ``blob`` with ``torch.save`` to a temporary file beside ``path``, then rename it to ``path``; returns
    the file's size in bytes. A reader sees the old file or the whole new one, never a torn one. On any failure the
    temporary file is removed and the exception re-raised (see :data:`STORE_FAILURES`)."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            torch.save(blob, handle)
            handle.flush()
            os.fsync(handle.fileno())
            size = os.fstat(handle.fileno()).st_size
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return size


def temporaries_of(artifact: pathlib.Path) -> list[pathlib.Path]:
    """The temporary files written for ``artifact`` (``<folder>/<name>-<key16>.pt``): ``.<name>-<key16>.*.tmp``,
    by :func:`save_atomic` and by a pack's unpacking (``.<name>-<key16>.pt.*.tmp``)."""
    return sorted(artifact.parent.glob(f".{artifact.stem}.*.tmp"))


def remove_stale_temporaries(artifact: pathlib.Path) -> list[pathlib.Path]:
    """Remove what a killed build of ``artifact`` left; call it holding the artifact's lock, when no other build
    can be writing one. Returns the files removed."""
    removed = []
    for tmp in temporaries_of(artifact):
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
            removed.append(tmp)
    return removed


# ----------------------------------------------------------------------------------------------
# the lock per artifact


def lock_path(artifact: pathlib.Path) -> pathlib.Path:
    """The lock file of ``artifact``: ``<name>-<key16>.lock`` beside ``<name>-<key16>.pt``."""
    return artifact.with_suffix(".lock")


@dataclasses.dataclass(frozen=True)
class LockState:
    """What :func:`artifact_lock` got: ``held`` the lock; else ``failure``, why not (``None``: no ``fcntl``)."""
    held: bool
    failure: Optional[OSError] = None


def _open_lock_file(path: pathlib.Path) -> int:
    return os.open(path, os.O_RDWR | os.O_CREAT, 0o666)


def _still_at(fd: int, path: pathlib.Path) -> bool:
    """Whether ``path`` still names the open file ``fd``: a lock file removed while a process waited on it (its
    holder removes it on release) excludes nobody who opens the path afresh."""
    try:
        there = os.stat(path)
    except FileNotFoundError:
        return False
    mine = os.fstat(fd)
    return (mine.st_dev, mine.st_ino) == (there.st_dev, there.st_ino)


def _acquire(path: pathlib.Path, blocking: bool, on_wait: Optional[Callable[[], None]] = None) -> Optional[int]:
    """The open, locked lock file ``path`` (a descriptor); ``None`` when it is held elsewhere and not
    ``blocking``. Raises ``OSError`` when the file cannot be created or locked."""
    while True:
        fd = _open_lock_file(path)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                if not blocking:
                    os.close(fd)
                    return None
                if on_wait is not None:
                    on_wait()
                    on_wait = None
                fcntl.flock(fd, fcntl.LOCK_EX)
            if _still_at(fd, path):
                return fd
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)  # locked a removed file: try again on the one at the path now


def _release(fd: int, path: pathlib.Path) -> None:
    # Removed while still held, so that no lock file stays behind; a process waiting on this file sees it gone
    # (_still_at) and locks the path afresh.
    with contextlib.suppress(OSError):
        os.unlink(path)
    os.close(fd)


@contextlib.contextmanager
def artifact_lock(artifact: pathlib.Path, on_wait: Optional[Callable[[], None]] = None) -> Iterator[LockState]:
    """Hold the lock of ``artifact`` for the block, waiting for another process (or thread) that holds it;
    ``on_wait`` is called once before waiting. Where the lock file cannot be created or locked (a read-only
    folder, a full disk) or there is no ``fcntl``, the block runs without the lock: see :class:`LockState`."""
    if fcntl is None:
        yield LockState(held=False)
        return
    path = lock_path(artifact)
    try:
        fd = _acquire(path, blocking=True, on_wait=on_wait)
    except OSError as exc:
        yield LockState(held=False, failure=exc)
        return
    try:
        yield LockState(held=True)
    finally:
        _release(fd, path)


def lock_is_free(artifact: pathlib.Path) -> bool:
    """Whether no process holds the lock of ``artifact`` now (always true without ``fcntl``); creates no file."""
    path = lock_path(artifact)
    if fcntl is None or not path.exists():
        return True
    try:
        fd = os.open(path, os.O_RDWR)
    except FileNotFoundError:
        return True
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    finally:
        os.close(fd)  # also releases the lock just taken
    return True


def remove_lock_file(path: pathlib.Path) -> bool:
    """Remove the lock file ``path`` unless a process holds it (its build goes on); returns whether it did."""
    if fcntl is None:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
            return True
        return False
    try:
        fd = _acquire(path, blocking=False)
    except OSError:
        return False
    if fd is None:
        return False
    _release(fd, path)
    return True


# ----------------------------------------------------------------------------------------------
# the cache's own files, for clearing and pruning


def cache_files(folder: pathlib.Path) -> list[tuple[pathlib.Path, pathlib.Path]]:
    """``(file, its artifact's path)`` for each artifact, temporary and lock file in ``folder``, sorted; no other
    file (other names, folders such as the ledger's) is ever listed."""
    found = []
    for file in sorted(folder.iterdir()):
        match = _ARTIFACT_FILE.match(file.name) or _LOCK_FILE.match(file.name) or _TEMPORARY_FILE.match(file.name)
        if match and file.is_file():
            found.append((file, folder / f"{match[1]}.pt"))
    return found


def leftovers(files: list[tuple[pathlib.Path, pathlib.Path]], doomed: list[pathlib.Path]) -> list[pathlib.Path]:
    """Of ``files`` (:func:`cache_files`), what killed runs left: temporaries whose artifact's lock no build holds,
    and such unheld lock files whose artifact is gone or ``doomed``."""
    found = []
    for file, artifact in files:
        if file == artifact or not lock_is_free(artifact):
            continue
        if file.suffix == ".tmp" or not artifact.exists() or artifact in doomed:
            found.append(file)
    return found


def remove_files(files: list[pathlib.Path]) -> list[pathlib.Path]:
    """Remove ``files``; a lock file only while no build holds it. Returns those removed, sorted."""
    removed = []
    for file in files:
        if file.suffix == ".lock":
            if remove_lock_file(file):
                removed.append(file)
            continue
        with contextlib.suppress(FileNotFoundError):
            file.unlink()
            removed.append(file)
    return sorted(removed)
