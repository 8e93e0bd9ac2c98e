"""The hashed locks of scripts/lock_pythons.py, one per Python a reader may use, against requirements.txt (no network:
the resolution itself is the script's, run where the package index is reachable)."""
from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("lock_pythons", ROOT / "scripts" / "lock_pythons.py")
lock_pythons = importlib.util.module_from_spec(spec)
spec.loader.exec_module(lock_pythons)

LOCKS = sorted((ROOT / "locks").glob("py*-*.txt"))
PIN = re.compile(r"^(?P<name>[A-Za-z0-9._-]+)==(?P<version>\S+) \\\n    --hash=sha256:(?P<digest>[0-9a-f]{64})$", re.M)


def read_lock(path: Path) -> dict:
    text = path.read_text()
    pins = {m["name"].lower().replace("_", "-"): Version(m["version"]) for m in PIN.finditer(text)}
    entries = [block for block in text.split("\n") if block and not block.startswith(("#", "    --hash"))]
    assert len(entries) == len(pins), f"{path.name}: a line that is not 'name==version' with its hash"
    return pins


def test_a_lock_for_every_python_a_reader_may_use():
    pythons = {re.match(r"py(\d+\.\d+)-", path.name)[1] for path in LOCKS}
    assert set(lock_pythons.PYTHONS) <= pythons, pythons


@pytest.mark.parametrize("path", LOCKS, ids=[path.name for path in LOCKS])
def test_each_lock_pins_every_requirement_within_its_bounds_with_a_hash(path):
    python = re.match(r"py(\d+\.\d+)-", path.name)[1]
    assert path.read_text().startswith(f"# Python {python},")  # `make venv` reads the Python from this header
    pins = read_lock(path)
    for line in lock_pythons.requirement_lines(ROOT / "requirements.txt"):
        requirement = Requirement(line)
        name = requirement.name.lower()
        if name in lock_pythons.NOT_LOCKED:
            assert name not in pins, f"{path.name} pins {name}, which TORCH_SPEC pins"
            continue
        assert name in pins, f"{path.name}: {name} is not pinned"
        assert requirement.specifier.contains(pins[name], prereleases=True), \
            f"{path.name}: {name}=={pins[name]} is outside requirements.txt's {requirement.specifier}"
    assert not [name for name in pins if name.startswith("nvidia-") or name in ("triton", "hoi-tutorial")]


def test_requirement_names_are_read_as_pip_reads_them():
    assert lock_pythons.requirement_name("scikit-fmm>=2023.4") == "scikit-fmm"
    assert lock_pythons.requirement_name("jupyter-book>=1.0,<2") == "jupyter-book"
    assert lock_pythons.requirement_name("Torch >= 2.10") == "torch"
