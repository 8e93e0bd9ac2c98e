"""The release metadata agree: one version, one repository address, the licences the metadata names; and
scripts/release.py, which prepares, registers and checks a release, on a copy of the files it touches."""
import ast
import datetime
import hashlib
import json
import re
import shutil
import zipfile
from pathlib import Path

import nbformat

import pytest
import yaml

import hoi_tutorial

from helpers import load_script

tomllib = pytest.importorskip("tomllib")  # Python 3.11+

ROOT = Path(__file__).resolve().parents[1]


def _pyproject(root=ROOT):
    return tomllib.loads((root / "pyproject.toml").read_text())


def _citation(root=ROOT):
    return yaml.safe_load((root / "CITATION.cff").read_text())


try:
    from packaging.version import Version
except ImportError:  # packaging comes with pip's environments; the project's two forms are simple enough to parse
    class Version:
        """``X.Y.Z`` or ``X.Y.Z.devN``, ordered as PEP 440 orders them (a dev version before its release)."""

        def __init__(self, text):
            match = re.fullmatch(r"(\d+)\.(\d+)\.(\d+)(?:\.dev(\d+))?", text)
            assert match, f"expected a version X.Y.Z or X.Y.Z.devN, got {text!r}"
            self.release = tuple(int(part) for part in match.groups()[:3])
            self.dev = None if match.group(4) is None else int(match.group(4))
            self.is_devrelease, self.base_version = self.dev is not None, ".".join(map(str, self.release))

        def _key(self):
            return self.release, (-1, self.dev) if self.is_devrelease else (0, 0)

        def __eq__(self, other):
            return self._key() == other._key()

        def __gt__(self, other):
            return self._key() > other._key()


INIT = Path("src") / "hoi_tutorial" / "__init__.py"
PACK_MODULE = Path("src") / "hoi_tutorial" / "infra" / "pack.py"
RELEASE_HEADING = re.compile(r"^## \[(\d+\.\d+\.\d+)\] — (\d{4}-\d{2}-\d{2})$", flags=re.M)


def _assert_one_version(root):
    """The package is a release (``X.Y.Z``: everything names it, and CHANGELOG dates it) or the code after one
    (``X.Y.Z.devN``: the work is listed under ``## [Unreleased]``, and CITATION.cff still cites the last release,
    the one a reader can install)."""
    version = _pyproject(root)["project"]["version"]
    assert re.findall(r'^__version__ = "(.*)"$', (root / INIT).read_text(), flags=re.M) == [version]
    assert re.fullmatch(r"\d+\.\d+\.\d+(\.dev\d+)?", version), f"expected X.Y.Z or X.Y.Z.devN, got {version!r}"
    changelog = (root / "CHANGELOG.md").read_text()
    released = RELEASE_HEADING.findall(changelog)
    assert released, "CHANGELOG.md: expected release headings '## [X.Y.Z] — YYYY-MM-DD'"
    newest, date = released[0]
    datetime.date.fromisoformat(date)  # a date that exists
    headings = re.findall(r"^## .*$", changelog, flags=re.M)
    citation = _citation(root)
    if Version(version).is_devrelease:
        assert Version(Version(version).base_version) > Version(newest), \
            f"{version} is the development of a release newer than CHANGELOG.md's newest, {newest}"
        assert headings[0] == "## [Unreleased]", "CHANGELOG.md: expected '## [Unreleased]' on top for a dev version"
        assert str(citation["version"]) == newest  # the last release, which a reader can install and cite
    else:
        assert newest == version == str(citation["version"])  # the newest release is the package's version
        unreleased = re.search(r"^## \[Unreleased\]\n(.*?)(?=^## )", changelog, flags=re.M | re.S)
        assert unreleased is None or not unreleased.group(1).strip(), \
            f"CHANGELOG.md lists unreleased changes, so the code is not {version}: make its version the next X.Y.Z.dev0"
    assert str(citation["date-released"]) == date


def test_one_version_everywhere():
    _assert_one_version(ROOT)
    assert hoi_tutorial.__version__ == _pyproject()["project"]["version"]  # the package that runs is this one


def test_the_version_rule_knows_dev_versions():
    assert Version("0.2.0.dev0").is_devrelease and not Version("0.2.0").is_devrelease
    assert Version("0.2.0") > Version("0.2.0.dev0") > Version("0.1.0")
    assert Version(Version("0.2.0.dev3").base_version) == Version("0.2.0")


def test_one_repository_address():
    url = yaml.safe_load((ROOT / "_config.yml").read_text())["repository"]["url"]
    assert _pyproject()["project"]["urls"]["Repository"] == url
    assert _citation()["repository-code"] == url
    assert _pyproject()["project"]["urls"]["Changelog"].startswith(url + "/")


def test_the_licences_are_there_and_named_alike():
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert _pyproject()["project"]["license"] == {"text": "MIT"} and _citation()["license"] == "MIT"
    content = (ROOT / "LICENSE-CONTENT.md").read_text()
    assert "CC BY 4.0" in content and "creativecommons.org/licenses/by/4.0" in content


def test_the_citation_cites_the_three_papers():
    titles = [r["title"] for r in _citation()["references"]]
    assert any(t.startswith("NIFTY") for t in titles) and any(t.startswith("CHOICE") for t in titles)
    assert "Stochastic Scene-Aware Motion Prediction" in titles


def _requirements(path):
    from packaging.requirements import Requirement

    lines = [line.split("#")[0].strip() for line in (ROOT / path).read_text().splitlines()]
    return [Requirement(line) for line in lines if line]


def test_the_lock_pins_every_requirement_within_its_bounds():
    from packaging.utils import canonicalize_name

    pins = {canonicalize_name(r.name): r for r in _requirements("requirements.lock")}
    for pin in pins.values():  # exact versions only
        assert len(pin.specifier) == 1 and next(iter(pin.specifier)).operator == "==", pin
    for requirement in _requirements("requirements.txt"):
        name = canonicalize_name(requirement.name)
        if name == "torch":  # pinned by TORCH_SPEC (its build differs between CPU, CUDA and Colab)
            assert name not in pins
            continue
        assert name in pins, f"requirements.lock: {requirement.name} is not pinned; run `make lock`"
        version = next(iter(pins[name].specifier)).version
        assert requirement.specifier.contains(version, prereleases=True), (requirement, version)


def test_the_books_footer_names_the_licences_year():
    # Jupyter Book prints "© Copyright <copyright>" in every page's footer; without the key it prints its own default.
    year = re.search(r"Copyright \(c\) (\d{4})", (ROOT / "LICENSE").read_text()).group(1)
    assert str(yaml.safe_load((ROOT / "_config.yml").read_text())["copyright"]) == year


# --------------------------------------------------------------------------------------------------
# scripts/release.py, on a copy of what it reads and writes (--root)


release = load_script("release")
NOTEBOOK = Path("notebooks") / "01_toy_world.ipynb"
COPIED = ("pyproject.toml", "CITATION.cff", "CHANGELOG.md", "_config.yml", INIT, PACK_MODULE,
          Path("src") / "hoi_tutorial" / "viz" / "render.py", NOTEBOOK)


@pytest.fixture
def checkout(tmp_path):
    """A copy of the files a release reads and writes, as this checkout has them (a development version)."""
    for name in COPIED:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / name, tmp_path / name)
    return tmp_path


def _run(capsys, *args):
    code = release.main([str(arg) for arg in args])
    out, err = capsys.readouterr()
    return code, out + err


def _snapshot(root):
    return {p: p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _fake_pack(root, version, scale="toy", seed=0, extra=b""):
    """A zip named and described as make artifacts would (its manifest's first fields; no artifacts needed here)."""
    path = root / "build" / "artifacts" / f"hoi_tutorial-{version}-{scale}-seed{seed}.zip"
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w") as archive:
        manifest = {"format": 2, "package": "hoi_tutorial", "version": version, "scale": scale, "seed": seed}
        archive.writestr("manifest.json", json.dumps(manifest) + extra.decode())
    return path


def _released_packs(root):
    tree = ast.parse((root / PACK_MODULE).read_text())
    node = next(n for n in tree.body if isinstance(n, ast.AnnAssign) and n.target.id == "RELEASED_PACKS")
    return ast.literal_eval(node.value)


def test_check_names_what_a_release_still_misses_and_changes_nothing(checkout, capsys):
    before = _snapshot(checkout)
    code, out = _run(capsys, "--check", "0.2.0", "--root", checkout)
    assert code == 1 and _snapshot(checkout) == before
    missing = [line for line in out.splitlines() if line.startswith("missing")]
    for what in ('pyproject.toml: version = "0.2.0.dev0", expected "0.2.0"', "__version__ = \"0.2.0.dev0\"",
                 "CHANGELOG.md: expected '## [0.2.0] — YYYY-MM-DD'", "'## [Unreleased]' lists changes",
                 'CITATION.cff: version "0.1.0"', "expected set-up cells that install @v0.2.0"):
        assert any(what in line for line in missing), (what, out)
    assert "git tag" not in out and "not ready: 6 item(s) missing" in out
    code, out = _run(capsys, "--check", "0.2.0.dev0", "--root", checkout)
    assert code == 1 and "missing  0.2.0.dev0 is not a release version X.Y.Z" in out


def test_prepare_makes_a_release_that_check_passes(checkout, capsys):
    notebook_before = nbformat.read(checkout / NOTEBOOK, as_version=4)
    code, out = _run(capsys, "--prepare", "0.2.0", "--root", checkout)
    today = datetime.date.today().isoformat()
    assert code == 0, out
    _assert_one_version(checkout)  # a release, by the rule the repository itself is held to
    assert _pyproject(checkout)["project"]["version"] == "0.2.0" and str(_citation(checkout)["version"]) == "0.2.0"
    assert str(_citation(checkout)["date-released"]) == today
    changelog = (checkout / "CHANGELOG.md").read_text()
    unreleased_bullets = (ROOT / "CHANGELOG.md").read_text().split("## [Unreleased]\n", 1)[1]
    assert changelog.split("## [Unreleased]\n", 1)[1] == f"\n## [0.2.0] — {today}\n" + unreleased_bullets
    notebook = nbformat.read(checkout / NOTEBOOK, as_version=4)
    assert '@v0.2.0"' in notebook.cells[0].source and "tag v0.2.0" in notebook.cells[0].source
    assert [c.source for c in notebook.cells[1:]] == [c.source for c in notebook_before.cells[1:]]  # cell 1 alone

    before = _snapshot(checkout)
    code, out = _run(capsys, "--check", "0.2.0", "--root", checkout)
    assert code == 0 and _snapshot(checkout) == before, out
    assert "missing" not in out and "RELEASED_PACKS lists none" in out
    assert 'git tag -a v0.2.0 -m "hoi_tutorial 0.2.0"' in out and "git push origin v0.2.0" in out
    # prepared once: a second --prepare of the same or an older version is refused and changes nothing
    for version in ("0.2.0", "0.1.5"):
        code, out = _run(capsys, "--prepare", version, "--root", checkout)
        assert code == 2 and "expected a version newer than CHANGELOG.md's newest release, 0.2.0" in out
    assert _snapshot(checkout) == before


def test_prepare_refuses_what_it_cannot_release(checkout, capsys):
    before = _snapshot(checkout)
    code, out = _run(capsys, "--prepare", "0.2.0.dev1", "--root", checkout)
    assert code == 2 and "expected a release version X.Y.Z" in out
    code, out = _run(capsys, "--prepare", "0.2.0", "--date", "2027-02-30", "--root", checkout)
    assert code == 2 and "expected a date YYYY-MM-DD that exists" in out
    changelog = checkout / "CHANGELOG.md"
    text = changelog.read_text()
    changelog.write_text(text[:text.index("## [Unreleased]\n") + 16] + "\n" + text[text.index("## [0.1.0]"):])
    code, out = _run(capsys, "--prepare", "0.2.0", "--root", checkout)
    assert code == 2 and "'## [Unreleased]' lists nothing" in out
    changelog.write_text(text)
    render = checkout / "src" / "hoi_tutorial" / "viz" / "render.py"
    render.rename(render.with_suffix(".txt"))  # what the set-up cells are stamped from: refused before any write
    code, out = _run(capsys, "--prepare", "0.2.0", "--root", checkout)
    assert code == 2 and "which the set-up cells are stamped from" in out
    render.with_suffix(".txt").rename(render)
    assert _snapshot(checkout) == before


def test_register_writes_the_pack_hash_that_check_compares(checkout, capsys):
    assert _run(capsys, "--prepare", "0.2.0", "--date", "2027-01-15", "--root", checkout)[0] == 0
    pack = _fake_pack(checkout, "0.2.0")
    digest = hashlib.sha256(pack.read_bytes()).hexdigest()
    code, out = _run(capsys, "--check", "0.2.0", "--root", checkout)
    assert code == 1 and f"RELEASED_PACKS['{pack.name}'] is None, expected" in out and digest in out

    source_before = (checkout / PACK_MODULE).read_text()
    code, out = _run(capsys, "--register", pack, "--root", checkout)
    assert code == 0 and _released_packs(checkout) == {pack.name: digest}
    after = (checkout / PACK_MODULE).read_text()  # only the literal's lines changed
    assert after.replace(f'{{\n    "{pack.name}": "{digest}",\n}}', "{}") == source_before
    code, out = _run(capsys, "--check", "0.2.0", "--root", checkout)
    assert code == 0 and f"RELEASED_PACKS lists build/artifacts/{pack.name}'s SHA-256 {digest}" in out
    assert f"https://github.com/hoi-tutorial/hoi_tutorial/releases/download/v0.2.0/{pack.name}" in out

    rebuilt = _fake_pack(checkout, "0.2.0", extra=b" ")  # another build: the registered hash no longer holds
    code, out = _run(capsys, "--check", "0.2.0", "--root", checkout)
    assert code == 1 and f"RELEASED_PACKS['{pack.name}'] is '{digest}', expected" in out
    assert _run(capsys, "--register", rebuilt, "--root", checkout)[0] == 0
    assert _released_packs(checkout) == {pack.name: hashlib.sha256(rebuilt.read_bytes()).hexdigest()}

    # refused: another version's pack, a renamed pack, a file that is no pack
    before = _snapshot(checkout)
    code, out = _run(capsys, "--register", _fake_pack(checkout, "0.2.0.dev0"), "--root", checkout)
    assert code == 2 and "expected a pack of 0.2.0 (pyproject.toml's version)" in out
    renamed = _fake_pack(checkout, "0.2.0", seed=1).rename(pack.with_name("hoi_tutorial-0.2.0-toy-seed2.zip"))
    code, out = _run(capsys, "--register", renamed, "--root", checkout)
    assert code == 2 and "its manifest says version, scale, seed = ('0.2.0', 'toy', 1)" in out
    (checkout / "notes.zip").write_bytes(b"no zip")
    code, out = _run(capsys, "--register", checkout / "notes.zip", "--root", checkout)
    assert code == 2 and "expected a pack named hoi_tutorial-<version>-<scale>-seed<seed>.zip" in out
    assert {p: b for p, b in _snapshot(checkout).items() if "build" not in p.parts and p.suffix != ".zip"} == \
        {p: b for p, b in before.items() if "build" not in p.parts and p.suffix != ".zip"}


def test_register_refuses_on_a_development_version(checkout, capsys):
    code, out = _run(capsys, "--register", _fake_pack(checkout, "0.2.0.dev0"), "--root", checkout)
    assert code == 2 and "pyproject.toml's version (run --prepare first): expected a release version X.Y.Z" in out
    assert _released_packs(checkout) == {}


def test_develop_starts_the_next_version_after_a_release(checkout, capsys):
    assert _run(capsys, "--prepare", "0.2.0", "--date", "2027-01-15", "--root", checkout)[0] == 0
    code, out = _run(capsys, "--develop", "0.3.0", "--root", checkout)
    assert code == 0, out
    _assert_one_version(checkout)  # a development version, by the rule the repository itself is held to
    assert _pyproject(checkout)["project"]["version"] == "0.3.0.dev0"
    assert str(_citation(checkout)["version"]) == "0.2.0"  # still cites the release a reader can install
    assert '@main"' in nbformat.read(checkout / NOTEBOOK, as_version=4).cells[0].source
    code, out = _run(capsys, "--develop", "0.2.0", "--root", checkout)
    assert code == 2 and "newer than CHANGELOG.md's newest release, 0.2.0" in out


def test_hash_prints_what_a_class_hands_out(checkout, capsys):
    pack = _fake_pack(checkout, "0.2.0.dev0")
    code, out = _run(capsys, "--hash", pack)
    digest = hashlib.sha256(pack.read_bytes()).hexdigest()
    assert code == 0 and f"sha256 {digest}  {pack.name}" in out and f"{pack.name}#sha256={digest}" in out
