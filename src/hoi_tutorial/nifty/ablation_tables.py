"""The rows of NIFTY's ablation tables (Supp. Tables 3, 4, 6, 7; chapters 7-10), with the pose-only share in
place of the column that is zero at toy scale.

The supplement reads "% Skel. Dist. ≤ 25cm" (Appendix D.1): the share of final poses within 25 cm, summed over
22 joints, of an anchor pose. No sample of ours comes that near (chapter 6), so the column is 0 for every row and
cannot separate two variants. Its stand-in is chapter 6's (ours): the share of final poses *posed like the data*,
whose pose-only distance (``MotionScores.pose_distance``: the skeleton distance with the body moved onto the
anchor's root) is at most a threshold chosen on the model's own samples of its training conditions, never on the
test scenes (``scoring.pose_threshold``).

    row = ablation_row(run.samples.metrics, threshold)    # ours, beside the paper's row
    side_by_side(paper, {"NIFTY": row}, columns=ablation_columns(threshold))
"""
from __future__ import annotations

from typing import Sequence

from .paper_numbers import SUPPLEMENT_COLUMNS
from .scoring import MotionScores, pose_row, table_counts, table_row

__all__ = ["SKELETON_SHARE_COLUMN", "pose_share_column", "ablation_columns", "ablation_row", "ablation_counts"]

# The paper's column that the pose-only share stands in for.
SKELETON_SHARE_COLUMN = "% Skel. Dist. ≤ 25cm ↑"


def pose_share_column(threshold: float) -> str:
    """The pose-only share's column name for a threshold in metres (as ``scoring.pose_row`` names it)."""
    return f"% Pose Dist. ≤ {100 * float(threshold):.0f}cm ↑"


def ablation_columns(threshold: float, columns: Sequence[str] = SUPPLEMENT_COLUMNS) -> tuple:
    """``columns`` with the pose-only share right after "% Skel. Dist. ≤ 25cm" (the paper's stays, for its values)."""
    columns = tuple(columns)
    if SKELETON_SHARE_COLUMN not in columns:
        raise ValueError(f"columns: expected {SKELETON_SHARE_COLUMN!r} among them, got {list(columns)}")
    at = columns.index(SKELETON_SHARE_COLUMN) + 1
    return columns[:at] + (pose_share_column(threshold),) + columns[at:]


def ablation_row(results: MotionScores, threshold: float, columns: Sequence[str] = SUPPLEMENT_COLUMNS) -> dict:
    """Our row of an ablation table: ``scoring.table_row``'s ``columns`` less "% Skel. Dist. ≤ 25cm" (all zero
    here), plus the % of final poses with a pose-only distance at most ``threshold`` (metres, summed over the 22
    joints; ``scoring.pose_threshold``)."""
    row = table_row(results, columns=[c for c in columns if c != SKELETON_SHARE_COLUMN])
    row[pose_share_column(threshold)] = pose_row(results, threshold)[pose_share_column(threshold)]
    return row


def ablation_counts(results: MotionScores, threshold: float) -> dict:
    """The counts behind :func:`ablation_row`'s percentages, ``"k / n"``: reached, posed like the data, and not
    penetrating among those that reached."""
    counts = table_counts(results)
    return {"D2O ≤ 2cm": counts["D2O ≤ 2cm"],
            f"Pose Dist. ≤ {100 * float(threshold):.0f}cm": pose_row(results, threshold)["count"],
            "Pen. ≤ 2cm": counts["Pen. ≤ 2cm"]}
