"""The release metadata agree: one version, one repository address, the licences the metadata names."""
import datetime
import re
from pathlib import Path

import pytest
import yaml

import hoi_tutorial

tomllib = pytest.importorskip("tomllib")  # Python 3.11+

ROOT = Path(__file__).resolve().parents[1]


def _pyproject():
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def _citation():
    return yaml.safe_load((ROOT / "CITATION.cff").read_text())


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


RELEASE_HEADING = re.compile(r"^## \[(\d+\.\d+\.\d+)\] — (\d{4}-\d{2}-\d{2})$", flags=re.M)


def test_one_version_everywhere():
    """The package is a release (``X.Y.Z``: everything names it, and CHANGELOG dates it) or the code after one
    (``X.Y.Z.devN``: the work is listed under ``## [Unreleased]``, and CITATION.cff still cites the last release,
    the one a reader can install)."""
    version = _pyproject()["project"]["version"]
    assert hoi_tutorial.__version__ == version
    assert re.fullmatch(r"\d+\.\d+\.\d+(\.dev\d+)?", version), f"expected X.Y.Z or X.Y.Z.devN, got {version!r}"
    changelog = (ROOT / "CHANGELOG.md").read_text()
    released = RELEASE_HEADING.findall(changelog)
    assert released, "CHANGELOG.md: expected release headings '## [X.Y.Z] — YYYY-MM-DD'"
    newest, date = released[0]
    datetime.date.fromisoformat(date)  # a date that exists
    headings = re.findall(r"^## .*$", changelog, flags=re.M)
    citation = _citation()
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
