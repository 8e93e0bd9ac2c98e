"""Every chapter notebook runs top to bottom at toy scale: an exception or a failed claim assert
in any cell fails its test. Executed copies go to a temporary folder, never into notebooks/."""
import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK_DIR = REPO_ROOT / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
# Longest a single cell may run; matches execute.timeout in _config.yml.
CELL_TIMEOUT_S = 600


def _notebook_params():
    if not NOTEBOOKS:
        return [pytest.param(None, id="no-notebooks", marks=pytest.mark.skip(reason="no notebooks yet"))]
    return [pytest.param(path, id=path.stem) for path in NOTEBOOKS]


@pytest.mark.notebook
@pytest.mark.parametrize("notebook", _notebook_params())
def test_notebook_executes(notebook, tmp_path, monkeypatch):
    papermill = pytest.importorskip("papermill")
    # The kernel imports the library from this working tree, not from some other installation.
    src = str(REPO_ROOT / "src")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (src, os.environ.get("PYTHONPATH")) if p))
    # Kernels draw figures inline, exactly as in the built book and in Colab.
    monkeypatch.delenv("MPLBACKEND", raising=False)
    monkeypatch.setenv("PYVISTA_OFF_SCREEN", "true")
    papermill.execute_notebook(
        str(notebook),
        str(tmp_path / notebook.name),
        parameters={"SCALE": "toy", "SEED": 0},
        kernel_name="python3",
        cwd=str(NOTEBOOK_DIR),
        execution_timeout=CELL_TIMEOUT_S,
        progress_bar=False,
    )
