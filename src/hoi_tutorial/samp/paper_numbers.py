"""SAMP's reported numbers, transcribed exactly from the paper, for the tables the chapters set beside ours.

One source for the chapters and the results ledger. Rows are the paper's method names as printed;
``INF`` stands for the paper's ∞ ("the method failed to reach the goal within 3 minutes").

Source: SAMP (ICCV 2021), §5.2 and Tables 1-5; Appendix G (interaction-encoder ablation).
"""
from __future__ import annotations

from types import MappingProxyType

__all__ = ["INF", "TABLE1", "GOALNET", "PATH_PLANNING_PENETRATION", "TABLE2", "TABLE3", "TABLE4", "TABLE5",
           "NO_INTERACTION_ENCODER"]

INF = float("inf")


def _frozen(values: dict) -> MappingProxyType:
    return MappingProxyType({key: MappingProxyType(dict(row)) if isinstance(row, dict) else row
                             for key, row in values.items()})


# Table 1: diversity (APD, Eq. 6) per action; higher is more diverse.
TABLE1 = _frozen({
    "GT": {"Walk": 5.95, "Run": 7.74, "Sit": 5.18, "Liedown": 7.52},
    "SAMP": {"Walk": 5.63, "Run": 5.75, "Sit": 5.05, "Liedown": 6.69},
})

# §5.2 "GoalNet": reconstruction error of 150 unseen goals on test objects, and APD-Pos / APD-Rot (Eqs. 7-8) of
# N = 10 generated goals on each of L = 150 objects, against the labelled (GT) goals' APD.
GOALNET = _frozen({
    "reconstruction": {"position (cm)": 6.04, "direction (deg)": 2.29},
    "GoalNet": {"APD-Pos (cm)": 16.42, "APD-Rot (deg)": 41.27},
    "GT": {"APD-Pos (cm)": 16.18, "APD-Rot (deg)": 90.23},
})

# §5.2 "Path Planning Module": percentage of frames with a penetration, 10 runs in a cluttered scene.
PATH_PLANNING_PENETRATION = MappingProxyType({
    "SAMP with Path Planning": 3.8,
    "SAMP without Path Planning": 11.2,
    "NSM": 8.11,
})

# Table 2: average execution time in seconds.
TABLE2 = _frozen({
    "Sit": {"MLP": 13.06, "MoE": 12.99, "SAMP": 12.53, "GT": 11.7},
    "Liedown": {"MLP": INF, "MoE": INF, "SAMP": 17.06, "GT": 15.49},
})

# Table 3: average precision, positional (cm) and rotational (deg) error at the goal.
TABLE3 = _frozen({
    "MLP": {"Sit PE (cm)": 9.27, "Sit RE (deg)": 3.99, "Liedown PE (cm)": INF, "Liedown RE (deg)": INF},
    "MoE": {"Sit PE (cm)": 7.99, "Sit RE (deg)": 5.73, "Liedown PE (cm)": INF, "Liedown RE (deg)": INF},
    "SAMP": {"Sit PE (cm)": 6.09, "Sit RE (deg)": 3.55, "Liedown PE (cm)": 5.76, "Liedown RE (deg)": 6.45},
})

# Table 4: Fréchet distance on X~ (Eq. 9).
TABLE4 = _frozen({
    "MLP": {"Idle": 102.85, "Walk": 121.18, "Run": 150.56, "Sit": 105.87, "Liedown": 36.85},
    "MoE": {"Idle": 102.91, "Walk": 114.17, "Run": 151.14, "Sit": 105.10, "Liedown": 35.79},
    "SAMP": {"Idle": 102.72, "Walk": 111.09, "Run": 141.11, "Sit": 104.68, "Liedown": 17.30},
})

# Table 5: SAMP against NSM, for sitting and carrying.
TABLE5 = _frozen({
    "Sit": {
        "SAMP": {"Precision PE (cm)": 15.97, "Precision RE (deg)": 5.38, "Execution Time (sec)": 12.93, "FD": 6.20,
                 "Diversity": 0.44, "Penetration (%)": 3.8},
        "NSM": {"Precision PE (cm)": 16.95, "Precision RE (deg)": 2.32, "Execution Time (sec)": 10.26, "FD": 4.21,
                "Diversity": 0.0, "Penetration (%)": 8.11},
    },
    "Carry": {
        "SAMP": {"Precision PE (cm)": 4.58, "Precision RE (deg)": 1.78, "Execution Time (sec)": 13.29, "FD": 10.17,
                 "Diversity": 0.26, "Penetration (%)": 3.62},
        "NSM": {"Precision PE (cm)": 4.72, "Precision RE (deg)": 1.65, "Execution Time (sec)": 12.82, "FD": 7.31,
                "Diversity": 0.0, "Penetration (%)": 8.45},
    },
})
TABLE5 = MappingProxyType({action: _frozen(rows) for action, rows in TABLE5.items()})

# Appendix G: precision at the goal without the interaction encoder, against with it.
NO_INTERACTION_ENCODER = _frozen({
    "without Interaction Encoder": {"PE (cm)": 14.82, "RE (deg)": 3.65},
    "with Interaction Encoder": {"PE (cm)": 6.09, "RE (deg)": 3.55},
})
