"""Every chapter follows the notebook conventions: stored without outputs, a hidden set-up cell
first (installing from the repository named in _config.yml), papermill's parameters cell second,
listed in the table of contents, and at least one assert on computed values."""
import importlib.util
from pathlib import Path

import nbformat
import pytest
import yaml

REPO_ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((REPO_ROOT / "notebooks").glob("*.ipynb"))

spec = importlib.util.spec_from_file_location("notebook_cells", REPO_ROOT / "scripts" / "notebook_cells.py")
notebook_cells = importlib.util.module_from_spec(spec)
spec.loader.exec_module(notebook_cells)


def _toc_files():
    toc = yaml.safe_load((REPO_ROOT / "_toc.yml").read_text())
    found = []

    def walk(node):
        if isinstance(node, dict):
            if "file" in node:
                found.append(node["file"])
            for value in node.values():
                walk(value)
        elif isinstance(node, list):
            for item in node:
                walk(item)

    walk(toc)
    return set(found)


params = [pytest.param(p, id=p.stem) for p in NOTEBOOKS] or [
    pytest.param(None, marks=pytest.mark.skip(reason="no notebooks yet"))
]


@pytest.mark.parametrize("path", params)
def test_notebook_conventions(path):
    nb = nbformat.read(path, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(not c.outputs and c.execution_count is None for c in code), "notebook has stored outputs"
    assert nb.cells[0].source == notebook_cells.setup_source(notebook_cells.uses_render(nb)), \
        "cell 1 is not the current set-up cell"
    assert "hide-cell" in nb.cells[0].metadata.get("tags", [])
    second = nb.cells[1]
    assert "parameters" in second.metadata.get("tags", []), "cell 2 must be papermill's parameters cell"
    for name in ("SCALE", "SEED", "DEVICE"):
        assert f"{name} =" in second.source, f"parameters cell lacks {name}"
    assert any("assert " in c.source for c in code), "a chapter asserts what it claims"
    assert f"notebooks/{path.stem}" in _toc_files(), "chapter missing from _toc.yml"
