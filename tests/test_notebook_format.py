"""Every chapter follows the notebook conventions: stored without outputs, a hidden set-up cell
first (installing from the repository named in _config.yml), papermill's parameters cell second (the
pretrained pack off; folded on the page), the hidden pretrained-pack cell third, listed in the table of contents, and at least one assert on computed values."""
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
    assert notebook_cells.PRETRAINED_LINE in second.source, "the pretrained pack is off by default"
    assert notebook_cells.PARAMETERS_FOLD in second.metadata.get("tags", []), "the parameters cell is folded on the page"
    third = nb.cells[2]
    assert third.source == notebook_cells.pretrained_source(path.stem) and "hide-cell" in third.metadata.get("tags", []), \
        "cell 3 is not the current pretrained-pack cell"
    assert any("assert " in c.source for c in code), "a chapter asserts what it claims"
    assert f"notebooks/{path.stem}" in _toc_files(), "chapter missing from _toc.yml"


def test_stamping_adds_the_pretrained_parameter_and_cell(tmp_path):
    nb = nbformat.v4.new_notebook()
    params = nbformat.v4.new_code_cell('SCALE = "toy"\nSEED = 0\nDEVICE = "auto"\nN = 3', metadata={"tags": ["parameters"]})
    nb.cells = [params, nbformat.v4.new_code_cell("assert N == 3")]
    path = tmp_path / "chapter.ipynb"
    nbformat.write(nb, path)
    assert notebook_cells.stamp(path, check=True)
    assert notebook_cells.stamp(path)
    cells = nbformat.read(path, as_version=4).cells
    assert [c.source.splitlines()[0] for c in cells[1:3]] == ['SCALE = "toy"', cells[2].source.splitlines()[0]]
    assert cells[1].source == 'SCALE = "toy"\nSEED = 0\nDEVICE = "auto"\n' + notebook_cells.PRETRAINED_LINE + "N = 3"
    assert cells[2].source == notebook_cells.pretrained_source("chapter") and cells[3].source == "assert N == 3"
    assert 'chapter="chapter"' in cells[2].source  # the pack unpacks what this chapter uses
    assert cells[1].metadata["tags"] == ["parameters", notebook_cells.PARAMETERS_FOLD]
    assert not notebook_cells.stamp(path)  # stamped once: nothing left to change
    namespace = {"SCALE": "toy", "SEED": 0}
    exec(notebook_cells.PRETRAINED_LINE, namespace)
    exec(notebook_cells.pretrained_source("chapter"), namespace)  # off by default: unpacks nothing
    assert namespace["PRETRAINED"] is False and namespace["_pack"] is None

