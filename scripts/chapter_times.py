"""Print each chapter's execution time from a Jupyter Book build log (CI calls it after the book build).

myst-nb logs "Executed notebook in X seconds" once per executed chapter; the chapter is named on the same
line (Sphinx's location prefix) or by the last "reading sources... [..%] <docname>" line before it.

    python scripts/chapter_times.py book.log
"""
import re
import sys

ANSI = re.compile(r"\x1b\[[0-9;]*m")  # colour codes Sphinx may write even into a log file
READING = re.compile(r"reading sources\.\.\. \[\s*\d+%\]\s+(\S+)")
EXECUTED = re.compile(r"Executed notebook in ([0-9.]+) seconds")
LOCATION = re.compile(r"(\S+?)(?:\.ipynb)?:\s*(?:\d+:\s*)?Executed notebook")


def chapter_times(lines):
    """``[(chapter, seconds)]`` in the order the log executed them."""
    times, current = [], None
    for line in lines:
        for part in ANSI.sub("", line).split("\r"):  # Sphinx's progress lines overwrite each other with carriage returns
            match = READING.search(part)
            if match:
                current = match.group(1)
            match = EXECUTED.search(part)
            if match:
                located = LOCATION.search(part)
                name = located.group(1).rsplit("/", 1)[-1] if located else (current or "?")
                times.append((name, float(match.group(1))))
    return times


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print(__doc__.strip().splitlines()[-1].strip(), file=sys.stderr)
        return 2
    with open(argv[0], encoding="utf-8", errors="replace") as log:
        times = chapter_times(log)
    if not times:
        print("no chapter execution times in the log (were the chapters executed?)")
        return 1
    width = max(len(name) for name, _ in times)
    for name, seconds in times:
        print(f"  {name:<{width}}  {seconds:7.1f} s")
    print(f"  {'total':<{width}}  {sum(s for _, s in times):7.1f} s over {len(times)} chapter(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
