"""A digest of Python source by what it runs: comments, docstrings and blank lines do not count.

The artifact cache keys an artifact by the source of the code that built it, and a pretrained pack records the same
digests to tell whether the installed code is the code that built its artifacts (``cache.module_digests``). A
digest of the raw file bytes changed with every comment, docstring or blank line: each such edit rebuilt every
artifact and refused every published pack, though none changes what an artifact is made of. This digest hashes
the text with these removed:

- comments (``tokenize``'s COMMENT tokens);
- docstrings: the first statement of a module, class, function or async function body when it is a string
  literal (``ast``). Every other string counts: an error message, a constant, a string statement further down;
- blank lines, and the whitespace that ends a line outside a string literal.

Indentation counts (it is meaning in Python), and so does every character of a string literal, the lines of one
that spans lines included. What is hashed is the cleaned text, not a token stream (``tokenize`` splits an f-string
into several tokens from Python 3.12 on), so Python 3.10 to 3.13 give the same digest for the same file. Text that
does not parse, even dedented (a lambda's lines from ``inspect.getsource``), is hashed as it is: its digest changes
more often than needed, never less.
"""
from __future__ import annotations

import ast
import functools
import hashlib
import io
import textwrap
import tokenize
from typing import Iterator, Optional

__all__ = ["source_digest"]

# (first line, first column, last line, end column): lines from 1 and columns in characters, the end excluded
Span = tuple[int, int, int, int]

# Tokens that open and close an f-string (Python 3.12+) or a t-string (3.14+); earlier, one STRING token.
_STRING_OPENS = {getattr(tokenize, name) for name in ("FSTRING_START", "TSTRING_START") if hasattr(tokenize, name)}
_STRING_CLOSES = {getattr(tokenize, name) for name in ("FSTRING_END", "TSTRING_END") if hasattr(tokenize, name)}


@functools.lru_cache(maxsize=1024)  # the cache asks for the same modules at every key; parsing one takes milliseconds
def source_digest(text: str, name: str = "<source>") -> str:
    """The sha256 hex of ``name`` and the Python source ``text`` without comments, docstrings and blank lines.

    Args:
        text: a module's text, or a fragment (a function's, a class's) that parses once dedented.
        name: what the text is (a module's name); part of the digest, so that two modules of one text differ.
    """
    cleaned = _cleaned_source(text)
    body = "\0" + cleaned if cleaned is not None else "\0raw\0" + text  # source never holds "\0": no overlap
    return hashlib.sha256((name + body).encode("utf-8", "surrogatepass")).hexdigest()


def _cleaned_source(text: str) -> Optional[str]:
    """``text`` without comments, docstrings, blank lines and line-ending whitespace, lines joined by ``"\\n"``;
    ``None`` when neither it nor its dedented text parses (the digest then takes the raw text)."""
    text = text.replace("\r\n", "\n").replace("\r", "\n")  # as Python reads a file, and one index per line
    for candidate in (text, textwrap.dedent(text)):
        try:
            return _cleaned(candidate)
        except (SyntaxError, ValueError, tokenize.TokenError, RecursionError):
            continue  # ValueError: a null byte (before 3.12), or text that UTF-8 cannot encode
    return None


def _cleaned(text: str) -> str:
    """The cleaned ``text`` (lines joined by ``"\\n"``); raises what ``ast.parse`` or ``tokenize`` raise."""
    lines = text.split("\n")
    tree = ast.parse(text)
    tokens = list(tokenize.generate_tokens(io.StringIO(text).readline))
    docstrings = list(_docstring_spans(tree, lines))
    comments = [(*token.start, token.start[0], token.start[1] + len(token.string))  # a comment ends its line
                for token in tokens if token.type == tokenize.COMMENT]
    cut = _ranges_by_line(docstrings + comments, lines)
    open_lines = _lines_ending_in_a_string(tokens, docstrings)
    kept = []
    for number, line in enumerate(lines, start=1):
        line = _without(line, cut.get(number, ()))
        if number in open_lines:
            kept.append(line)  # the rest of the line is a string literal's: every character counts
        elif line.rstrip():
            kept.append(line.rstrip())
    return "\n".join(kept)


def _ranges_by_line(spans: list[Span], lines: list[str]) -> dict[int, list[tuple[int, int]]]:
    """``{line number: [(start, end) character ranges]}`` that ``spans`` cover, line by line."""
    cut = {}
    for first, start, last, end in spans:
        for number in range(first, last + 1):
            cut.setdefault(number, []).append((start if number == first else 0,
                                               end if number == last else len(lines[number - 1])))
    return cut


def _without(line: str, ranges) -> str:
    """``line`` less the characters in ``ranges`` (``(start, end)`` pairs, end excluded, in any order, may overlap)."""
    pieces, at = [], 0
    for start, end in sorted(ranges):
        pieces.append(line[at:max(at, start)])
        at = max(at, end)
    return "".join(pieces) + line[at:]


def _character_column(line: str, utf8_offset: int) -> int:
    """The character index in ``line`` of ``ast``'s column ``utf8_offset`` (a UTF-8 byte offset)."""
    return len(line.encode("utf-8")[:utf8_offset].decode("utf-8"))


def _docstring_spans(tree: ast.AST, lines: list[str]) -> Iterator[Span]:
    """Where each docstring is: the first statement of a module, class or function body that is a string literal."""
    for node in ast.walk(tree):
        if not isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) or not node.body:
            continue
        first = node.body[0]
        if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
            yield (first.lineno, _character_column(lines[first.lineno - 1], first.col_offset),
                   first.end_lineno, _character_column(lines[first.end_lineno - 1], first.end_col_offset))


def _lines_ending_in_a_string(tokens: list[tokenize.TokenInfo], docstrings: list[Span]) -> set[int]:
    """The numbers of the lines whose end lies inside a string literal that is not a docstring: their blank lines
    and trailing whitespace are the string's characters. Only a literal's first position and last line are read:
    Python 3.12.1 gives the end column of a literal over several lines in bytes, where others give characters."""
    inside = set()
    depth, opened = 0, None  # how deep in f-strings, and where the outermost one opened
    for token in tokens:
        if token.type in _STRING_OPENS:
            opened = opened if depth else token.start
            depth += 1
            continue
        if token.type in _STRING_CLOSES:
            depth -= 1
            start, last = (None, None) if depth else (opened, token.end[0])
        elif token.type == tokenize.STRING and not depth:
            start, last = token.start, token.end[0]
        else:
            continue
        if start is not None and start[0] < last and not any(doc[:2] <= start < doc[2:] for doc in docstrings):
            inside.update(range(start[0], last))
    return inside
