"""Resolve requirements.txt for every Python a reader may use and write one hashed lock per Python.

`make lock` (scripts/lock_requirements.sh) installs the requirements into a fresh environment of *this* machine's
Python and freezes it: one lock, for one Python. A reader on Colab runs another Python, and the interpreters of
other versions cannot always be installed where the lock is made. pip's resolver can resolve for a Python it does
not run on (``--python-version``, ``--platform``), from the wheels each release publishes for it; this script asks
it to, once per Python, and writes ``locks/py<X.Y>-<platform>.txt``: every distribution at its exact version with
the SHA-256 of the file pip chose (pip's hash-checking format), so that

    pip install torch==2.13.0
    pip install --require-hashes -r locks/py3.13-manylinux_x86_64.txt
    pip install --no-deps -e .

installs exactly what was resolved, or refuses a file that differs. Not in a lock: torch (its build differs between
CPU, CUDA and Colab; ``TORCH_SPEC`` pins it, as in `make venv`) and the package itself. scikit-fmm publishes no
wheels, only a source archive that pip compiles: it is resolved on its own, its archive's hash pinned.

    python scripts/lock_pythons.py                      # 3.10-3.13, manylinux x86_64 (Colab's platform)
    python scripts/lock_pythons.py --pythons 3.13

It needs the package index (the network), not the interpreters. ``tests/test_locks.py`` checks every lock against
requirements.txt without the network.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]
PYTHONS = ("3.10", "3.11", "3.12", "3.13")
# The wheel tags a manylinux x86_64 machine (Colab's) accepts, newest first: pip takes a target's tags only as given.
PLATFORMS = {"manylinux_x86_64": ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64",
                                  "manylinux2014_x86_64", "manylinux1_x86_64", "linux_x86_64")}
NOT_LOCKED = ("torch",)            # pinned by TORCH_SPEC where the book is installed
SOURCE_ONLY = ("scikit-fmm",)      # no wheels published: resolved on its own, its source archive's hash pinned


def requirement_name(line: str) -> str:
    """The distribution a requirements line names (``"scikit-fmm>=2023.4"`` -> ``"scikit-fmm"``), lower case."""
    return Requirement(line).name.lower()


def requirement_lines(path: Path) -> list[str]:
    """The requirement lines of a requirements file, comments and blank lines dropped."""
    lines = [line.split("#", 1)[0].strip() for line in path.read_text().splitlines()]
    return [line for line in lines if line]


def _resolve(python: str, platform: str, requirements: list[str], no_deps: bool) -> list[dict]:
    """pip's resolution of ``requirements`` for ``python`` on ``platform``: the report's ``install`` records."""
    with tempfile.TemporaryDirectory() as work:
        report = Path(work) / "report.json"
        command = [sys.executable, "-m", "pip", "install", "--dry-run", "--ignore-installed", "--quiet",
                   "--python-version", python, "--target", str(Path(work) / "target"), "--report", str(report)]
        command += ["--no-deps"] if no_deps else ["--only-binary=:all:"]
        for tag in PLATFORMS[platform]:
            command += ["--platform", tag]
        subprocess.run(command + requirements, check=True)
        return json.loads(report.read_text())["install"]


def lock_text(python: str, platform: str, records: list[dict]) -> str:
    """The lock file for one Python: a header, then ``name==version --hash=sha256:...`` per distribution."""
    lines = [f"# Python {python}, {platform}: every distribution requirements.txt resolves to, at its exact version",
             "# with the SHA-256 of the file pip chose (pip install --require-hashes -r this file). Written by",
             "# scripts/lock_pythons.py; torch is pinned by TORCH_SPEC instead, scikit-fmm is a source archive."]
    for record in sorted(records, key=lambda r: r["metadata"]["name"].lower()):
        name, version = record["metadata"]["name"], record["metadata"]["version"]
        digest = record["download_info"]["archive_info"]["hashes"]["sha256"]
        lines.append(f"{name}=={version} \\\n    --hash=sha256:{digest}")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pythons", nargs="+", default=list(PYTHONS))
    parser.add_argument("--platform", default="manylinux_x86_64", choices=sorted(PLATFORMS))
    parser.add_argument("--out", type=Path, default=ROOT / "locks")
    args = parser.parse_args(argv)
    requirements = requirement_lines(ROOT / "requirements.txt")
    wheels = [r for r in requirements if requirement_name(r) not in NOT_LOCKED + SOURCE_ONLY]
    sources = [r for r in requirements if requirement_name(r) in SOURCE_ONLY]
    args.out.mkdir(parents=True, exist_ok=True)
    for python in args.pythons:
        records = _resolve(python, args.platform, wheels, no_deps=False)
        records += _resolve(python, args.platform, sources, no_deps=True) if sources else []
        path = args.out / f"py{python}-{args.platform}.txt"
        path.write_text(lock_text(python, args.platform, records))
        print(f"wrote {path.relative_to(ROOT)} ({len(records)} distributions)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
