"""Measure each chapter's prose against the chapter template, and check the template's markers.

The template (short sentences, the method equation by equation, a summary, exercises, and the intervals, seeds and
verdicts moved to a folded ``## Reproduction check`` at the end) is described in the book's contributor notes; this
script turns it into numbers and into a pass/fail check. It uses the standard library only (the notebooks are read
as JSON), so it runs before any environment is installed.

What it measures, per chapter (one table row each):

- ``main words``: words of the *main text*, the markdown cells before the ``## Reproduction check`` heading (the
  part of the heading's own cell above it included); the whole notebook's markdown when there is no such heading.
  ``check words``: words of the markdown from that heading on.
- ``median`` / ``mean``: the median and mean sentence length (words) of the main text.
- ``num/100w``: numbers per 100 main-text words: digit runs (a decimal part included) outside inline code and
  math, references to numbered things left out (``Eq. 11``, ``Table 3``, ``§8.2``, ``Chapter 2``, ``Figure 4``,
  ``Algorithm 1``, ``Exercise 2``, ``Section 3``, ``Step 2``).
- ``share %``: the share of main-text words in sentences about intervals, seeds, verdicts or the ledger: a sentence
  counts, all its words, when it contains a word of :data:`INTERVAL_VOCABULARY`.
- ``eqs`` / ``tagged``: displayed equations in the markdown (each ``$$ ... $$`` block and each ``{math}`` directive
  counted once), and how many of them carry a ``\\tag{...}``.
- ``eq cells``: code cells tagged ``equation`` that contain ``assert_allclose`` or ``assert_close``.
- ``pseudo``: pseudocode boxes, directives with the option ``:class: pseudocode``.
- ``exercises`` / ``solutions``: ``### Exercise N`` headings, and code cells tagged ``solution`` containing ``assert``.
- ``figures``: code cells that show a figure, by a simple proxy: the cell calls ``plt.show(``, ``display(fig``, or a
  plotting / showing function of the book's ``viz`` package (``viz.plot_...(``, ``viz.show_...(``,
  ``viz.render_...(``, ``viz.animate_...(``).
- ``history``: development-history phrases (:data:`HISTORY_PHRASES`) found in the main text.

Text preparation before counting words and sentences (:func:`prose`): heading lines, fenced code blocks (``````` and
``~~~``), displayed math (``$$ ... $$`` and ``{math}``), MyST directive fences and their ``:option:`` lines, markdown
table lines (starting with ``|``), HTML comments and tags, and images are dropped; the text inside admonitions,
dropdowns and the other :data:`PROSE_DIRECTIVES` is kept, the body of any other directive (``literalinclude``,
``code-cell``, ``figure`` ...) dropped. ``[text](url)`` becomes ``text``; a role such as ``{cite:p}`key``` becomes
one word, an inline math span ``$...$`` one word, an inline code span one word. A word is a whitespace-separated
token with at least one letter or digit.

Sentences (:func:`sentences`) end at ``.``, ``?`` or ``!`` followed by white space (closing quotes or brackets in
between allowed), at blank lines and at the start of each bullet item (each bullet ends a sentence); not after the
abbreviations of :data:`ABBREVIATIONS` (``e.g.``, ``i.e.``, ``Eq.``, ``Fig.``, ``cf.``, ``vs.``, ``et al.`` ...) and
never inside a decimal number (``0.5``).

``--check`` exits 1 and prints one line per missing part, ``<chapter>: <what is missing>``, when a chapter misses
one of the template's parts (:func:`template_problems`):

1. the first markdown cell starts with a ``# `` title and contains "You will learn", "Prerequisites" and "Time";
2. the parameters cell (tag ``parameters``) is also tagged ``hide-input``;
3. a ``## Summary`` heading with 3-5 bullets after it in its cell;
4. a ``## Exercises`` heading; at least 3 ``### Exercise N`` headings numbered 1..n in order; for each, a solution
   cell (tags ``solution`` and ``hide-cell``, so source and output are folded; first line
   ``# Solution to exercise N``) after it that contains ``assert``; at least one exercise with a visible code cell (not tagged ``solution``, ``hide-*``,
   ``remove-cell`` or ``remove-input``) between its heading and its solution (the "complete this function" one);
5. ``## Reproduction check`` is the last H2 heading; after it every markdown cell's text, headings aside, is inside
   ``{dropdown}`` blocks (colon or backtick fences; an admonition with ``:class: dropdown`` also counts) and every
   code cell is tagged ``hide-cell`` or ``hide-input``;
6. the order: title, ``## Summary``, ``## Exercises``, ``## Reproduction check``;
7. every displayed equation carrying a ``\\tag{...}`` is followed, before the next tagged displayed equation or the
   next H2 heading, by a code cell tagged ``equation`` with ``assert_allclose`` / ``assert_close``; at least one
   such cell per chapter; every cell tagged ``equation`` has one of those asserts;
8. main-text share <= :data:`MAX_INTERVAL_SHARE` % and median sentence length <= :data:`MAX_MEDIAN_SENTENCE` words;
9. no history phrase in the main text.

Usage::

    python scripts/prose_stats.py                       # every notebooks/*.ipynb, a markdown table
    python scripts/prose_stats.py notebooks/18_*.ipynb  # some chapters
    python scripts/prose_stats.py --json                # the same numbers as JSON
    python scripts/prose_stats.py --check               # exit 1 and list what each chapter misses
    python scripts/prose_stats.py --check notebooks/17_choice_table3.ipynb
"""
from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import List, Optional, Sequence, Tuple

REPO_ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK_DIR = REPO_ROOT / "notebooks"

# Thresholds of check 8 (the template's prose rules for the main text).
MAX_INTERVAL_SHARE = 15.0  # % of main-text words in interval/seed/verdict/ledger sentences
MAX_MEDIAN_SENTENCE = 25.0  # words

# The heading that starts the folded part of a chapter; matched on an H2 title, case-insensitively.
REPRODUCTION_HEADING = "reproduction check"

# A sentence is "about intervals, seeds, verdicts or the ledger" when it contains one of these (regular
# expressions, matched case-insensitively as whole words). Kept deliberately small: words the book uses for its
# statistical protocol and its verdicts, not for the methods it explains.
INTERVAL_VOCABULARY = (
    r"intervals?",  # confidence, bootstrap, Wilson intervals
    r"bootstrap\w*",  # bootstrap, bootstrapped
    r"seeds?|seeded",  # seed, seeds, the SEED parameter
    r"verdicts?",
    r"inconclusive",
    r"ledger",  # the results ledger
    r"paired",  # paired comparisons / differences
    r"coverage",
    r"straddl\w*",  # an interval straddles zero
    r"(?:not\s+)?held(?![- ]out)",  # "held" / "not held" as a verdict; "held-out" data is not one
    r"confidence",  # confidence level / interval
    r"(?:not\s+|partly\s+)?reproduced",  # the verdicts "reproduced", "not reproduced"
    r"wilson",  # the Wilson score interval
)
INTERVAL_RE = re.compile(r"\b(?:%s)\b" % "|".join(f"(?:{p})" for p in INTERVAL_VOCABULARY), re.IGNORECASE)

# Development history has no place in a chapter (check 9). Conservative on purpose: phrases that hardly occur
# except when a text talks about its own earlier states.
HISTORY_PHRASES = (
    r"earlier version",
    r"first written",
    r"previous version",
    r"an older version",
    r"until recently",
    r"this session",
)
HISTORY_RE = re.compile(r"\b(?:%s)\b" % "|".join(HISTORY_PHRASES), re.IGNORECASE)

# No sentence ends after these (compared case-insensitively, without the final period).
ABBREVIATIONS = frozenset({"e.g", "i.e", "eq", "eqs", "fig", "figs", "sec", "secs", "cf", "vs", "al", "approx",
                           "resp", "ref", "refs", "tab", "alg", "ch"})

# Directives whose body is prose (kept for the word counts); the body of any other directive is dropped.
PROSE_DIRECTIVES = frozenset({"admonition", "dropdown", "note", "tip", "hint", "important", "warning", "caution",
                              "attention", "danger", "error", "seealso", "margin", "sidebar", "topic", "epigraph",
                              "pull-quote", "card", "tab-set", "tab-item", "div", "exercise", "solution"})
MATH_DIRECTIVES = frozenset({"math"})

# Numbers right after these are references to numbered things, not quantities.
REFERENCE_WORDS = r"(?:eqs?\.|equations?|tables?|figs?\.|figures?|secs?\.|sections?|§|algorithms?|chapters?|exercises?|steps?)"
REFERENCE_BEFORE_RE = re.compile(REFERENCE_WORDS + r"\s*$", re.IGNORECASE)
NUMBER_RE = re.compile(r"(?<![\w.])\d+(?:[.,]\d+)*")

# Code cells counted as figures (a proxy: see the module docstring).
FIGURE_RE = re.compile(r"plt\.show\(|display\(\s*fig\b|\bviz\.(?:\w+\.)?(?:plot|show|render|animate)_\w*\(")
# The asserts an equation cell checks the library with.
EQUATION_ASSERT_RE = re.compile(r"assert_allclose|assert_close")
TAG_RE = re.compile(r"\\tag\{([^}]*)\}")
HIDDEN_TAGS = frozenset({"solution", "remove-cell", "remove-input"})

_HEADING_RE = re.compile(r"^ {0,3}(#{1,6})(?:[ \t]+(.*?))?[ \t]*#*[ \t]*$")
_BACKTICK_OPEN_RE = re.compile(r"^\s*(`{3,}|~{3,})\s*(.*?)\s*$")
_COLON_OPEN_RE = re.compile(r"^\s*(:{3,})\s*\{([\w:.-]+)\}\s*(.*?)\s*$")
_DIRECTIVE_INFO_RE = re.compile(r"^\{([\w:.-]+)\}\s*(.*)$")
_OPTION_RE = re.compile(r"^\s*:([\w-]+):(?:\s+(.*?))?\s*$")
_BULLET_RE = re.compile(r"^(\s*)(?:[-*+]|\d+[.)])\s+")
_RULE_RE = re.compile(r"^\s*(?:-{3,}|\*{3,}|_{3,})\s*$")
_SENTENCE_END_RE = re.compile(r"[.?!][\"'\u201d\u2019)\]*_]*\s+")


# ---------------------------------------------------------------------------------------------------------------
# Reading notebooks


def load_notebook(path) -> dict:
    """The notebook at ``path`` as a dict (its JSON), every cell's ``source`` joined into one string."""
    nb = json.loads(Path(path).read_text(encoding="utf-8"))
    for cell in nb.get("cells", []):
        if isinstance(cell.get("source"), list):
            cell["source"] = "".join(cell["source"])
    return nb


def cell_source(cell: dict) -> str:
    source = cell.get("source", "")
    return "".join(source) if isinstance(source, list) else source


def cell_tags(cell: dict) -> List[str]:
    return list(cell.get("metadata", {}).get("tags", []) or [])


# ---------------------------------------------------------------------------------------------------------------
# Scanning markdown: which lines are prose, headings, fences, code, math


@dataclass
class Line:
    """One line of a markdown cell as :func:`scan` classifies it.

    ``kind``: ``prose``, ``blank``, ``heading``, ``fence`` (a fence's opening or closing line), ``option`` (a
    directive's ``:option:`` line), ``code`` (inside a code block or a non-prose directive) or ``math`` (the whole
    body of a ``{math}`` directive, emitted at its closing fence). ``dropdown``: inside a dropdown block.
    """

    kind: str
    text: str
    dropdown: bool = False
    level: int = 0  # a heading's level


@dataclass
class _Frame:
    char: str
    length: int
    name: Optional[str]  # the directive's name; None for a plain code block
    classes: set = field(default_factory=set)
    options_open: bool = True
    yaml_open: bool = False
    body: list = field(default_factory=list)

    @property
    def kept(self) -> bool:
        return self.name in PROSE_DIRECTIVES

    @property
    def dropdown(self) -> bool:
        return self.name == "dropdown" or (self.name == "admonition" and "dropdown" in self.classes)


def _closes(line: str, frame: _Frame) -> bool:
    stripped = line.strip()
    return (len(stripped) >= frame.length and set(stripped) == {frame.char})


def _opener(line: str) -> Optional[_Frame]:
    match = _COLON_OPEN_RE.match(line)
    if match:
        return _Frame(":", len(match.group(1)), match.group(2).lower())
    match = _BACKTICK_OPEN_RE.match(line)
    if match:
        fence, info = match.groups()
        if fence[0] == "`" and "`" in info:
            return None  # inline code, not a fence
        directive = _DIRECTIVE_INFO_RE.match(info)
        return _Frame(fence[0], len(fence), directive.group(1).lower() if directive else None)
    return None


def scan(markdown: str) -> List[Line]:
    """Classify every line of a markdown cell (see :class:`Line`); HTML comments are removed first."""
    markdown = re.sub(r"<!--.*?-->", "", markdown, flags=re.DOTALL)
    lines: List[Line] = []
    stack: List[_Frame] = []

    def in_dropdown() -> bool:
        return any(f.dropdown for f in stack)

    def close(frame: _Frame, text: str):
        stack.pop()
        if frame.name in MATH_DIRECTIVES:
            lines.append(Line("math", "\n".join(frame.body), in_dropdown()))
        lines.append(Line("fence", text, in_dropdown() or frame.dropdown))

    def option(frame: _Frame, text: str) -> bool:
        """Whether ``text`` is one of ``frame``'s options (recorded); ends the options at the first other line."""
        if frame.name is None or not frame.options_open:
            return False
        if frame.yaml_open:
            if text.strip() == "---":
                frame.yaml_open = frame.options_open = False
            else:
                _record_option(frame, text)
            return True
        if not frame.body and text.strip() == "---":
            frame.yaml_open = True
            return True
        if _OPTION_RE.match(text):
            _record_option(frame, text)
            return True
        frame.options_open = False
        return False

    for text in markdown.split("\n"):
        top = stack[-1] if stack else None
        if top is not None and not top.kept:  # a code block, math, another directive: only its closing fence
            if _closes(text, top):
                close(top, text)
            elif option(top, text):
                lines.append(Line("option", text, in_dropdown()))
            else:
                top.body.append(text)
                lines.append(Line("code", text, in_dropdown()))
            continue
        if top is not None and option(top, text):
            lines.append(Line("option", text, in_dropdown()))
            continue
        if top is not None and _closes(text, top):
            close(top, text)
            continue
        frame = _opener(text)
        if frame is not None:
            stack.append(frame)
            lines.append(Line("fence", text, in_dropdown()))
            continue
        heading = _HEADING_RE.match(text)
        if heading:
            lines.append(Line("heading", (heading.group(2) or "").strip(), in_dropdown(), len(heading.group(1))))
        elif not text.strip():
            lines.append(Line("blank", text, in_dropdown()))
        else:
            lines.append(Line("prose", text, in_dropdown()))
        if top is not None:
            top.body.append(text)
    while stack:  # fences left open at the end of the cell
        close(stack[-1], "")
    return lines


def _record_option(frame: _Frame, text: str):
    match = _OPTION_RE.match(text) or re.match(r"^\s*([\w-]+)\s*:\s*(.*?)\s*$", text)
    if match and match.group(1) == "class":
        frame.classes.update((match.group(2) or "").split())


def headings(markdown: str) -> List[Tuple[int, str]]:
    """``(level, title)`` of each heading of a markdown cell, in order (lines in code blocks are not headings)."""
    return [(line.level, line.text) for line in scan(markdown) if line.kind == "heading"]


def flatten(lines: Sequence[Line], markers: bool = False) -> str:
    """The prose of scanned lines as one string: prose lines as they are, each displayed ``{math}`` block as one
    ``$$ ... $$`` line, every other line blank (a paragraph break); with ``markers``, each heading as a line
    ``\\x00H<level>\\x00<title>`` (used to order headings and equations)."""
    out = []
    for line in lines:
        if line.kind == "prose":
            out.append(line.text)
        elif line.kind == "math":
            out.append("$$" + line.text.replace("\n", " ") + "$$")
        elif line.kind == "heading" and markers:
            out.append(f"\x00H{line.level}\x00{line.text}")
        else:
            out.append("")
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------------------------
# Splitting a notebook into main text and reproduction check


def _is_reproduction_heading(level: int, title: str) -> bool:
    return level == 2 and title.strip().lower().startswith(REPRODUCTION_HEADING)


def reproduction_start(nb: dict) -> Optional[Tuple[int, int]]:
    """``(cell index, line index)`` of the ``## Reproduction check`` heading, or None."""
    for index, cell in enumerate(nb["cells"]):
        if cell.get("cell_type") != "markdown":
            continue
        for number, line in enumerate(scan(cell_source(cell))):
            if line.kind == "heading" and _is_reproduction_heading(line.level, line.text):
                return index, number
    return None


def _split_markdown(nb: dict) -> Tuple[List[str], List[str]]:
    start = reproduction_start(nb)
    main, check = [], []
    for index, cell in enumerate(nb["cells"]):
        if cell.get("cell_type") != "markdown":
            continue
        source = re.sub(r"<!--.*?-->", "", cell_source(cell), flags=re.DOTALL)  # as scan() sees it
        if start is None or index < start[0]:
            main.append(source)
        elif index > start[0]:
            check.append(source)
        else:
            rows = source.split("\n")
            main.append("\n".join(rows[:start[1]]))
            check.append("\n".join(rows[start[1]:]))
    return main, check


def main_text(nb: dict) -> str:
    """The markdown of the main text: every markdown cell before ``## Reproduction check`` (all when none)."""
    return "\n\n".join(_split_markdown(nb)[0])


def reproduction_text(nb: dict) -> str:
    """The markdown from the ``## Reproduction check`` heading on (empty when there is none)."""
    return "\n\n".join(_split_markdown(nb)[1])


def all_markdown(nb: dict) -> str:
    return "\n\n".join(cell_source(c) for c in nb["cells"] if c.get("cell_type") == "markdown")


# ---------------------------------------------------------------------------------------------------------------
# Prose: words, sentences, numbers, share


def _inline(text: str) -> str:
    """Links, roles, code and inline math of one paragraph reduced to words (see the module docstring)."""
    text = re.sub(r"!\[[^\]]*\]\([^)]*\)", " ", text)  # images
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # [text](url) -> text
    text = re.sub(r"\{[\w:.+-]+\}`[^`]*`", "REF", text)  # {cite:p}`key`, {eq}`label` -> one word
    text = re.sub(r"(`+)(.+?)\1", lambda m: "`" + re.sub(r"\s+", "\u00b7", m.group(2).strip()) + "`", text)
    text = re.sub(r"(?<![\\$])\$(?=\S)[^$\n]+?(?<=\S)\$(?![\d$])", "MATH", text)  # inline math -> one word
    text = re.sub(r"<[^>\n]+>", " ", text)  # HTML tags
    return text


def blocks(markdown: str) -> List[str]:
    """The prose of ``markdown`` (see :func:`prose`) as blocks that always end a sentence: paragraphs and bullet
    items, each on one line."""
    flat = flatten(scan(markdown))
    flat = re.sub(r"\$\$.*?\$\$", "\x01", flat, flags=re.DOTALL)  # displayed math
    out, current = [], []
    for line in flat.split("\n"):
        if line.strip() == "\x01":  # a displayed equation on lines of its own: the sentence around it goes on
            continue
        line = line.replace("\x01", " ")
        bullet = _BULLET_RE.match(line)
        if not line.strip() or line.lstrip().startswith("|") or _RULE_RE.match(line) or bullet:
            if current:
                out.append(" ".join(current))
            current = []
            if bullet:
                current.append(line[bullet.end():].strip())
            continue
        current.append(line.strip())
    if current:
        out.append(" ".join(current))
    out = [" ".join(_inline(b).split()) for b in out]
    return [b for b in out if word_count(b)]


def prose(markdown: str) -> str:
    """The text that words and sentences are counted in, one block (paragraph, bullet item) per line."""
    return "\n".join(blocks(markdown))


def words(text: str) -> List[str]:
    """Whitespace-separated tokens with at least one letter or digit."""
    return [t for t in text.split() if re.search(r"\w", t)]


def word_count(text: str) -> int:
    return len(words(text))


def _split_block(block: str) -> List[str]:
    pieces, start = [], 0
    for match in _SENTENCE_END_RE.finditer(block):
        before = block[start:match.start()].split()
        last = before[-1].lstrip("([\"'\u201c\u2018*_").lower() if before else ""
        if last in ABBREVIATIONS:
            continue
        pieces.append(block[start:match.end()].strip())
        start = match.end()
    pieces.append(block[start:].strip())
    return [p for p in pieces if word_count(p)]


def sentences(markdown: str) -> List[str]:
    """The sentences of a markdown text (prepared by :func:`prose`)."""
    return [s for block in blocks(markdown) for s in _split_block(block)]


def sentence_lengths(markdown: str) -> List[int]:
    return [word_count(s) for s in sentences(markdown)]


def numbers(text: str) -> List[str]:
    """The numbers typed in prepared prose: digit runs outside inline code and math, references to numbered
    things (``Eq. 11``, ``Table 3``, ``§8.2`` ...) left out."""
    found = []
    for token_match in re.finditer(r"\S+", text):
        if token_match.group().startswith("`"):
            continue  # inline code
        for match in NUMBER_RE.finditer(token_match.group()):
            position = token_match.start() + match.start()
            if not REFERENCE_BEFORE_RE.search(text[max(0, position - 20):position]):
                found.append(match.group())
    return found


def numbers_per_100_words(markdown: str) -> float:
    text = prose(markdown)
    n_words = word_count(text)
    return 100.0 * len(numbers(text)) / n_words if n_words else 0.0


def is_interval_sentence(sentence: str) -> bool:
    """Whether a sentence talks about intervals, seeds, verdicts or the ledger (:data:`INTERVAL_VOCABULARY`)."""
    return bool(INTERVAL_RE.search(sentence))


def interval_share(markdown: str) -> float:
    """The share (%) of the words of ``markdown`` that are in sentences about intervals, seeds, verdicts or the
    ledger (0 for a text without words)."""
    found = sentences(markdown)
    total = sum(word_count(s) for s in found)
    about = sum(word_count(s) for s in found if is_interval_sentence(s))
    return 100.0 * about / total if total else 0.0


def history_phrases(markdown: str) -> List[str]:
    """The development-history phrases (:data:`HISTORY_PHRASES`) in a markdown text's prose, in order."""
    return [m.group(0) for m in HISTORY_RE.finditer(" ".join(blocks(markdown)))]


# ---------------------------------------------------------------------------------------------------------------
# Counting template parts


def displayed_equations(markdown: str) -> List[str]:
    """The displayed equations (``$$ ... $$`` blocks and ``{math}`` directives) of a markdown text, each once."""
    return re.findall(r"\$\$(.*?)\$\$", flatten(scan(markdown)), flags=re.DOTALL)


def pseudocode_boxes(markdown: str) -> int:
    """Directives with ``:class: pseudocode`` (the template's boxes for the paper's algorithms)."""
    count = 0
    for line in scan(markdown):
        match = _OPTION_RE.match(line.text) if line.kind == "option" else None
        if match and match.group(1) == "class" and "pseudocode" in (match.group(2) or "").split():
            count += 1
    return count


def _code_cells(nb: dict, tag: Optional[str] = None) -> List[Tuple[int, dict]]:
    return [(i, c) for i, c in enumerate(nb["cells"])
            if c.get("cell_type") == "code" and (tag is None or tag in cell_tags(c))]


def is_equation_cell(cell: dict) -> bool:
    """A code cell tagged ``equation`` that checks the library with ``assert_allclose`` / ``assert_close``."""
    return (cell.get("cell_type") == "code" and "equation" in cell_tags(cell)
            and bool(EQUATION_ASSERT_RE.search(cell_source(cell))))


def equation_cells(nb: dict) -> int:
    return sum(is_equation_cell(c) for c in nb["cells"])


def is_solution_cell(cell: dict) -> bool:
    """A code cell tagged ``solution`` that contains ``assert``."""
    return (cell.get("cell_type") == "code" and "solution" in cell_tags(cell)
            and re.search(r"\bassert", cell_source(cell)) is not None)


def solution_cells(nb: dict) -> int:
    return sum(is_solution_cell(c) for c in nb["cells"])


def figure_cells(nb: dict) -> int:
    """Code cells that show a figure (the proxy :data:`FIGURE_RE`)."""
    return sum(bool(FIGURE_RE.search(cell_source(c))) for _, c in _code_cells(nb))


def outline(nb: dict) -> List[Tuple[str, int, str]]:
    """The notebook's headings, displayed equations and equation cells in order, as ``(kind, cell index,
    text)``: kind ``h1`` ... ``h6`` (text: the title), ``eq`` (the equation's TeX) or ``eqcell``."""
    events = []
    for index, cell in enumerate(nb["cells"]):
        if cell.get("cell_type") == "markdown":
            flat = flatten(scan(cell_source(cell)), markers=True)
            for match in re.finditer(r"\x00H(\d)\x00([^\n]*)|\$\$(.*?)\$\$", flat, flags=re.DOTALL):
                if match.group(1):
                    events.append((f"h{match.group(1)}", index, match.group(2)))
                else:
                    events.append(("eq", index, match.group(3)))
        elif is_equation_cell(cell):
            events.append(("eqcell", index, ""))
    return events


def exercise_headings(nb: dict) -> List[Tuple[int, int]]:
    """``(exercise number, cell index)`` of each ``### Exercise N`` heading, in order."""
    found = []
    for kind, index, title in outline(nb):
        match = re.match(r"exercise\s+(\d+)\b", title.strip(), re.IGNORECASE)
        if kind == "h3" and match:
            found.append((int(match.group(1)), index))
    return found


# ---------------------------------------------------------------------------------------------------------------
# Per-chapter statistics


@dataclass
class ChapterStats:
    chapter: str
    main_words: int
    check_words: int
    median_sentence: float
    mean_sentence: float
    numbers_per_100_words: float
    interval_share: float
    equations: int
    tagged_equations: int
    equation_cells: int
    pseudocode_boxes: int
    exercises: int
    solutions: int
    figures: int
    history: List[str]


def chapter_stats(nb: dict, chapter: str) -> ChapterStats:
    main, check = main_text(nb), reproduction_text(nb)
    lengths = sentence_lengths(main)
    equations = displayed_equations(all_markdown(nb))
    return ChapterStats(
        chapter=chapter,
        main_words=word_count(prose(main)),
        check_words=word_count(prose(check)),
        median_sentence=float(statistics.median(lengths)) if lengths else 0.0,
        mean_sentence=round(float(statistics.mean(lengths)), 1) if lengths else 0.0,
        numbers_per_100_words=round(numbers_per_100_words(main), 1),
        interval_share=round(interval_share(main), 1),
        equations=len(equations),
        tagged_equations=sum(bool(TAG_RE.search(e)) for e in equations),
        equation_cells=equation_cells(nb),
        pseudocode_boxes=pseudocode_boxes(all_markdown(nb)),
        exercises=len(exercise_headings(nb)),
        solutions=solution_cells(nb),
        figures=figure_cells(nb),
        history=history_phrases(main),
    )


COLUMNS = (  # (header, field)
    ("chapter", "chapter"), ("main words", "main_words"), ("check words", "check_words"),
    ("median", "median_sentence"), ("mean", "mean_sentence"), ("num/100w", "numbers_per_100_words"),
    ("share %", "interval_share"), ("eqs", "equations"), ("tagged", "tagged_equations"),
    ("eq cells", "equation_cells"), ("pseudo", "pseudocode_boxes"), ("exercises", "exercises"),
    ("solutions", "solutions"), ("figures", "figures"), ("history", "history"),
)


def markdown_table(rows: Sequence[ChapterStats]) -> str:
    """The statistics as a markdown table, one row per chapter, its columns aligned."""
    cells = [[h for h, _ in COLUMNS]]
    for row in rows:
        values = []
        for _, name in COLUMNS:
            value = getattr(row, name)
            values.append(", ".join(value) if isinstance(value, list) else str(value))
        cells.append(values)
    widths = [max(len(r[i]) for r in cells) for i in range(len(COLUMNS))]
    lines = ["| " + " | ".join(v.ljust(w) if i == 0 else v.rjust(w) for i, (v, w) in enumerate(zip(r, widths))) + " |"
             for r in cells]
    lines.insert(1, "|" + "|".join(("-" * (w + 1) + ":") if i else ("-" * (w + 2)) for i, w in enumerate(widths)) + "|")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------------------------
# The template check


def _title_problems(nb: dict) -> List[str]:
    first = next((c for c in nb["cells"] if c.get("cell_type") == "markdown"), None)
    if first is None:
        return ["no markdown cell (expected a title cell starting with '# ')"]
    source = cell_source(first)
    problems = []
    if not source.lstrip().startswith("# "):
        problems.append("the first markdown cell does not start with a '# ' title")
    for needed, pattern in (("You will learn", r"You will learn"), ("Prerequisites", r"\bPrerequisites\b"),
                            ("Time", r"\bTime\b")):
        if not re.search(pattern, source):
            problems.append(f"the title cell lacks '{needed}' (the 'In this chapter' box)")
    return problems


def _parameters_problems(nb: dict) -> List[str]:
    cells = _code_cells(nb, "parameters")
    if not cells:
        return ["no parameters cell (a code cell tagged 'parameters')"]
    if "hide-input" not in cell_tags(cells[0][1]):
        return [f"the parameters cell (cell {cells[0][0] + 1}) is not tagged 'hide-input'"]
    return []


def _h2(nb: dict, name: str) -> Optional[int]:
    """Cell index of the first H2 whose title starts with ``name`` (case-insensitive)."""
    for kind, index, title in outline(nb):
        if kind == "h2" and title.strip().lower().startswith(name):
            return index
    return None


def summary_bullets(nb: dict) -> Optional[int]:
    """The number of top-level bullets after the ``## Summary`` heading in its cell (None without the heading)."""
    for cell in nb["cells"]:
        if cell.get("cell_type") != "markdown":
            continue
        lines = scan(cell_source(cell))
        for number, line in enumerate(lines):
            if line.kind == "heading" and line.level == 2 and line.text.strip().lower().startswith("summary"):
                count = 0
                for after in lines[number + 1:]:
                    if after.kind == "heading":
                        break
                    bullet = _BULLET_RE.match(after.text) if after.kind == "prose" else None
                    if bullet and len(bullet.group(1)) < 2:
                        count += 1
                return count
    return None


def _summary_problems(nb: dict) -> List[str]:
    count = summary_bullets(nb)
    if count is None:
        return ["no '## Summary' heading"]
    if not 3 <= count <= 5:
        return [f"'## Summary' has {count} bullets after it in its cell (3-5 expected)"]
    return []


def _solution_for(nb: dict, number: int) -> Optional[Tuple[int, dict]]:
    pattern = re.compile(rf"#\s*Solution to exercise\s+{number}\b", re.IGNORECASE)
    for index, cell in _code_cells(nb, "solution"):
        first = next((l for l in cell_source(cell).split("\n") if l.strip()), "")
        if pattern.match(first.strip()):
            return index, cell
    return None


def _visible(cell: dict) -> bool:
    tags = cell_tags(cell)
    return not any(t in HIDDEN_TAGS or t.startswith("hide-") for t in tags)


def _exercise_problems(nb: dict) -> List[str]:
    problems = []
    if _h2(nb, "exercises") is None:
        problems.append("no '## Exercises' heading")
    found = exercise_headings(nb)
    numbers_found = [n for n, _ in found]
    if len(found) < 3:
        problems.append(f"{len(found)} '### Exercise N' headings (at least 3 expected)")
    if numbers_found and numbers_found != list(range(1, len(found) + 1)):
        problems.append(f"exercise headings numbered {numbers_found} (expected 1..{len(found)} in order)")
    has_code_exercise = False
    for number, heading_index in found:
        solution = _solution_for(nb, number)
        if solution is None:
            problems.append(f"exercise {number} has no solution cell (a code cell tagged 'solution' whose first "
                            f"line is '# Solution to exercise {number}')")
            continue
        index, cell = solution
        if index < heading_index:
            problems.append(f"the solution to exercise {number} (cell {index + 1}) comes before its heading")
        if "hide-cell" not in cell_tags(cell):  # source and output folded: the reader tries first
            problems.append(f"the solution to exercise {number} (cell {index + 1}) is not tagged 'hide-cell'")
        if not is_solution_cell(cell):
            problems.append(f"the solution to exercise {number} (cell {index + 1}) has no 'assert'")
        between = nb["cells"][heading_index + 1:index]
        if any(c.get("cell_type") == "code" and _visible(c) for c in between):
            has_code_exercise = True
    if found and not has_code_exercise:
        problems.append("no exercise has a visible code cell between its heading and its solution "
                        "(the 'complete this function' exercise)")
    return problems


def _reproduction_problems(nb: dict) -> List[str]:
    start = reproduction_start(nb)
    if start is None:
        return ["no '## Reproduction check' heading"]
    problems = []
    h2s = [(index, title) for kind, index, title in outline(nb) if kind == "h2"]
    last_index, last_title = h2s[-1]
    if not _is_reproduction_heading(2, last_title):
        problems.append(f"'## Reproduction check' is not the last H2 heading ('## {last_title}' follows it)")
    for index in range(start[0], len(nb["cells"])):
        cell = nb["cells"][index]
        if cell.get("cell_type") == "markdown":
            lines = scan(cell_source(cell))
            if index == start[0]:
                lines = lines[start[1]:]
            outside = [l for l in lines if l.kind in ("prose", "code", "math") and not l.dropdown]
            if outside:
                problems.append(f"cell {index + 1} (markdown after '## Reproduction check') has text outside a "
                                f"{{dropdown}} block: {outside[0].text.strip()[:50]!r}")
        elif cell.get("cell_type") == "code" and index > start[0]:
            if not {"hide-cell", "hide-input"} & set(cell_tags(cell)):
                problems.append(f"cell {index + 1} (code after '## Reproduction check') is not tagged 'hide-cell' "
                                f"or 'hide-input'")
    return problems


def _order_problems(nb: dict) -> List[str]:
    first_markdown = next((i for i, c in enumerate(nb["cells"]) if c.get("cell_type") == "markdown"), None)
    title = next((index for kind, index, _ in outline(nb) if kind == "h1"), None)
    title = first_markdown if title is None else title
    parts = [("title", title), ("## Summary", _h2(nb, "summary")), ("## Exercises", _h2(nb, "exercises")),
             ("## Reproduction check", _h2(nb, REPRODUCTION_HEADING))]
    present = [(name, index) for name, index in parts if index is not None]
    found = [name for name, _ in sorted(present, key=lambda p: p[1])]  # a stable sort keeps ties in template order
    if found != [name for name, _ in present]:
        return [f"parts out of order: found {', '.join(found)} (expected title, ## Summary, ## Exercises, "
                f"## Reproduction check)"]
    return []


def _equation_problems(nb: dict) -> List[str]:
    problems = []
    events = outline(nb)
    for position, (kind, index, tex) in enumerate(events):
        tag = TAG_RE.search(tex) if kind == "eq" else None
        if tag is None:
            continue
        checked = False
        for later_kind, _, later_text in events[position + 1:]:
            if later_kind == "eqcell":
                checked = True
                break
            if later_kind == "h2" or (later_kind == "eq" and TAG_RE.search(later_text)):
                break
        if not checked:
            problems.append(f"equation ({tag.group(1)}) (cell {index + 1}) is not followed by a code cell tagged "
                            f"'equation' with assert_allclose/assert_close")
    for index, cell in _code_cells(nb, "equation"):
        if not is_equation_cell(cell):
            problems.append(f"cell {index + 1} is tagged 'equation' but has no assert_allclose/assert_close")
    if not equation_cells(nb):
        problems.append("no equation cell (a code cell tagged 'equation' with assert_allclose/assert_close)")
    return problems


def _prose_problems(nb: dict) -> List[str]:
    main = main_text(nb)
    problems = []
    share = interval_share(main)
    if share > MAX_INTERVAL_SHARE:
        problems.append(f"main-text share of interval/seed/verdict/ledger sentences is {share:.1f} % "
                        f"(at most {MAX_INTERVAL_SHARE:g} % expected)")
    lengths = sentence_lengths(main)
    median = statistics.median(lengths) if lengths else 0
    if median > MAX_MEDIAN_SENTENCE:
        problems.append(f"main-text median sentence length is {median:g} words (at most "
                        f"{MAX_MEDIAN_SENTENCE:g} expected)")
    for phrase in history_phrases(main):
        problems.append(f"history phrase {phrase!r} in the main text (no development history expected)")
    return problems


def template_problems(nb: dict) -> List[str]:
    """Every part of the chapter template that the notebook misses, one message each (empty: it follows it)."""
    return (_title_problems(nb) + _parameters_problems(nb) + _summary_problems(nb) + _exercise_problems(nb)
            + _reproduction_problems(nb) + _order_problems(nb) + _equation_problems(nb) + _prose_problems(nb))


# ---------------------------------------------------------------------------------------------------------------
# Command line


def default_notebooks() -> List[Path]:
    return sorted(NOTEBOOK_DIR.glob("*.ipynb"))


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("notebooks", nargs="*", type=Path, help="chapters (default: every notebooks/*.ipynb)")
    parser.add_argument("--json", action="store_true", help="machine-readable output")
    parser.add_argument("--check", action="store_true", help="exit 1 when a chapter misses a template part")
    args = parser.parse_args(argv)
    paths = args.notebooks or default_notebooks()
    if not paths:
        print("no notebooks found", file=sys.stderr)
        return 2
    chapters = [(path.stem, load_notebook(path)) for path in paths]
    if args.check:
        problems = {name: template_problems(nb) for name, nb in chapters}
        if args.json:
            print(json.dumps(problems, indent=1))
        else:
            for name, found in problems.items():
                for problem in found:
                    print(f"{name}: {problem}")
        if any(problems.values()):
            return 1
        if not args.json:
            print(f"all {len(chapters)} chapters follow the template")
        return 0
    rows = [chapter_stats(nb, name) for name, nb in chapters]
    print(json.dumps([asdict(r) for r in rows], indent=1) if args.json else markdown_table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
