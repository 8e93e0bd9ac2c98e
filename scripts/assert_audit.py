"""List every chapter's asserts and what kind of check each is.

    python scripts/assert_audit.py            # one line per assert
    python scripts/assert_audit.py --summary  # counts per chapter

Conventions (book/conventions.md, "Comparisons and uncertainty"): an assert on a computed comparison reads the
verdict of an interval (``interval.holds(...)``); any other assert checks how something was built (a shape, a
guard, an identity) and says so in a comment just above it. This script sorts the asserts of ``notebooks/*.ipynb``
into those two kinds and flags the rest:

- ``interval``: the asserted expression calls ``.holds(``;
- ``guard``: a comment in the few lines above says it is a guard, a wiring or protocol check, an identity or a
  property that holds by design;
- ``exercise``: an assert in an exercise's solution (a cell tagged ``solution``) that is neither of the above: it
  checks the outcome the exercise states, with the margin its text gives ("How a chapter is laid out"), so that
  a change of the library that breaks an exercise fails the build; it is not a claim of the paper;
- ``unmarked``: none of these (``tests/test_chapter_asserts.py`` requires there be none).
"""
from __future__ import annotations

import argparse
import ast
import json
import pathlib
import re
from collections import Counter

ROOT = pathlib.Path(__file__).resolve().parents[1]
# Words a comment above a by-design assert uses.
GUARD_WORDS = re.compile(r"guard|wiring|identity|by design|by construction|not a comparison|propert|protocol|"
                         r"cross-check|known answer|floor|checks? of what|not comparisons", re.IGNORECASE)
LOOKBACK = 4  # lines above an assert searched for its comment, besides the block of asserts it heads


def _code(cell) -> str:
    return "".join(cell["source"])


def _block_above(lines: list[str], index: int) -> list[str]:
    """The assert's line and the block above it that its comment may head: comment lines, other asserts and their
    continuation lines, and the headers of loops and conditions they sit in, up to the first other statement."""
    block = [lines[index]]
    indent = len(lines[index]) - len(lines[index].lstrip())
    for line in reversed(lines[:index]):
        stripped = line.strip()
        own_indent = len(line) - len(line.lstrip())
        if not stripped:
            break
        if (stripped.startswith(("#", "assert")) or own_indent > indent
                or (stripped.endswith(":") and stripped.split()[0] in ("for", "if", "with", "while"))):
            block.append(line)
            indent = min(indent, own_indent)
            continue
        break
    return block


def chapter_asserts(path: pathlib.Path) -> list[dict]:
    """The asserts of one notebook: ``{"cell", "line", "text", "kind"}`` each, in order."""
    found = []
    cells = json.loads(path.read_text())["cells"]
    for index, cell in enumerate(cells):
        if cell["cell_type"] != "code" or "assert" not in _code(cell):
            continue
        source = _code(cell)
        in_solution = "solution" in cell.get("metadata", {}).get("tags", [])
        try:
            tree = ast.parse(source)
        except SyntaxError:  # IPython magics: the set-up cell, which holds no assert
            continue
        lines = source.splitlines()
        for node in ast.walk(tree):
            if not isinstance(node, ast.Assert):
                continue
            test = ast.get_source_segment(source, node.test) or ""
            near = lines[max(0, node.lineno - 1 - LOOKBACK):node.lineno - 1]
            comments = " ".join(line.split("#", 1)[1] for line in _block_above(lines, node.lineno - 1) + near
                                if "#" in line)
            if ".holds(" in test:
                kind = "interval"
            elif GUARD_WORDS.search(comments):
                kind = "guard"
            elif in_solution:
                kind = "exercise"
            else:
                kind = "unmarked"
            found.append({"cell": index, "line": node.lineno, "text": " ".join(test.split()), "kind": kind})
    return found


def all_chapters() -> dict[str, list[dict]]:
    return {path.stem: chapter_asserts(path) for path in sorted((ROOT / "notebooks").glob("*.ipynb"))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--summary", action="store_true", help="counts per chapter instead of one line per assert")
    args = parser.parse_args()
    chapters = all_chapters()
    if args.summary:
        total = Counter()
        for name, asserts in chapters.items():
            counts = Counter(a["kind"] for a in asserts)
            total.update(counts)
            print(f"{name:40s} " + ", ".join(f"{counts[k]} {k}" for k in ("interval", "guard", "exercise", "unmarked")))
        print(f"{'all chapters':40s} " + ", ".join(f"{total[k]} {k}" for k in ("interval", "guard", "exercise", "unmarked")))
        return
    for name, asserts in chapters.items():
        for a in asserts:
            print(f"{name} cell {a['cell']} line {a['line']}: {a['kind']:8s} {a['text'][:110]}")


if __name__ == "__main__":
    main()
