"""Pretrained packs: what a book run built, packed with a manifest, unpacked only where the installed code built it."""
from __future__ import annotations

import hashlib
import importlib
import json
import zipfile

import numpy as np
import pytest

from hoi_tutorial.infra import cache, load_or_build, pack


@pytest.fixture
def toy_library(derived_package):
    """A two-module library whose artifacts the cache derives from its imports, as it does for hoi_tutorial's."""
    root = derived_package("packpkg", {
        "packpkg/__init__.py": "",
        "packpkg/maths.py": "def scale(x):\n    return 2 * x\n",
        "packpkg/data.py": "import numpy as np\n\nfrom . import maths\n\n\n"
                           "def build():\n    return {'v': np.arange(4.0) * maths.scale(1)}\n",
        "packpkg/other.py": "def build():\n    return {'w': [1, 2, 3]}\n",
    })
    return root, importlib.import_module("packpkg.data"), importlib.import_module("packpkg.other")


def _book_run(folder, monkeypatch, data, other):
    """Two artifacts built into ``folder`` the way a chapter builds them."""
    monkeypatch.setenv("HOI_CACHE", str(folder))
    first = load_or_build("toy_data", {"n": 4}, data.build, verbose=False)
    second = load_or_build("toy_other", {"n": 3}, other.build, verbose=False)
    return first, second


def test_a_pack_unpacked_into_an_empty_cache_is_loaded_without_building(tmp_path, monkeypatch, toy_library):
    _, data, other = toy_library
    built = _book_run(tmp_path / "run", monkeypatch, data, other)
    manifest = pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0)
    assert [f["name"].split("-")[0] for f in manifest["files"]] == ["toy_data", "toy_other"]
    # each artifact records the library modules it ran: the builder's and what it imports, nothing unrelated
    assert set(manifest["files"][0]["modules"]) == {"packpkg.data", "packpkg.maths"}
    assert set(manifest["files"][1]["modules"]) == {"packpkg.other"}
    with zipfile.ZipFile(tmp_path / "p.zip") as archive:
        assert json.loads(archive.read("manifest.json")) == manifest
        for record in manifest["files"]:
            assert hashlib.sha256(archive.read(record["name"])).hexdigest() == record["sha256"]

    empty = tmp_path / "reader"
    report = pack.unpack(tmp_path / "p.zip", empty, scale="toy", seed=0, verbose=False)
    assert len(report.unpacked) == 2 and not report.stale and not report.present
    monkeypatch.setenv("HOI_CACHE", str(empty))
    with cache.cache_only():  # NotCachedError instead of a build
        loaded = (load_or_build("toy_data", {"n": 4}, data.build, verbose=False),
                  load_or_build("toy_other", {"n": 3}, other.build, verbose=False))
    np.testing.assert_array_equal(loaded[0]["v"], built[0]["v"])
    assert loaded[1] == built[1]
    # unpacking again leaves the identical files alone
    again = pack.unpack(tmp_path / "p.zip", empty, verbose=False)
    assert len(again.present) == 2 and not again.unpacked


def test_files_that_deflate_well_are_deflated_and_the_rest_stored(tmp_path, monkeypatch, derived_package):
    derived_package("deflpkg", {  # library code: an artifact a pack holds records the modules that built it
        "deflpkg/__init__.py": "",
        "deflpkg/arrays.py": "import numpy as np\n\n\n"
                             "def floats():  # deflate gains little\n"
                             "    noise = np.random.default_rng(0).standard_normal(200_000)\n"
                             "    return {'x': noise.astype(np.float32)}\n\n\n"
                             "def zeros():\n    return {'x': np.zeros(200_000, dtype=np.float32)}\n",
    })
    arrays = importlib.import_module("deflpkg.arrays")
    monkeypatch.setenv("HOI_CACHE", str(tmp_path / "run"))
    load_or_build("floats", {}, arrays.floats, verbose=False)
    load_or_build("zeros", {}, arrays.zeros, verbose=False)
    manifest = pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0)
    with zipfile.ZipFile(tmp_path / "p.zip") as archive:
        kinds = {info.filename.split("-")[0]: info.compress_type for info in archive.infolist()}
    assert kinds["floats"] == zipfile.ZIP_STORED and kinds["zeros"] == zipfile.ZIP_DEFLATED
    report = pack.unpack(tmp_path / "p.zip", tmp_path / "reader", verbose=False)
    assert sorted(report.unpacked) == sorted(f["name"] for f in manifest["files"])
    for record in manifest["files"]:
        assert hashlib.sha256((tmp_path / "reader" / record["name"]).read_bytes()).hexdigest() == record["sha256"]


def test_a_chapter_unpacks_only_what_it_used_when_the_pack_was_made(tmp_path, monkeypatch, toy_library):
    _, data, other = toy_library
    _book_run(tmp_path / "run", monkeypatch, data, other)
    names = sorted(p.name for p in (tmp_path / "run").iterdir())
    first = next(n for n in names if n.startswith("toy_data"))
    manifest = pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0,
                              chapters={"01_data": [first], "02_both": names})
    assert manifest["chapters"] == {"01_data": [first], "02_both": names}
    only = pack.unpack(tmp_path / "p.zip", tmp_path / "a", chapter="01_data", verbose=False)
    assert only.unpacked == [first] and only.chapter == "01_data" and "chapter 01_data" in only.summary()
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == [first]
    # a chapter the manifest does not list, or none, gets every artifact
    for chapter in ("99_unknown", None):
        folder = tmp_path / f"b_{chapter}"
        assert sorted(pack.unpack(tmp_path / "p.zip", folder, chapter=chapter, verbose=False).unpacked) == names
    with pytest.raises(ValueError, match="chapters"):
        pack.make_pack(tmp_path / "q.zip", tmp_path / "run", scale="toy", seed=0,
                       chapters={"01_data": ["toy_gone-0123456789abcdef.pt"]})


def test_a_pack_built_before_a_library_edit_is_refused_for_what_the_edit_touches(tmp_path, monkeypatch, toy_library):
    root, data, other = toy_library
    _book_run(tmp_path / "run", monkeypatch, data, other)
    pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0)
    (root / "packpkg/maths.py").write_text("def scale(x):\n    return 3 * x\n")  # reached by toy_data only
    report = pack.unpack(tmp_path / "p.zip", tmp_path / "reader", verbose=False)
    assert [n.split("-")[0] for n in report.unpacked] == ["toy_other"]
    assert list(report.stale.values()) == [["packpkg.maths"]]
    assert "1 refused, built from other code (packpkg.maths)" in report.summary()
    # and refused as a whole, with a message that says so, once the edit touches every artifact
    (root / "packpkg/other.py").write_text("def build():\n    return {'w': [1, 2, 3, 4]}\n")
    with pytest.raises(pack.PackMismatchError, match="built from other code.*packpkg.maths, packpkg.other"):
        pack.unpack(tmp_path / "p.zip", tmp_path / "reader2", verbose=False)
    assert not list((tmp_path / "reader2").glob("*.pt"))


def test_a_pack_for_another_scale_or_seed_or_damaged_is_refused(tmp_path, monkeypatch, toy_library):
    _, data, other = toy_library
    _book_run(tmp_path / "run", monkeypatch, data, other)
    manifest = pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0)
    with pytest.raises(pack.PackMismatchError, match="holds seed 0 artifacts; this chapter runs seed 1"):
        pack.unpack(tmp_path / "p.zip", tmp_path / "r", scale="toy", seed=1)
    with pytest.raises(pack.PackMismatchError, match="holds scale 'toy'"):
        pack.unpack(tmp_path / "p.zip", tmp_path / "r", scale="small", seed=0)
    with pytest.raises(pack.PackMismatchError, match="SHA-256 is not the expected"):
        pack.unpack(tmp_path / "p.zip", tmp_path / "r", sha256="0" * 64)
    # a file whose bytes are not the manifest's: the damaged file never reaches the cache
    damaged = tmp_path / "damaged.zip"
    with zipfile.ZipFile(tmp_path / "p.zip") as source, zipfile.ZipFile(damaged, "w") as target:
        for item in source.infolist():
            payload = source.read(item)
            if item.filename == manifest["files"][1]["name"]:
                payload = payload[:-1] + bytes([payload[-1] ^ 1])
            target.writestr(item, payload)
    with pytest.raises(pack.PackMismatchError, match="does not match its SHA-256"):
        pack.unpack(damaged, tmp_path / "r2", verbose=False)
    assert [p.name for p in (tmp_path / "r2").iterdir()] == [manifest["files"][0]["name"]]
    # a name that is not an artifact file (a path out of the cache) is refused before anything is written
    evil = tmp_path / "evil.zip"
    bad = dict(manifest, files=[dict(manifest["files"][0], name="../outside.pt")])
    with zipfile.ZipFile(evil, "w") as target:
        target.writestr("manifest.json", json.dumps(bad))
    with pytest.raises(pack.PackMismatchError, match="not an artifact file name"):
        pack.unpack(evil, tmp_path / "r3")
    with pytest.raises(pack.PackMismatchError, match="expected a pretrained pack"):
        (tmp_path / "not.zip").write_text("hello")
        pack.unpack(tmp_path / "not.zip", tmp_path / "r4")
    with pytest.raises(FileNotFoundError, match="neither"):
        pack.unpack(tmp_path / "missing.zip")


def test_make_pack_needs_artifacts_that_record_their_modules(tmp_path):
    with pytest.raises(FileNotFoundError, match="no artifact files"):
        pack.make_pack(tmp_path / "p.zip", tmp_path, scale="toy", seed=0)
    import torch

    torch.save({"format": cache.FORMAT, "key": "0" * 64, "payload": {}, "checksum": ""},
               tmp_path / "old-0123456789abcdef.pt")
    with pytest.raises(ValueError, match="records the library modules it ran"):
        pack.make_pack(tmp_path / "p.zip", tmp_path, scale="toy", seed=0)
    # an artifact of an earlier cache format records digests of another meaning (the raw bytes of format 1)
    torch.save({"format": cache.FORMAT - 1, "key": "0" * 64, "payload": {}, "checksum": "",
                "modules": {"hoi_tutorial.infra.cache": "0" * 64}}, tmp_path / "old-0123456789abcdef.pt")
    with pytest.raises(ValueError, match="rebuild it in an empty cache"):
        pack.make_pack(tmp_path / "p.zip", tmp_path, scale="toy", seed=0)
    # one built from a notebook's code alone records no module: unpack could not check it against the installed code
    torch.save({"format": cache.FORMAT, "key": "0" * 64, "payload": {}, "checksum": "", "modules": {}},
               tmp_path / "old-0123456789abcdef.pt")
    with pytest.raises(ValueError, match="it records none"):
        pack.make_pack(tmp_path / "p.zip", tmp_path, scale="toy", seed=0)


def test_a_pack_of_an_earlier_format_is_refused_even_where_its_digests_match(tmp_path, monkeypatch, toy_library):
    # Format 1 recorded digests of the modules' raw bytes: a pack of it is refused whole, not checked module by module.
    _, data, other = toy_library
    _book_run(tmp_path / "run", monkeypatch, data, other)
    manifest = pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0)
    earlier = tmp_path / "earlier.zip"
    with zipfile.ZipFile(tmp_path / "p.zip") as source, zipfile.ZipFile(earlier, "w") as target:
        for item in source.infolist():
            target.writestr(item, source.read(item) if item.filename != "manifest.json"
                            else json.dumps(dict(manifest, format=pack.PACK_FORMAT - 1)))
    with pytest.raises(pack.PackMismatchError, match=f"format {pack.PACK_FORMAT}, got package 'hoi_tutorial', "
                                                     f"format {pack.PACK_FORMAT - 1}"):
        pack.unpack(earlier, tmp_path / "reader", verbose=False)
    assert not (tmp_path / "reader").exists()  # refused before anything is written


def test_use_pretrained_reads_the_chapter_parameter(tmp_path, monkeypatch):
    import pooch

    def no_network(*args, **kwargs):
        raise AssertionError("nothing is downloaded unless asked, and then only against a known SHA-256")

    monkeypatch.setattr(pooch, "retrieve", no_network)
    assert pack.use_pretrained(False, "toy", 0) is None
    assert pack.use_pretrained("", "toy", 0) is None
    with pytest.raises(TypeError, match="PRETRAINED: expected False, True, or a pack's path or URL"):
        pack.use_pretrained(3, "toy", 0)
    # a development version has no release, so no release pack, whatever the registry or sha256 say
    monkeypatch.setattr(pack, "_version", lambda: "0.2.0.dev0")
    monkeypatch.setitem(pack.RELEASED_PACKS, pack.pack_name("toy", 2), "AB" * 32)
    for sha256 in (None, "AB" * 32):
        with pytest.raises(pack.PackMismatchError, match=r"0\.2\.0\.dev0 is a development version .* has no release "
                                                         r"pack.*local path.*'#sha256=<hex>'"):
            pack.use_pretrained(True, "toy", 2, sha256=sha256)
    with pytest.raises(pack.PackMismatchError, match="development version"):
        pack.release_pack_url("toy", 2)
    assert pack.pack_name("toy", 2) == "hoi_tutorial-0.2.0.dev0-toy-seed2.zip"  # a class's own pack of main
    # True on a release: the release's pack, only with its SHA-256 from the package's registry
    monkeypatch.setattr(pack, "_version", lambda: "0.1.0")
    name = pack.pack_name("toy", 2)
    monkeypatch.setattr(pack, "RELEASED_PACKS", {})
    with pytest.raises(pack.PackMismatchError, match=f"lists no SHA-256 for a released pack {name}.*'#sha256=<hex>'"):
        pack.use_pretrained(True, "toy", 2)
    seen = {}
    monkeypatch.setattr(pack, "unpack", lambda source, **kw: seen.update(source=source, **kw))
    monkeypatch.setitem(pack.RELEASED_PACKS, name, "AB" * 32)
    pack.use_pretrained(True, "toy", 2)
    assert seen["source"].endswith("/v0.1.0/hoi_tutorial-0.1.0-toy-seed2.zip")
    assert seen["sha256"] == "ab" * 32
    with pytest.raises(pack.PackMismatchError, match="is not the SHA-256 that hoi_tutorial .* lists"):
        pack.use_pretrained(True, "toy", 2, sha256="cd" * 32)
    assert pack.pack_name("small", 1, "9.9") == "hoi_tutorial-9.9-small-seed1.zip"


def test_a_url_is_fetched_with_pooch_and_a_failed_download_says_what_to_do(tmp_path, monkeypatch, toy_library):
    import pooch

    _, data, other = toy_library
    _book_run(tmp_path / "run", monkeypatch, data, other)
    pack.make_pack(tmp_path / "p.zip", tmp_path / "run", scale="toy", seed=0)
    digest = pack._sha256_file(tmp_path / "p.zip")
    asked = {}

    def retrieve(url, known_hash, path, progressbar):
        asked.update(url=url, known_hash=known_hash)
        return str(tmp_path / "p.zip")

    monkeypatch.setattr(pooch, "retrieve", retrieve)
    report = pack.unpack("https://example.org/p.zip", tmp_path / "reader", sha256=digest.upper(), verbose=False)
    assert asked == {"url": "https://example.org/p.zip", "known_hash": "sha256:" + digest}
    assert len(report.unpacked) == 2
    # the hash may ride on the URL, as pip's do, so that PRETRAINED alone carries it (the fragment is not sent)
    pack.unpack(f"https://example.org/p.zip#sha256={digest}", tmp_path / "reader", verbose=False)
    assert asked == {"url": "https://example.org/p.zip", "known_hash": "sha256:" + digest}
    with pytest.raises(pack.PackMismatchError, match="expected one SHA-256"):
        pack.unpack(f"https://example.org/p.zip#sha256={digest}", tmp_path / "reader", sha256="0" * 64)
    with pytest.raises(ValueError, match="expected a SHA-256 of 64 hexadecimal digits"):
        pack.unpack("https://example.org/p.zip", tmp_path / "reader", sha256="not-a-hash")

    def offline(*args, **kwargs):
        raise ConnectionError("no network")

    monkeypatch.setattr(pooch, "retrieve", offline)
    with pytest.raises(FileNotFoundError, match="could not download .*ConnectionError.*PRETRAINED"):
        pack.unpack("https://example.org/p.zip", tmp_path / "reader2", sha256=digest)


def test_make_pack_script_packs_a_filled_cache_with_its_manifest_beside_it(tmp_path, monkeypatch, toy_library,
                                                                          capsys):
    import importlib.util
    from pathlib import Path

    _, data, other = toy_library
    _book_run(tmp_path / "run", monkeypatch, data, other)
    script = Path(__file__).resolve().parents[1] / "scripts" / "make_pack.py"
    spec = importlib.util.spec_from_file_location("make_pack_script", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.main(["--no-run", "--cache", str(tmp_path / "run"), "--out", str(tmp_path / "out"),
                        "--seed", "3"]) == 0
    target = tmp_path / "out" / pack.pack_name("toy", 3)
    assert target.stat().st_mode & 0o777 == 0o644
    assert json.loads(target.with_suffix(".json").read_text()) == pack.read_manifest(target)
    assert f"sha256 {pack._sha256_file(target)}" in capsys.readouterr().out
