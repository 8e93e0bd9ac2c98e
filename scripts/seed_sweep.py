"""Run chapters with several seeds (SEED 0, 1 and 2 by default) and print, seed by seed, whether each run passed
(its claim asserts) and every verdict line it printed ("... is held", "inconclusive", "not held").

A chapter's comments and discussion quote numbers measured with SEED 0, 1 and 2, and assert a direction only where
its interval held for each with a margin. Those numbers move when the code the chapter runs changes: rerun this
for the chapters a change reaches, and compare. It measures and never gates (exit code 0 unless it cannot start).

    python scripts/seed_sweep.py 13_samp_baselines                    # SEED 0, 1, 2; a cache under build/
    python scripts/seed_sweep.py 12_samp_motionnet 13_samp_baselines --seeds 1 2 --cache ~/.cache/hoi_tutorial
    python scripts/seed_sweep.py 14_samp_pipeline --keep sweep_out      # also keep the executed notebooks
"""
import argparse
import json
import re
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench  # noqa: E402  (scripts/bench.py: finding and running notebooks)

# a verdict as the book prints it: "... is held", "...: inconclusive", "'...' is not held"
VERDICT = re.compile(r"\b(held|not held|inconclusive)\b")
# progress bars and cache lines are not results
NOISE = re.compile(r"it/s|s/it|\d+%\||^\[cache\]|^\[worker\]")


def verdict_lines(notebook: dict) -> list:
    """The lines of an executed notebook's printed output (its streams) that carry a verdict, in order."""
    lines = []
    for cell in notebook.get("cells", []):
        for output in cell.get("outputs", []):
            if output.get("output_type") != "stream":
                continue
            for line in "".join(output.get("text", "")).splitlines():
                if VERDICT.search(line) and not NOISE.search(line):
                    lines.append(line.strip())
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="+", help="stems, file names or paths of the chapters")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--scale", default="toy")
    parser.add_argument("--cache", type=Path, default=bench.REPO_ROOT / "build" / "seed_sweep" / "cache",
                        help="the artifact cache the runs share (kept: a second sweep loads what the first built)")
    parser.add_argument("--keep", type=Path, help="copy the executed notebooks to KEEP/seed<N>/")
    parser.add_argument("--cell-timeout", type=int, default=bench.CELL_TIMEOUT_S)
    args = parser.parse_args(argv)

    paths = bench.find_notebooks(args.notebooks)
    args.cache.mkdir(parents=True, exist_ok=True)
    summary = []
    with tempfile.TemporaryDirectory(prefix="hoi_seed_sweep_") as tmp:
        for path in paths:
            for seed in args.seeds:
                out_dir = Path(tmp) / f"seed{seed}"
                out_dir.mkdir(exist_ok=True)
                print(f"[sweep] {path.stem}, SEED {seed} ...", flush=True)
                seconds, error = bench.run_notebook(path, args.cache, out_dir,
                                                    {"SCALE": args.scale, "SEED": seed}, timeout=args.cell_timeout)
                executed = out_dir / path.name
                lines = verdict_lines(json.loads(executed.read_text())) if executed.exists() else []
                status = "passed" if error is None else f"FAILED: {error}"
                print(f"[sweep] {path.stem}, SEED {seed}: {status} ({seconds:.0f} s)")
                for line in lines:
                    print(f"    {line}")
                summary.append((path.stem, seed, status))
                if args.keep and executed.exists():
                    (args.keep / f"seed{seed}").mkdir(parents=True, exist_ok=True)
                    shutil.copy(executed, args.keep / f"seed{seed}" / path.name)
    print()
    for stem, seed, status in summary:
        print(f"{stem:32s} SEED {seed}: {status}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
