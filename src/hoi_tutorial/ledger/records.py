"""What the chapters computed for each claim, recorded in the artifact cache, and the ledger built from it.

A :class:`ClaimRecord` holds one chapter run's result for one claim and one seed: the text of what was
computed, the named directions that were checked and whether each held, the status derived from them, and
two digests (of the chapter's code cells and of the library's source) that tell whether the record still
belongs to the code in the checkout. Records live in ``<cache>/ledger/`` as small JSON files.
"""
from __future__ import annotations

import dataclasses
import datetime
import functools
import hashlib
import json
import os
import pathlib
import tempfile
from typing import Mapping, Optional, Sequence

import numpy as np

from ..infra.cache import STORAGE_MODULES, cache_dir
from ..infra.cleaned_source import source_digest
from ..intervals import VERDICTS
from .claims import CLAIMS, PAPERS, Claim, claim

__all__ = ["STATUSES", "ClaimRecord", "LedgerError", "record", "load_record", "record_path", "status_of", "verdict_of",
           "chapter_digest", "library_digest", "chapter_title", "ledger_rows", "markdown_table", "summary",
           "chapter_summary"]

# In the order the ledger counts them. "inconclusive": every checked direction's interval straddles its threshold
# (neither reproduced nor refuted at this sample size); "shown": a figure or an algorithm, no direction to check;
# "planned": no chapter regenerates the claim yet.
STATUSES = ("reproduced", "partly", "inconclusive", "not reproduced", "shown", "planned")
SCALES = ("toy", "small", "paper")
_PACKAGE = pathlib.Path(__file__).resolve().parents[1]   # src/hoi_tutorial
_REPO_ROOT = _PACKAGE.parents[1]                          # the checkout (src layout), when there is one
_FORMAT = 2   # 2: a check is a verdict ("held", "inconclusive", "not held"), no longer a bool


class LedgerError(RuntimeError):
    """A claim's record is missing or belongs to other code: the ledger cannot be built from it."""


@dataclasses.dataclass(frozen=True)
class ClaimRecord:
    """One chapter run's result for one claim.

    key: the claim (:data:`hoi_tutorial.ledger.CLAIMS`). seed, scale: the chapter's parameters.
    ours: what the chapter computed, in words and numbers. checks: ``((direction, verdict), ...)`` in the
    order given, each verdict one of :data:`hoi_tutorial.intervals.VERDICTS`. status: from the checks
    (:func:`status_of`). chapter: the notebook stem. chapter_digest,
    library_digest: the code that made it (``None`` where the chapter file was not found).
    recorded_at: UTC time, ISO 8601.
    """
    key: str
    seed: int
    scale: str
    ours: str
    checks: tuple
    status: str
    chapter: str
    chapter_digest: Optional[str]
    library_digest: str
    recorded_at: str

    @property
    def held(self) -> int:
        """How many of the checked directions held."""
        return sum(1 for _, verdict in self.checks if verdict == "held")

    @property
    def inconclusive(self) -> int:
        """How many of the checked directions were inconclusive (their interval straddles the threshold)."""
        return sum(1 for _, verdict in self.checks if verdict == "inconclusive")

    def status_text(self) -> str:
        """The status with its counts, e.g. ``"partly (2 of 3)"`` or ``"partly (1 of 3; 1 inconclusive)"``."""
        if not self.checks:
            return self.status
        text = f"{self.held} of {len(self.checks)}"
        if self.inconclusive:
            text += f"; {self.inconclusive} inconclusive"
        return f"{self.status} ({text})"


def verdict_of(value) -> str:
    """A check's verdict: a computed bool is ``"held"`` or ``"not held"``; a verdict string (what
    :meth:`hoi_tutorial.intervals.Interval.verdict` returns) is kept. Anything else is an error."""
    if isinstance(value, (bool, np.bool_)):
        return "held" if value else "not held"
    if isinstance(value, str) and value in VERDICTS:
        return value
    raise TypeError(f"expected a computed bool or a verdict {VERDICTS} (Interval.verdict), got "
                    f"{type(value).__name__} {value!r}")


def status_of(checks: Optional[Mapping[str, object]]) -> str:
    """The status of a record from its checks (each a bool or a verdict, :func:`verdict_of`).

    ``"reproduced"`` when every checked direction held; ``"inconclusive"`` when every one was inconclusive;
    ``"not reproduced"`` when none held and at least one did not; ``"partly"`` when some held and some did not
    or were inconclusive; ``"shown"`` when nothing directional was checked (``None`` or empty)."""
    if not checks:
        return "shown"
    verdicts = [verdict_of(v) for v in checks.values()]
    held, inconclusive = verdicts.count("held"), verdicts.count("inconclusive")
    if held == len(verdicts):
        return "reproduced"
    if inconclusive == len(verdicts):
        return "inconclusive"
    return "not reproduced" if held == 0 else "partly"


# -------------------------------------------------------------------------------------------------- digests


def _chapter_path(chapter: str) -> pathlib.Path:
    return _REPO_ROOT / "notebooks" / f"{chapter}.ipynb"


def chapter_digest(chapter: str) -> Optional[str]:
    """SHA-256 of a chapter's code cells, in order, or ``None`` when the checkout's notebook is not found
    (the library installed on its own, as in Colab)."""
    path = _chapter_path(chapter)
    if not path.is_file():
        return None
    cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
    digest = hashlib.sha256()
    for cell in cells:
        if cell.get("cell_type") == "code":
            source = cell.get("source", "")
            digest.update(("".join(source) if isinstance(source, list) else source).encode("utf-8"))
            digest.update(b"\x00")
    return digest.hexdigest()


# The artifact cache's own modules and the pack's: how artifacts are stored and shipped, not what a claim computes;
# and the package's __init__, which holds its version (a release changes it and nothing a claim computes).
_STORAGE = STORAGE_MODULES | {"hoi_tutorial.infra.pack", "hoi_tutorial"}


def _module_name(path: pathlib.Path) -> str:
    """``hoi_tutorial.infra.cache`` for ``.../hoi_tutorial/infra/cache.py`` (a package: its ``__init__`` dropped)."""
    parts = (_PACKAGE.name, *path.relative_to(_PACKAGE).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.lru_cache(maxsize=None)
def _library_digest(stamp) -> str:
    digest = hashlib.sha256()
    for path, _ in stamp:   # each file by what it runs, as the artifact cache keys it (comments and docstrings aside)
        digest.update(source_digest(path.read_text(encoding="utf-8"), path.relative_to(_PACKAGE).as_posix()).encode())
    return digest.hexdigest()


def library_digest() -> str:
    """SHA-256 of the library's source (every ``.py`` file of ``hoi_tutorial`` except this ledger package and the
    code that stores artifacts and packs, which compute nothing a claim depends on), comments, docstrings and blank
    lines aside (:func:`hoi_tutorial.infra.source_digest`): a record goes stale when the code changes, not its prose."""
    files = sorted(p for p in _PACKAGE.rglob("*.py") if "ledger" not in p.relative_to(_PACKAGE).parts
                   and _module_name(p) not in _STORAGE)
    return _library_digest(tuple((p, p.stat().st_mtime_ns) for p in files))


def chapter_title(chapter: str) -> str:
    """The chapter's title (its first ``# `` heading), or its stem when the notebook is not found."""
    path = _chapter_path(chapter)
    if path.is_file():
        for cell in json.loads(path.read_text(encoding="utf-8"))["cells"]:
            if cell.get("cell_type") == "markdown":
                source = cell.get("source", "")
                for line in ("".join(source) if isinstance(source, list) else source).splitlines():
                    if line.startswith("# "):
                        return line[2:].strip()
    return chapter


# ------------------------------------------------------------------------------------------ writing, reading


def record_path(key: str, seed: int, scale: str) -> pathlib.Path:
    """Where the record of ``key`` for one seed and scale lives in the artifact cache."""
    return cache_dir() / "ledger" / f"{key}.seed{seed}.{scale}.json"


def _check_seed_scale(seed, scale):
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed: expected an int (the chapter's SEED), got {type(seed).__name__}")
    if scale not in SCALES:
        raise ValueError(f"scale: expected one of {SCALES} (the chapter's SCALE), got {scale!r}")


def record(key: str, *, ours: str, checks: Optional[Mapping[str, bool]] = None, seed: int,
           scale: str) -> ClaimRecord:
    """Record what a chapter computed for claim ``key`` and return the record.

    ours: what was computed, with the counts behind any share (non-empty text).
    checks: ``{direction in words: verdict}``, each value a computed boolean or, for a direction measured with
    an interval, ``Interval.verdict(...)`` ("held", "inconclusive" or "not held"); ``None`` for a claim with no
    direction to check (a figure, an algorithm), whose status is then "shown".
    seed, scale: the chapter's ``SEED`` and ``SCALE``.
    """
    found = claim(key)
    if found.chapter is None:
        raise ValueError(f"claim {key!r} is planned ({found.planned}); give it a chapter in "
                         "hoi_tutorial.ledger.claims before recording it")
    if not isinstance(ours, str) or not ours.strip():
        raise ValueError(f"ours: expected the text of what the chapter computed for {key!r}, got {ours!r}")
    _check_seed_scale(seed, scale)
    if checks is not None:
        if not isinstance(checks, Mapping):
            raise TypeError(f"checks: expected a mapping {{direction: verdict}}, got {type(checks).__name__}")
        for name, value in checks.items():
            if not isinstance(name, str) or not name.strip():
                raise ValueError(f"checks: each direction needs a name in words, got {name!r}")
            try:
                verdict_of(value)
            except TypeError as error:
                raise TypeError(f"checks[{name!r}]: {error}") from None
    items = tuple((name, verdict_of(value)) for name, value in (checks or {}).items())
    result = ClaimRecord(key=key, seed=int(seed), scale=scale, ours=ours.strip(), checks=items,
                         status=status_of(dict(items)), chapter=found.chapter,
                         chapter_digest=chapter_digest(found.chapter), library_digest=library_digest(),
                         recorded_at=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"))
    path = record_path(key, int(seed), scale)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = dataclasses.asdict(result) | {"format": _FORMAT}
    handle, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    with os.fdopen(handle, "w", encoding="utf-8") as out:
        json.dump(payload, out, ensure_ascii=False, indent=1)
    os.replace(tmp, path)
    return result


def load_record(key: str, seed: int, scale: str) -> Optional[ClaimRecord]:
    """The stored record of ``key`` for one seed and scale, or ``None`` when there is none."""
    claim(key)
    _check_seed_scale(seed, scale)
    path = record_path(key, seed, scale)
    if not path.is_file():
        return None
    payload = json.loads(path.read_text(encoding="utf-8"))
    if payload.pop("format", None) != _FORMAT:
        return None
    payload["checks"] = tuple((name, verdict_of(verdict)) for name, verdict in payload["checks"])
    return ClaimRecord(**payload)


def _stale_reason(found: ClaimRecord) -> Optional[str]:
    if found.chapter != claim(found.key).chapter:
        return f"recorded by chapter {found.chapter}, but the claim now belongs to {claim(found.key).chapter}"
    current = chapter_digest(found.chapter)
    if current is None:
        return f"the chapter notebook notebooks/{found.chapter}.ipynb is not in this checkout"
    if found.chapter_digest != current:
        return "the chapter's code changed after the record was made"
    if found.library_digest != library_digest():
        return "the library's source changed after the record was made"
    return None


# ---------------------------------------------------------------------------------------------- the ledger


def ledger_rows(*, seed: int = 0, scale: str = "toy", claims: Sequence[Claim] = CLAIMS) -> list:
    """One row per claim, built from the records alone.

    Each row is a dict: ``claim`` (:class:`Claim`), ``record`` (the :class:`ClaimRecord` for ``seed``, or
    ``None`` for a planned claim), ``status`` and ``other_seeds`` (``{seed: ClaimRecord}``: current records of
    other seeds at the same scale, made by running a chapter with another ``SEED``).

    Raises :class:`LedgerError`, naming every claim and the chapter to execute, when a claim that a chapter
    regenerates has no record for ``seed`` and ``scale``, or its record was made by other code.
    """
    _check_seed_scale(seed, scale)
    rows, problems = [], []
    for c in claims:
        if c.chapter is None:
            rows.append({"claim": c, "record": None, "status": "planned", "other_seeds": {}})
            continue
        found = load_record(c.key, seed, scale)
        if found is None:
            problems.append(f"{c.key}: no record for SEED={seed}, SCALE={scale!r}; execute chapter "
                            f"notebooks/{c.chapter}.ipynb with these parameters")
            continue
        reason = _stale_reason(found)
        if reason:
            problems.append(f"{c.key}: its record is stale ({reason}); execute chapter notebooks/{c.chapter}.ipynb "
                            f"again with SEED={seed}, SCALE={scale!r}")
            continue
        others = {}
        for path in sorted((cache_dir() / "ledger").glob(f"{c.key}.seed*.{scale}.json")):
            other_seed = path.name[len(c.key) + len(".seed"):-len(f".{scale}.json")]
            if other_seed.isdigit() and int(other_seed) != seed:
                other = load_record(c.key, int(other_seed), scale)
                if other is not None and _stale_reason(other) is None:
                    others[int(other_seed)] = other
        rows.append({"claim": c, "record": found, "status": found.status, "other_seeds": others})
    if problems:
        raise LedgerError(f"the results ledger cannot be built: {len(problems)} of {len(claims)} claims lack a "
                          "current record (the ledger shows only what the chapters computed):\n  "
                          + "\n  ".join(problems))
    return rows


def summary(rows: Sequence[Mapping]):
    """A table (pandas DataFrame) of how many claims of each paper have each status."""
    import pandas as pd

    counts = {paper: {status: 0 for status in STATUSES} for paper in PAPERS}
    for row in rows:
        counts[row["claim"].paper][row["status"]] += 1
    table = pd.DataFrame(counts).T[list(STATUSES)]
    table["claims"] = table.sum(axis=1)
    table.loc["all"] = table.sum(axis=0)
    return table


def chapter_summary(records: Sequence[ClaimRecord]):
    """What one chapter recorded, as a table for its last cell: claim, status, the directions checked, ours.

    Returns a pandas ``Styler`` (whole texts, no index; its ``.data`` is the DataFrame).
    """
    import pandas as pd

    if not records or not all(isinstance(r, ClaimRecord) for r in records):
        raise TypeError("records: expected a non-empty list of ClaimRecord (what ledger.record returned)")
    frame = pd.DataFrame([{
        "claim": f"{claim(r.key).paper} {claim(r.key).source}: {claim(r.key).statement}",
        "status": r.status_text(),
        "checked": "; ".join(f"{name}: {_VERDICT_WORD[verdict]}" for name, verdict in r.checks) or "—",
        "ours": r.ours,
    } for r in records])
    return frame.style.hide(axis="index").set_properties(**{"text-align": "left", "vertical-align": "top"})


_VERDICT_WORD = {"held": "yes", "not held": "no", "inconclusive": "inconclusive"}


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def markdown_table(rows: Sequence[Mapping], paper: str, *, link_suffix: str = ".ipynb") -> str:
    """One paper's ledger as a Markdown table: claim, the paper's numbers, ours, status, chapter.

    Chapters are linked as ``../notebooks/<stem><link_suffix>``, relative to ``reference/`` (MyST resolves a link
    to a notebook of the book into a link to its page).
    """
    if paper not in PAPERS:
        raise ValueError(f"paper: expected one of {PAPERS}, got {paper!r}")
    lines = ["| claim | the paper's numbers | ours | status | chapter |", "| --- | --- | --- | --- | --- |"]
    for row in rows:
        c, found = row["claim"], row["record"]
        if c.paper != paper:
            continue
        if found is None:
            ours, status, chapter = c.planned, "planned", "—"
        else:
            ours = f"seed {found.seed}: {found.ours}"
            if found.checks:
                ours += " Checked: " + "; ".join(f"{name} ({_VERDICT_WORD[verdict]})"
                                                 for name, verdict in found.checks) + "."
            status = found.status_text()
            for other_seed, other in sorted(row["other_seeds"].items()):
                status += f"; seed {other_seed}: {other.status_text()}"
            chapter = f"[{chapter_title(c.chapter)}](../notebooks/{c.chapter}{link_suffix})"
        lines.append("| " + " | ".join(_cell(x) for x in (f"{c.source}: {c.statement}", c.paper_numbers, ours,
                                                           status, chapter)) + " |")
    return "\n".join(lines)
