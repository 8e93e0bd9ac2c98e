"""Every chapter assert is an interval's verdict, a commented guard or an exercise's check (scripts/assert_audit.py)."""
import importlib.util
import json
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "scripts" / "assert_audit.py"
spec = importlib.util.spec_from_file_location("assert_audit", SCRIPT)
assert_audit = importlib.util.module_from_spec(spec)
spec.loader.exec_module(assert_audit)


def _notebook(tmp_path, *cells, tags=None):
    path = tmp_path / "chapter.ipynb"
    tags = tags or {}
    path.write_text(json.dumps({"cells": [{"cell_type": "code", "source": source,
                                           "metadata": {"tags": tags.get(index, [])}}
                                          for index, source in enumerate(cells)]}))
    return path


def test_the_audit_tells_intervals_guards_and_bare_comparisons_apart(tmp_path):
    path = _notebook(
        tmp_path,
        "%pip install nothing\nassert False",                                  # a magic: not parsed, not counted
        "gap = intervals.paired_difference(a, b)\nassert gap.holds('below'), 'a should be lower'",
        "# A guard on the data as built, not a result.\nassert len(clips) == 12",
        "for action in ACTIONS:\n    # an identity: the two are the same arithmetic\n    assert x == y",
        "# Checks below.\nassert mean_a < mean_b\nassert len(clips) > 0",
        "x = 1\ny = 2\nz = 3\nw = 4\nv = 5\n# a guard far above\nu = 6\nq = 7\nr = 8\ns = 9\nt = 0\nassert ok",
    )
    kinds = [(a["cell"], a["kind"]) for a in assert_audit.chapter_asserts(path)]
    assert kinds == [(1, "interval"), (2, "guard"), (3, "guard"), (4, "unmarked"), (4, "unmarked"),
                     (5, "unmarked")]


def test_an_exercise_solution_asserts_its_stated_outcome(tmp_path):
    solution = "# Solution to exercise 1\nassert ratio > 2, 'the stated outcome'"
    path = _notebook(tmp_path, solution, solution, "found = intervals.share_interval(x)\nassert found.holds('above')",
                     tags={0: ["hide-cell", "solution"], 2: ["hide-cell", "solution"]})
    kinds = [(a["cell"], a["kind"]) for a in assert_audit.chapter_asserts(path)]
    assert kinds == [(0, "exercise"), (1, "unmarked"), (2, "interval")]  # outside a solution: unmarked


def test_every_chapter_assert_is_an_interval_verdict_a_commented_guard_or_an_exercise_check():
    chapters = assert_audit.all_chapters()
    assert len(chapters) == 19
    unmarked = [f"{name} cell {a['cell']}: {a['text'][:80]}" for name, asserts in chapters.items() for a in asserts
                if a["kind"] == "unmarked"]
    assert not unmarked, "asserts that neither read an interval's verdict nor say they are guards:\n" + \
        "\n".join(unmarked)
