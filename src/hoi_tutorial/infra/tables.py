"""Paper tables: the paper's numbers beside ours, same rows and columns."""
from __future__ import annotations

import math
import numbers
from typing import Mapping, Optional, Sequence

__all__ = ["side_by_side", "format_seconds", "MISSING"]

MISSING = "—"
SOURCES = ("paper", "ours")


def _format_value(value, decimals: int) -> str:
    if value is None:
        return MISSING
    if isinstance(value, str):
        return value
    if isinstance(value, numbers.Real):
        value = float(value)
        if math.isnan(value):
            return MISSING
        return f"{value:.{decimals}f}"
    raise TypeError(f"table entry: expected a number, a string or None, got {type(value).__name__}")


def _ordered_union(*groups) -> list:
    seen = {}
    for group in groups:
        for item in group:
            seen.setdefault(item, None)
    return list(seen)


def side_by_side(paper: Mapping[str, Mapping[str, object]], ours: Mapping[str, Mapping[str, float]],
                 *, columns: Optional[Sequence[str]] = None, decimals: int = 2,
                 higher_is_better: Optional[Mapping[str, bool]] = None):
    """A table with one row per method and, for each metric, the paper's value beside ours.

    Args:
        paper: ``{method: {metric: value}}`` as printed in the paper (numbers, or strings such
            as ``"12.3±0.4"`` kept verbatim).
        ours: ``{method: {metric: value}}`` measured here.
        columns: metrics to show, in order; default: the paper's metrics, then any others.
        decimals: digits after the decimal point for numbers.
        higher_is_better: ``{metric: bool}``; adds ↑ or ↓ to that metric's label.

    Returns:
        a ``pandas.DataFrame`` of strings, rows = methods (the paper's order, then ours),
        columns = MultiIndex (metric, source) with source ``"paper"`` or ``"ours"``; entries
        that a side does not report are ``"—"``.
    """
    try:
        import pandas as pd
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("side_by_side needs pandas (pip install pandas)") from exc
    if not isinstance(decimals, int) or decimals < 0:
        raise ValueError(f"decimals: expected an int >= 0, got {decimals!r}")
    for table_name, table in (("paper", paper), ("ours", ours)):
        if not isinstance(table, Mapping) or not all(isinstance(v, Mapping) for v in table.values()):
            raise TypeError(f"{table_name}: expected a dict {{method: {{metric: value}}}}")
    higher_is_better = dict(higher_is_better or {})
    methods = _ordered_union(paper, ours)
    if columns is None:
        columns = _ordered_union(*(paper[m] for m in paper), *(ours[m] for m in ours))
    columns = list(columns)

    def label(metric: str) -> str:
        if metric not in higher_is_better:
            return metric
        return f"{metric} {'↑' if higher_is_better[metric] else '↓'}"

    header = pd.MultiIndex.from_tuples(
        [(label(metric), source) for metric in columns for source in SOURCES],
        names=["metric", "source"],
    )
    rows = []
    for method in methods:
        row = []
        for metric in columns:
            for table in (paper, ours):
                row.append(_format_value(table.get(method, {}).get(metric), decimals))
        rows.append(row)
    return pd.DataFrame(rows, index=pd.Index(methods, name="method"), columns=header)


def format_seconds(seconds: float) -> str:
    """A duration for people: ``"0.42 s"``, ``"12.3 s"``, ``"2 min 05 s"``, ``"1 h 02 min"``."""
    if not isinstance(seconds, numbers.Real) or not math.isfinite(seconds) or seconds < 0:
        raise ValueError(f"seconds: expected a finite number >= 0, got {seconds!r}")
    if seconds < 1:
        return f"{seconds:.2f} s"
    if seconds < 60:
        return f"{seconds:.1f} s"
    whole = int(round(seconds))
    if whole < 3600:
        return f"{whole // 60} min {whole % 60:02d} s"
    return f"{whole // 3600} h {(whole % 3600) // 60:02d} min"
