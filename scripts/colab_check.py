"""Run chapters the way a reader on a bare Colab runtime does: from the set-up cell alone.

Every chapter's first cell installs the library only where ``import hoi_tutorial`` fails. CI and
local builds always have the library, so that branch never runs there. This check makes it run:

1. it creates a fresh virtual environment in a temporary folder holding what a Colab runtime already
   has, at Colab's versions (``COLAB_PACKAGES``: numpy, scipy, pandas, matplotlib, the Jupyter kernel
   with IPython 7 and ipywidgets 7, tqdm, networkx, scikit-learn, pooch, ...) plus papermill, the
   runner; not the library nor the dependencies Colab lacks (pyvista, trimesh, scikit-fmm, ...);
2. it registers a Jupyter kernel for that environment and checks, with a probe notebook, that the
   kernel runs the environment's interpreter and cannot import ``hoi_tutorial``;
3. it executes each chapter with papermill on that kernel, with ``HOI_TUTORIAL_SOURCE`` pointing at
   a copy of this checkout (so the set-up cell installs the working tree, not the repository),
   an empty artifact cache (``HOI_CACHE``), ``MPLBACKEND=Agg`` and ``SCALE=toy``. Between chapters
   the environment is put back to its bare state, so each chapter installs the library itself.
4. after each chapter it compares the environment with the bare runtime: the set-up cell must leave
   every one of Colab's packages at Colab's version (a replaced ipywidgets or IPython makes Colab ask
   for a restart), and install no test package, and the render extra (pyvista, VTK) only for a
   chapter that renders.

A chapter passes when it runs from its set-up cell alone and changes none of Colab's packages. When a chapter imports a module that the
set-up cell's install does not bring (its distribution is missing from ``[project]
dependencies`` in ``pyproject.toml``), the check fails with a message naming the module.
The time of every step is printed; the temporary folders are removed at the end (``--keep``
keeps them for inspection).

Usage::

    python scripts/colab_check.py                       # chapters 03, 11 and 15: one of each paper
    python scripts/colab_check.py notebooks/05_object_interaction_fields.ipynb
    make colab-check COLAB_CHAPTERS="notebooks/01_toy_world.ipynb"
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Iterator, Optional, Sequence

REPO_ROOT = Path(__file__).resolve().parents[1]
# One chapter of each paper: NIFTY (renders in 3D), SAMP (does not), CHOICE (renders).
DEFAULT_CHAPTERS = ("notebooks/03_synthetic_interaction_data.ipynb", "notebooks/11_samp_goals_and_paths.ipynb",
                    "notebooks/15_choice_fields.ipynb")
# torch comes first and pinned: the pin selects the CPU build, an unpinned torch would pull the CUDA build
# (gigabytes). Colab's CPU runtime has torch 2.11.0+cpu on Python 3.13; the check runs this machine's Python and
# its CPU torch.
TORCH_SPEC = os.environ.get("TORCH_SPEC", "torch==2.13.0")
# What a Colab runtime already has, at its versions: the packages of Colab's published `pip freeze`
# (github.com/googlecolab/backend-info, pip-freeze.txt of 2026-08-19) that the library, its chapters or the
# Jupyter kernel use. The set-up cell must leave each as it is.
COLAB_PACKAGES = (
    "numpy==2.1.3", "scipy==1.16.3", "pandas==2.2.3", "matplotlib==3.10.0", "pillow==11.3.0",
    "networkx==3.6.1", "scikit-learn==1.6.1", "tqdm==4.67.3", "pooch==1.9.0", "rtree==1.4.1", "PyYAML==6.0.3",
    "ipykernel==6.17.1", "ipython==7.34.0", "ipywidgets==7.7.1", "jupyter_client==7.4.9", "traitlets==5.7.1",
    "nbformat==5.11.1",
)
# The runner, which Colab does not need.
RUNNER_PACKAGES = ("papermill",)
# Installed by the test or render extras only: a chapter's set-up cell brings none of these (render: only a chapter
# that renders).
TEST_ONLY = ("pytest", "hypothesis", "nbval", "diffusers")
RENDER_ONLY = ("pyvista", "vtk")
KERNEL_NAME = "hoi-colab-check"
SOURCE_VARIABLE = "HOI_TUTORIAL_SOURCE"
# Files the library's install needs: what a ``pip install git+...`` of the repository builds from.
SOURCE_FILES = ("pyproject.toml", "README.md", "src")
# Variables of the calling environment that would let the kernel see more than a bare runtime.
DROPPED_VARIABLES = ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME", "JUPYTER_PATH", "DISPLAY", "PYVISTA_OFF_SCREEN",
                     "HOI_CACHE", SOURCE_VARIABLE)

NO_MODULE = re.compile(r"No module named '([^']+)'")


class CheckFailed(Exception):
    """A step of the check failed; the message says which and why."""


# --------------------------------------------------------------------------------------------------
# Reading a failed run


def missing_module_message(chapter: str, module: str, cell: Optional[int] = None) -> str:
    """The message for a chapter that imports a module the set-up cell's install does not bring."""
    where = f" (cell {cell})" if cell is not None else ""
    top = module.split(".")[0]
    if top == "hoi_tutorial":
        return (f"{chapter}{where}: 'import hoi_tutorial' still fails after the set-up cell: its "
                f"'%pip install' did not install the library (see pip's output in that cell)")
    return (f"{chapter}{where}: the chapter imports the module '{module}', which the set-up cell's "
            f"install does not bring. Add the distribution that provides '{top}' to [project] "
            f"dependencies in pyproject.toml.")


def _read_notebook(path: Path) -> Optional[dict]:
    """An executed notebook as a dict with joined sources and texts, or None when unreadable."""
    import nbformat

    try:
        return nbformat.read(path, as_version=4)
    except Exception:  # papermill may not have written it (the kernel did not start)
        return None


def first_error(nb: dict) -> Optional[tuple]:
    """``(cell index, ename, evalue)`` of the first error output in an executed notebook, or None.

    The index counts every cell of papermill's output (markdown cells and its injected-parameters
    cell included), from 0.
    """
    for index, cell in enumerate(nb.get("cells", [])):
        for output in cell.get("outputs", []) if cell.get("cell_type") == "code" else []:
            if output.get("output_type") == "error":
                return index, output.get("ename", ""), output.get("evalue", "")
    return None


def diagnose(chapter: str, nb: Optional[dict], log: str = "") -> str:
    """A one-paragraph reason for a failed chapter, from papermill's output notebook (or its log).

    A missing module (``ModuleNotFoundError``, or an ``ImportError`` saying "No module named") is
    named, with where to declare it; any other error is reported as ``cell N: Name: value``.
    """
    error = first_error(nb) if nb is not None else None
    if error is not None:
        cell, ename, evalue = error
        match = NO_MODULE.search(evalue)
        if ename in ("ModuleNotFoundError", "ImportError") and match:
            return missing_module_message(chapter, match.group(1), cell)
        return f"{chapter} (cell {cell}): {ename}: {evalue}"
    match = NO_MODULE.search(log)
    if match:
        return missing_module_message(chapter, match.group(1))
    tail = "\n".join(log.strip().splitlines()[-15:])
    return f"{chapter}: papermill failed without an error in the notebook; its last output:\n{tail}"


# --------------------------------------------------------------------------------------------------
# Steps


@contextlib.contextmanager
def step(name: str, times: list) -> Iterator[None]:
    """Time a step, print its duration and record ``(name, seconds, ok)`` in ``times``."""
    print(f"--- {name}", flush=True)
    start = time.perf_counter()
    ok = False
    try:
        yield
        ok = True
    finally:
        seconds = time.perf_counter() - start
        times.append((name, seconds, ok))
        print(f"    {'done' if ok else 'FAILED'} in {seconds:.1f} s", flush=True)


def run(command: Sequence, env: Optional[dict] = None, cwd: Optional[Path] = None) -> str:
    """Run a command; return its output, or raise :class:`CheckFailed` with the output's tail."""
    result = subprocess.run([str(c) for c in command], env=env, cwd=cwd, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    if result.returncode != 0:
        tail = "\n".join(result.stdout.strip().splitlines()[-25:])
        raise CheckFailed(f"command failed ({result.returncode}): {' '.join(map(str, command))}\n{tail}")
    return result.stdout


def _renders(chapter: Path) -> bool:
    """Whether a chapter renders in 3D (its set-up cell installs the render extra; scripts/notebook_cells.py)."""
    import importlib.util

    import nbformat

    spec = importlib.util.spec_from_file_location("notebook_cells", REPO_ROOT / "scripts" / "notebook_cells.py")
    cells = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(cells)
    return cells.uses_render(nbformat.read(chapter, as_version=4))


def bare_environment(venv: Path) -> dict:
    """The environment the kernel sees: the caller's, less anything pointing at another Python."""
    env = {k: v for k, v in os.environ.items() if k not in DROPPED_VARIABLES}
    other_bins = {str(Path(sys.prefix) / "bin"), str(REPO_ROOT / ".venv" / "bin")}
    path = [p for p in env.get("PATH", "").split(os.pathsep) if p and p not in other_bins]
    env["PATH"] = os.pathsep.join([str(venv / "bin")] + path)
    env["VIRTUAL_ENV"] = str(venv)
    env["PYTHONNOUSERSITE"] = "1"
    return env


def copy_source(target: Path) -> Path:
    """Copy what the library's install builds from (the working tree, not the last commit)."""
    target.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.egg-info", "*.pyc")
    for name in SOURCE_FILES:
        source = REPO_ROOT / name
        if source.is_dir():
            shutil.copytree(source, target / name, ignore=ignore)
        else:
            shutil.copy2(source, target / name)
    return target


def write_probe(path: Path) -> Path:
    """A notebook that prints the kernel's interpreter and whether ``hoi_tutorial`` can be imported."""
    import nbformat

    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": KERNEL_NAME, "language": "python", "display_name": KERNEL_NAME}
    nb.cells = [nbformat.v4.new_code_cell(
        "import importlib.util, json, sys\n"
        "print(json.dumps({'executable': sys.executable,\n"
        "                  'hoi_tutorial': importlib.util.find_spec('hoi_tutorial') is not None}))\n")]
    nbformat.write(nb, path)
    return path


def read_probe(path: Path) -> dict:
    """The JSON line the probe notebook printed."""
    import nbformat

    nb = nbformat.read(path, as_version=4)  # joins the text that the file stores as a list of lines
    text = "".join(o.get("text", "") for cell in nb.cells if cell.cell_type == "code"
                   for o in cell.outputs if o.get("output_type") == "stream")
    lines = text.strip().splitlines()
    if not lines:
        raise CheckFailed("the probe notebook printed nothing")
    return json.loads(lines[-1])


def freeze(python: Path) -> dict:
    """``{name: requirement line}`` of what an environment holds."""
    lines = run([python, "-m", "pip", "freeze", "--all"]).splitlines()
    found = {}
    for line in lines:
        name = re.split(r"[=@ ]", line.strip(), maxsplit=1)[0].lower().replace("_", "-")
        if name:
            found[name] = line.strip()
    return found


def _name(requirement: str) -> str:
    return re.split(r"[=<>@ \[]", requirement.strip(), maxsplit=1)[0].lower().replace("_", "-")


def changed_by_setup(chapter: str, bare: dict, now: dict, renders: bool) -> list:
    """What a chapter's set-up cell did that a Colab runtime would not want: Colab's packages at other versions,
    a test package, or the render extra in a chapter that does not render (``bare`` and ``now``: :func:`freeze`)."""
    problems = []
    for requirement in COLAB_PACKAGES:
        name = _name(requirement)
        if bare.get(name) != now.get(name):
            problems.append(f"{chapter}: the set-up cell changed Colab's {bare.get(name, name)} to "
                            f"{now.get(name, 'nothing')} (Colab would ask for a restart); loosen the requirement "
                            "in pyproject.toml")
    for name in TEST_ONLY + (() if renders else RENDER_ONLY):
        if name in now and name not in bare:
            problems.append(f"{chapter}: the set-up cell installed {now[name]}, which "
                            f"{'only the tests need' if name in TEST_ONLY else 'only chapters that render need'}")
    return problems


def restore(python: Path, bare: dict) -> None:
    """Put an environment back to the packages in ``bare`` (a :func:`freeze`): remove what a chapter
    installed, reinstall what it upgraded."""
    now = freeze(python)
    added = sorted(set(now) - set(bare))
    changed = [bare[name] for name in bare if now.get(name) != bare[name]]
    if added:
        run([python, "-m", "pip", "uninstall", "--yes", *added])
    if changed:
        run([python, "-m", "pip", "install", "--quiet", "--no-deps", *changed])


def execute(python: Path, notebook: Path, output: Path, env: dict, cwd: Path, timeout: int,
            parameters: Sequence = ("SCALE", "toy")) -> tuple:
    """Execute a notebook with papermill on the check's kernel; return ``(ok, log)``.

    ``parameters`` are ``name, value`` pairs, flat, injected after the chapter's parameters cell.
    """
    command = [python, "-m", "papermill", notebook, output, "-k", KERNEL_NAME,
               "--cwd", cwd, "--execution-timeout", str(timeout), "--no-progress-bar", "--log-output"]
    for name, value in zip(parameters[::2], parameters[1::2]):
        command += ["-p", name, value]
    result = subprocess.run([str(c) for c in command], env=env, text=True, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT)
    return result.returncode == 0, result.stdout


# --------------------------------------------------------------------------------------------------
# The check


def check(chapters: Sequence[Path], keep: bool = False, timeout: int = 1800) -> int:
    """Run the check on ``chapters``; print a summary and return 0 when every chapter passed."""
    chapters = [Path(c).resolve() for c in chapters]
    for chapter in chapters:
        if not chapter.is_file():
            raise SystemExit(f"no such chapter: {chapter}")
    root = Path(tempfile.mkdtemp(prefix="hoi-colab-check-"))
    venv, times, failures = root / "venv", [], []
    python = venv / "bin" / "python"
    print(f"colab-check in {root} (removed at the end{'; --keep: kept' if keep else ''})", flush=True)
    try:
        with step("create the virtual environment", times):
            run([sys.executable, "-m", "venv", venv])
        env = bare_environment(venv)
        with step(f"install {TORCH_SPEC} (first, so the CPU build is kept)", times):
            run([python, "-m", "pip", "install", "--quiet", TORCH_SPEC], env=env)
        with step(f"install Colab's packages at Colab's versions, and the runner: "
                  f"{' '.join(COLAB_PACKAGES + RUNNER_PACKAGES)}", times):
            run([python, "-m", "pip", "install", "--quiet", *COLAB_PACKAGES, *RUNNER_PACKAGES], env=env)
            pinned = freeze(python)
            off = [r for r in COLAB_PACKAGES if pinned.get(_name(r), "").lower().replace("_", "-")
                   != r.lower().replace("_", "-")]
            if off:
                raise CheckFailed("the runner moved Colab's packages off their versions: "
                                  + ", ".join(f"{r} (now {pinned.get(_name(r))})" for r in off))
        with step(f"register the kernel {KERNEL_NAME!r} for the environment", times):
            run([python, "-m", "ipykernel", "install", "--prefix", venv, "--name", KERNEL_NAME,
                 "--display-name", "Python 3 (colab-check)"], env=env)
            bare = freeze(python)
        with step("probe: the kernel runs the environment's Python, without hoi_tutorial", times):
            probe = write_probe(root / "probe.ipynb")
            ok, log = execute(python, probe, root / "probe-out.ipynb", env, root, 120, parameters=())
            if not ok:
                raise CheckFailed("the probe notebook failed:\n" + "\n".join(log.splitlines()[-20:]))
            seen = read_probe(root / "probe-out.ipynb")
            print(f"    kernel interpreter: {seen['executable']}")
            if Path(seen["executable"]).parent.resolve() != (venv / "bin").resolve():
                raise CheckFailed(f"the kernel runs {seen['executable']}, not the environment's Python")
            if seen["hoi_tutorial"]:
                raise CheckFailed("hoi_tutorial is importable before any set-up cell ran")
        source = copy_source(root / "source")
        for number, chapter in enumerate(chapters):
            name = chapter.name
            if number:
                with step("reset the environment to the bare runtime", times):
                    restore(python, bare)
            cache, work = root / f"cache-{number}", root / f"work-{number}"
            cache.mkdir()
            work.mkdir()
            chapter_env = dict(env, **{SOURCE_VARIABLE: str(source), "HOI_CACHE": str(cache),
                                       "MPLBACKEND": "Agg", "SCALE": "toy"})
            output = root / f"out-{name}"
            try:
                with step(f"chapter {name}", times):
                    ok, log = execute(python, chapter, output, chapter_env, work, timeout)
                    nb = _read_notebook(output)
                    if not ok:
                        raise CheckFailed(diagnose(name, nb, log))
                    setup = nb.cells[0] if nb is not None and nb.cells else None
                    if setup is not None and "setup" in setup.metadata.get("tags", []):
                        seconds = setup.metadata.get("papermill", {}).get("duration") or 0.0
                        print(f"    set-up cell (the library's install): {seconds:.1f} s")
                    now = freeze(python)
                    if "hoi-tutorial" not in now:
                        raise CheckFailed(f"{name}: ran, but the set-up cell did not install hoi_tutorial")
                    problems = changed_by_setup(name, bare, now, renders=_renders(chapter))
                    if problems:
                        raise CheckFailed("\n".join(problems))
                    print(f"    Colab's {len(COLAB_PACKAGES)} packages unchanged; no test package"
                          f"{'' if _renders(chapter) else ', no render package'}")
            except CheckFailed as exc:
                failures.append(str(exc))
                print(f"    {exc}", flush=True)
    except CheckFailed as exc:
        failures.append(str(exc))
        print(f"    {exc}", flush=True)
    finally:
        if keep:
            print(f"kept {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)
    print("\ncolab-check timings:")
    for name, seconds, ok in times:
        print(f"  {seconds:8.1f} s  {'ok    ' if ok else 'FAILED'}  {name}")
    print(f"  {sum(t for _, t, _ in times):8.1f} s  total")
    if failures:
        print("\ncolab-check FAILED:")
        for failure in failures:
            print("  - " + failure.replace("\n", "\n    "))
        return 1
    print(f"\ncolab-check passed: {', '.join(c.name for c in chapters)} ran from the set-up cell alone")
    return 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("chapters", nargs="*", type=Path,
                        default=[REPO_ROOT / c for c in DEFAULT_CHAPTERS],
                        help="notebooks to execute (default: chapters 03, 11 and 15, one of each paper)")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folders for inspection")
    parser.add_argument("--timeout", type=int, default=1800, help="seconds allowed per cell (default 1800)")
    args = parser.parse_args(argv)
    return check(args.chapters, keep=args.keep, timeout=args.timeout)


if __name__ == "__main__":
    sys.exit(main())
