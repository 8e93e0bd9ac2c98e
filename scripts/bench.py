"""Time every chapter notebook from an empty artifact cache (cold) and again with the cache it
left behind (warm), and print the times beside the budgets from the design.

It measures and never gates: the exit code is 0 even when a notebook is over budget or fails.

    python scripts/bench.py                          # every notebooks/*.ipynb
    python scripts/bench.py --notebooks 01_toy_world  # a subset, by stem, file name or path
    python scripts/bench.py --isolated               # a fresh cache for each notebook (the instructor's case)
    python scripts/bench.py --cell-timeout 600       # stop a cell after 600 s (default: the readers' 1800 s)
    python scripts/bench.py --keep bench_out         # also keep the executed notebooks (cold/, warm/)
    python scripts/bench.py --pretrained PACK.zip    # each notebook alone, from an empty cache and the pack
                                                     # (its PRETRAINED parameter): the instructor's case
"""
import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK_DIR = REPO_ROOT / "notebooks"

# Budgets at SCALE="toy" on 2 CPU cores (DESIGN.md, "Scale presets and budgets").
COLD_BUDGET_S = 180.0  # in reading order, from the cache the chapters before it left
ALONE_BUDGET_S = 360.0  # alone, from an empty cache (--isolated)
WARM_BUDGET_S = 30.0
BOOK_BUDGET_S = 20 * 60.0
CELL_TIMEOUT_S = 1800  # the readers' commands' limit (the Makefile's CELL_TIMEOUT); CI keeps 600 s


def find_notebooks(selection):
    """Return the notebook paths to time, in reading order.

    selection: list of stems, file names or paths; empty or None means every notebooks/*.ipynb.
    """
    every = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
    if not selection:
        return every
    by_name = {p.stem: p for p in every} | {p.name: p for p in every}
    chosen = []
    for item in selection:
        path = by_name.get(item) or Path(item)
        if not path.is_file():
            raise SystemExit(f"--notebooks: no notebook {item!r}; expected one of {sorted(p.stem for p in every)}")
        chosen.append(path.resolve())
    return chosen


def run_notebook(path, cache_dir, out_dir, parameters, timeout=CELL_TIMEOUT_S):
    """Execute one notebook with papermill; return (seconds, error message or None)."""
    import papermill

    os.environ["HOI_CACHE"] = str(cache_dir)
    start = time.perf_counter()
    try:
        papermill.execute_notebook(
            str(path),
            str(out_dir / path.name),
            parameters=parameters,
            kernel_name="python3",
            cwd=str(path.parent),
            execution_timeout=timeout,
            progress_bar=False,
        )
        error = None
    except Exception as exc:  # a failing chapter is reported in the table, not raised
        error = f"{type(exc).__name__}: {str(exc).strip().splitlines()[-1] if str(exc).strip() else ''}"
    return time.perf_counter() - start, error


def format_seconds(seconds):
    return "—" if seconds is None else f"{seconds:7.1f}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--notebooks", nargs="+", help="stems, file names or paths of the notebooks to time")
    parser.add_argument("--scale", default="toy", help="SCALE parameter passed to every notebook (budgets are for toy)")
    parser.add_argument("--seed", type=int, default=0, help="SEED parameter passed to every notebook")
    parser.add_argument("--keep", metavar="DIR", help="copy the executed notebooks to DIR/cold and DIR/warm")
    parser.add_argument("--cell-timeout", type=int, default=CELL_TIMEOUT_S,
                        help=f"seconds a cell may run (default {CELL_TIMEOUT_S}, the readers' commands' limit)")
    parser.add_argument("--isolated", action="store_true",
                        help="give each notebook its own empty cache instead of one shared by the run, as in a book build")
    parser.add_argument("--pretrained", metavar="PACK",
                        help="a pretrained pack (scripts/make_pack.py): each notebook runs alone from an empty cache "
                             "with PRETRAINED set to it, once (the warm run is skipped); budget: the warm one")
    args = parser.parse_args(argv)
    if args.pretrained:
        if not Path(args.pretrained).is_file():
            raise SystemExit(f"--pretrained: expected a pack file, {args.pretrained!r} is not one")
        args.isolated = True

    notebooks = find_notebooks(args.notebooks)
    if not notebooks:
        print("no notebooks to time")
        return 0

    # The kernels import this working tree, draw figures inline (as in the book) and render offscreen.
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO_ROOT / "src"), os.environ.get("PYTHONPATH")) if p)
    os.environ.pop("MPLBACKEND", None)
    os.environ["PYVISTA_OFF_SCREEN"] = "true"
    parameters = {"SCALE": args.scale, "SEED": args.seed}
    if args.pretrained:
        parameters["PRETRAINED"] = str(Path(args.pretrained).resolve())
    phases = ("cold",) if args.pretrained else ("cold", "warm")

    work_dir = Path(tempfile.mkdtemp(prefix="hoi_bench_"))
    results = {}
    try:
        shared_cache = work_dir / "cache"
        shared_cache.mkdir()
        cache_of = {}
        for path in notebooks:
            cache_of[path] = shared_cache
            if args.isolated:
                cache_of[path] = work_dir / f"cache_{path.stem}"
                cache_of[path].mkdir()
        for phase in phases:
            out_dir = work_dir / phase
            out_dir.mkdir()
            for path in notebooks:
                print(f"[{phase}] {path.name} ...", flush=True)
                results[(phase, path)] = run_notebook(path, cache_of[path], out_dir, parameters, args.cell_timeout)
                seconds, error = results[(phase, path)]
                print(f"[{phase}] {path.name}: {seconds:.1f} s" + (f", failed ({error})" if error else ""), flush=True)
        if args.keep:
            for phase in phases:
                shutil.copytree(work_dir / phase, Path(args.keep) / phase, dirs_exist_ok=True)
    finally:
        shutil.rmtree(work_dir, ignore_errors=True)

    name_width = max(len("notebook"), max(len(p.stem) for p in notebooks))
    cold_budget = ALONE_BUDGET_S if args.isolated else COLD_BUDGET_S
    first = "pack s" if args.pretrained else "cold s"
    header = f"{'notebook':<{name_width}}  {first:>7}  {'warm s':>7}  notes"
    print()
    print(f"SCALE={args.scale}, {os.cpu_count()} CPU cores (budgets assume 2), "
          f"{'one cache per notebook' if args.isolated else 'one cache shared in reading order'}"
          + (f", each from an empty cache and the pack {Path(args.pretrained).name}" if args.pretrained else ""))
    if args.pretrained:
        print(f"budget: <= {WARM_BUDGET_S:.0f} s per notebook from the pack (the warm budget)")
    else:
        print(f"budgets: cold <= {cold_budget:.0f} s per notebook ({'alone' if args.isolated else 'in reading order'}), "
              f"warm <= {WARM_BUDGET_S:.0f} s, book <= {BOOK_BUDGET_S / 60:.0f} min")
    print(header)
    print("-" * len(header))
    total_cold = total_warm = 0.0
    over = 0
    first_budget = WARM_BUDGET_S if args.pretrained else cold_budget
    for path in notebooks:
        cold_s, cold_error = results[("cold", path)]
        warm_s, warm_error = results.get(("warm", path), (None, None))
        total_cold += cold_s
        total_warm += warm_s or 0.0
        notes = []
        if cold_error:
            notes.append(f"{'pack' if args.pretrained else 'cold'} run failed ({cold_error})")
        if warm_error:
            notes.append(f"warm run failed ({warm_error})")
        if cold_s > first_budget:
            notes.append(f"OVER {'the warm' if args.pretrained else 'cold'} budget by {cold_s - first_budget:.0f} s")
        if warm_s is not None and warm_s > WARM_BUDGET_S:
            notes.append(f"OVER warm budget by {warm_s - WARM_BUDGET_S:.0f} s")
        over += any(n.startswith("OVER") for n in notes)
        print(f"{path.stem:<{name_width}}  {format_seconds(cold_s)}  {format_seconds(warm_s)}  {'; '.join(notes) or 'ok'}")
    print("-" * len(header))
    if args.pretrained:
        print(f"{'total':<{name_width}}  {format_seconds(total_cold)}")
    elif args.isolated:  # each chapter rebuilt what it needs: the sum is not the book's time
        print(f"{'total':<{name_width}}  {format_seconds(total_cold)}  {format_seconds(total_warm)}  "
              "(each alone: not the book's time)")
    else:
        book_note = "ok" if total_cold <= BOOK_BUDGET_S else f"OVER book budget by {total_cold - BOOK_BUDGET_S:.0f} s"
        print(f"{'total':<{name_width}}  {format_seconds(total_cold)}  {format_seconds(total_warm)}  "
              f"cold total vs book budget: {book_note} (the book build adds Sphinx time)")
    failed = sum(bool(results[(phase, p)][1]) for phase in phases for p in notebooks)
    print(f"{len(notebooks)} notebook(s), {over} over budget, {failed} failed run(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
