"""Source digests: comments, docstrings and blank lines leave them alone; every edit to the code changes them."""
from __future__ import annotations

import hashlib
import importlib
import pathlib
import sys

import pytest

import hoi_tutorial
from hoi_tutorial.infra import cache, pack, source_digest
from hoi_tutorial.infra.cleaned_source import _cleaned_source

# A module with every kind of docstring, comments, a string statement that is not a docstring, and a loop whose
# indentation is meaning.
SOURCE = '''\
"""A module: its docstring."""
import math

LIMIT = 3  # how many


class Box:
    """A box."""

    def area(self, side):
        """The area."""
        if side < 0:
            raise ValueError("side: expected a length >= 0")
        "a string statement, not a docstring"
        return side * side


async def fetch(n):
    """Fetch."""
    return n


def summed(values):
    total = 0
    for value in values:
        total += value * LIMIT
    return total
'''

CLEANED = '''\
import math
LIMIT = 3
class Box:
    def area(self, side):
        if side < 0:
            raise ValueError("side: expected a length >= 0")
        "a string statement, not a docstring"
        return side * side
async def fetch(n):
    return n
def summed(values):
    total = 0
    for value in values:
        total += value * LIMIT
    return total'''


def _edited(old: str, new: str) -> str:
    assert SOURCE.count(old) == 1, old
    return SOURCE.replace(old, new)


def test_the_digest_hashes_the_name_and_the_text_without_comments_docstrings_and_blank_lines():
    assert _cleaned_source(SOURCE) == CLEANED
    assert source_digest(SOURCE, "pkg.mod") == hashlib.sha256(("pkg.mod\0" + CLEANED).encode()).hexdigest()
    assert source_digest(SOURCE) == hashlib.sha256(("<source>\0" + CLEANED).encode()).hexdigest()
    assert source_digest(SOURCE, "pkg.other") != source_digest(SOURCE, "pkg.mod")


@pytest.mark.parametrize("old, new", [
    ("# how many", "# how many boxes, at most"),  # a comment
    ("LIMIT = 3  # how many\n", "LIMIT = 3\n"),  # a comment removed
    ("        return side * side\n", "        # a whole line of comment\n        return side * side\n"),
    ('"""A module: its docstring."""', '"""A module.\n\nIts docstring, over three lines now."""'),
    ('"""A box."""', "'''A box, described.'''"),  # a class's
    ('"""The area."""', '"""The area, in square units."""'),  # a function's
    ('"""Fetch."""', '"""Fetch, later."""'),  # an async function's
    ('    """Fetch."""\n', ""),  # a docstring removed
    ("    total = 0\n", "    total = 0\n\n\n"),  # blank lines added
    ("\n\nclass Box", "\nclass Box"),  # a blank line removed
    ("    return total\n", "    return total   \t\n"),  # trailing whitespace
    ("    return total\n", "    return total"),  # no newline at the end
], ids=["comment", "comment removed", "comment line", "module docstring", "class docstring", "function docstring",
        "async docstring", "docstring removed", "blank lines added", "blank line removed", "trailing whitespace",
        "no final newline"])
def test_comments_docstrings_blank_lines_and_trailing_whitespace_keep_the_digest(old, new):
    assert source_digest(_edited(old, new), "m") == source_digest(SOURCE, "m")


@pytest.mark.parametrize("old, new", [
    ("LIMIT = 3", "LIMIT = 4"),  # a constant
    ("expected a length >= 0", "expected a length > 0"),  # an error message
    ("a string statement, not a docstring", "another string statement"),  # a string further down a body
    ("        total += value * LIMIT\n    return total\n",
     "        total += value * LIMIT\n        return total\n"),  # indentation: a return inside the loop
    ("total = 0\n    for value in values:\n        total += value * LIMIT\n    return total",
     "result = 0\n    for value in values:\n        result += value * LIMIT\n    return result"),  # a renamed variable
    ("import math\n", "import math as m\n"),
], ids=["constant", "error message", "string statement", "indentation", "renamed variable", "import"])
def test_an_edit_to_the_code_changes_the_digest(old, new):
    assert source_digest(_edited(old, new), "m") != source_digest(SOURCE, "m")


def test_every_character_of_a_string_over_several_lines_counts():
    text = 'TEMPLATE = """first\n\nlast"""  # a template\n'
    assert _cleaned_source(text) == 'TEMPLATE = """first\n\nlast"""'
    for edited in ('TEMPLATE = """first\nlast"""\n', 'TEMPLATE = """first  \n\nlast"""\n',
                   'TEMPLATE = f"""first\n\n{1}last"""\n'):
        assert source_digest(edited) != source_digest(text)
    assert source_digest('TEMPLATE = """first\n\nlast"""  \n\n') == source_digest(text)


def test_non_ascii_text_is_cut_where_the_comments_and_docstrings_are():
    # ast counts columns in UTF-8 bytes, tokenize in characters: "θ" and "≤" are two and three bytes, one character
    text = ('ANGLE = "θ ≤ π"  # θ in radians, ≤ π\n'
            "def turned(θ):  # ≤\n"
            '    """Turned by θ ≤ π."""\n'
            "    return θ * 2  # doubled θ\n"
            'def bound(): "θ ≤ the bound"; return "≤"\n')
    assert _cleaned_source(text) == ('ANGLE = "θ ≤ π"\n'
                                     "def turned(θ):\n"
                                     "    return θ * 2\n"
                                     'def bound(): ; return "≤"')
    assert source_digest(text.replace("doubled θ", "θ twice")) == source_digest(text)
    assert source_digest(text.replace('return "≤"', 'return "<"')) != source_digest(text)


def test_an_indented_fragment_is_cleaned_dedented_and_one_that_does_not_parse_is_hashed_raw():
    method = '    def area(self):\n        """The area."""\n        return 1  # one\n'
    assert _cleaned_source(method) == "def area(self):\n    return 1"
    fragment = "    build = lambda: make(x,\n"  # a lambda's line from inspect.getsource: no closing parenthesis
    assert _cleaned_source(fragment) is None
    assert source_digest(fragment) == source_digest(fragment)
    assert source_digest(fragment) == hashlib.sha256(("<source>\0raw\0" + fragment).encode()).hexdigest()
    assert source_digest(fragment + "  # a comment\n") != source_digest(fragment)  # raw: everything counts


# ------------------------------------------------------------------------------------- the cache and the pack


def test_an_edit_to_prose_keeps_a_modules_keys_and_an_edit_to_code_changes_them(derived_package, monkeypatch):
    monkeypatch.setattr(sys, "dont_write_bytecode", True)  # a reload must read the edited file, not a stale .pyc
    root = derived_package("digestprobe", {
        "digestprobe/__init__.py": "",
        "digestprobe/tool.py": "SCALE = 2\n\n\ndef build():\n    return {'v': SCALE}\n",
    })
    module = importlib.import_module("digestprobe.tool")

    def keys():
        importlib.reload(module)
        return (cache.module_digests([module.__name__]), cache.artifact_key("x", {"a": 1}, code=(module,)),
                cache.artifact_key("x", {"a": 1}, code=(module.build,)))

    before = keys()
    path = root / "digestprobe/tool.py"
    path.write_text('"""A tool: its docstring."""\n\nSCALE = 2  # the scale\n\n\n\ndef build():\n'
                    '    """The artifact."""\n    # a comment line\n    return {\'v\': SCALE}  \n')
    assert keys() == before
    path.write_text("SCALE = 3\n\n\ndef build():\n    return {'v': SCALE}\n")
    after = keys()
    assert after[0] != before[0] and after[1] != before[1] and after[2] != before[2]


def test_the_pack_and_the_cache_digest_the_installed_code_alike():
    name = "hoi_tutorial.infra.cache"
    assert pack._installed_digest(name) == cache.module_digests([name])[name]
    assert pack._installed_digest("hoi_tutorial.no_such_module") is None


def test_every_library_file_is_cleaned_not_hashed_raw():
    root = pathlib.Path(hoi_tutorial.__file__).parent
    files = sorted(root.rglob("*.py"))
    assert len(files) > 50
    assert [str(p.relative_to(root)) for p in files if _cleaned_source(cache._file_source(p)) is None] == []
