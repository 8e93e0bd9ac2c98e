"""NIFTY's reported numbers, transcribed exactly from the paper, for the tables the chapters set beside ours.

One source for the chapters and the results ledger: a chapter shows ``TABLE1[action]`` next to its own
row instead of typing the paper's numbers into a cell. Keys are the column names of
:data:`TABLE1_COLUMNS`; rows are the paper's method names.

Source: NIFTY (CVPR 2024), Table 1 "Quantitative Comparison" (sitting and lifting; 500 test scenes per
action).
"""
from __future__ import annotations

from types import MappingProxyType

__all__ = ["TABLE1", "TABLE1_COLUMNS", "TABLE1_METHODS", "SUPPLEMENT_COLUMNS"]

TABLE1_METHODS = ("Cond. VAE", "Cond. MDM", "NIFTY")

# Table 1's columns, in its order (direction of each in its name).
TABLE1_COLUMNS = ("Foot Skating ↓", "% D2O ≤ 2cm ↑", "D2O 95th % ↓", "Skel. Dist. ↓", "Contact IoU ↑", "% Pen. ≤ 2cm ↑")

# The supplementary tables' columns (Tables 3, 4, 6, 7: Table 1's plus "% Skel. Dist. ≤ 25cm", read with a threshold
# of 25 cm on the summed skeleton distance, Appendix D.1).
SUPPLEMENT_COLUMNS = ("Foot Skating ↓", "% D2O ≤ 2cm ↑", "D2O 95th % ↓", "Skel. Dist. ↓", "% Skel. Dist. ≤ 25cm ↑",
                      "Contact IoU ↑", "% Pen. ≤ 2cm ↑")


def _rows(values: dict) -> MappingProxyType:
    return MappingProxyType({method: MappingProxyType(dict(zip(TABLE1_COLUMNS, row))) for method, row in values.items()})


# NIFTY Table 1, read row by row: foot skating, % D2O <= 2 cm, D2O 95th percentile, skeleton distance,
# contact IoU, % penetration <= 2 cm.
TABLE1 = MappingProxyType({
    "sit": _rows({
        "Cond. VAE": (0.77, 88.8, 0.13, 1.07, 0.21, 46.6),
        "Cond. MDM": (0.36, 37.9, 1.06, 2.81, 0.04, 50.5),
        "NIFTY": (0.47, 99.6, 0.00, 0.54, 0.54, 65.0),
    }),
    "lift": _rows({
        "Cond. VAE": (0.66, 57.4, 0.66, 1.70, 0.03, 60.1),
        "Cond. MDM": (0.28, 36.3, 1.14, 2.58, 0.02, 46.2),
        "NIFTY": (0.34, 77.7, 0.05, 0.42, 0.17, 68.5),
    }),
})
