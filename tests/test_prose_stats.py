"""scripts/prose_stats.py: the prose measures (words, sentences, numbers, the interval share) and the template
check, on made-up notebooks whose counts are known, and its command line's exit codes."""
import copy
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
SCRIPT = REPO_ROOT / "scripts" / "prose_stats.py"

spec = importlib.util.spec_from_file_location("prose_stats", SCRIPT)
prose_stats = importlib.util.module_from_spec(spec)
sys.modules["prose_stats"] = prose_stats  # dataclasses look their module up by name
spec.loader.exec_module(prose_stats)


# ---------------------------------------------------------------------------------------------------------------
# A chapter that follows the template, with known counts


def md(source):
    return {"cell_type": "markdown", "metadata": {}, "source": source}


def code(source, tags=()):
    return {"cell_type": "code", "metadata": {"tags": list(tags)} if tags else {}, "source": source,
            "outputs": [], "execution_count": None}


TITLE = """# A toy chapter

This chapter builds a tiny filter. It runs in seconds.

:::{admonition} In this chapter
:class: tip
**You will learn**
- compute the gain of a filter

**Prerequisites**: [Chapter 2](02_diffusion_and_guidance.ipynb), a little algebra.

**Time**: about 5 s from the pretrained pack; about 1 min cold on 2 cores.
:::
"""
# sentences (words): 6, 4, 3, 6, 6, 15; numbers 5, 1, 2 ("Chapter 2" is a reference)

METHOD = """## 1. The gain

The gain weighs the prediction against the measurement, e.g. when the noise is large. The filter is
$$ K = P (P + R)^{-1} \\tag{20} $$
where $P$ is the variance of the prediction and $R$ that of the measurement.
"""
# sentences: 14, 17 (the displayed equation inside the second one is dropped, each inline math span one word)

LIBRARY = """:::{dropdown} The library's code: `toy.gain`
```{literalinclude} ../src/toy.py
:pyobject: gain
```
:::

:::{admonition} Algorithm 1: the filter
:class: pseudocode
```text
for each frame t:
    predict, then update
```
:::
"""
# no words: directive fences, options and non-prose bodies are dropped

RESULTS = """## 2. Results

The interval straddles zero with seed 0. The filter beats the raw measurement in 9 of 10 runs.

```{math}
y = 2 x
```
"""
# sentences: 7 (about intervals), 11; numbers 0, 9, 10; one more displayed (untagged) equation

SUMMARY = """## Summary

- The gain weighs prediction against measurement.
- A small gain trusts the prediction.
- The filter averages along the dynamics.
"""
# sentences: 6, 6, 6

REPRODUCTION = """## Reproduction check

:::{dropdown} Intervals and seeds
The bootstrap interval is printed below. Seeds 1 and 2 agree.
:::
"""
# 11 words, outside the main text

MAIN_SENTENCES = [6, 4, 3, 6, 6, 15, 14, 17, 7, 11, 6, 6, 6, 5, 10, 10]
MAIN_WORDS = sum(MAIN_SENTENCES)  # 132
INTERVAL_WORDS = 7
MAIN_NUMBERS = 8  # 5, 1, 2; 0, 9, 10; 10 (exercise 2); 0.1 (exercise 3)


def template_notebook():
    cells = [
        code("# set-up\n", ["hide-cell", "setup"]),
        code('SCALE = "toy"\nSEED = 0\n', ["parameters", "hide-input"]),
        code("# pretrained pack\n", ["hide-cell", "pretrained"]),
        md(TITLE),
        code("import numpy as np\nimport matplotlib.pyplot as plt\n", ["hide-input"]),
        md(METHOD),
        code("P, R = 2.0, 1.0\nnp.testing.assert_allclose(P / (P + R), 2 / 3)\n", ["equation"]),
        md(LIBRARY),
        md(RESULTS),
        code("plt.plot([1, 2])\nplt.show()\n"),
        md(SUMMARY),
        md("## Exercises\n\n### Exercise 1. Complete the gain\n\nWrite the function `kalman_gain(P, R)` below.\n"),
        code("def kalman_gain(P, R):\n    ...  # your code here\n"),
        code("# Solution to exercise 1\ndef kalman_gain(P, R):\n    return P / (P + R)\n\n"
             "assert abs(kalman_gain(2.0, 1.0) - 2 / 3) < 1e-9\n", ["hide-cell", "solution"]),
        md("### Exercise 2. A large noise\n\nSet the noise to 10 and check the gain falls.\n"),
        code("# Solution to exercise 2\nassert kalman_gain(2.0, 10.0) < 0.2, 'the gain did not fall'\n",
             ["hide-cell", "solution"]),
        md("### Exercise 3. A small noise\n\nSet the noise to 0.1 and check the gain rises.\n"),
        code("# Solution to exercise 3\nassert kalman_gain(2.0, 0.1) > 0.9, 'the gain did not rise'\n",
             ["hide-cell", "solution"]),
        md(REPRODUCTION),
        code("from hoi_tutorial import ledger\n", ["hide-cell"]),
    ]
    return {"cells": cells, "metadata": {}, "nbformat": 4, "nbformat_minor": 5}


def write(tmp_path, nb, name="99_toy"):
    path = tmp_path / f"{name}.ipynb"
    # sources as lists of lines, as Jupyter stores them
    stored = copy.deepcopy(nb)
    for cell in stored["cells"]:
        cell["source"] = cell["source"].splitlines(keepends=True)
    path.write_text(json.dumps(stored, indent=1))
    return path


def cell_index(nb, starts):
    return next(i for i, c in enumerate(nb["cells"]) if c["source"].startswith(starts))


def test_the_template_notebook_passes_the_check():
    assert prose_stats.template_problems(template_notebook()) == []


def test_the_counts_are_what_was_built(tmp_path):
    nb = prose_stats.load_notebook(write(tmp_path, template_notebook()))
    main = prose_stats.main_text(nb)
    assert prose_stats.sentence_lengths(main) == MAIN_SENTENCES
    stats = prose_stats.chapter_stats(nb, "99_toy")
    assert stats.main_words == MAIN_WORDS == 132
    assert stats.check_words == 11
    assert stats.median_sentence == 6.0
    assert stats.mean_sentence == round(MAIN_WORDS / len(MAIN_SENTENCES), 1)
    assert stats.interval_share == round(100 * INTERVAL_WORDS / MAIN_WORDS, 1)
    assert stats.numbers_per_100_words == round(100 * MAIN_NUMBERS / MAIN_WORDS, 1)
    assert (stats.equations, stats.tagged_equations, stats.equation_cells) == (2, 1, 1)
    assert stats.pseudocode_boxes == 1
    assert (stats.exercises, stats.solutions, stats.figures) == (3, 3, 1)
    assert stats.history == []


def test_without_a_reproduction_check_all_markdown_is_main_text():
    nb = template_notebook()
    nb["cells"] = [c for c in nb["cells"] if not c["source"].startswith("## Reproduction check")]
    stats = prose_stats.chapter_stats(nb, "toy")
    assert (stats.main_words, stats.check_words) == (MAIN_WORDS, 0)


def test_text_above_the_heading_in_its_cell_is_main_text():
    nb = template_notebook()
    index = cell_index(nb, "## Reproduction check")
    nb["cells"][index]["source"] = "One more main sentence.\n\n" + REPRODUCTION
    stats = prose_stats.chapter_stats(nb, "toy")
    assert (stats.main_words, stats.check_words) == (MAIN_WORDS + 4, 11)


# ---------------------------------------------------------------------------------------------------------------
# One broken part at a time: the check names it


def _set(nb, starts, source=None, tags=None):
    cell = nb["cells"][cell_index(nb, starts)]
    if source is not None:
        cell["source"] = source
    if tags is not None:
        cell["metadata"]["tags"] = tags


def _drop(nb, starts):
    del nb["cells"][cell_index(nb, starts)]


def _insert_after(nb, starts, cell):
    nb["cells"].insert(cell_index(nb, starts) + 1, cell)


def _move_summary_after_exercises(nb):
    summary = nb["cells"].pop(cell_index(nb, "## Summary"))
    nb["cells"].insert(cell_index(nb, "## Reproduction check"), summary)


BROKEN = {
    "no title": (lambda nb: _set(nb, "# A toy", TITLE.replace("# A toy chapter", "A toy chapter")),
                 "'# ' title"),
    "no learning objectives": (lambda nb: _set(nb, "# A toy", TITLE.replace("You will learn", "Goals")),
                               "'You will learn'"),
    "no prerequisites": (lambda nb: _set(nb, "# A toy", TITLE.replace("Prerequisites", "Needs")), "'Prerequisites'"),
    "no time": (lambda nb: _set(nb, "# A toy", TITLE.replace("**Time**", "**Duration**")), "'Time'"),
    "parameters shown": (lambda nb: _set(nb, "SCALE", tags=["parameters"]), "not tagged 'hide-input'"),
    "no summary": (lambda nb: _drop(nb, "## Summary"), "no '## Summary' heading"),
    "two summary bullets": (lambda nb: _set(nb, "## Summary", "## Summary\n\n- One.\n- Two.\n"),
                            "'## Summary' has 2 bullets"),
    "six summary bullets": (lambda nb: _set(nb, "## Summary", "## Summary\n\n" + "- A point.\n" * 6),
                            "'## Summary' has 6 bullets"),
    "no exercises heading": (lambda nb: _set(nb, "## Exercises", nb["cells"][cell_index(nb, "## Exercises")]["source"]
                                             .replace("## Exercises\n\n", "")), "no '## Exercises' heading"),
    "two exercises": (lambda nb: [_drop(nb, "### Exercise 3"), _drop(nb, "# Solution to exercise 3")],
                      "2 '### Exercise N' headings (at least 3 expected)"),
    "exercises misnumbered": (lambda nb: _set(nb, "### Exercise 3", "### Exercise 4. A small noise\n\nSet it.\n"),
                              "exercise headings numbered [1, 2, 4]"),
    "no solution": (lambda nb: _drop(nb, "# Solution to exercise 2"), "exercise 2 has no solution cell"),
    "solution without assert": (lambda nb: _set(nb, "# Solution to exercise 3", "# Solution to exercise 3\nx = 1\n"),
                                "exercise 3 (cell 18) has no 'assert'"),
    "solution shown": (lambda nb: _set(nb, "# Solution to exercise 2", tags=["solution"]),
                       "exercise 2 (cell 16) is not tagged 'hide-cell'"),
    "no code exercise": (lambda nb: _drop(nb, "def kalman_gain"), "complete this function"),
    "no reproduction check": (lambda nb: _drop(nb, "## Reproduction check"), "no '## Reproduction check' heading"),
    "reproduction check not last": (lambda nb: nb["cells"].append(md("## Appendix\n\nMore.\n")),
                                    "is not the last H2 heading ('## Appendix' follows it)"),
    "text outside a dropdown": (lambda nb: _set(nb, "## Reproduction check", REPRODUCTION + "\nThe verdict holds.\n"),
                                "text outside a {dropdown} block: 'The verdict holds.'"),
    "code after the check shown": (lambda nb: _set(nb, "from hoi_tutorial import ledger", tags=[]),
                                   "cell 20 (code after '## Reproduction check') is not tagged 'hide-cell'"),
    "summary after exercises": (_move_summary_after_exercises, "parts out of order"),
    "equation unchecked": (lambda nb: _set(nb, "P, R = 2.0", tags=[]), "equation (20) (cell 6) is not followed"),
    "equation cell without assert": (lambda nb: _set(nb, "P, R = 2.0", "P, R = 2.0\nprint(P / (P + R))\n"),
                                     "tagged 'equation' but has no assert_allclose"),
    "second tagged equation unchecked": (lambda nb: _insert_after(nb, "P, R = 2.0",
                                                                  md("$$ P' = (1 - K) P \\tag{21} $$\n")),
                                         "equation (21) (cell 8) is not followed"),
    "interval-heavy main text": (lambda nb: _set(nb, "## 2. Results", RESULTS.replace(
        "The filter beats", "The seeds agree and the paired bootstrap interval straddles zero; the verdict, "
                            "recorded in the ledger, is inconclusive. Then the filter beats")),
                                 "share of interval/seed/verdict/ledger sentences is"),
    "long sentences": (lambda nb: _set(nb, "## 2. Results", "## 2. Results\n\n" + ("word " * 30 + "end. ") * 20),
                       "median sentence length is 31 words"),
    "history": (lambda nb: _set(nb, "## 1. The gain", METHOD + "\nAn earlier version of this chapter used a loop.\n"),
                "history phrase 'earlier version'"),
}


@pytest.mark.parametrize("name", sorted(BROKEN))
def test_the_check_names_each_missing_part(name):
    break_it, expected = BROKEN[name]
    nb = template_notebook()
    break_it(nb)
    problems = prose_stats.template_problems(nb)
    assert any(expected in p for p in problems), problems


def test_no_equation_cell_at_all_is_reported():
    nb = template_notebook()
    _drop(nb, "P, R = 2.0")
    problems = prose_stats.template_problems(nb)
    assert any(p.startswith("no equation cell") for p in problems), problems
    assert any("equation (20)" in p for p in problems), problems


# ---------------------------------------------------------------------------------------------------------------
# Text preparation


def test_sentences_do_not_split_on_abbreviations_or_decimals():
    text = ("See e.g. Fig. 3 and Eq. 11 for details. The value is 0.5 here, i.e. small. Compare vs. the baseline "
            "(cf. Sec. 2)! Eqs. 15 and 16 follow Chi et al. closely. Is it? Yes.")
    assert prose_stats.sentences(text) == [
        "See e.g. Fig. 3 and Eq. 11 for details.",
        "The value is 0.5 here, i.e. small.",
        "Compare vs. the baseline (cf. Sec. 2)!",
        "Eqs. 15 and 16 follow Chi et al. closely.",
        "Is it?",
        "Yes.",
    ]


def test_bullets_and_blank_lines_end_sentences():
    text = "The pieces:\n- first item\n- second item. Still the second\n  and its next line\n\nA new paragraph"
    assert prose_stats.sentences(text) == ["The pieces:", "first item", "second item.",
                                           "Still the second and its next line", "A new paragraph"]


def test_math_is_stripped():
    text = "The map $f(x) = x^2 + 1$ is smooth.\n$$\ny = 3 x + 4\n$$\nand ends here."
    assert prose_stats.sentences(text) == ["The map MATH is smooth.", "and ends here."]
    assert prose_stats.numbers(prose_stats.prose(text)) == []
    assert prose_stats.displayed_equations(text) == ["\ny = 3 x + 4\n"]


def test_markup_is_stripped():
    text = """# A heading that is not counted

<!-- a comment
over two lines -->
Read [the ledger](../reference/ledger.ipynb) and {cite:p}`lu2024choice` with `SEED = 0`.

```python
x = 1. This is code.
```

~~~
tilde code
~~~

| a | table |
|---|---|

:::{note}
:class: margin
Kept inside a note.
:::
"""
    assert prose_stats.prose(text) == "Read the ledger and REF with `SEED\u00b7=\u00b70`.\nKept inside a note."
    assert prose_stats.word_count(prose_stats.prose(text)) == 11
    assert prose_stats.numbers(prose_stats.prose(text)) == []  # the 0 is inside inline code


def test_nested_fences_and_pseudocode():
    text = """::::{dropdown} Outer
:::{note}
Inner text.
:::
````{admonition} Box
:class: pseudocode
```text
for t: # not a heading
```
````
::::"""
    assert prose_stats.prose(text) == "Inner text."
    assert prose_stats.pseudocode_boxes(text) == 1
    assert prose_stats.headings(text) == []
    assert all(line.dropdown for line in prose_stats.scan(text))


def test_numbers_leave_out_references():
    text = prose_stats.prose("Eq. 11 and Table 3 (§8.2) give 4.5 m in 2 of 3 runs, Chapter 2 says.")
    assert prose_stats.numbers(text) == ["4.5", "2", "3"]


def test_interval_share_of_a_known_text():
    text = "The model learns fast. The bootstrap interval covers zero. We used three seeds here. The loss falls."
    # 4 + 5 + 5 + 3 words; the second and third sentences are about intervals and seeds
    assert prose_stats.interval_share(text) == pytest.approx(100 * 10 / 17)
    assert not prose_stats.is_interval_sentence("The held-out set is small.")
    assert prose_stats.is_interval_sentence("The claim held for SEED 0.")
    assert prose_stats.is_interval_sentence("The claim is not held.")
    assert prose_stats.interval_share("") == 0.0


def test_history_phrases():
    assert prose_stats.history_phrases("This was first written for a loop. Until recently it was slow.") == [
        "first written", "Until recently"]
    assert prose_stats.history_phrases("The versions agree.") == []


# ---------------------------------------------------------------------------------------------------------------
# Command line


def run(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True,
                          timeout=60)


def test_cli_check_passes_on_the_template(tmp_path):
    path = write(tmp_path, template_notebook())
    result = run("--check", path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "all 1 chapters follow the template" in result.stdout


def test_cli_check_fails_and_names_the_chapter(tmp_path):
    good = write(tmp_path, template_notebook(), "01_good")
    nb = template_notebook()
    _drop(nb, "## Summary")
    bad = write(tmp_path, nb, "02_bad")
    result = run("--check", good, bad)
    assert result.returncode == 1
    lines = result.stdout.strip().splitlines()
    assert lines and all(line.startswith("02_bad: ") for line in lines)
    assert "02_bad: no '## Summary' heading" in lines


def test_cli_table_and_json(tmp_path):
    path = write(tmp_path, template_notebook())
    table = run(path)
    assert table.returncode == 0
    assert table.stdout.startswith("| chapter") and "99_toy" in table.stdout
    as_json = run("--json", path)
    assert as_json.returncode == 0
    rows = json.loads(as_json.stdout)
    assert rows[0]["chapter"] == "99_toy" and rows[0]["main_words"] == MAIN_WORDS


# ---------------------------------------------------------------------------------------------------------------
# Every chapter of the book follows the lesson template (book/conventions.md, "How a chapter is laid out")


@pytest.mark.parametrize("chapter", [p.stem for p in prose_stats.default_notebooks()])
def test_chapter_follows_the_template(chapter):
    nb = prose_stats.load_notebook(REPO_ROOT / "notebooks" / f"{chapter}.ipynb")
    assert prose_stats.template_problems(nb) == []
