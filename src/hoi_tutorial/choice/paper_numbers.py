"""CHOICE's reported numbers, transcribed exactly from the paper, for the tables the chapters set beside ours.

Rows are the paper's method names as printed; values with a spread are kept as the printed strings.

Sources: CHOICE (Lu et al. 2024), §8.2.2, Table 3 ("Comparison among SE(3) trajectory planners for the end
effector"; INTPs run three times per scene with different latent initialisations, mean ± std); §8.3.1, Table 4
("Ablation study and comparison to the human motion data": unsmoothness and sliding in cm/s², the Fréchet
distance over 2 s pose windows, the wrist's RMS curvature in cm⁻¹; "-" where the paper prints none); §7,
Table 2 ("The distribution of action labels and task descriptions for the key joints", seconds and %; the
key-joint action column as printed, "Draw" included).
"""
from __future__ import annotations

from types import MappingProxyType

__all__ = ["TABLE3_COLUMNS", "TABLE3", "TABLE4_COLUMNS", "TABLE4", "TABLE2_COLUMNS", "TABLE2"]

TABLE3_COLUMNS = ("unsmooth.", "safety dist.", "succ. rate")


def _rows(values: dict) -> MappingProxyType:
    return MappingProxyType({k: MappingProxyType(dict(zip(TABLE3_COLUMNS, v))) for k, v in values.items()})


TABLE3 = MappingProxyType({
    "w/o reshaping": _rows({
        "cuRobo": (4.07, 7.64, 100),
        "Diffusion": (4.74, 6.88, 82.9),
        "INTP-2Ch-D_t": ("4.21 ± 0.10", "8.15 ± 0.11", 97.6),
        "INTP-2Ch-D_o'": ("4.32 ± 0.16", "7.09 ± 0.19", 91.7),
        "INTP-3Channels": ("4.30 ± 0.09", "8.66 ± 0.13", 98.8),
    }),
    "w/ reshaping": _rows({
        "cuRobo": (5.01, 7.48, 96.4),
        "Diffusion": (5.55, 6.09, 71.9),
        "INTP-2Ch-D_t": ("5.26 ± 0.17", "7.34 ± 0.19", 89.9),
        "INTP-2Ch-D_o'": ("5.58 ± 0.29", "5.74 ± 0.23", 78.6),
        "INTP-3Channels": ("4.85 ± 0.20", "7.82 ± 0.15", 95.8),
    }),
})

TABLE4_COLUMNS = ("Unsmth.", "Slid.", "FD", "EE RMSC")

TABLE4 = MappingProxyType({k: MappingProxyType(dict(zip(TABLE4_COLUMNS, v))) for k, v in {
    "w/ KF + cuRobo": (6.54, 7.22, 691, 0.0725),
    "w/o goal phase": (6.78, 7.55, 819, 0.0982),
    "w/ matched goal": (6.36, 6.80, 689, 0.0721),
    "w/ predicted goal": (6.30, 6.86, 711, 0.0614),
    "w/ KF goal": (5.94, 6.17, 670, 0.0509),
    "Dataset": (2.22, 1.02, "-", 0.0408),
}.items()})

TABLE2_COLUMNS = ("Key Joint Action", "Task", "Seconds", "%")

TABLE2 = (  # rows in the paper's order; the key-joint action spans the rows of its tasks
    ("Object Manipulate", "Grasp/Place", 3451, 12.7),
    ("Object Manipulate", "Cook", 2845, 10.5),
    ("Object Manipulate", "Drink", 98, 0.4),
    ("Object Manipulate", "Pour", 3075, 11.3),
    ("Door Manipulate", "Door opening/closing", 3046, 11.2),
    ("Draw", "Drawer Drag", 1731, 6.4),
    ("Idle", "Turn/Stand/Squat", 23352, 85.9),
    ("Walk", "Approach", 3845, 14.1),
)
