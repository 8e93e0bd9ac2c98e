"""The artifact cache never loses work: a failed store keeps the build, one build per artifact across processes, the
leftovers of killed builds removed, and what the installed code can no longer use pruned."""
from __future__ import annotations

import errno
import json
import multiprocessing
import os
import subprocess
import sys
import time
import warnings
import zipfile
from pathlib import Path

import pytest
import torch

from hoi_tutorial.infra import (CacheStoreWarning, NotCachedError, cache_only, clear_cache, load_or_build, make_pack,
                                prune_cache)
from hoi_tutorial.infra import cache as cache_module
from hoi_tutorial.infra import cache_store, seeding
from hoi_tutorial.infra.code_closure import code_closure

from helpers import counting

try:
    import fcntl
except ImportError:  # Windows: the cache takes no locks
    fcntl = None

REPO_ROOT = Path(__file__).resolve().parents[1]
needs_locks = pytest.mark.skipif(fcntl is None, reason="the cache locks artifacts with fcntl.flock")


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path, monkeypatch):
    """An empty cache folder, and a process that has not yet warned about a failed store nor kept any artifact."""
    folder = tmp_path / "cache"
    monkeypatch.setenv("HOI_CACHE", str(folder))
    monkeypatch.setattr(cache_store, "_STORE_WARNED", False)
    monkeypatch.setattr(cache_module, "_UNSTORED", {})
    return folder


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
    build, calls = counting(lambda: {"w": torch.arange(5.0)})
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
        build_other, other_calls = counting(lambda: [1, 2])
        assert load_or_build("other", {}, build_other, verbose=False) == [1, 2]
        assert load_or_build("other", {}, build_other, verbose=False) == [1, 2]
    assert "[cache] kept precious" in capsys.readouterr().out
    assert len(calls) == 1 and len(other_calls) == 1 and _store_warnings(again) == []
    assert _files(isolated_cache) == []


def test_a_lock_file_that_cannot_be_created_builds_without_the_lock(isolated_cache, monkeypatch):
    def read_only(path):
        raise OSError(errno.EROFS, "Read-only file system", str(path))

    monkeypatch.setattr(cache_store, "_open_lock_file", read_only)
    build, calls = counting(lambda: 7)
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
    build, calls = counting(lambda: "built here")
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
    build, calls = counting(lambda: torch.ones(3))
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


# ---------------------------------------------------------------------------------- pruning


def _other_code(path: Path) -> None:
    """Make the artifact file ``path`` look built by other code: every module digest it records changed, its
    payload and checksum left as they are."""
    blob = torch.load(path, weights_only=True)
    assert blob["modules"], "the artifact should record the library modules it ran"
    blob["modules"] = {module: "0" * 64 for module in blob["modules"]}
    torch.save(blob, path)


def _zeros():
    return {"v": torch.zeros(2)}


def _ones():
    return {"v": torch.ones(2)}


def _two_artifacts(folder: Path) -> tuple[Path, Path]:
    """Two artifacts that ran library code (their blobs record ``seeding``'s modules); returns their files."""
    load_or_build("current", {}, _zeros, code=(seeding,), verbose=False)
    load_or_build("outdated", {}, _ones, code=(seeding,), verbose=False)
    return next(folder.glob("current-*.pt")), next(folder.glob("outdated-*.pt"))


def test_prune_removes_artifacts_of_other_code_and_what_nothing_can_read(isolated_cache):
    current, outdated = _two_artifacts(isolated_cache)
    _other_code(outdated)
    corrupt = isolated_cache / "corrupt-00000000000000aa.pt"
    corrupt.write_bytes(b"not a zip file")
    older = isolated_cache / "older-00000000000000bb.pt"
    torch.save({"format": cache_module.FORMAT - 1, "key": "0" * 64, "payload": 1, "checksum": "", "modules": {}},
               older)
    orphan_lock = isolated_cache / "gone-00000000000000cc.lock"
    orphan_lock.touch()
    kept_lock = cache_store.lock_path(current)
    kept_lock.touch()  # a leftover, but its artifact is current: left
    stale_tmp = isolated_cache / f".{current.stem}.k1ll3d_x.tmp"
    stale_tmp.write_bytes(b"half")
    # Not the cache's names, or not its files: never touched.
    (isolated_cache / "notes.txt").write_text("keep me")
    (isolated_cache / "model-123.pt").write_bytes(b"someone else's checkpoint")
    (isolated_cache / "model-0123456789ABCDEF.pt").write_bytes(b"not a key: capitals")
    (isolated_cache / "tmp8a7sd6f").write_bytes(b"someone else's temporary")
    ledger = isolated_cache / "ledger"
    ledger.mkdir()
    (ledger / "claim.seed0.toy.json").write_text("{}")
    (ledger / "broken-0000000000000000.pt").write_bytes(b"in a folder: never looked at")
    before = _files(isolated_cache)

    expected = sorted([outdated, corrupt, older, orphan_lock, stale_tmp])
    assert prune_cache(dry_run=True) == expected
    assert _files(isolated_cache) == before  # a dry run removes nothing
    assert prune_cache() == expected
    assert _files(isolated_cache) == sorted(set(before) - {p.name for p in expected})
    assert current.exists() and kept_lock.exists() and (ledger / "claim.seed0.toy.json").exists()
    assert (ledger / "broken-0000000000000000.pt").exists()
    assert prune_cache() == []
    with cache_only():  # what was kept still loads
        assert torch.equal(load_or_build("current", {}, _zeros, code=(seeding,), verbose=False)["v"], torch.zeros(2))


@needs_locks
def test_prune_leaves_what_a_running_build_holds(isolated_cache):
    writing = isolated_cache / ".busy-00000000000000dd.0000wrtg.tmp"
    isolated_cache.mkdir(parents=True, exist_ok=True)
    writing.write_bytes(b"being written")
    lock = isolated_cache / "busy-00000000000000dd.lock"
    fd = os.open(lock, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        assert prune_cache() == [] and writing.exists() and lock.exists()
    finally:
        os.close(fd)
    assert prune_cache() == sorted([writing, lock])


def test_prune_follows_an_edit_of_the_library(isolated_cache, derived_package):
    import importlib

    root = derived_package("prunepkg", {"prunepkg/__init__.py": "",
                                        "prunepkg/maths.py": "def make():\n    return [1, 2]\n",
                                        "prunepkg/words.py": "def make():\n    return 'a'\n"})
    maths, words = importlib.import_module("prunepkg.maths"), importlib.import_module("prunepkg.words")
    load_or_build("numbers", {}, maths.make, verbose=False)
    load_or_build("letters", {}, words.make, verbose=False)
    assert prune_cache(dry_run=True) == []
    (root / "prunepkg/maths.py").write_text("def make():\n    return [1, 2, 3]\n")
    assert [p.name.split("-")[0] for p in prune_cache()] == ["numbers"]
    (root / "prunepkg/words.py").unlink()  # a module that is gone counts as changed
    assert [p.name.split("-")[0] for p in prune_cache()] == ["letters"]


def _pack_at(folder: Path, name: str, edit=None) -> Path:
    """A pack of the cache's artifacts, as pooch stores a download (``<md5>-<file name>``), its manifest edited."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{'ab' * 16}-{name}"
    manifest = make_pack(path, scale="toy", seed=0)
    if edit is not None:
        edit(manifest)
        with zipfile.ZipFile(path) as archive:
            members = {n: archive.read(n) for n in archive.namelist() if n != "manifest.json"}
        with zipfile.ZipFile(path, "w") as archive:
            archive.writestr("manifest.json", json.dumps(manifest))
            for member, data in members.items():
                archive.writestr(member, data)
    return path


def _refuse_every_artifact(manifest):
    for record in manifest["files"]:
        record["modules"] = {module: "0" * 64 for module in record["modules"]}


def test_prune_removes_downloaded_packs_the_installed_code_cannot_use(isolated_cache):
    current, outdated = _two_artifacts(isolated_cache)
    packs = isolated_cache / "packs"
    usable = _pack_at(packs, "usable.zip")
    _other_code(outdated)  # one refused artifact: the pack still serves the other
    partly = _pack_at(packs, "partly.zip")
    refused = _pack_at(packs, "refused.zip", _refuse_every_artifact)
    older = _pack_at(packs, "older.zip", lambda manifest: manifest.update(format=manifest["format"] - 1))
    damaged = packs / f"{'cd' * 16}-damaged.zip"
    damaged.write_bytes(b"PK not really")
    foreign = packs / "my-pack.zip"  # not as pooch names a download: left
    foreign.write_bytes(b"PK not really")
    pruned = prune_cache()
    assert [p for p in pruned if p.parent == packs] == sorted([refused, older, damaged])
    assert usable.exists() and partly.exists() and foreign.exists()


def test_make_prune_cache_script_prints_what_it_removes(isolated_cache):
    current, outdated = _two_artifacts(isolated_cache)
    _other_code(outdated)
    script = [sys.executable, str(REPO_ROOT / "scripts" / "prune_cache.py")]
    env = {**os.environ, "PYTHONPATH": str(REPO_ROOT / "src")}
    dry = subprocess.run([*script, "--dry-run"], env=env, capture_output=True, text=True, check=True).stdout
    assert f"would remove {outdated.name}" in dry and "would remove 1 file(s)" in dry and outdated.exists()
    done = subprocess.run(script, env=env, capture_output=True, text=True, check=True).stdout
    assert f"removed {outdated.name}" in done and not outdated.exists() and current.exists()
