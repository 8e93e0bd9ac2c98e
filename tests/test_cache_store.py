"""The artifact cache never loses work: a failed store keeps the build, one build per artifact across processes, the
leftovers of killed builds removed."""
from __future__ import annotations

import errno
import multiprocessing
import os
import time
import warnings
from pathlib import Path

import pytest
import torch

from hoi_tutorial.infra import CacheStoreWarning, NotCachedError, cache_only, clear_cache, load_or_build
from hoi_tutorial.infra import cache as cache_module
from hoi_tutorial.infra import cache_store
from hoi_tutorial.infra.code_closure import code_closure

try:
    import fcntl
except ImportError:  # Windows: the cache takes no locks
    fcntl = None

needs_locks = pytest.mark.skipif(fcntl is None, reason="the cache locks artifacts with fcntl.flock")


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path, monkeypatch):
    """An empty cache folder, and a process that has not yet warned about a failed store nor kept any artifact."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("HOI_CACHE", str(folder))
    monkeypatch.setattr(cache_store, "_STORE_WARNED", False)
    monkeypatch.setattr(cache_module, "_UNSTORED", {})
    return folder


def _counting(build):
    calls = []

    def wrapped():
        calls.append(1)
        return build()

    return wrapped, calls


def _files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def _store_warnings(record) -> list:
    return [w for w in record if issubclass(w.category, CacheStoreWarning)]


def test_the_caches_own_modules_import_only_each_other():
    # Left out of every key, so that mending them rebuilds nothing; a module they imported would be left out too.
    assert "hoi_tutorial.infra.cache_store" in cache_module.STORAGE_MODULES
    assert set(code_closure(cache_module.__name__)) <= cache_module.STORAGE_MODULES


# ---------------------------------------------------------------------------------- a failed store


def _partial_write_then(failure):
    def save(obj, handle, *args, **kwargs):
        handle.write(b"PK\x03\x04 a partial zip")  # torch.save fails part-way through
        raise failure

    return save


_FULL_DISK = {
    "torch.save RuntimeError": ("save", RuntimeError(
        "[enforce fail at inline_container.cc:626] . unexpected pos 64 vs 0: PytorchStreamWriter failed writing "
        "file data/0: file write failed, No space left on device")),
    "torch.save ENOSPC": ("save", OSError(errno.ENOSPC, "No space left on device")),
    "fsync EIO": ("fsync", OSError(errno.EIO, "Input/output error")),
    "os.replace EACCES": ("replace", OSError(errno.EACCES, "Permission denied")),
}


@pytest.mark.parametrize("failure", list(_FULL_DISK))
def test_a_failed_store_keeps_the_build_and_warns_once(isolated_cache, monkeypatch, capsys, failure):
    where, exc = _FULL_DISK[failure]
    if where == "save":
        monkeypatch.setattr(cache_module.torch, "save", _partial_write_then(exc))
    else:
        def fail(*args, **kwargs):
            raise exc

        monkeypatch.setattr(cache_store.os, where, fail)
    build, calls = _counting(lambda: {"w": torch.arange(5.0)})
    with pytest.warns(CacheStoreWarning) as record:
        built = load_or_build("precious", {"n": 5}, build)
    (warning,) = _store_warnings(record)
    message = str(warning.message)
    assert str(isolated_cache) in message and type(exc).__name__ in message
    assert str(exc).splitlines()[0][:60] in message
    assert warning.filename == __file__  # points at the caller of load_or_build
    assert "kept in memory" in capsys.readouterr().out
    assert torch.equal(built["w"], torch.arange(5.0))
    assert _files(isolated_cache) == []  # no partial temporary, no artifact, no lock

    # The same artifact again in this process: the kept copy, not a second build, and no second warning.
    with warnings.catch_warnings(record=True) as again:
        warnings.simplefilter("always")
        kept = load_or_build("precious", {"n": 5}, build)
        kept["w"].add_(1.0)  # a copy: what one caller changes, the next does not get
        assert torch.equal(load_or_build("precious", {"n": 5}, build, verbose=False)["w"], torch.arange(5.0))
        with cache_only():  # it counts as cached in this process
            load_or_build("precious", {"n": 5}, build, verbose=False)
        # Another artifact that fails to store is kept too, but one warning per process is all (the cause, a full
        # disk or a read-only folder, is the same for every artifact).
        build_other, other_calls = _counting(lambda: [1, 2])
        assert load_or_build("other", {}, build_other, verbose=False) == [1, 2]
        assert load_or_build("other", {}, build_other, verbose=False) == [1, 2]
    assert "[cache] kept precious" in capsys.readouterr().out
    assert len(calls) == 1 and len(other_calls) == 1 and _store_warnings(again) == []
    assert _files(isolated_cache) == []


def test_a_lock_file_that_cannot_be_created_builds_without_the_lock(isolated_cache, monkeypatch):
    def read_only(path):
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(cache_store, "_open_lock_file", read_only)
    build, calls = _counting(lambda: 7)
    with pytest.warns(CacheStoreWarning, match="could not create the lock file of locked-.*Read-only file system"):
        assert load_or_build("locked", {}, build, verbose=False) == 7
    assert [name.split("-")[0] for name in _files(isolated_cache)] == ["locked"]  # stored all the same
    assert load_or_build("locked", {}, build, verbose=False) == 7 and len(calls) == 1


def test_cache_only_never_takes_the_lock(isolated_cache, monkeypatch):
    def no_lock(*args, **kwargs):
        raise AssertionError("cache_only took the lock")

    monkeypatch.setattr(cache_module, "artifact_lock", no_lock)
    with cache_only(), pytest.raises(NotCachedError, match="unbuilt"):
        load_or_build("unbuilt", {}, lambda: 1, verbose=False)


# ---------------------------------------------------------------------------------- one build across processes


def _build_counted(counter: str, barrier, results) -> None:
    """In a spawned process: build (or load) one artifact whose build counts itself in ``counter`` and takes 1 s;
    puts the artifact, the id of the process that built it, on ``results``."""
    def build():
        with open(counter, "a") as handle:
            handle.write(f"{os.getpid()}\n")
        time.sleep(1.0)
        return os.getpid()

    barrier.wait()  # both ask at once
    results.put(load_or_build("contested", {"what": "one build for two processes"}, build, verbose=False))


@needs_locks
def test_two_processes_asking_for_one_artifact_build_it_once(isolated_cache, tmp_path):
    counter = tmp_path / "builds.txt"
    context = multiprocessing.get_context("spawn")
    barrier, results = context.Barrier(2), context.Queue()
    workers = [context.Process(target=_build_counted, args=(str(counter), barrier, results)) for _ in range(2)]
    for worker in workers:
        worker.start()
    values = [results.get(timeout=120) for _ in workers]
    for worker in workers:
        worker.join(timeout=30)
    assert [worker.exitcode for worker in workers] == [0, 0]
    builders = counter.read_text().splitlines()
    assert len(builders) == 1, builders
    assert values == [int(builders[0])] * 2
    assert [name.rsplit(".", 1)[1] for name in _files(isolated_cache)] == ["pt"]  # the lock is gone with its holder


@needs_locks
def test_a_waiting_build_loads_what_the_holder_stored(isolated_cache, capsys):
    # One process, two open lock files: a flock on one excludes the other (what a second process sees).
    build, calls = _counting(lambda: "built here")
    path = cache_module.artifact_path("waited", cache_module.artifact_key("waited", {}, (build,)))
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(cache_store.lock_path(path), os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    assert not cache_store.lock_is_free(path)

    def holder_stores_then_releases():
        torch.save({"format": cache_module.FORMAT, "key": cache_module.artifact_key("waited", {}, (build,)),
                    "payload": "stored by the holder", "checksum": cache_module._checksum("stored by the holder"),
                    "modules": {}}, path)
        os.unlink(cache_store.lock_path(path))  # as the holder releases: the file goes, then the lock
        os.close(fd)

    import threading

    timer = threading.Timer(1.0, holder_stores_then_releases)
    timer.start()
    try:
        assert load_or_build("waited", {}, build) == "stored by the holder"
    finally:
        timer.join()
    assert "waiting for another process building waited" in capsys.readouterr().out
    assert calls == [] and _files(isolated_cache) == [path.name]


# ---------------------------------------------------------------------------------- a killed build


def test_a_killed_builds_temporaries_are_removed_by_the_next_build(isolated_cache):
    build, calls = _counting(lambda: torch.ones(3))
    path = cache_module.artifact_path("interrupted", cache_module.artifact_key("interrupted", {}, (build,)))
    path.parent.mkdir(parents=True, exist_ok=True)
    stale = [path.parent / f".{path.stem}.k1ll3d_x.tmp", path.parent / f".{path.name}.unpack01.tmp"]
    someone_elses = path.parent / ".interrupted_too-0123456789abcdef.abcdefgh.tmp"
    for file in (*stale, someone_elses):
        file.write_bytes(b"half an artifact")
    load_or_build("interrupted", {}, build, verbose=False)
    assert not any(file.exists() for file in stale) and someone_elses.exists()
    assert len(calls) == 1 and path.exists()
    assert clear_cache() == 2  # the artifact and the other temporary
    assert _files(isolated_cache) == []


@needs_locks
def test_clear_cache_removes_leftover_locks_but_not_a_held_one(isolated_cache):
    load_or_build("first", {}, lambda: 1, verbose=False)
    (path,) = isolated_cache.glob("first-*.pt")
    leftover = isolated_cache / "gone-0123456789abcdef.lock"
    leftover.touch()
    cache_store.lock_path(path).touch()
    held = isolated_cache / "building-fedcba9876543210.lock"
    fd = os.open(held, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        assert clear_cache("first") == 1 and _files(isolated_cache) == sorted([leftover.name, held.name])
        assert clear_cache() == 0 and _files(isolated_cache) == [held.name]
    finally:
        os.close(fd)
