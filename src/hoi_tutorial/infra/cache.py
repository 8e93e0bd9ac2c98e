"""The artifact cache: build a data set or train a model once, reload it afterwards.

An artifact is stored under a key made from its configuration *and* the source code that
produced it, so changing either one rebuilds it instead of reusing a stale file. Comments,
docstrings and blank lines do not count (``source_digest``): they change nothing an artifact
is made of, so editing them alone rebuilds nothing. Files are written atomically (a temporary
file in the same folder, then ``os.replace``), loaded with ``torch.load(..., weights_only=True)``
(no arbitrary pickle is ever executed), and verified (key and checksum); a file that fails any
check is reported and rebuilt.

Storing never costs a build: when the file cannot be written (a full disk, a read-only folder), the artifact is
returned all the same and kept in memory until the process ends, with one :class:`CacheStoreWarning` per process.
A build holds a lock beside its file (``<name>-<key16>.lock``, by ``fcntl.flock``; none where that is missing),
so a second process that needs the same artifact waits and loads what the first stored, and what a killed build
left (``.<name>-<key16>.*.tmp``) is removed then. :func:`prune_cache` (``make prune-cache``) removes artifacts
and downloaded packs that the installed code can no longer use, and leftover temporaries and locks
(``infra.cache_store`` writes and locks the files).

The folder is ``$HOI_CACHE`` when that is set, else ``$XDG_CACHE_HOME/hoi_tutorial``, else
``~/.cache/hoi_tutorial``.

Typical use in a chapter::

    from hoi_tutorial.infra import load_or_build, state_dict_to_cpu
    from hoi_tutorial.world import mocap

    clips = load_or_build("toy_mocap", cfg, lambda: mocap.generate(cfg, seed=SEED),
                          code=(mocap,))

    model = SitModel(model_cfg)
    state = load_or_build("nifty_sit_model", (model_cfg, train_cfg),
                          lambda: state_dict_to_cpu(train_sit_model(model_cfg, train_cfg, clips)),
                          code=(hoi_tutorial.nifty, hoi_tutorial.nn))
    model.load_state_dict(state)

``code`` takes functions, classes and modules; a package stands for every ``.py`` file in
it. ``build`` is always part of ``code``, and every library module that an item of ``code`` is
defined in, or imports, transitively, counts as well (``code_closure``): an edit to a function a
builder reaches only through another module rebuilds the artifact. ``code`` then lists only what
imports cannot show. The cache's own modules (``STORAGE_MODULES``) are left out: they decide how
an artifact is stored, not what it holds, and a change to that bumps ``FORMAT``. Artifacts are nested dicts, lists
and tuples of torch tensors, numpy arrays and python scalars / strings / ``None``; what comes back is
always on the CPU and identical whether it was just built or loaded.
"""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import functools
import hashlib
import importlib
import inspect
import json
import os
import pathlib
import re
import threading
import tokenize
import time
import types
import warnings
from collections import OrderedDict
from typing import Any, Callable, Iterable

import numpy as np
import torch

from .cache_store import (PACK_FILE, STORE_FAILURES, CacheStoreWarning, artifact_lock, cache_files, describe_failure,
                          leftovers, remove_files, remove_stale_temporaries, save_atomic, warn_store_failed)
from .code_closure import code_closure, module_file
from .cleaned_source import source_digest

__all__ = [
    "CacheStoreWarning",
    "CorruptArtifactWarning",
    "NotCachedError",
    "cache_only",
    "cache_dir",
    "artifact_key",
    "module_digests",
    "derived_code",
    "DERIVED_PACKAGES",
    "STORAGE_MODULES",
    "artifact_path",
    "load_or_build",
    "clear_cache",
    "prune_cache",
    "state_dict_to_cpu",
]

FORMAT = 2  # 2: code hashed without comments, docstrings and blank lines (source_digest), the cache's own left out
_NUMPY_TAG = "__hoi_numpy__"
_NAME_PATTERN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,99}$")
_PRIMITIVES = (bool, int, float, str, bytes, type(None))


class NotCachedError(LookupError):
    """Raised by :func:`load_or_build` inside :func:`cache_only` when an artifact would be built."""


_CACHE_ONLY = threading.local()


@contextlib.contextmanager
def cache_only():
    """Inside the block, :func:`load_or_build` loads what is cached and raises
    :class:`NotCachedError` instead of building anything (used to find out which builds remain)."""
    previous = getattr(_CACHE_ONLY, "active", False)
    _CACHE_ONLY.active = True
    try:
        yield
    finally:
        _CACHE_ONLY.active = previous


class CorruptArtifactWarning(UserWarning):
    """A cached artifact could not be loaded or verified and is being rebuilt."""


# ----------------------------------------------------------------------------------------------
# where


def cache_dir() -> pathlib.Path:
    """The cache folder, created on demand (``$HOI_CACHE``, read at call time, wins)."""
    override = os.environ.get("HOI_CACHE")
    if override:
        folder = pathlib.Path(override).expanduser()
    else:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join("~", ".cache")
        folder = pathlib.Path(base).expanduser() / "hoi_tutorial"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def _check_name(name) -> str:
    if not isinstance(name, str) or not _NAME_PATTERN.match(name):
        raise ValueError(
            "name: expected an identifier-like string (letters, digits and '_', not starting "
            f"with a digit, at most 100 characters), got {name!r}"
        )
    return name


# ----------------------------------------------------------------------------------------------
# the key


def _canonical(obj, where: str):
    """``obj`` as plain JSON values (dataclasses as dicts, tuples as lists, numpy as python)."""
    if isinstance(obj, np.generic):
        return _canonical(obj.item(), where)
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return _canonical(dataclasses.asdict(obj), where)
    if isinstance(obj, dict):
        out = {}
        for key, value in obj.items():
            if not isinstance(key, str):
                raise TypeError(f"{where}: dict keys must be str, got {type(key).__name__} {key!r}")
            out[key] = _canonical(value, f"{where}[{key!r}]")
        return out
    if isinstance(obj, (list, tuple)):
        return [_canonical(value, f"{where}[{i}]") for i, value in enumerate(obj)]
    if isinstance(obj, np.ndarray):
        return {"__ndarray__": str(obj.dtype), "shape": list(obj.shape), "data": obj.tolist()}
    if isinstance(obj, torch.Tensor):
        t = obj.detach().cpu()
        return {"__tensor__": str(t.dtype), "shape": list(t.shape), "data": t.tolist()}
    raise TypeError(
        f"{where}: cannot put a {type(obj).__name__} into an artifact key; use numbers, strings, "
        "None, lists, tuples, dicts, dataclasses or numpy / torch arrays"
    )


def _code_fingerprint(code: types.CodeType) -> str:
    """Bytecode and constants of a function (when its source text cannot be found)."""
    parts = [code.co_code.hex(), repr(code.co_names), repr(code.co_varnames)]
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            parts.append(_code_fingerprint(const))
        elif isinstance(const, frozenset):
            parts.append(repr(sorted(map(repr, const))))
        else:
            parts.append(repr(const))
    return "\n".join(parts)


def _file_source(path: pathlib.Path) -> str:
    """The text of a Python file as Python reads it (its encoding line, universal newlines); a file that is not
    text in its encoding comes back one character per byte, so that its digest still follows every byte."""
    try:
        with tokenize.open(path) as handle:
            return handle.read()
    except (SyntaxError, UnicodeDecodeError):
        return path.read_bytes().decode("latin-1")


def _module_digest(module: types.ModuleType) -> str:
    """The source digest of a module's file; of every ``.py`` file (named by its relative path) for a package."""
    if hasattr(module, "__path__"):
        digests = []
        for root in sorted(set(module.__path__)):
            root_path = pathlib.Path(root)
            for file in sorted(root_path.rglob("*.py")):
                if "__pycache__" in file.parts:
                    continue
                digests.append(source_digest(_file_source(file), file.relative_to(root_path).as_posix()))
        if digests:
            return hashlib.sha256("\n".join(digests).encode()).hexdigest()
    try:
        filename = inspect.getsourcefile(module) or module.__file__
    except TypeError:
        filename = None
    if not filename or not os.path.exists(filename):
        raise TypeError(f"code: module {module.__name__!r} has no source file to hash")
    return source_digest(_file_source(pathlib.Path(filename)))


def _sha256(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def _source_digest(item) -> str:
    """The sha256 hex of an item of ``code``: of its source text without comments, docstrings and blank lines."""
    if isinstance(item, types.ModuleType):
        return _module_digest(item)
    if isinstance(item, functools.partial):
        return _source_digest(item.func)
    if isinstance(item, types.MethodType):
        return _source_digest(item.__func__)
    if isinstance(item, (types.FunctionType, type)):
        try:
            return source_digest(inspect.getsource(item))  # a method's indented text is cleaned dedented
        except (OSError, TypeError):
            pass
        # No source text (an interactive session, exec): fall back to the compiled code.
        if isinstance(item, types.FunctionType):
            return _sha256(_code_fingerprint(item.__code__))
        parts = [item.__qualname__]
        for attr, value in sorted(vars(item).items()):
            func = getattr(value, "__func__", value)
            if isinstance(func, types.FunctionType):
                parts.append(attr + "\n" + _code_fingerprint(func.__code__))
        return _sha256("\n".join(parts))
    if callable(item):
        if isinstance(item, types.BuiltinFunctionType):
            return _sha256(f"builtin:{item.__module__}.{item.__qualname__}")
        return _source_digest(type(item))
    raise TypeError(
        f"code: expected functions, classes or modules, got {type(item).__name__} {item!r}"
    )


# Packages whose code is followed through its imports (``code_closure``): the library's own.
DERIVED_PACKAGES = {__name__.split(".")[0]}
# The cache's own machinery: every builder imports it, yet it decides how an artifact is stored and keyed, not what
# the artifact holds. Left out of every key, so that mending it (a full disk, a lock) rebuilds nothing; a change to
# how artifacts are stored or keyed bumps FORMAT instead, which moves every key at once.
STORAGE_MODULES = frozenset({__name__, f"{__package__}.cache_store", f"{__package__}.code_closure",
                             f"{__package__}.cleaned_source"})


def _module_name_of(item) -> str | None:
    """The name of the module that defines ``item`` (a module: itself)."""
    if isinstance(item, types.ModuleType):
        return item.__name__
    if isinstance(item, functools.partial):
        return _module_name_of(item.func)
    if isinstance(item, types.MethodType):
        return _module_name_of(item.__func__)
    return getattr(item, "__module__", None)


def derived_code(code: Iterable) -> list[str]:
    """The library modules the items of ``code`` run: each item's defining module and every library module it
    imports, transitively (``code_closure``), sorted, less the cache's own :data:`STORAGE_MODULES`. Items defined
    outside ``DERIVED_PACKAGES`` (a notebook's cell, a test) add none: their own source text is hashed as given."""
    modules = set()
    for item in code:
        module = _module_name_of(item)
        if module and module.split(".")[0] in DERIVED_PACKAGES:
            modules.update(code_closure(module))
    return sorted(modules - STORAGE_MODULES)


def module_digests(modules: Iterable[str]) -> dict:
    """``{module: sha256 hex}`` of the installed source of each library module (its name and file text, without
    comments, docstrings and blank lines: ``source_digest``): what :func:`artifact_key` hashes for the modules an
    artifact runs, and what a pretrained pack records for each artifact so that it can tell whether the installed
    code is the code that built it."""
    digests = {}
    for module in sorted(modules):
        path = module_file(module)
        if path is None:
            raise ValueError(f"modules: {module!r} has no source file to hash")
        digests[module] = source_digest(_file_source(path), module)
    return digests


def artifact_key(name: str, config, code: Iterable = ()) -> str:
    """The sha256 hex key of an artifact: its name, configuration and producing source code.

    Args:
        name: identifier-like artifact name (``"nifty_sit_model"``).
        config: numbers, strings, ``None``, lists, tuples, dicts with str keys, dataclasses
            and small numpy / torch arrays, in any nesting; anything else is a ``TypeError``.
        code: functions, classes and modules whose source text produced the artifact (a
            package counts with all its ``.py`` files); order does not matter. The library
            modules they import, transitively, count too (:func:`derived_code`): list here only
            what imports cannot show.
    """
    _check_name(name)
    code = tuple(code)
    digests = {_source_digest(item) for item in code}
    digests.update(module_digests(derived_code(code)).values())
    digests = sorted(digests)
    document = {"format": FORMAT, "name": name, "config": _canonical(config, "config"),
                "code": digests}
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def artifact_path(name: str, key: str) -> pathlib.Path:
    """Where the artifact ``name`` with ``key`` (from :func:`artifact_key`) is stored."""
    return cache_dir() / f"{_check_name(name)}-{key[:16]}.pt"


# ----------------------------------------------------------------------------------------------
# encoding for weights_only loading


def _encode(obj, where: str):
    """Replace numpy arrays by tagged uint8 tensors; tensors go to the CPU, detached."""
    if isinstance(obj, torch.Tensor):
        t = obj.detach().cpu()
        if t.layout != torch.strided:
            raise TypeError(f"{where}: only dense tensors can be cached, got layout {t.layout}")
        if t.untyped_storage().nbytes() != t.numel() * t.element_size():
            t = t.contiguous().clone()  # a view: store its own elements, not the whole base
        return t
    if isinstance(obj, (np.ndarray, np.generic)):
        array = np.asarray(obj)
        if array.dtype.hasobject:
            raise TypeError(f"{where}: numpy arrays of python objects cannot be cached safely")
        raw = array.tobytes()
        data = torch.frombuffer(bytearray(raw), dtype=torch.uint8) if raw else torch.empty(0, dtype=torch.uint8)
        return {
            _NUMPY_TAG: FORMAT,
            "descr": np.lib.format.dtype_to_descr(array.dtype),
            "shape": list(array.shape),
            "scalar": isinstance(obj, np.generic),
            "data": data,
        }
    if isinstance(obj, _PRIMITIVES):
        return obj
    if isinstance(obj, dict):
        if _NUMPY_TAG in obj:
            raise ValueError(f"{where}: the key {_NUMPY_TAG!r} is reserved by the cache")
        out = OrderedDict() if isinstance(obj, OrderedDict) else {}
        for key, value in obj.items():
            if not isinstance(key, _PRIMITIVES):
                raise TypeError(f"{where}: dict keys must be str, int, float, bool or None, "
                                f"got {type(key).__name__}")
            out[key] = _encode(value, f"{where}[{key!r}]")
        if hasattr(obj, "_metadata"):  # a module state_dict's version information
            out._metadata = copy.deepcopy(obj._metadata)
        return out
    if type(obj) is list:
        return [_encode(value, f"{where}[{i}]") for i, value in enumerate(obj)]
    if type(obj) is tuple:
        return tuple(_encode(value, f"{where}[{i}]") for i, value in enumerate(obj))
    raise TypeError(
        f"{where}: cannot cache a {type(obj).__name__}; artifacts are dicts, lists and tuples "
        "of tensors, numpy arrays, numbers, strings and None"
    )


def _decode(obj):
    if isinstance(obj, dict):
        if _NUMPY_TAG in obj:
            dtype = np.lib.format.descr_to_dtype(obj["descr"])
            raw = obj["data"].numpy()
            array = np.frombuffer(raw.tobytes(), dtype=dtype).reshape(obj["shape"]).copy()
            return array[()] if obj["scalar"] else array
        out = OrderedDict() if isinstance(obj, OrderedDict) else {}
        for key, value in obj.items():
            out[key] = _decode(value)
        if hasattr(obj, "_metadata"):
            out._metadata = obj._metadata
        return out
    if isinstance(obj, list):
        return [_decode(value) for value in obj]
    if isinstance(obj, tuple):
        return tuple(_decode(value) for value in obj)
    return obj


def _checksum(payload) -> str:
    """sha256 over the encoded payload: structure, tensor dtypes, shapes and bytes."""
    digest = hashlib.sha256()

    def walk(obj):
        if isinstance(obj, torch.Tensor):
            digest.update(f"T{obj.dtype}{tuple(obj.shape)}".encode())
            flat = obj.contiguous().reshape(-1)
            if flat.numel():
                digest.update(flat.view(torch.uint8).numpy())
        elif isinstance(obj, dict):
            digest.update(f"D{len(obj)}".encode())
            for key, value in obj.items():
                digest.update(repr(key).encode())
                walk(value)
        elif isinstance(obj, (list, tuple)):
            digest.update(f"{'L' if isinstance(obj, list) else 'U'}{len(obj)}".encode())
            for value in obj:
                walk(value)
        else:
            digest.update(f"P{type(obj).__name__}:{obj!r}".encode())

    walk(payload)
    return digest.hexdigest()


# ----------------------------------------------------------------------------------------------
# load, save, build


def _format_bytes(size: int) -> str:
    if size >= 1e6:
        return f"{size / 1e6:.1f} MB"
    return f"{size / 1e3:.1f} kB"


def _load_verified(path: pathlib.Path, key: str):
    """Return ``(artifact, None)`` or ``(None, reason)`` when the file fails a check."""
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # truncated file, bad zip, forbidden pickle: all mean rebuild
        first_line = (str(exc).strip().splitlines() or [""])[0][:200]
        return None, f"{type(exc).__name__}: {first_line}"
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        return None, "unknown file format"
    if blob.get("key") != key:
        return None, "key mismatch"
    try:
        if _checksum(blob.get("payload")) != blob.get("checksum"):
            return None, "checksum mismatch"
        return _decode(blob["payload"]), None
    except Exception as exc:
        return None, f"{type(exc).__name__}: {exc}"


# Artifacts this process loaded, by file (path, key, inode, size, modification time): a chapter loads the same
# artifact many times (each build checks what it needs, warm_cache first checks every build), and a copy of one
# loaded before is much quicker than reading and checking the file again. A copy, so that what a caller changes
# changes nothing another caller gets; the oldest are forgotten past _LOADED_LIMIT bytes of files.
_LOADED: "OrderedDict[tuple, tuple[int, Any]]" = OrderedDict()
_LOADED_LIMIT = 512 * 2**20
_LOADED_LOCK = threading.Lock()
# Artifacts built in this process that could not be stored (a full disk, a read-only folder), by (file, key): kept,
# whatever their size, until the process ends, since the next call for one would otherwise build it again.
_UNSTORED: dict = {}
_MISSING = object()  # "not found" (an artifact may itself be None)


def _loaded_before(identity: tuple):
    with _LOADED_LOCK:
        found = _LOADED.get(identity)
        if found is None:
            return _MISSING
        _LOADED.move_to_end(identity)
    return copy.deepcopy(found[1])


def _remember_loaded(identity: tuple, size: int, artifact) -> None:
    if size > _LOADED_LIMIT:
        return
    kept = copy.deepcopy(artifact)
    with _LOADED_LOCK:
        _LOADED[identity] = (size, kept)
        while sum(n for n, _ in _LOADED.values()) > _LOADED_LIMIT:
            _LOADED.popitem(last=False)


def _kept_unstored(path: pathlib.Path, key: str):
    """A copy of the artifact this process built for ``path`` and ``key`` and could not store, else ``_MISSING``."""
    with _LOADED_LOCK:
        found = _UNSTORED.get((str(path), key), _MISSING)
    return found if found is _MISSING else copy.deepcopy(found)


def _keep_unstored(path: pathlib.Path, key: str, artifact) -> None:
    with _LOADED_LOCK:
        _UNSTORED[(str(path), key)] = artifact


def _read_stored(name: str, path: pathlib.Path, key: str, verbose: bool):
    """``(artifact, None)`` from the stored file; ``(_MISSING, None)`` when there is none, ``(_MISSING, reason)``
    when it fails a check."""
    try:
        stat = path.stat()
    except FileNotFoundError:
        return _MISSING, None
    identity = (str(path), key, stat.st_ino, stat.st_size, stat.st_mtime_ns)
    artifact = _loaded_before(identity)
    if artifact is _MISSING:
        artifact, reason = _load_verified(path, key)
        if reason is not None:
            return _MISSING, reason
        _remember_loaded(identity, stat.st_size, artifact)
    if verbose:
        print(f"[cache] loaded {name} ({_format_bytes(stat.st_size)})")
    return artifact, None


def _find(name: str, path: pathlib.Path, key: str, verbose: bool):
    """What :func:`_read_stored` gives, from the copy kept in memory first (a build this process could not store)."""
    artifact = _kept_unstored(path, key)
    if artifact is _MISSING:
        return _read_stored(name, path, key, verbose)
    if verbose:
        print(f"[cache] kept {name} (in memory: the cache could not store it)")
    return artifact, None


def _build_and_store(name: str, path: pathlib.Path, key: str, build: Callable[[], Any], code: tuple,
                     verbose: bool):
    """``build()``, stored under ``path``; kept in memory instead when it cannot be stored (warned once)."""
    if verbose:
        print(f"[cache] building {name} ...")
    start = time.perf_counter()
    payload = _encode(build(), "artifact")
    # "modules": the library code it ran, for a pretrained pack (infra.pack) to check against the installed code
    blob = {"format": FORMAT, "key": key, "payload": payload, "checksum": _checksum(payload),
            "modules": module_digests(derived_code(code))}
    try:
        size = save_atomic(blob, path)
    except STORE_FAILURES as exc:  # the build is done: losing it to a full disk would waste it, so keep it
        _keep_unstored(path, key, _decode(payload))
        warn_store_failed(path.parent, f"store {path.name}", exc, stacklevel=3)
        if verbose:
            print(f"[cache] built {name} in {time.perf_counter() - start:.1f} s, kept in memory: not stored "
                  f"({describe_failure(exc)})")
    else:
        if verbose:
            print(f"[cache] built {name} in {time.perf_counter() - start:.1f} s ({_format_bytes(size)})")
    return _decode(payload)


def load_or_build(name: str, config, build: Callable[[], Any], code: Iterable = (), *,
                  verbose: bool = True):
    """Load the artifact ``name`` for ``config`` from the cache, or ``build()`` and store it.

    A build runs holding the artifact's lock (``<name>-<key[:16]>.lock``), so that a second process asking for it
    meanwhile waits and then loads what the first stored. An artifact that cannot be stored is returned all the
    same, and kept in memory for the rest of the process (:class:`CacheStoreWarning`, once per process).

    Args:
        name: identifier-like artifact name; the file is ``<cache_dir>/<name>-<key[:16]>.pt``.
        config: everything the artifact depends on (see :func:`artifact_key`).
        build: called with no arguments when there is no valid cached copy; returns the
            artifact (nested dicts / lists / tuples of tensors, numpy arrays, numbers, strings).
        code: functions, classes and modules that produce it; ``build`` is always added.
        verbose: print one line saying whether the artifact was loaded or built.

    Returns:
        the artifact, tensors on the CPU and detached, numpy dtypes and shapes preserved.
    """
    _check_name(name)
    code = (*tuple(code), build)
    key = artifact_key(name, config, code)
    path = artifact_path(name, key)
    artifact, reason = _find(name, path, key, verbose)
    if artifact is not _MISSING:
        return artifact
    if reason is not None:
        warnings.warn(f"rebuilding corrupt artifact {path} ({reason})", CorruptArtifactWarning, stacklevel=2)
    if getattr(_CACHE_ONLY, "active", False):
        raise NotCachedError(f"artifact {name!r} is not cached (key {key[:16]})")
    waiting = (lambda: print(f"[cache] waiting for another process building {name} ...")) if verbose else None
    with artifact_lock(path, on_wait=waiting) as lock:
        if lock.failure is not None:  # a read-only folder, a full disk: build without the lock
            warn_store_failed(path.parent, f"create the lock file of {path.name}", lock.failure, stacklevel=2)
        if lock.held:
            remove_stale_temporaries(path)  # a killed build's: no other build of it can be writing one now
            # Another process (or thread) may have built it while this one waited for the lock.
            artifact, again = _find(name, path, key, verbose)
            if artifact is not _MISSING:
                return artifact
            if again is not None and reason is None:
                warnings.warn(f"rebuilding corrupt artifact {path} ({again})", CorruptArtifactWarning, stacklevel=2)
        return _build_and_store(name, path, key, build, code, verbose)


def clear_cache(name: str | None = None) -> int:
    """Delete the cached artifacts called ``name`` (all artifacts when ``None``), their temporaries and their lock
    files (but a lock a build holds now).

    Only this cache's own files are touched. Returns the number of artifact and temporary files removed.
    """
    stem = re.compile(rf"^{re.escape(_check_name(name))}-[0-9a-f]{{16}}$") if name is not None else None
    chosen = [file for file, artifact in cache_files(cache_dir()) if stem is None or stem.match(artifact.stem)]
    return sum(file.suffix != ".lock" for file in remove_files(chosen))


def _installed_digest(module: str, memo: dict) -> str | None:
    """What :func:`module_digests` gives for ``module`` in the installed library (``None``: no such module)."""
    if module not in memo:
        memo[module] = module_digests([module])[module] if module_file(module) is not None else None
    return memo[module]


def _records_modules(modules) -> bool:
    """Whether ``modules`` is what an artifact records of the code it ran: ``{module name: sha256 hex}``."""
    return isinstance(modules, dict) and all(isinstance(m, str) and isinstance(d, str) for m, d in modules.items())


def _ran_other_code(modules: dict, memo: dict) -> bool:
    """Whether ``modules`` (``{module: sha256}``, as an artifact records them) names a library module whose installed
    source differs, or that is gone: the key of an artifact that ran it hashed other source than the installed."""
    return any(_installed_digest(module, memo) != digest for module, digest in modules.items())


def _stale_artifact(path: pathlib.Path, memo: dict) -> bool:
    """Whether no key of the installed code can reach the artifact file ``path``: it cannot be read, is of another
    :data:`FORMAT`, or ran library code whose installed source differs."""
    try:
        # mmap: the tensors are mapped, not read; only the format and the modules are looked at
        blob = torch.load(path, map_location="cpu", weights_only=True, mmap=True)
    except Exception:  # truncated, not a zip, a forbidden pickle: nothing can load it
        return True
    if not isinstance(blob, dict) or blob.get("format") != FORMAT or not _records_modules(blob.get("modules")):
        return True
    return _ran_other_code(blob["modules"], memo)


def _stale_pack(path: pathlib.Path, memo: dict) -> bool:
    """Whether the downloaded pack ``path`` can serve the installed code nothing: it cannot be read, is of another
    format (``pack.read_manifest`` refuses it), or every artifact in it ran code whose installed source differs
    (what ``pack.unpack`` would refuse)."""
    # Imported by name, not by an import statement: the cache's own modules are left out of every key and import
    # only each other, and code_closure reads import statements, inside functions too.
    pack = importlib.import_module(f"{__package__}.pack")
    try:
        records = pack.read_manifest(path)["files"]
        recorded = [record["modules"] for record in records]
    except (ValueError, OSError, LookupError, TypeError):  # PackMismatchError is a ValueError
        return True
    if not all(_records_modules(modules) for modules in recorded):
        return True
    return all(_ran_other_code(modules, memo) for modules in recorded)


def prune_cache(dry_run: bool = False) -> list[pathlib.Path]:
    """Remove from the cache what the installed code can no longer use, and what killed runs left behind.

    Removed from the cache folder: artifact files (``<name>-<key16>.pt``) that cannot be read, are of another
    :data:`FORMAT`, or ran a library module whose installed source differs or is gone (the ``"modules"`` each
    records: no key of the installed code can reach them); the temporaries of killed builds
    (``.<name>-<key16>.*.tmp``); lock files (``<name>-<key16>.lock``) whose artifact is gone. The temporaries and
    lock of an artifact whose lock a build holds now are left (without ``fcntl`` no lock is seen: prune while no
    build runs). Removed from ``packs/``: downloaded packs (``<md5>-<file>.zip``, as pooch names them) that cannot
    be read, are of another pack format, or whose every artifact the installed code would refuse. An artifact is
    judged by what it records, not by its payload (one that fails its checksum is rebuilt by :func:`load_or_build`).
    Nothing else is touched: other names, other folders (the ledger's ``ledger/``).

    Args:
        dry_run: only say what would be removed.

    Returns:
        the files removed (with ``dry_run``: that would be), sorted.
    """
    folder, memo = cache_dir(), {}
    files = cache_files(folder)
    doomed = [file for file, artifact in files if file == artifact and _stale_artifact(file, memo)]
    doomed += leftovers(files, doomed)
    packs = folder / "packs"
    if packs.is_dir():
        doomed += [pack for pack in sorted(packs.iterdir())
                   if pack.is_file() and PACK_FILE.match(pack.name) and _stale_pack(pack, memo)]
    return sorted(doomed) if dry_run else remove_files(doomed)


def state_dict_to_cpu(module: torch.nn.Module) -> "OrderedDict[str, torch.Tensor]":
    """A detached CPU copy of ``module.state_dict()`` (safe to cache; training on is harmless)."""
    state = module.state_dict()
    out = OrderedDict((key, value.detach().to("cpu", copy=True)) for key, value in state.items())
    if hasattr(state, "_metadata"):
        out._metadata = copy.deepcopy(state._metadata)
    return out
