"""CHOICE's reported numbers, transcribed exactly from the paper, for the tables the chapters set beside ours.

Rows are the paper's method names as printed; values with a spread are kept as the printed strings.

Source: CHOICE (Lu et al. 2024), §8.2.2, Table 3 ("Comparison among SE(3) trajectory planners for the end
effector"; INTPs run three times per scene with different latent initialisations, mean ± std).
"""
from __future__ import annotations

from types import MappingProxyType

__all__ = ["TABLE3_COLUMNS", "TABLE3"]

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
