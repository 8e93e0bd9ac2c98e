"""Pretrained packs: the artifacts of a whole book run, in one file, for a reader who would rather not wait.

A chapter opened alone in a fresh runtime builds everything before it (data, models, evaluations): minutes to tens of
minutes on a laptop. A *pack* holds what ``make artifacts`` built (every chapter at one scale and seed) with a
manifest: the package version, the scale and seed, and for each artifact file its SHA-256 and the library modules it
ran with the SHA-256 of their source (what :func:`~hoi_tutorial.infra.cache.load_or_build` records). :func:`unpack`
copies into the cache only the artifacts whose modules are the installed ones, comments, docstrings and blank lines
aside (``cache.module_digests``), so a pack never stands in for code it was not built from: a pack built before a
library edit is refused for what the edit touches, and refused as a whole when that is everything.

Typical use (a chapter's ``PRETRAINED`` parameter does this in its third cell)::

    from hoi_tutorial.infra import use_pretrained
    use_pretrained("hoi_tutorial-0.1.0-toy-seed0.zip", scale="toy", seed=0)   # a path, a URL, or True

Nothing is downloaded unless asked: ``PRETRAINED = False`` (the default, and CI's) builds everything.
"""
from __future__ import annotations

import dataclasses
import datetime
import hashlib
import json
import os
import pathlib
import re
import tempfile
import zipfile
import zlib
from typing import Optional, Union

import torch

from .cache import FORMAT as CACHE_FORMAT
from .cache import cache_dir, module_digests
from .code_closure import module_file
from .presets import check_scale
from .seeding import check_seed

__all__ = ["PACK_FORMAT", "PackMismatchError", "UnpackReport", "pack_name", "release_pack_url", "make_pack",
           "read_manifest", "unpack", "use_pretrained"]

PACK_FORMAT = 2  # 2: the module digests ignore comments, docstrings and blank lines (cache.FORMAT 2)
MANIFEST = "manifest.json"
# The cache's own file names (cache.artifact_path): nothing else is ever written from a pack.
_ARTIFACT_FILE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]{0,99}-[0-9a-f]{16}\.pt$")
# Where a release's pack is published (its assets), by version, scale and seed.
RELEASE_URL = "https://github.com/hoi-tutorial/hoi_tutorial/releases/download/v{version}/{name}"


class PackMismatchError(ValueError):
    """A pack that cannot serve this installation: another scale or seed, or built from other code."""


def _version() -> str:
    from .. import __version__
    return __version__


def pack_name(scale: str = "toy", seed: int = 0, version: Optional[str] = None) -> str:
    """The file name of a pack: ``hoi_tutorial-<version>-<scale>-seed<seed>.zip``."""
    return f"hoi_tutorial-{version or _version()}-{check_scale(scale)}-seed{check_seed(seed)}.zip"


def release_pack_url(scale: str = "toy", seed: int = 0, version: Optional[str] = None) -> str:
    """Where the release ``version`` (default: the installed one) publishes its pack for ``scale`` and ``seed``."""
    version = version or _version()
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
        ``chapters``.

    Raises:
        FileNotFoundError: no cache folder or no artifact in it.
        ValueError: an artifact that does not record the modules it ran (built by an older library): rebuild it;
            a chapter's file that the cache does not hold.
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
# reading and unpacking


def read_manifest(path: Union[str, os.PathLike]) -> dict:
    """The manifest of the pack file ``path``, checked to be one this library can read."""
    path = pathlib.Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            manifest = json.loads(archive.read(MANIFEST))
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError) as exc:
        raise PackMismatchError(f"{path}: expected a pretrained pack (a zip file with {MANIFEST}), "
                                f"could not read it ({type(exc).__name__}: {exc})") from None
    if not isinstance(manifest, dict) or manifest.get("package") != "hoi_tutorial" \
            or manifest.get("format") != PACK_FORMAT:
        raise PackMismatchError(f"{path}: expected a hoi_tutorial pack of format {PACK_FORMAT}, got package "
                                f"{manifest.get('package')!r}, format {manifest.get('format')!r}")
    return manifest


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


def _fetch(source: str, sha256: Optional[str]) -> pathlib.Path:
    """A local path to the pack ``source`` (a path, or an http(s) URL downloaded once with pooch)."""
    if re.match(r"^https?://", source):
        import pooch  # only for a download

        known = f"sha256:{sha256}" if sha256 else None
        try:
            return pathlib.Path(pooch.retrieve(source, known_hash=known, path=cache_dir() / "packs",
                                               progressbar=True))
        except ValueError:  # pooch's hash mismatch
            raise
        except Exception as exc:  # no network, no such release asset (HTTP 404), ...
            raise FileNotFoundError(f"pack: could not download {source} ({type(exc).__name__}: {exc}); set "
                                    "PRETRAINED to a pack's path or another URL, or to False to build everything"
                                    ) from exc
    path = pathlib.Path(source).expanduser()
    if not path.is_file():
        raise FileNotFoundError(f"pack: expected a pack file or an http(s) URL, {source!r} is neither")
    if sha256 and _sha256_file(path) != sha256.lower():
        raise PackMismatchError(f"{path}: its SHA-256 is not the expected {sha256}")
    return path


def unpack(source: Union[str, os.PathLike], cache: Union[str, os.PathLike, None] = None, *,
           scale: Optional[str] = None, seed: Optional[int] = None, sha256: Optional[str] = None,
           chapter: Optional[str] = None, verbose: bool = True) -> UnpackReport:
    """Unpack the pack ``source`` (a path or URL) into the cache folder ``cache`` (default: the cache).

    Only artifacts whose recorded modules all have, installed, the same source (SHA-256) are copied; each file is
    checked against the manifest's SHA-256 before it is moved into place, and an identical file already there is
    left alone.

    Args:
        scale, seed: the reader's; a pack built for others is refused (its artifacts would never be loaded).
        sha256: the pack file's expected SHA-256 (checked by pooch for a URL, here for a path).
        chapter: a chapter's notebook name (``"12_samp_motionnet"``): only the artifacts that chapter loaded or
            built when the pack was made (the manifest's ``chapters``); every artifact when the manifest does not
            list the chapter.

    Raises:
        PackMismatchError: another scale or seed, a file that fails its hash, or no artifact that matches the
            installed code (a pack built from other code), with what differs.
    """
    path = _fetch(str(source), sha256)
    manifest = read_manifest(path)
    for what, ours in (("scale", None if scale is None else check_scale(scale)),
                       ("seed", None if seed is None else check_seed(seed))):
        if ours is not None and manifest.get(what) != ours:
            raise PackMismatchError(f"{path.name} holds {what} {manifest.get(what)!r} artifacts; this chapter "
                                    f"runs {what} {ours!r}: set PRETRAINED = False, or use a pack built for it")
    folder = pathlib.Path(cache) if cache is not None else cache_dir()
    folder.mkdir(parents=True, exist_ok=True)
    installed = {}
    report = UnpackReport(source=path.name, version=str(manifest.get("version")), unpacked=[], present=[], stale={})
    records = manifest["files"]
    wanted = manifest.get("chapters", {}).get(chapter) if chapter is not None else None
    if wanted is not None:
        wanted = set(wanted)
        records = [record for record in records if record["name"] in wanted]
        report.chapter = chapter
    with zipfile.ZipFile(path) as archive:
        for record in records:
            name = record["name"]
            if not _ARTIFACT_FILE.match(name):
                raise PackMismatchError(f"{path.name}: {name!r} is not an artifact file name; refusing the pack")
            differing = []
            for module, digest in record["modules"].items():
                if module not in installed:
                    installed[module] = _installed_digest(module)
                if installed[module] != digest:
                    differing.append(module)
            if differing:
                report.stale[name] = differing
                continue
            target = folder / name
            if target.exists() and _sha256_file(target) == record["sha256"]:
                report.present.append(name)
                continue
            fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name}.", suffix=".tmp")
            try:
                digest = hashlib.sha256()
                with os.fdopen(fd, "wb") as out, archive.open(name) as member:
                    for block in iter(lambda: member.read(1 << 20), b""):
                        digest.update(block)
                        out.write(block)
                if digest.hexdigest() != record["sha256"]:
                    raise PackMismatchError(f"{path.name}: {name} does not match its SHA-256 in the manifest "
                                            "(a damaged pack): download it again")
                os.replace(tmp, target)
            except BaseException:
                pathlib.Path(tmp).unlink(missing_ok=True)
                raise
            report.unpacked.append(name)
    if records and not report.unpacked and not report.present:
        modules = sorted({m for ms in report.stale.values() for m in ms})
        which = f"artifacts that chapter {chapter} uses" if wanted is not None else "artifacts"
        raise PackMismatchError(
            f"{path.name} was built from other code (version {manifest.get('version')}): every one of its "
            f"{len(records)} {which} ran library modules whose source differs from the installed "
            f"hoi_tutorial {_version()} ({', '.join(modules[:8])}{' ...' if len(modules) > 8 else ''}). "
            "Install the release the pack was built from, or set PRETRAINED = False to build everything")
    if verbose:
        print(report.summary())
    return report


def use_pretrained(pretrained, scale: str, seed: int, sha256: Optional[str] = None,
                   chapter: Optional[str] = None) -> Optional[UnpackReport]:
    """What a chapter's ``PRETRAINED`` parameter asks for: ``False`` / ``None`` / ``""`` nothing, ``True`` the
    installed release's pack for ``scale`` and ``seed`` (:func:`release_pack_url`), a string a pack's path or URL;
    ``chapter`` (the chapter's notebook name) unpacks only what that chapter uses (:func:`unpack`)."""
    if pretrained is None or pretrained is False or pretrained == "":
        return None
    if pretrained is True:
        pretrained = release_pack_url(scale, seed)
    if not isinstance(pretrained, (str, os.PathLike)):
        raise TypeError(f"PRETRAINED: expected False, True, or a pack's path or URL, got {pretrained!r}")
    return unpack(pretrained, scale=scale, seed=seed, sha256=sha256, chapter=chapter)
