"""The toy world is bit-for-bit what ``tests/data/world_fingerprints.json`` records.

The JSON holds SHA-256 fingerprints of toy-mocap clips, objects and scenes (see
``scripts/world_fingerprints.py``). When the toy world changes on purpose, regenerate it with

    python scripts/world_fingerprints.py --write tests/data/world_fingerprints.json
"""
import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "world_fingerprints.json"

pytestmark = pytest.mark.slow


def _script():
    spec = importlib.util.spec_from_file_location("world_fingerprints", ROOT / "scripts" / "world_fingerprints.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_world_matches_recorded_fingerprints():
    script = _script()
    expected = json.loads(GOLDEN.read_text(encoding="utf-8"))
    differences = script.compare(expected, script.fingerprints())
    assert not differences, (
        f"{len(differences)} of {len(expected)} toy-world fingerprints differ from {GOLDEN.name}:\n"
        + "\n".join(differences[:50])
        + ("\n..." if len(differences) > 50 else "")
        + "\nIf the toy world changed on purpose, regenerate the file with\n"
        "    python scripts/world_fingerprints.py --write tests/data/world_fingerprints.json"
    )
