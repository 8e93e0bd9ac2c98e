"""The release metadata agree: one version, one repository address, the licences the metadata names."""
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


def test_one_version_everywhere():
    version = _pyproject()["project"]["version"]
    assert hoi_tutorial.__version__ == version
    assert str(_citation()["version"]) == version
    released = re.findall(r"^## \[(\d+\.\d+\.\d+)\] — (\d{4}-\d{2}-\d{2})$", (ROOT / "CHANGELOG.md").read_text(),
                          flags=re.M)
    assert released, "CHANGELOG.md: expected release headings '## [X.Y.Z] — YYYY-MM-DD'"
    assert released[0][0] == version  # the newest release is the package's version
    assert str(_citation()["date-released"]) == released[0][1]


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
