"""Which numeric kernels this machine uses, and an environment that makes it use others.

Another CPU picks other BLAS and vector kernels, which round differently in the last bits. CI runs the library's
tests twice: once as the machine is, once with the variables ``--other`` prints, so that a test that depends on
last bits fails in CI rather than on a reader's machine.

Usage::

    python scripts/numeric_env.py --show     # the kernels in use (OpenBLAS core type, torch's CPU capability, MKL_CBWR)
    eval "$(python scripts/numeric_env.py --other)"   # export variables that select other kernels

The variables: ``OPENBLAS_CORETYPE`` (numpy's and scipy's OpenBLAS; one generation older than the machine's
core type), ``ATEN_CPU_CAPABILITY`` (torch's own vectorised kernels; one width narrower) and ``MKL_CBWR=COMPATIBLE``
(torch's MKL; its conditional-numerical-reproducibility mode that runs the same code path on every CPU).
"""
from __future__ import annotations

import argparse
import os
import platform
import sys

# Older to newer; --other takes the core type before the machine's.
OPENBLAS_CORES = ("Prescott", "Core2", "Nehalem", "Sandybridge", "Haswell", "SkylakeX", "Cooperlake",
                  "SapphireRapids")
ATEN_CAPABILITIES = ("default", "avx2", "avx512")
# OpenBLAS names some cores of other families; map them onto the ladder above.
_ALSO = {"Zen": "Haswell", "Skylake": "Haswell", "Atom": "Core2", "Dunnington": "Core2", "Penryn": "Core2",
         "Opteron": "Prescott", "Barcelona": "Prescott", "Bulldozer": "Sandybridge", "Piledriver": "Sandybridge",
         "Steamroller": "Sandybridge", "Excavator": "Sandybridge"}


def kernels() -> dict:
    """What this process uses: ``{"openblas": [core type per library], "torch": capability, "mkl_cbwr": ...}``."""
    import numpy  # noqa: F401 - load numpy's OpenBLAS before asking threadpoolctl
    import scipy.linalg  # noqa: F401 - and scipy's
    import torch

    found = {"openblas": [], "torch": torch.backends.cpu.get_cpu_capability(),
             "mkl_cbwr": os.environ.get("MKL_CBWR", "(unset: MKL picks by CPU)"), "machine": platform.machine()}
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        found["openblas"] = ["(threadpoolctl not installed)"]
    else:
        found["openblas"] = sorted({f"{info.get('architecture')} ({info.get('prefix')})"
                                    for info in threadpool_info() if info.get("internal_api") == "openblas"})
    return found


def other_environment(found: dict) -> dict:
    """Variables that select kernels other than ``found``'s (empty where there is nothing older to choose)."""
    env = {"MKL_CBWR": "COMPATIBLE"}
    cores = [entry.split(" ")[0] for entry in found["openblas"]]
    core = next((c for c in cores if c in OPENBLAS_CORES or c in _ALSO), None)
    if core is not None and found["machine"] in ("x86_64", "AMD64"):
        rank = OPENBLAS_CORES.index(_ALSO.get(core, core))
        env["OPENBLAS_CORETYPE"] = OPENBLAS_CORES[rank - 1] if rank > 0 else OPENBLAS_CORES[1]
    capability = str(found["torch"]).lower()
    if capability in ATEN_CAPABILITIES:
        rank = ATEN_CAPABILITIES.index(capability)
        env["ATEN_CPU_CAPABILITY"] = ATEN_CAPABILITIES[rank - 1] if rank > 0 else ATEN_CAPABILITIES[1]
    return env


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--show", action="store_true", help="print the kernels this process uses")
    group.add_argument("--other", action="store_true", help="print `export` lines that select other kernels")
    args = parser.parse_args(argv)
    found = kernels()
    if args.show:
        print(f"numeric kernels: OpenBLAS {', '.join(found['openblas']) or '(none found)'}; torch CPU capability "
              f"{found['torch']}; MKL_CBWR {found['mkl_cbwr']}; machine {found['machine']}")
    else:
        for name, value in other_environment(found).items():
            print(f"export {name}={value}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
