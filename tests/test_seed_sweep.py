"""The seed sweep's reader of verdicts (scripts/seed_sweep.py)."""
import importlib.util
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "seed_sweep.py"
sys.path.insert(0, str(SCRIPT.parent))
spec = importlib.util.spec_from_file_location("seed_sweep", SCRIPT)
seed_sweep = importlib.util.module_from_spec(spec)
spec.loader.exec_module(seed_sweep)


def test_verdict_lines_are_the_printed_lines_that_carry_a_verdict():
    notebook = {"cells": [
        {"cell_type": "markdown", "source": ["the claim is held"]},
        {"cell_type": "code", "outputs": [
            {"output_type": "stream", "name": "stdout",
             "text": ["Supp. G: sit PE -14.7 cm [-30.4, 0.335]: 'lower with the encoder' is inconclusive\n",
                      "device: cpu\n", "[cache] loaded samp_motion_samp (6.8 MB): held\n"]},
            {"output_type": "stream", "name": "stderr", "text": "MotionNet:  50%|█████     | 450/900 [held]\n"},
            {"output_type": "execute_result", "data": {"text/plain": ["'x' is held"]}}]},
        {"cell_type": "code", "outputs": [
            {"output_type": "stream", "name": "stdout", "text": "goals reached 40 points: 'more' is held\n"
                                                                "planning: 'less' is not held\n"}]}]}
    assert seed_sweep.verdict_lines(notebook) == [
        "Supp. G: sit PE -14.7 cm [-30.4, 0.335]: 'lower with the encoder' is inconclusive",
        "goals reached 40 points: 'more' is held", "planning: 'less' is not held"]
