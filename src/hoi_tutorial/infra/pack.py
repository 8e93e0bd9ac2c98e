"""Pretrained packs: the artifacts of a whole book run, in one file, for a reader who would rather not wait.

A chapter opened alone in a fresh runtime builds everything before it (data, models, evaluations): minutes to tens of
minutes on a laptop. A *pack* holds what ``make artifacts`` built (every chapter at one scale and seed) with a
manifest: the package version, the scale and seed, and for each artifact file its size, its SHA-256 and the library
modules it ran with the SHA-256 of their source (what :func:`~hoi_tutorial.infra.cache.load_or_build` records).
:func:`unpack` copies into the cache only the artifacts whose modules are the installed ones, comments, docstrings
and blank lines aside (``cache.module_digests``), so a pack never stands in for code it was not built from: a pack
built before a library edit is refused for what the edit touches, and refused as a whole when that is everything.

A pack is untrusted input until checked, and its manifest does not vouch for itself:

- a download is checked against a SHA-256 that does not come from the pack: the caller's (``sha256=``, or a URL
  ending ``#sha256=<hex>``) or, for the installed release's own pack, :data:`RELEASED_PACKS`, the hashes the
  package ships (like pooch's ``known_hash``); a URL without one is refused before anything is downloaded, and a
  download whose hash differs is deleted. A local path needs no hash: the reader chose the file;
- the manifest (at most 16 MB) is checked against its schema (:func:`_validate_manifest`) and the zip against the
  manifest: exactly its files, each of its declared size, in all below a cap and within the cache folder's free
  space, before anything is decompressed; while extracting, a member that yields more bytes than declared (a zip
  bomb lies in its headers) or other bytes than its SHA-256 is deleted and the pack refused;
- what lands in the cache is read only by ``torch.load(..., weights_only=True)``, whose known flaws were mended in
  torch 2.6 and 2.10 (hence ``torch>=2.10``).

Typical use (a chapter's ``PRETRAINED`` parameter does this in its third cell)::

    from hoi_tutorial.infra import use_pretrained
    use_pretrained("hoi_tutorial-0.1.0-toy-seed0.zip", scale="toy", seed=0)   # a path, True, or a URL with its hash
    use_pretrained("https://example.org/hoi_tutorial-0.1.0-toy-seed0.zip#sha256=<hex>", scale="toy", seed=0)

Nothing is downloaded unless asked: ``PRETRAINED = False`` (the default, and CI's) builds everything.
"""
from __future__ import annotations

import collections
import dataclasses
import datetime
import hashlib
import json
import os
import pathlib
import re
import shutil
import tempfile
import urllib.parse
import zipfile
import zlib
from typing import Optional, Union

import torch

from . import cache as _cache
from .cache import FORMAT as CACHE_FORMAT
from .cache import cache_dir, module_digests
from .code_closure import module_file
from .presets import check_scale
from .seeding import check_seed

__all__ = ["PACK_FORMAT", "RELEASED_PACKS", "PackMismatchError", "UnpackReport", "pack_name", "release_pack_url",
           "is_development_version", "make_pack", "read_manifest", "unpack", "use_pretrained"]

PACK_FORMAT = 2  # 2: the module digests ignore comments, docstrings and blank lines (cache.FORMAT 2)
MANIFEST = "manifest.json"
# The cache's own file names (cache.artifact_path): nothing else is ever written from a pack.
_ARTIFACT_FILE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,99}-[0-9a-f]{16}\.pt$")
# Where a release's pack is published (its assets), by version, scale and seed.
RELEASE_URL = "https://github.com/hoi-tutorial/hoi_tutorial/releases/download/v{version}/{name}"
# The SHA-256 (hex) of each pack a release published, by file name (pack_name): what ``PRETRAINED = True`` checks a
# download against, as pooch's ``known_hash`` does. A release adds its packs' hashes before it is tagged
# (``python scripts/release.py --register PACK.zip``, which rewrites this literal: keep it a plain dict of strings):
# no artifact's code reaches this module, so the edit leaves the packs valid. No release has a pack yet, so
# ``True`` is refused until one does.
RELEASED_PACKS: dict = {}
# A development version (PEP 440 ``X.Y.Z.devN``, the code between two releases) has no release, hence no pack.
_DEVELOPMENT_VERSION = re.compile(r"\.dev\d+(?:\+[A-Za-z0-9.]+)?$")

# Limits on what a pack may ask of the reader's machine, checked before anything is decompressed.
_MANIFEST_MAX_BYTES = 16 << 20  # a record is a name, a size and a digest per module: 16 MB holds thousands
_PACK_MAX_BYTES = 64 << 30  # all artifacts together: about 50 times the toy pack (1.37 GB unpacked)
_SPACE_MARGIN_BYTES, _SPACE_MARGIN_SHARE = 256 << 20, 0.05  # room left free on the cache's disk after unpacking
_SHA256_HEX = re.compile(r"^[0-9a-f]{64}$")
_MODULE_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(?:\.[A-Za-z_][A-Za-z0-9_]*){0,15}$")
_MEMBER_COMPRESSION = (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED)  # what make_pack writes
_URL = re.compile(r"^https?://", flags=re.I)


class PackMismatchError(ValueError):
    """A pack that cannot serve this installation: another scale or seed, built from other code, or not what it
    should be (another SHA-256, a manifest off its schema, sizes that disagree or do not fit)."""


def _version() -> str:
    from .. import __version__
    return __version__


def pack_name(scale: str = "toy", seed: int = 0, version: Optional[str] = None) -> str:
    """The file name of a pack: ``hoi_tutorial-<version>-<scale>-seed<seed>.zip``."""
    return f"hoi_tutorial-{version or _version()}-{check_scale(scale)}-seed{check_seed(seed)}.zip"


def is_development_version(version: str) -> bool:
    """Whether ``version`` is a development version (``0.2.0.dev0``): code between releases, which no release
    published, so no release pack was built from it."""
    return bool(_DEVELOPMENT_VERSION.search(version))


def _no_release_pack(version: str, what: str) -> PackMismatchError:
    return PackMismatchError(
        f"{what}: hoi_tutorial {version} is a development version (code between releases, such as the repository's "
        "main branch), and a development version has no release pack. Set PRETRAINED to a pack's local path, or to "
        "its URL ending '#sha256=<hex>' (a pack built from this code by `make artifacts`), or install a release, or "
        "set PRETRAINED = False to build everything")


def release_pack_url(scale: str = "toy", seed: int = 0, version: Optional[str] = None) -> str:
    """Where the release ``version`` (default: the installed one) publishes its pack for ``scale`` and ``seed``.

    Raises:
        PackMismatchError: ``version`` is a development version, which has no release to publish a pack.
    """
    version = version or _version()
    if is_development_version(version):
        raise _no_release_pack(version, f"release_pack_url(version={version!r})")
    return RELEASE_URL.format(version=version, name=pack_name(scale, seed, version))


_DEFLATE_WORTH = 0.75  # deflate a file when it shrinks to at most this share of its size


def _compression(path: pathlib.Path, sample: int = 8 << 20) -> int:
    """How a file goes into a pack: deflated where that saves a quarter or more (judged on its first 8 MB), else
    stored. Most of an artifact's bytes are floats (weights, motions), which deflate shrinks by a tenth or two, and
    inflating them at every unpack would cost a reader more time than the smaller download saves."""
    with open(path, "rb") as handle:
        head = handle.read(sample)
    if not head:
        return zipfile.ZIP_STORED
    return zipfile.ZIP_DEFLATED if len(zlib.compress(head, 6)) <= _DEFLATE_WORTH * len(head) else zipfile.ZIP_STORED


def _sha256_file(path: pathlib.Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _installed_digest(module: str) -> Optional[str]:
    """What ``cache.module_digests`` gives for ``module`` in the installed library (``None``: no such module)."""
    if module_file(module) is None:
        return None
    return module_digests([module])[module]


# ----------------------------------------------------------------------------------------------
# making a pack


def make_pack(path: Union[str, os.PathLike], cache: Union[str, os.PathLike, None] = None, *, scale: str,
              seed: int, chapters: Optional[dict] = None) -> dict:
    """Pack every artifact of the cache folder ``cache`` (default: the cache) into the zip file ``path``.

    Args:
        path: the pack to write (``.zip``; replaced atomically when it exists).
        cache: the folder of a book run at one scale and seed (``make artifacts`` gives each run its own).
        scale, seed: what that run used; recorded, and checked by :func:`unpack` against the reader's.
        chapters: ``{chapter: artifact file names}``, what each chapter loaded or built in that run
            (``scripts/make_pack.py`` records it): :func:`unpack` for one chapter unpacks only its own.

    Returns:
        the manifest (also stored in the pack as ``manifest.json``): ``format``, ``package``, ``version``,
        ``scale``, ``seed``, ``torch``, ``created``, ``files`` (one record per artifact file: ``name``,
        ``bytes``, ``sha256``, ``modules`` = {library module: sha256 of its source}) and, when given,
        ``chapters``: the schema :func:`_validate_manifest` checks.

    Raises:
        FileNotFoundError: no cache folder or no artifact in it.
        ValueError: an artifact that does not record the modules it ran (built by an older library): rebuild it;
            one that ran none (built from a notebook's code alone, which :func:`unpack` could not check against
            the installed code); a chapter's file that the cache does not hold.
    """
    folder = pathlib.Path(cache) if cache is not None else cache_dir()
    if not folder.is_dir():
        raise FileNotFoundError(f"cache: expected the folder of a book run, {folder} is not a folder")
    files = sorted(p for p in folder.iterdir() if p.is_file() and _ARTIFACT_FILE.match(p.name))
    if not files:
        raise FileNotFoundError(f"cache: no artifact files (<name>-<key>.pt) in {folder}")
    records = []
    for file in files:
        blob = torch.load(file, map_location="cpu", weights_only=True)
        modules = blob.get("modules") if isinstance(blob, dict) else None
        if not isinstance(blob, dict) or blob.get("format") != CACHE_FORMAT or not isinstance(modules, dict):
            raise ValueError(f"{file.name}: expected an artifact that records the library modules it ran "
                             "(built by this library's load_or_build); rebuild it in an empty cache")
        if not modules:  # built from code outside the library (a notebook's cell): nothing to check it against
            raise ValueError(f"{file.name}: expected an artifact that records the library modules it ran, it records "
                             "none (built from code outside the library); delete it from the cache folder, or build "
                             "it with library code")
        records.append({"name": file.name, "bytes": file.stat().st_size, "sha256": _sha256_file(file),
                        "modules": dict(sorted(modules.items()))})
    manifest = {
        "format": PACK_FORMAT, "package": "hoi_tutorial", "version": _version(),
        "scale": check_scale(scale), "seed": check_seed(seed), "torch": torch.__version__,
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "files": records,
    }
    if chapters is not None:
        packed = {record["name"] for record in records}
        for chapter, names in chapters.items():
            missing = sorted(set(names) - packed)
            if not isinstance(chapter, str) or missing:
                raise ValueError(f"chapters[{chapter!r}]: expected names of the cache's artifact files; not in "
                                 f"{folder}: {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}")
        manifest["chapters"] = {chapter: sorted(set(names)) for chapter, names in sorted(chapters.items())}
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as archive:
            archive.writestr(MANIFEST, json.dumps(manifest, indent=1))
            for file in files:
                archive.write(file, arcname=file.name, compress_type=_compression(file))
        os.replace(tmp, path)
    except BaseException:
        pathlib.Path(tmp).unlink(missing_ok=True)
        raise
    return manifest


# ----------------------------------------------------------------------------------------------
# reading a pack: the manifest against its schema, then the zip against the manifest


def _shown(value, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters: a manifest's values come from whoever made the pack."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _json_type(value) -> str:
    """The JSON name of a parsed value's type, for messages."""
    names = {dict: "object", list: "array", str: "string", bool: "boolean", int: "number", float: "number"}
    return "null" if value is None else names.get(type(value), type(value).__name__)


def _is_count(value) -> bool:
    """A JSON integer >= 0 (``true`` is an int to Python, not to JSON)."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _is_text(value, limit: int = 200) -> bool:
    return isinstance(value, str) and 0 < len(value) <= limit


def _is_sha256(value) -> bool:
    return isinstance(value, str) and bool(_SHA256_HEX.match(value))


def _validate_header(manifest, where: str) -> None:
    """The manifest's top level: a JSON object of this package and format, with the run's fields."""
    if not isinstance(manifest, dict):
        raise PackMismatchError(f"{where}: expected {MANIFEST} to hold a JSON object (what make_pack writes), "
                                f"got a JSON {_json_type(manifest)}")
    package, format_ = manifest.get("package"), manifest.get("format")
    if package != "hoi_tutorial" or not _is_count(format_) or format_ != PACK_FORMAT:
        raise PackMismatchError(f"{where}: expected a hoi_tutorial pack of format {PACK_FORMAT}, got package "
                                f"{_shown(package)}, format {_shown(format_)}")
    for key in ("version", "scale", "torch", "created"):
        if not _is_text(manifest.get(key)):
            raise PackMismatchError(f"{where}: {MANIFEST}: expected '{key}' to be a non-empty string of at most 200 "
                                    f"characters, got {_shown(manifest.get(key))}")
    if not _is_count(manifest.get("seed")):
        raise PackMismatchError(f"{where}: {MANIFEST}: expected 'seed' to be an integer >= 0, got "
                                f"{_shown(manifest.get('seed'))}")
    if not isinstance(manifest.get("files"), list) or not manifest["files"]:
        raise PackMismatchError(f"{where}: {MANIFEST}: expected 'files' to be a non-empty array of artifact "
                                f"records, got {_shown(manifest.get('files'))}")


def _validate_record(record, index: int, where: str, packages: frozenset) -> str:
    """``files[index]`` of a manifest: its name, size, SHA-256 and the library modules that built it. Returns the
    name (the artifact's file name in the pack and in the cache)."""
    label = f"{where}: {MANIFEST} files[{index}]"
    if not isinstance(record, dict):
        raise PackMismatchError(f"{label}: expected a record (an object with name, bytes, sha256, modules), got a "
                                f"JSON {_json_type(record)}")
    if "name" not in record:
        raise PackMismatchError(f"{label}: expected a 'name' (the artifact's file name), the record has none")
    name = record["name"]
    if not isinstance(name, str) or not _ARTIFACT_FILE.match(name):
        raise PackMismatchError(f"{label}: 'name' {_shown(name)} is not an artifact file name (expected the "
                                "cache's '<name>-<16 hex digits>.pt': no folder, no '..', no backslash)")
    label = f"{label} ({name})"
    if not _is_count(record.get("bytes")):
        raise PackMismatchError(f"{label}: expected 'bytes' (the file's size) to be an integer >= 0, got "
                                f"{_shown(record.get('bytes'))}")
    if not _is_sha256(record.get("sha256")):
        raise PackMismatchError(f"{label}: expected 'sha256' to be 64 lowercase hex digits, got "
                                f"{_shown(record.get('sha256'))}")
    modules = record.get("modules")
    if not isinstance(modules, dict) or not modules:
        raise PackMismatchError(f"{label}: expected 'modules' to be a non-empty object {{library module: SHA-256 "
                                f"of its source}} (the code that built it, checked against the installed code), "
                                f"got {_shown(modules)}")
    for module, digest in modules.items():
        if not (isinstance(module, str) and len(module) <= 200 and _MODULE_NAME.match(module)
                and module.split(".")[0] in packages):
            raise PackMismatchError(f"{label}: expected 'modules' to name modules of {', '.join(sorted(packages))}, "
                                    f"got {_shown(module)}")
        if not _is_sha256(digest):
            raise PackMismatchError(f"{label}: expected modules[{module!r}] to be a SHA-256 digest (64 lowercase "
                                    f"hex digits), got {_shown(digest)}")
    return name


def _validate_chapters(chapters, names: set, where: str) -> None:
    """The manifest's optional ``chapters``: {chapter: [file names that ``files`` lists]}."""
    if not isinstance(chapters, dict):
        raise PackMismatchError(f"{where}: {MANIFEST}: expected 'chapters' to be an object {{chapter: [file "
                                f"names]}}, got a JSON {_json_type(chapters)}")
    for chapter, listed in chapters.items():
        if not _is_text(chapter) or not isinstance(listed, list) or not all(isinstance(n, str) for n in listed):
            raise PackMismatchError(f"{where}: {MANIFEST} chapters[{_shown(chapter)}]: expected an array of the "
                                    f"manifest's file names, got {_shown(listed)}")
        unknown = sorted(set(listed) - names)
        if unknown:
            raise PackMismatchError(f"{where}: {MANIFEST} chapters[{_shown(chapter)}]: expected file names that "
                                    f"'files' lists, got {_shown(unknown[0])}")


def _validate_manifest(manifest, where: str) -> dict:
    """``manifest`` (parsed JSON) checked against the schema of what :func:`make_pack` writes; returns it.

    The schema, as plain checks: an object with ``package`` ``"hoi_tutorial"``, ``format`` :data:`PACK_FORMAT`,
    ``version``, ``scale``, ``torch`` and ``created`` non-empty strings, ``seed`` an integer >= 0, ``files`` a
    non-empty array of records and, optionally, ``chapters`` ({chapter: [file names that ``files`` lists]}). A
    record: ``name`` one of the cache's artifact file names (``<name>-<16 hex digits>.pt``: no folder, no ``..``,
    no backslash), each once; ``bytes`` an integer >= 0; ``sha256`` 64 lowercase hex digits; ``modules`` a
    non-empty {module: 64 hex digits} of modules of the packages whose code the cache follows
    (``cache.DERIVED_PACKAGES``): checking a module imports its parent packages (``find_spec``), so a manifest
    may name only the library's own. Keys the schema does not name are ignored: nothing reads them.

    Raises:
        PackMismatchError: the first departure, naming the pack (``where``), the record and what was expected.
    """
    _validate_header(manifest, where)
    packages = frozenset(_cache.DERIVED_PACKAGES)
    names = set()
    for index, record in enumerate(manifest["files"]):
        name = _validate_record(record, index, where, packages)
        if name in names:
            raise PackMismatchError(f"{where}: {MANIFEST} files[{index}] ({name}): expected each file once, it is "
                                    "listed twice")
        names.add(name)
    if "chapters" in manifest:
        _validate_chapters(manifest["chapters"], names, where)
    return manifest


def _check_member_kind(info: zipfile.ZipInfo, label: str) -> None:
    """A member stored or deflated and not encrypted, as :func:`make_pack` writes them."""
    if info.compress_type not in _MEMBER_COMPRESSION or info.flag_bits & 0x1:
        raise PackMismatchError(f"{label}: expected a stored or deflated, unencrypted zip member (as make_pack "
                                f"writes), got compression method {info.compress_type}"
                                f"{', encrypted' if info.flag_bits & 0x1 else ''}")


def _check_members(archive: zipfile.ZipFile, manifest: dict, where: str) -> None:
    """The zip against its validated manifest, before anything is decompressed: exactly ``manifest.json`` and the
    listed files, each of its declared size (``ZipInfo.file_size``, the size the zip promises to inflate to), all
    together at most :data:`_PACK_MAX_BYTES`."""
    members = {info.filename: info for info in archive.infolist()}
    listed = {record["name"] for record in manifest["files"]}
    extra = sorted(set(members) - listed - {MANIFEST})
    if extra:
        raise PackMismatchError(f"{where}: holds {_shown(extra[0])}, which its {MANIFEST} does not list (expected "
                                f"only {MANIFEST} and the files it lists)")
    for index, record in enumerate(manifest["files"]):
        name, declared = record["name"], record["bytes"]
        label = f"{where}: {MANIFEST} files[{index}] ({name})"
        info = members.get(name)
        if info is None:
            raise PackMismatchError(f"{label}: expected the zip to hold it, it does not (an incomplete pack)")
        if info.file_size != declared:
            raise PackMismatchError(f"{label}: declares {declared} bytes, the zip's entry {info.file_size} "
                                    "(expected them equal)")
        _check_member_kind(info, label)
    total = sum(record["bytes"] for record in manifest["files"])
    if total > _PACK_MAX_BYTES:
        raise PackMismatchError(f"{where}: its files declare {total / 1e9:.1f} GB in all; expected at most "
                                f"{_PACK_MAX_BYTES / 1e9:.1f} GB")


def _open_pack(path: pathlib.Path) -> zipfile.ZipFile:
    """``path`` opened as a zip file, or a :class:`PackMismatchError` that says it is none."""
    try:
        return zipfile.ZipFile(path)
    except (FileNotFoundError, PermissionError, IsADirectoryError):
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, ValueError, OSError) as exc:
        raise PackMismatchError(f"{path}: expected a pretrained pack (a zip file with {MANIFEST}), could not read "
                                f"it ({type(exc).__name__}: {_shown(str(exc), 120)})") from None


def _manifest_of(archive: zipfile.ZipFile, where: str) -> dict:
    """The manifest of the open pack ``archive``, read within :data:`_MANIFEST_MAX_BYTES`, validated
    (:func:`_validate_manifest`) and checked against the zip's members (:func:`_check_members`)."""
    names = archive.namelist()
    if len(set(names)) != len(names):  # a reader would see one of the two, a checker perhaps the other
        twice = next(name for name, count in collections.Counter(names).items() if count > 1)
        raise PackMismatchError(f"{where}: expected each zip member once, it holds {_shown(twice)} twice")
    if MANIFEST not in names:
        raise PackMismatchError(f"{where}: expected a pretrained pack (a zip file with {MANIFEST}), it has no "
                                f"{MANIFEST}")
    info = archive.getinfo(MANIFEST)
    _check_member_kind(info, f"{where}: {MANIFEST}")
    if info.file_size > _MANIFEST_MAX_BYTES:
        raise PackMismatchError(f"{where}: {MANIFEST} declares {info.file_size} bytes; expected at most "
                                f"{_MANIFEST_MAX_BYTES} (a manifest is kilobytes)")
    try:
        with archive.open(info) as member:
            text = member.read(_MANIFEST_MAX_BYTES + 1)  # bounded whatever the header says
        manifest = json.loads(text)
    except (zipfile.BadZipFile, zlib.error, EOFError, ValueError, RecursionError) as exc:
        raise PackMismatchError(f"{where}: expected {MANIFEST} to be readable JSON, could not read it "
                                f"({type(exc).__name__}: {_shown(str(exc), 120)})") from None
    manifest = _validate_manifest(manifest, where)
    _check_members(archive, manifest, where)
    return manifest


def read_manifest(path: Union[str, os.PathLike]) -> dict:
    """The manifest of the pack file ``path``, checked against its schema (:func:`_validate_manifest`), with the
    zip checked against it (:func:`_check_members`); no artifact is decompressed.

    Raises:
        PackMismatchError: not a zip, no readable manifest, or a departure from the schema, saying what was expected.
    """
    path = pathlib.Path(path)
    with _open_pack(path) as archive:
        return _manifest_of(archive, path.name)


# ----------------------------------------------------------------------------------------------
# fetching and unpacking


@dataclasses.dataclass
class UnpackReport:
    """What :func:`unpack` did: file names unpacked, already present, and refused with the modules that differ."""
    source: str
    version: str
    unpacked: list
    present: list
    stale: dict  # file name -> modules whose installed source differs from the pack's (or is missing)
    chapter: Optional[str] = None  # the chapter whose artifacts alone were unpacked (None: every artifact)

    def summary(self) -> str:
        usable = len(self.unpacked) + len(self.present)
        which = f"the artifacts chapter {self.chapter} uses" if self.chapter else "the artifacts"
        line = (f"[pack] {usable} of {usable + len(self.stale)} of {which} in {self.source} (version "
                f"{self.version}) match the installed code: {len(self.unpacked)} unpacked, {len(self.present)} "
                "already cached")
        if self.stale:
            modules = sorted({m for ms in self.stale.values() for m in ms})
            shown = ", ".join(modules[:5]) + (f" and {len(modules) - 5} more" if len(modules) > 5 else "")
            line += (f"; {len(self.stale)} refused, built from other code ({shown}): the chapters build those "
                     "themselves")
        return line


def _normal_sha256(sha256, what: str) -> Optional[str]:
    """``sha256`` (64 hex digits, or pooch's ``"sha256:<hex>"``) in lowercase; ``None`` for none given."""
    if sha256 is None or sha256 == "":
        return None
    text = sha256.strip().lower() if isinstance(sha256, str) else ""
    text = text[len("sha256:"):] if text.startswith("sha256:") else text
    if not _SHA256_HEX.match(text):
        raise ValueError(f"{what}: expected a SHA-256 of 64 hexadecimal digits, got {_shown(sha256)}")
    return text


def _split_url_hash(source: str) -> tuple:
    """``(URL, SHA-256 or None)`` of a URL that may end ``#sha256=<hex>``, as pip's do: how ``PRETRAINED``, one
    string in a chapter's parameters, carries the hash its download is checked against (a fragment is never sent
    to the server)."""
    url, fragment = urllib.parse.urldefrag(source)
    if fragment.lower().startswith("sha256="):
        return url, _normal_sha256(fragment[len("sha256="):], f"{url}#sha256=")
    return source, None


def _download(url: str, sha256: str) -> pathlib.Path:
    """``url`` downloaded once with pooch into the cache folder's ``packs/``, only as the file whose SHA-256 is
    ``sha256``: pooch checks a download before moving it into place (and deletes it where it differs) and a copy
    downloaded earlier before returning it (and downloads again where that differs), one pass over the bytes."""
    import pooch  # only for a download

    try:
        return pathlib.Path(pooch.retrieve(url, known_hash=f"sha256:{sha256}", path=cache_dir() / "packs",
                                           progressbar=True))
    except ValueError as exc:  # pooch's hash mismatch (tqdm, its only other one, is a dependency)
        raise PackMismatchError(f"{url}: refused: the download's SHA-256 is not the expected {sha256}, and the "
                                f"download was deleted ({_shown(str(exc), 200)})") from None
    except Exception as exc:  # no network, no such release asset (HTTP 404), ...
        raise FileNotFoundError(f"pack: could not download {url} ({type(exc).__name__}: {exc}); set PRETRAINED to "
                                "a pack's path or another URL, or to False to build everything") from exc


def _fetch(source: str, sha256: Optional[str]) -> pathlib.Path:
    """A local path to the pack ``source``: a path as it is (checked against ``sha256`` where given), or an http(s)
    URL downloaded against ``sha256`` or the URL's ``#sha256=<hex>``; a URL with neither is refused before
    anything is downloaded, since a pack's manifest cannot vouch for the pack."""
    expected = _normal_sha256(sha256, "sha256")
    if _URL.match(source):
        url, in_url = _split_url_hash(source)
        if expected and in_url and expected != in_url:
            raise PackMismatchError(f"{url}: expected one SHA-256, got sha256={expected} and the URL's "
                                    f"#sha256={in_url}")
        expected = expected or in_url
        if expected is None:
            raise PackMismatchError(
                f"{url}: a pack is downloaded only against its SHA-256, and none was given. End the URL with "
                "'#sha256=<hex>' or pass sha256='<hex>' (scripts/make_pack.py prints a pack's hash), or download "
                "the pack yourself and give its path, or set PRETRAINED = False to build everything")
        return _download(url, expected)
    path = pathlib.Path(source).expanduser()
    if not path.is_file():
        raise FileNotFoundError(f"pack: expected a pack file or an http(s) URL, {source!r} is neither")
    if expected and _sha256_file(path) != expected:
        raise PackMismatchError(f"{path}: its SHA-256 is not the expected {expected}")
    return path


def _check_run(manifest: dict, scale: Optional[str], seed: Optional[int], where: str) -> None:
    """Refuse a pack built for another scale or seed than the reader's (its artifacts would never be loaded)."""
    for what, ours in (("scale", None if scale is None else check_scale(scale)),
                       ("seed", None if seed is None else check_seed(seed))):
        if ours is not None and manifest[what] != ours:
            raise PackMismatchError(f"{where} holds {what} {manifest[what]!r} artifacts; this chapter runs {what} "
                                    f"{ours!r}: set PRETRAINED = False, or use a pack built for it")


def _to_unpack(records: list, folder: pathlib.Path, report: UnpackReport) -> list:
    """The records to copy into ``folder``; the others go into ``report``: ``stale`` where a module's installed
    source differs from the pack's, ``present`` where the identical file is there already."""
    installed, chosen = {}, []
    for record in records:
        name = record["name"]
        differing = []
        for module, digest in record["modules"].items():
            if module not in installed:
                installed[module] = _installed_digest(module)
            if installed[module] != digest:
                differing.append(module)
        if differing:
            report.stale[name] = differing
        elif (folder / name).exists() and _sha256_file(folder / name) == record["sha256"]:
            report.present.append(name)
        else:
            chosen.append(record)
    return chosen


def _megabytes(count: int) -> str:
    return f"{count / 1e6:,.1f} MB"


def _check_space(folder: pathlib.Path, needed: int, where: str) -> None:
    """Refuse to unpack ``needed`` bytes into ``folder`` unless its disk keeps a margin free afterwards (5 %, at
    least 256 MB): a refusal now says more than a full disk in the middle of a chapter."""
    if not needed:
        return
    free = shutil.disk_usage(folder).free
    margin = max(_SPACE_MARGIN_BYTES, int(_SPACE_MARGIN_SHARE * needed))
    if needed + margin > free:
        raise PackMismatchError(f"{where}: unpacking needs {_megabytes(needed)} in {folder}, with {_megabytes(margin)}"
                                f" left free after it; its disk has {_megabytes(free)} free. Free some space, set "
                                "HOI_CACHE to a folder on a disk with room, or set PRETRAINED = False")


def _extract(archive: zipfile.ZipFile, record: dict, folder: pathlib.Path, where: str) -> None:
    """Copy the member ``record["name"]`` into ``folder`` through a temporary file, counting its bytes: a member
    that yields more than its declared ``bytes`` (a zip bomb's header lies), fails to inflate or differs from its
    ``sha256`` is deleted and refused before it takes the artifact's place."""
    name, declared = record["name"], record["bytes"]
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name}.", suffix=".tmp")
    try:
        digest, written = hashlib.sha256(), 0
        with os.fdopen(fd, "wb") as out, archive.open(name) as member:
            for block in iter(lambda: member.read(1 << 20), b""):
                written += len(block)
                if written > declared:
                    raise PackMismatchError(f"{where}: {name} inflates to more than the {declared} bytes its "
                                            "manifest declares (a zip bomb, or a damaged pack); refusing the pack")
                digest.update(block)
                out.write(block)
        if written != declared or digest.hexdigest() != record["sha256"]:
            raise PackMismatchError(f"{where}: {name} does not match its SHA-256 in the manifest "
                                    f"({written} of {declared} bytes; a damaged pack): download it again")
        os.replace(tmp, folder / name)
    except (zipfile.BadZipFile, zlib.error, EOFError) as exc:  # a CRC that fails, a truncated stream, ...
        pathlib.Path(tmp).unlink(missing_ok=True)
        raise PackMismatchError(f"{where}: could not inflate {name} ({type(exc).__name__}: {_shown(str(exc), 120)}; "
                                "a damaged pack): download it again") from None
    except BaseException:
        pathlib.Path(tmp).unlink(missing_ok=True)
        raise


def unpack(source: Union[str, os.PathLike], cache: Union[str, os.PathLike, None] = None, *,
           scale: Optional[str] = None, seed: Optional[int] = None, sha256: Optional[str] = None,
           chapter: Optional[str] = None, verbose: bool = True) -> UnpackReport:
    """Unpack the pack ``source`` (a path, or a URL with its SHA-256) into the cache folder ``cache`` (default: the
    cache).

    Only artifacts whose recorded modules all have, installed, the same source (SHA-256) are copied; an identical
    file already there is left alone. Before anything is decompressed the manifest is checked against its schema
    and the zip against the manifest (:func:`read_manifest`), and the space the copies need against the free space
    of ``cache``'s disk; each copy is counted against its declared size and checked against its SHA-256 before it
    is moved into place.

    Args:
        scale, seed: the reader's; a pack built for others is refused (its artifacts would never be loaded).
        sha256: the pack file's expected SHA-256 (64 hex digits): needed for an http(s) URL, unless the URL ends
            ``#sha256=<hex>``; checked, where given, for a path.
        chapter: a chapter's notebook name (``"12_samp_motionnet"``): only the artifacts that chapter loaded or
            built when the pack was made (the manifest's ``chapters``); every artifact when the manifest does not
            list the chapter.

    Raises:
        PackMismatchError: a URL without a SHA-256 or a file with another, a manifest or zip that departs from the
            schema, another scale or seed, too little free space, a file that inflates past its size or fails its
            hash, or no artifact that matches the installed code (a pack built from other code), with what differs.
        FileNotFoundError: no such file, or a download that failed.
    """
    path = _fetch(str(source), sha256)
    with _open_pack(path) as archive:
        manifest = _manifest_of(archive, path.name)
        _check_run(manifest, scale, seed, path.name)
        folder = pathlib.Path(cache) if cache is not None else cache_dir()
        folder.mkdir(parents=True, exist_ok=True)
        report = UnpackReport(source=path.name, version=manifest["version"], unpacked=[], present=[], stale={})
        records = manifest["files"]
        wanted = manifest.get("chapters", {}).get(chapter) if chapter is not None else None
        if wanted is not None:
            wanted = set(wanted)
            records = [record for record in records if record["name"] in wanted]
            report.chapter = chapter
        chosen = _to_unpack(records, folder, report)
        _check_space(folder, sum(record["bytes"] for record in chosen), path.name)
        for record in chosen:
            _extract(archive, record, folder, path.name)
            report.unpacked.append(record["name"])
    if records and not report.unpacked and not report.present:
        modules = sorted({m for ms in report.stale.values() for m in ms})
        which = f"artifacts that chapter {chapter} uses" if wanted is not None else "artifacts"
        raise PackMismatchError(
            f"{path.name} was built from other code (version {manifest['version']}): every one of its "
            f"{len(records)} {which} ran library modules whose source differs from the installed "
            f"hoi_tutorial {_version()} ({', '.join(modules[:8])}{' ...' if len(modules) > 8 else ''}). "
            "Install the release the pack was built from, or set PRETRAINED = False to build everything")
    if verbose:
        print(report.summary())
    return report


def _release_sha256(scale: str, seed: int, sha256: Optional[str]) -> str:
    """The SHA-256 that the installed release's pack for ``scale`` and ``seed`` must have: :data:`RELEASED_PACKS`'
    entry, or the caller's ``sha256`` (which must agree with it where there is one). A development version has
    neither a release nor its pack: refused whatever ``sha256`` says."""
    if is_development_version(_version()):
        raise _no_release_pack(_version(), "PRETRAINED = True")
    name = pack_name(scale, seed)
    known = _normal_sha256(RELEASED_PACKS.get(name), f"RELEASED_PACKS[{name!r}]")
    given = _normal_sha256(sha256, "sha256")
    if known and given and known != given:
        raise PackMismatchError(f"PRETRAINED = True: sha256={given} is not the SHA-256 that hoi_tutorial "
                                f"{_version()} lists for {name} ({known}); expected that one, or none")
    if not (known or given):
        raise PackMismatchError(
            f"PRETRAINED = True: hoi_tutorial {_version()} lists no SHA-256 for a released pack {name} "
            "(infra.pack.RELEASED_PACKS), so a download of it could not be checked: this version published none. "
            "Set PRETRAINED to a pack's local path, or to its URL ending '#sha256=<hex>', or to False to build "
            "everything")
    return known or given


def use_pretrained(pretrained, scale: str, seed: int, sha256: Optional[str] = None,
                   chapter: Optional[str] = None) -> Optional[UnpackReport]:
    """What a chapter's ``PRETRAINED`` parameter asks for: ``False`` / ``None`` / ``""`` nothing (no network);
    ``True`` the installed release's pack for ``scale`` and ``seed`` (:func:`release_pack_url`), checked against
    its SHA-256 in :data:`RELEASED_PACKS` (refused where there is none, unless ``sha256`` is given, and for a
    development version, which has no release); a string a pack's local path, or an http(s) URL with its SHA-256
    (``sha256``, or the URL ending ``#sha256=<hex>``).
    ``chapter`` (the chapter's notebook name) unpacks only what that chapter uses (:func:`unpack`)."""
    if pretrained is None or pretrained is False or pretrained == "":
        return None
    if pretrained is True:
        sha256 = _release_sha256(scale, seed, sha256)
        pretrained = release_pack_url(scale, seed)
    if not isinstance(pretrained, (str, os.PathLike)):
        raise TypeError(f"PRETRAINED: expected False, True, or a pack's path or URL, got {pretrained!r}")
    return unpack(pretrained, scale=scale, seed=seed, sha256=sha256, chapter=chapter)
