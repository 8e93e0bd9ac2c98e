"""The two cells every chapter starts with, and a tool to stamp them into notebooks.

Cell 1 installs the library only where ``import hoi_tutorial`` fails (a bare Colab runtime);
it is tagged ``hide-cell`` so the rendered book folds it away. The install address is read from
``_config.yml`` (the one place the repository URL is kept), and the version from ``pyproject.toml`` at stamp
time: a release installs its tag ``v<version>``, the version the page was built from, so a page and the code it
installs stay together after main moves on; a development version (``X.Y.Z.devN``) has no tag and installs
``main``. The environment variable ``HOI_TUTORIAL_SOURCE``, when set, replaces it with any other ``pip install``
target, e.g. the path of a local checkout (``make colab-check`` uses this). A chapter that calls
``hoi_tutorial.viz.render``'s renders installs the library with its ``render`` extra (pyvista and VTK); the others
install the core alone.
Cell 2 is papermill's ``parameters`` cell; the tool adds its ``PRETRAINED`` line where it is missing, and its
``hide-input`` tag (folded on the page, so the page opens on the chapter's title). Cell 3,
also hidden, unpacks a pretrained pack into the artifact cache when ``PRETRAINED`` asks for one
(``hoi_tutorial.infra.use_pretrained``; off by default, in CI and in ``make book``).

Usage: ``python scripts/notebook_cells.py notebooks/*.ipynb`` rewrites cell 1 of each notebook
from the current ``_config.yml`` and ``pyproject.toml`` (and strips outputs); ``--check`` only reports differences.
A release re-stamps every chapter (``scripts/release.py --prepare`` does).
"""
from __future__ import annotations

import argparse
import ast
import re
import sys
from pathlib import Path

import nbformat
import yaml

REPO_ROOT = Path(__file__).resolve().parents[1]
SETUP_TAGS = ["hide-cell", "setup"]
# Names the pip target that replaces the repository address in the set-up cell.
SOURCE_VARIABLE = "HOI_TUTORIAL_SOURCE"
# The extra (pyproject.toml) a chapter that renders in 3D installs, and the module whose functions need it (from a
# checkout's root).
RENDER_EXTRA = "render"
RENDER_MODULE = Path("src") / "hoi_tutorial" / "viz" / "render.py"
# PEP 440's X.Y.Z.devN (as hoi_tutorial.infra.pack): the code between two releases, which no tag names.
_DEVELOPMENT_VERSION = re.compile(r"\.dev\d+(?:\+[A-Za-z0-9.]+)?$")
# What a development version's set-up cell installs: the repository's default branch.
DEVELOPMENT_BRANCH = "main"
# render.py's exports that do not need pyvista
_RENDER_FREE = {"SKIN_COLOR", "OBJECT_COLORS", "CAMERAS", "RenderingUnavailable", "unavailable_image", "show_image"}


def repository_url(root: Path = REPO_ROOT) -> str:
    config = yaml.safe_load((root / "_config.yml").read_text())
    return config["repository"]["url"]


def package_version(root: Path = REPO_ROOT) -> str:
    """``[project] version`` of ``root``'s pyproject.toml: the version the book is built from."""
    text = (root / "pyproject.toml").read_text()
    try:
        import tomllib
    except ImportError:  # Python 3.10: the version line of the [project] table
        table = re.search(r"^\[project\]\s*$(.*?)(?=^\[|\Z)", text, flags=re.M | re.S)
        line = re.search(r'^version\s*=\s*"([^"]+)"\s*$', table.group(1), flags=re.M) if table else None
        if line is None:
            raise ValueError(f"{root / 'pyproject.toml'}: expected a [project] table with a version = \"...\" line")
        return line.group(1)
    return tomllib.loads(text)["project"]["version"]


def is_development(version: str) -> bool:
    """Whether ``version`` is a development version (``0.2.0.dev0``), which has no release tag."""
    return bool(_DEVELOPMENT_VERSION.search(version))


def git_ref(version: str) -> str:
    """What the set-up cell installs from the repository for ``version``: a release's tag ``v<version>``, or
    :data:`DEVELOPMENT_BRANCH` for a development version (no tag names it)."""
    return DEVELOPMENT_BRANCH if is_development(version) else f"v{version}"


def default_install_target(render: bool = False, root: Path = REPO_ROOT) -> str:
    """The pip requirement the set-up cell installs by default: the library from its repository at the version the
    book is built from (:func:`git_ref`), with the ``render`` extra for a chapter that renders."""
    extra = f"[{RENDER_EXTRA}]" if render else ""
    return f"hoi_tutorial{extra} @ git+{repository_url(root)}@{git_ref(package_version(root))}"


def install_target(environ=None, render: bool = False, root: Path = REPO_ROOT) -> str:
    """What the set-up cell passes to ``pip install``: ``$HOI_TUTORIAL_SOURCE`` when set and not
    empty (a local checkout, a wheel, another git address; ``[render]`` appended for a chapter that
    renders), else :func:`default_install_target`.

    The set-up cell computes the same thing in its own code (it cannot import this script); a test
    executes that code and compares it with this function.
    """
    import os

    environ = os.environ if environ is None else environ
    source = environ.get(SOURCE_VARIABLE)
    if source:
        return f"{source}[{RENDER_EXTRA}]" if render else source
    return default_install_target(render, root)


def render_functions(root: Path = REPO_ROOT) -> set:
    """The names ``hoi_tutorial.viz.render`` exports that need pyvista (read from its ``__all__``)."""
    module = root / RENDER_MODULE
    tree = ast.parse(module.read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "__all__" for t in node.targets):
            return set(ast.literal_eval(node.value)) - _RENDER_FREE
    raise ValueError(f"{module}: expected an __all__ list")


def uses_render(nb, root: Path = REPO_ROOT) -> bool:
    """Whether a notebook's code (cell 1 aside) calls one of :func:`render_functions`."""
    pattern = re.compile(r"\b(?:%s)\b" % "|".join(sorted(render_functions(root))))
    return any(pattern.search(c.source) for c in nb.cells[1:] if c.cell_type == "code")


def setup_source(render: bool = False, root: Path = REPO_ROOT) -> str:
    """The code of cell 1. It stays a no-op wherever ``hoi_tutorial`` imports; otherwise it installs
    ``$HOI_TUTORIAL_SOURCE`` or the repository at the version the book is built from (IPython expands ``{source}``
    in the ``%pip`` line), with the ``render`` extra for a chapter that renders (``render``)."""
    version = package_version(root)
    if is_development(version):  # no version number: a dev0 -> dev1 step leaves the cells as they are
        which = (f"# The development version: {DEVELOPMENT_BRANCH} (this page was built from code after the last "
                 "release, which has no tag).\n")
    else:
        which = f"# The release this page was built from: tag v{version}.\n"
    head = (
        "# Set-up for Colab: install the library only where it is missing (a no-op in CI and local builds).\n"
        + which
        + f"# {SOURCE_VARIABLE}, when set, replaces the repository address (e.g. a local checkout).\n"
    )
    repository = f"    from_repository = \"{default_install_target(render, root)}\"\n"
    if render:
        head += f"# This chapter renders in 3D: the library comes with its {RENDER_EXTRA} extra (pyvista, VTK).\n"
        choose = (repository
                  + f"    source = os.environ.get(\"{SOURCE_VARIABLE}\")\n"
                  f"    source = source + \"[{RENDER_EXTRA}]\" if source else from_repository\n")
    else:
        choose = repository + f"    source = os.environ.get(\"{SOURCE_VARIABLE}\") or from_repository\n"
    return (
        head
        + "try:\n"
        "    import hoi_tutorial  # noqa: F401\n"
        "except ImportError:\n"
        "    import os\n"
        + choose
        + "    %pip install --quiet \"{source}\"\n"
    )


# The parameter that asks for a pretrained pack, as the parameters cell states it (off by default).
PRETRAINED_LINE = "PRETRAINED = False  # True: the release's pretrained pack (a download); or a pack's path or URL\n"
PRETRAINED_TAGS = ["hide-cell", "pretrained"]
# The parameters cell is folded on the rendered page, so a chapter's page opens on its title (Colab ignores tags).
PARAMETERS_FOLD = "hide-input"


def pretrained_source(chapter: str) -> str:
    """The code of cell 3 of the chapter ``chapter`` (its notebook's name): unpack the artifacts of the pack
    ``PRETRAINED`` names that this chapter uses (nothing when it is ``False``)."""
    if not re.fullmatch(r"[0-9A-Za-z_]+", chapter):
        raise ValueError(f"chapter: expected a notebook's name (letters, digits, '_'), got {chapter!r}")
    return (
        "# A pretrained pack, only when PRETRAINED asks for one: the artifacts of this chapter that the installed code\n"
        "# built are unpacked into the cache, and the chapter loads them instead of building them.\n"
        "from hoi_tutorial.infra import use_pretrained\n"
        "\n"
        f'_pack = use_pretrained(PRETRAINED, scale=SCALE, seed=SEED, chapter="{chapter}")\n'
    )


def setup_cell(render: bool = False, root: Path = REPO_ROOT):
    return nbformat.v4.new_code_cell(setup_source(render, root), metadata={"tags": list(SETUP_TAGS)})


def parameters_cell(extra: str = "") -> nbformat.NotebookNode:
    source = (
        "# Parameters (papermill): the scale preset, the seed and the device.\n"
        'SCALE = "toy"  # "toy" (CPU, minutes), "small" or "paper"\n'
        "SEED = 0\n"
        'DEVICE = "auto"  # "auto" picks CUDA when present\n'
        + PRETRAINED_LINE
    ) + extra
    return nbformat.v4.new_code_cell(source, metadata={"tags": ["parameters"]})


def _with_pretrained_line(source: str) -> str:
    """The parameters cell's source with :data:`PRETRAINED_LINE` (after the ``DEVICE`` line) where it lacks one."""
    if re.search(r"^PRETRAINED\s*=", source, flags=re.M):
        return source
    lines = source.splitlines(keepends=True)
    at = next((i + 1 for i, line in enumerate(lines) if line.startswith("DEVICE")), len(lines))
    if at == len(lines) and lines and not lines[-1].endswith("\n"):
        lines[-1] += "\n"
    return "".join(lines[:at] + [PRETRAINED_LINE] + lines[at:])


def stamp(path: Path, check: bool = False, root: Path = REPO_ROOT) -> bool:
    """Make cell 1 the current set-up cell, give cell 2 its ``PRETRAINED`` line and its ``hide-input`` tag and cell 3
    the current pretrained cell; return True when the file was (or would be) changed. ``root``: the checkout whose
    ``_config.yml``, ``pyproject.toml`` and render module say what cell 1 installs."""
    nb = nbformat.read(path, as_version=4)
    cells = nb.cells
    first = cells[0] if cells else None
    is_setup = first is not None and "setup" in first.metadata.get("tags", [])
    wanted = setup_cell(uses_render(nb, root), root)
    setup_ok = is_setup and first.source == wanted.source and first.metadata.get("tags") == wanted.metadata["tags"]
    at = 1 if is_setup else 0  # where the parameters cell is now (cell 2 once the set-up cell is in place)
    params = cells[at] if len(cells) > at and "parameters" in cells[at].metadata.get("tags", []) else None
    params_ok = params is None or (_with_pretrained_line(params.source) == params.source
                                   and PARAMETERS_FOLD in params.metadata.get("tags", []))
    third = cells[at + 1] if len(cells) > at + 1 and "pretrained" in cells[at + 1].metadata.get("tags", []) else None
    third_ok = params is None or (third is not None and third.source == pretrained_source(path.stem)
                                  and third.metadata.get("tags") == PRETRAINED_TAGS)
    if setup_ok and params_ok and third_ok:
        return False
    if check:
        return True
    if is_setup:
        if "id" in first:  # keep the cell's id so a re-stamp changes only the source
            wanted.id = first.id
        cells[0] = wanted
    else:
        cells.insert(0, wanted)
    if params is not None:
        params.source = _with_pretrained_line(params.source)
        if PARAMETERS_FOLD not in params.metadata.get("tags", []):
            params.metadata["tags"] = list(params.metadata.get("tags", [])) + [PARAMETERS_FOLD]
        cell = nbformat.v4.new_code_cell(pretrained_source(path.stem), metadata={"tags": list(PRETRAINED_TAGS)})
        if third is not None:
            cell.id = third.id
            cells[2] = cell
        else:
            cells.insert(2, cell)
    for cell in cells:
        if cell.cell_type == "code":
            cell.outputs = []
            cell.execution_count = None
    nbformat.write(nb, path)
    return True


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="+", type=Path)
    parser.add_argument("--check", action="store_true", help="report notebooks whose set-up cell is stale")
    args = parser.parse_args(argv)
    stale = [p for p in args.notebooks if stamp(p, check=args.check)]
    for p in stale:
        print(("stale set-up cell: " if args.check else "stamped: ") + str(p))
    return 1 if (args.check and stale) else 0


if __name__ == "__main__":
    sys.exit(main())
