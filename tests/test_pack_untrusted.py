"""Pretrained packs as untrusted input: a manifest checked against its schema, sizes checked before anything is
inflated, and a download checked against a SHA-256 that does not come from the pack (served here from loopback)."""
from __future__ import annotations

import collections
import copy
import functools
import http.server
import importlib
import io
import json
import shutil
import threading
import warnings
import zipfile

import pytest

from hoi_tutorial.infra import load_or_build, pack


@pytest.fixture
def packed(tmp_path, monkeypatch, derived_package):
    """A pack of two artifacts built from library code (a derived package), as ``(its path, its manifest)``;
    ``$HOI_CACHE`` is then the empty folder ``reader``."""
    derived_package("untrustpkg", {
        "untrustpkg/__init__.py": "",
        "untrustpkg/data.py": "import numpy as np\n\n\ndef build():\n    return {'v': np.arange(4.0)}\n\n\n"
                              "def zeros():\n    return {'z': np.zeros(100_000, dtype=np.float32)}\n",
    })
    data = importlib.import_module("untrustpkg.data")
    monkeypatch.setenv("HOI_CACHE", str(tmp_path / "run"))
    load_or_build("toy_data", {"n": 4}, data.build, verbose=False)
    load_or_build("toy_zeros", {}, data.zeros, verbose=False)  # 400 kB that deflate to about 1 kB
    manifest = pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0)
    monkeypatch.setenv("HOI_CACHE", str(tmp_path / "reader"))
    return tmp_path / "p.zip", manifest


def _members(path) -> dict:
    """``{member name: bytes}`` of a zip file, manifest.json aside."""
    with zipfile.ZipFile(path) as archive:
        return {name: archive.read(name) for name in archive.namelist() if name != "manifest.json"}


def _write(path, manifest, members: dict):
    """A zip file with ``manifest`` as manifest.json (any JSON value; bytes as they are) and ``members``."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("manifest.json", manifest if isinstance(manifest, bytes) else json.dumps(manifest))
        for name, payload in members.items():
            archive.writestr(name, payload)
    return path


def _no_name(manifest, members):
    del manifest["files"][0]["name"]


def _renamed(new):
    def edit(manifest, members):
        old = manifest["files"][0]["name"]
        manifest["files"][0]["name"] = new
        members[new] = members.pop(old)
    return edit


def _first(key, value):
    def edit(manifest, members):
        manifest["files"][0][key] = value
    return edit


def _bad_digest(manifest, members):
    modules = manifest["files"][0]["modules"]
    modules[next(iter(modules))] = "0123abc"


def _foreign_module(manifest, members):  # checking it would import a package that is not the library's
    manifest["files"][0]["modules"] = {"antigravity.sub": "0" * 64}


def _duplicate(manifest, members):
    manifest["files"].append(copy.deepcopy(manifest["files"][0]))


def _missing(manifest, members):
    del members[manifest["files"][0]["name"]]


def _extra(manifest, members):
    members["sneaky-0123456789abcdef.pt"] = b"not listed"


def _size_lies(manifest, members):
    manifest["files"][0]["bytes"] += 1


def _unknown_chapter_file(manifest, members):
    manifest["chapters"] = {"01_toy_world": ["gone-0123456789abcdef.pt"]}


MALFORMED = {  # how the manifest (or the zip) departs, and what the message says was expected
    "a list": (lambda manifest, members: [manifest], r"manifest.json to hold a JSON object .*got a JSON array"),
    "a record without name": (_no_name, r"files\[0\]: expected a 'name'"),
    "empty modules": (_first("modules", {}), r"files\[0\] \(toy_data-[0-9a-f]{16}\.pt\): expected 'modules' to be "
                                             r"a non-empty object"),
    "modules a list": (_first("modules", ["untrustpkg.data"]), r"expected 'modules' to be a non-empty object"),
    "a bad module digest": (_bad_digest, r"expected modules\['untrustpkg.data'\] to be a SHA-256 digest .*'0123abc'"),
    "a foreign module": (_foreign_module, r"expected 'modules' to name modules of .*untrustpkg.*'antigravity.sub'"),
    "a bad sha256": (_first("sha256", "XYZ"), r"expected 'sha256' to be 64 lowercase hex digits, got 'XYZ'"),
    "bytes a boolean": (_first("bytes", True), r"expected 'bytes' \(the file's size\) to be an integer >= 0"),
    "negative bytes": (_first("bytes", -1), r"expected 'bytes' .* got -1"),
    "a path out of the cache": (_renamed("../toy_data-0123456789abcdef.pt"), r"'\.\./toy_data-0123456789abcdef\.pt' "
                                                                             r"is not an artifact file name"),
    "an absolute path": (_renamed("/tmp/toy_data-0123456789abcdef.pt"), r"is not an artifact file name"),
    "a backslash": (_renamed("..\\toy_data-0123456789abcdef.pt"), r"is not an artifact file name .*no backslash"),
    "a duplicate record": (_duplicate, r"files\[2\] \(toy_data-[0-9a-f]{16}\.pt\): expected each file once"),
    "a missing member": (_missing, r"files\[0\] \(toy_data-[0-9a-f]{16}\.pt\): expected the zip to hold it"),
    "an extra member": (_extra, r"holds 'sneaky-0123456789abcdef\.pt', which its manifest\.json does not list"),
    "a declared size that is not the zip's": (_size_lies, r"files\[0\] .*: declares \d+ bytes, the zip's entry \d+"),
    "a chapter's unknown file": (_unknown_chapter_file, r"chapters\['01_toy_world'\]: expected file names that"),
    "a seed that is a string": (lambda manifest, members: manifest.update(seed="0"), r"expected 'seed' to be an "
                                                                                       r"integer >= 0, got '0'"),
    "no files": (lambda manifest, members: manifest.update(files=[]), r"expected 'files' to be a non-empty array"),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_a_malformed_manifest_is_refused_saying_what_was_expected(tmp_path, packed, case):
    path, manifest = packed
    edit, message = MALFORMED[case]
    members, manifest = _members(path), copy.deepcopy(manifest)
    manifest = edit(manifest, members) or manifest
    bad = _write(tmp_path / "bad.zip", manifest, members)
    for read in (pack.read_manifest, lambda p: pack.unpack(p, tmp_path / "reader", verbose=False)):
        with pytest.raises(pack.PackMismatchError, match=message) as refused:
            read(bad)
        assert str(refused.value).startswith("bad.zip: ")  # names the pack
    assert not (tmp_path / "reader").exists()  # refused before anything is written


def test_a_manifest_that_is_no_json_or_too_long_and_a_member_twice_are_refused(tmp_path, packed, monkeypatch):
    path, manifest = packed
    members = _members(path)
    with pytest.raises(pack.PackMismatchError, match="bad.zip: expected manifest.json to be readable JSON"):
        pack.read_manifest(_write(tmp_path / "bad.zip", b'{"files": [', members))
    with pytest.raises(pack.PackMismatchError, match="bad.zip: expected manifest.json to be readable JSON"):
        pack.read_manifest(_write(tmp_path / "bad.zip", b"[" * 100_000 + b"]" * 100_000, members))
    with warnings.catch_warnings():  # zipfile warns of the duplicate it writes
        warnings.simplefilter("ignore")
        twice = _write(tmp_path / "twice.zip", manifest, members)
        with zipfile.ZipFile(twice, "a") as archive:
            archive.writestr("manifest.json", json.dumps(dict(manifest, seed=1)))
    with pytest.raises(pack.PackMismatchError, match="expected each zip member once, it holds 'manifest.json' twice"):
        pack.read_manifest(twice)
    monkeypatch.setattr(pack, "_MANIFEST_MAX_BYTES", 100)
    with pytest.raises(pack.PackMismatchError, match=r"manifest.json declares \d+ bytes; expected at most 100"):
        pack.read_manifest(path)


def test_sizes_are_checked_before_anything_is_inflated(tmp_path, packed, monkeypatch):
    path, manifest = packed
    total = sum(record["bytes"] for record in manifest["files"])
    cap = pack._PACK_MAX_BYTES
    monkeypatch.setattr(pack, "_PACK_MAX_BYTES", total - 1)
    with pytest.raises(pack.PackMismatchError, match=r"p.zip: its files declare .* GB in all; expected at most"):
        pack.unpack(path, tmp_path / "reader", verbose=False)
    monkeypatch.setattr(pack, "_PACK_MAX_BYTES", cap)
    # too little free space on the cache's disk, with a margin: refused with what it needs, nothing written
    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda folder: usage(10**12, 10**12 - 10**6, 10**6))
    with pytest.raises(pack.PackMismatchError, match=r"p.zip: unpacking needs 0.4 MB in .*reader, with 268.4 MB left "
                                                     r"free after it; its disk has 1.0 MB free"):
        pack.unpack(path, tmp_path / "reader", verbose=False)
    assert not list((tmp_path / "reader").iterdir())


def _zeros_record(manifest) -> dict:
    return next(record for record in manifest["files"] if record["name"].startswith("toy_zeros"))


def test_a_member_whose_header_lies_about_its_size_is_refused_and_deleted(tmp_path, packed):
    # A zip bomb: the header (and the manifest) declare 1000 bytes; the deflated stream holds 400 kB.
    path, manifest = packed
    members, manifest = _members(path), copy.deepcopy(manifest)
    zeros = _zeros_record(manifest)
    zeros["bytes"] = 1000
    bomb = _write(tmp_path / "bomb.zip", manifest, {})
    with zipfile.ZipFile(bomb, "a", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, payload in members.items():
            archive.writestr(name, payload)
        next(info for info in archive.filelist if info.filename == zeros["name"]).file_size = 1000
    assert pack.read_manifest(bomb)["files"] == manifest["files"]  # its sizes agree with the zip's
    with pytest.raises(pack.PackMismatchError, match=f"bomb.zip: could not inflate {zeros['name']}"):
        pack.unpack(bomb, tmp_path / "reader", verbose=False)
    assert not [p for p in (tmp_path / "reader").iterdir() if p.name.startswith((".toy_zeros", "toy_zeros"))]


def test_a_member_that_yields_more_than_declared_is_cut_off_and_deleted(tmp_path, packed, monkeypatch):
    # Where the zip reader would not stop at the declared size itself, the copy counts the bytes and stops.
    path, manifest = packed
    zeros = _zeros_record(manifest)
    real_open = zipfile.ZipFile.open

    def open_member(archive, name, *args, **kwargs):
        if name == zeros["name"]:
            return io.BytesIO(b"\0" * (zeros["bytes"] + (3 << 20)))
        return real_open(archive, name, *args, **kwargs)

    monkeypatch.setattr(zipfile.ZipFile, "open", open_member)
    with pytest.raises(pack.PackMismatchError, match=f"{zeros['name']} inflates to more than the {zeros['bytes']} "
                                                     "bytes its manifest declares"):
        pack.unpack(path, tmp_path / "reader", verbose=False)
    assert not [p for p in (tmp_path / "reader").iterdir() if "toy_zeros" in p.name]


# ----------------------------------------------------------------------------------------------
# downloads, from a server on loopback


@pytest.fixture
def server(tmp_path, monkeypatch):
    """An HTTP server on 127.0.0.1 serving the folder ``www``: ``(that folder, its base URL, the paths asked)``."""
    for name in ("http_proxy", "https_proxy", "all_proxy"):  # loopback only, never through a proxy
        monkeypatch.delenv(name, raising=False)
        monkeypatch.delenv(name.upper(), raising=False)
    root, asked = tmp_path / "www", []
    root.mkdir()

    class Handler(http.server.SimpleHTTPRequestHandler):
        def do_GET(self):
            asked.append(self.path)
            super().do_GET()

        def log_message(self, *args):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler, directory=str(root)))
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield root, f"http://127.0.0.1:{httpd.server_address[1]}", asked
    httpd.shutdown()
    httpd.server_close()
    thread.join()


def test_a_url_is_downloaded_against_the_given_sha256_and_unpacked(tmp_path, packed, server):
    path, manifest = packed
    root, base, asked = server
    shutil.copy(path, root / "p.zip")
    digest = pack._sha256_file(path)
    report = pack.use_pretrained(f"{base}/p.zip", "toy", 0, sha256=digest)
    assert sorted(report.unpacked) == sorted(record["name"] for record in manifest["files"])
    assert asked == ["/p.zip"]
    # the hash on the URL (PRETRAINED alone) serves as well; the copy downloaded before is checked, not fetched
    again = pack.use_pretrained(f"{base}/p.zip#sha256={digest}", "toy", 0)
    assert len(again.present) == 2 and asked == ["/p.zip"]


def test_a_url_without_a_sha256_is_refused_before_anything_is_downloaded(tmp_path, packed, server):
    path, _ = packed
    root, base, asked = server
    shutil.copy(path, root / "p.zip")
    with pytest.raises(pack.PackMismatchError, match=r"p.zip: a pack is downloaded only against its SHA-256, and none "
                                                     r"was given\. End the URL with '#sha256=<hex>'"):
        pack.use_pretrained(f"{base}/p.zip", "toy", 0)
    assert asked == [] and not (tmp_path / "reader" / "packs").exists()


def test_a_download_whose_sha256_differs_is_refused_and_deleted(tmp_path, packed, server):
    path, _ = packed
    root, base, asked = server
    blob = bytearray(path.read_bytes())
    blob[len(blob) // 2] ^= 1  # one byte of an artifact
    (root / "changed.zip").write_bytes(bytes(blob))
    with pytest.raises(pack.PackMismatchError, match=r"changed.zip: refused: the download's SHA-256 is not the "
                                                     r"expected [0-9a-f]{64}, and the download was deleted"):
        pack.use_pretrained(f"{base}/changed.zip", "toy", 0, sha256=pack._sha256_file(path))
    assert asked == ["/changed.zip"]
    assert not list((tmp_path / "reader" / "packs").iterdir())  # neither the download nor a partial file
    assert not list((tmp_path / "reader").glob("*.pt"))


def test_the_release_pack_is_checked_against_the_registry(tmp_path, packed, server, monkeypatch):
    path, _ = packed
    root, base, asked = server
    monkeypatch.setattr(pack, "_version", lambda: "0.1.0")  # a release (a development version has no release pack)
    name = pack.pack_name("toy", 0)
    shutil.copy(path, root / name)
    monkeypatch.setattr(pack, "release_pack_url", lambda scale, seed, version=None: f"{base}/{name}")
    monkeypatch.setattr(pack, "RELEASED_PACKS", {})
    with pytest.raises(pack.PackMismatchError, match=f"PRETRAINED = True: .* lists no SHA-256 for a released pack "
                                                     f"{name} .*local path.*'#sha256=<hex>'"):
        pack.use_pretrained(True, "toy", 0)
    assert asked == []
    monkeypatch.setitem(pack.RELEASED_PACKS, name, "0" * 64)  # a registry entry the served file does not match
    with pytest.raises(pack.PackMismatchError, match="the download's SHA-256 is not the expected 0000"):
        pack.use_pretrained(True, "toy", 0)
    monkeypatch.setitem(pack.RELEASED_PACKS, name, pack._sha256_file(path))
    report = pack.use_pretrained(True, "toy", 0, chapter="01_toy_world")
    assert len(report.unpacked) == 2 and asked == [f"/{name}", f"/{name}"]


def test_no_artifact_key_reaches_the_pack_module():
    # RELEASED_PACKS is edited after a pack is built (its hash is known only then): were pack.py in an artifact's
    # recorded code, adding the hash would make every artifact of that pack stale.
    import pkgutil

    import hoi_tutorial
    from hoi_tutorial.infra.code_closure import code_closure

    modules = [m.name for m in pkgutil.walk_packages(hoi_tutorial.__path__, "hoi_tutorial.")]
    reaching = [m for m in modules if m not in ("hoi_tutorial.infra", "hoi_tutorial.infra.pack")
                and "hoi_tutorial.infra.pack" in code_closure(m)]
    assert len(modules) > 50 and reaching == []
