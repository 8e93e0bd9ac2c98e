"""The Colab path of the chapters: the set-up cell's install source, the check's messages, the
declared dependencies, and (only when asked, ``HOI_COLAB_CHECK=1``) the check itself on chapter 1.

The full check builds a fresh environment and executes a chapter (minutes), so ``make test`` skips
it; run it with ``HOI_COLAB_CHECK=1 pytest tests/test_colab_check.py`` or ``make colab-check``.
"""
import ast
import importlib.metadata
import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_URL = "hoi_tutorial @ git+https://github.com/"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, REPO_ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


notebook_cells = _load("notebook_cells")
colab_check = _load("colab_check")


# --------------------------------------------------------------------------------------------------
# The set-up cell


class _RecordingShell:
    """Stands in for IPython's shell: records line magics, expanding ``{name}`` as IPython does."""

    def __init__(self, namespace):
        self.namespace = namespace
        self.magics = []

    def run_line_magic(self, name, line):
        from IPython.utils.text import DollarFormatter

        self.magics.append((name, DollarFormatter().vformat(line, args=[], kwargs=self.namespace)))


def _run_setup_cell(monkeypatch, importable, render=False):
    """Execute the stamped set-up cell (of a chapter that renders, with ``render``) as IPython would; return the
    line magics it ran."""
    from IPython.core.inputtransformer2 import TransformerManager

    code = TransformerManager().transform_cell(notebook_cells.setup_source(render))
    if not importable:
        monkeypatch.setitem(sys.modules, "hoi_tutorial", None)  # makes `import hoi_tutorial` fail
    namespace = {}
    shell = _RecordingShell(namespace)
    namespace["get_ipython"] = lambda: shell
    exec(compile(code, "<setup cell>", "exec"), namespace)
    return shell.magics


def test_setup_cell_is_a_no_op_where_the_library_imports(monkeypatch):
    monkeypatch.setenv(notebook_cells.SOURCE_VARIABLE, "/somewhere/hoi_tutorial")
    assert _run_setup_cell(monkeypatch, importable=True) == []


def test_setup_cell_installs_the_repository_by_default(monkeypatch):
    monkeypatch.delenv(notebook_cells.SOURCE_VARIABLE, raising=False)
    magics = _run_setup_cell(monkeypatch, importable=False)
    assert magics == [("pip", f'install --quiet "{notebook_cells.default_install_target()}"')]
    assert magics[0][1].startswith(f'install --quiet "{DEFAULT_URL}')


def test_setup_cell_honours_the_source_variable(monkeypatch):
    monkeypatch.setenv(notebook_cells.SOURCE_VARIABLE, "/somewhere/hoi_tutorial")
    assert _run_setup_cell(monkeypatch, importable=False) == [("pip", 'install --quiet "/somewhere/hoi_tutorial"')]
    # An empty variable counts as unset.
    monkeypatch.setenv(notebook_cells.SOURCE_VARIABLE, "")
    assert _run_setup_cell(monkeypatch, importable=False)[0][1].startswith(f'install --quiet "{DEFAULT_URL}')


def test_install_target_matches_the_cell(monkeypatch):
    assert notebook_cells.install_target({}) == notebook_cells.default_install_target()
    assert notebook_cells.install_target({"HOI_TUTORIAL_SOURCE": "dist/x.whl"}) == "dist/x.whl"
    monkeypatch.setenv(notebook_cells.SOURCE_VARIABLE, "/a/checkout")
    assert _run_setup_cell(monkeypatch, importable=False)[0][1] == (
        f'install --quiet "{notebook_cells.install_target()}"')


def test_a_chapter_that_renders_installs_the_render_extra_and_only_it(monkeypatch):
    """Chapters calling hoi_tutorial.viz.render's functions install ``hoi_tutorial[render]`` (pyvista, VTK); the
    others install the core alone, from the repository or from ``$HOI_TUTORIAL_SOURCE`` alike."""
    monkeypatch.delenv(notebook_cells.SOURCE_VARIABLE, raising=False)
    assert _run_setup_cell(monkeypatch, importable=False, render=True) == [
        ("pip", f'install --quiet "{notebook_cells.default_install_target(True)}"')]
    assert notebook_cells.default_install_target(True).startswith(DEFAULT_URL.replace("hoi_tutorial", "hoi_tutorial[render]"))
    monkeypatch.setenv(notebook_cells.SOURCE_VARIABLE, "/a/checkout")
    assert _run_setup_cell(monkeypatch, importable=False, render=True) == [("pip", 'install --quiet "/a/checkout[render]"')]
    assert notebook_cells.install_target(render=True) == "/a/checkout[render]"
    assert notebook_cells.install_target({}, render=True) == notebook_cells.default_install_target(True)
    assert {"render_scene", "render_body", "render_objects_grid"} <= notebook_cells.render_functions()
    assert "show_image" not in notebook_cells.render_functions()  # draws an array: no pyvista
    rendering = {p.name[:2] for p in sorted((REPO_ROOT / "notebooks").glob("*.ipynb"))
                 if notebook_cells.uses_render(nbformat.read(p, as_version=4))}
    assert "01" in rendering and "02" not in rendering and "19" not in rendering
    for p in sorted((REPO_ROOT / "notebooks").glob("*.ipynb")):
        first = nbformat.read(p, as_version=4).cells[0].source
        assert ("[render]" in first) == (p.name[:2] in rendering), p.name


def test_the_core_install_brings_no_test_book_or_render_package():
    """What a chapter's set-up cell installs without an extra: ``[project] dependencies``. The 3D renders, the
    tests and the book build are extras; packages the project never imports are in neither."""
    import tomllib
    from packaging.requirements import Requirement

    project = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["project"]
    core = {Requirement(r).name.lower() for r in project["dependencies"]}
    assert not core & {"pyvista", "vtk", "pytest", "hypothesis", "nbval", "diffusers", "jupyter-book", "papermill",
                       "ipywidgets", "safetensors"}
    assert [Requirement(r).name for r in project["optional-dependencies"]["render"]] == ["pyvista"]
    for name in ("pytest", "hypothesis", "nbval", "diffusers"):
        assert any(Requirement(r).name == name for r in project["optional-dependencies"]["test"])


def test_the_setup_cell_installs_the_version_the_book_is_built_from(tmp_path):
    """A release's pages install its tag, so that a page and the code it installs stay together after main moves on;
    a development version has no tag, and its pages install main."""
    for name in ("_config.yml", "pyproject.toml", str(notebook_cells.RENDER_MODULE)):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(REPO_ROOT / name, tmp_path / name)
    pyproject = tmp_path / "pyproject.toml"
    for version, ref in (("1.2.3", "v1.2.3"), ("1.3.0.dev0", "main")):
        pyproject.write_text(re.sub(r'^version = ".*"$', f'version = "{version}"', pyproject.read_text(), count=1,
                                    flags=re.M))
        assert notebook_cells.package_version(tmp_path) == version and notebook_cells.git_ref(version) == ref
        assert notebook_cells.default_install_target(root=tmp_path) == (
            "hoi_tutorial @ git+https://github.com/hoi-tutorial/hoi_tutorial@" + ref)
        assert notebook_cells.default_install_target(True, root=tmp_path).startswith("hoi_tutorial[render] @ git+")
        comment = notebook_cells.setup_source(root=tmp_path).splitlines()[1]
        assert comment == ("# The release this page was built from: tag v1.2.3." if ref != "main"
                           else "# The development version: main (this page was built from code after the last "
                                "release, which has no tag).")
    version = notebook_cells.package_version()
    assert notebook_cells.default_install_target().endswith("@" + notebook_cells.git_ref(version))


def test_every_chapter_has_the_current_setup_cell():
    stale = [p.name for p in sorted((REPO_ROOT / "notebooks").glob("*.ipynb"))
             if notebook_cells.stamp(p, check=True)]
    assert not stale, "re-stamp with: python scripts/notebook_cells.py notebooks/*.ipynb"


# --------------------------------------------------------------------------------------------------
# The check's messages


def _failed_notebook(ename, evalue, cell=3):
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell("pass") for _ in range(cell + 2)]
    nb.cells[cell].outputs = [nbformat.v4.new_output("error", ename=ename, evalue=evalue, traceback=[])]
    return nb


def test_a_missing_module_is_named_with_where_to_declare_it():
    nb = _failed_notebook("ModuleNotFoundError", "No module named 'skfmm'", cell=4)
    message = colab_check.diagnose("15_choice_fields.ipynb", nb)
    assert "15_choice_fields.ipynb (cell 4)" in message
    assert "'skfmm'" in message
    assert "pyproject.toml" in message and "dependencies" in message


def test_a_missing_submodule_names_its_top_level_package():
    nb = _failed_notebook("ModuleNotFoundError", "No module named 'sklearn.neighbors'")
    message = colab_check.diagnose("16.ipynb", nb)
    assert "'sklearn.neighbors'" in message and "provides 'sklearn'" in message


def test_a_failed_install_of_the_library_is_told_apart():
    nb = _failed_notebook("ModuleNotFoundError", "No module named 'hoi_tutorial'")
    message = colab_check.diagnose("01_toy_world.ipynb", nb)
    assert "set-up cell" in message and "did not install" in message


def test_other_errors_are_reported_as_they_are():
    nb = _failed_notebook("AssertionError", "guided walks too slow", cell=7)
    assert colab_check.diagnose("02.ipynb", nb) == "02.ipynb (cell 7): AssertionError: guided walks too slow"


def test_a_set_up_cell_that_changes_colabs_packages_or_brings_test_or_render_packages_is_told():
    bare = {colab_check._name(r): r for r in colab_check.COLAB_PACKAGES}
    assert bare["ipywidgets"] == "ipywidgets==7.7.1" and bare["jupyter-client"] == "jupyter_client==7.4.9"
    now = dict(bare, **{"hoi-tutorial": "hoi-tutorial==0.1.0", "trimesh": "trimesh==4.5.0"})
    assert colab_check.changed_by_setup("11.ipynb", bare, now, renders=False) == []
    now_widgets = dict(now, ipywidgets="ipywidgets==8.1.9")
    [message] = colab_check.changed_by_setup("11.ipynb", bare, now_widgets, renders=False)
    assert "changed Colab's ipywidgets==7.7.1 to ipywidgets==8.1.9" in message and "restart" in message
    with_render = dict(now, pyvista="pyvista==0.44.0", vtk="vtk==9.3.1", pytest="pytest==8.0.0")
    problems = colab_check.changed_by_setup("11.ipynb", bare, with_render, renders=False)
    assert len(problems) == 3 and "only the tests need" in problems[0]
    assert "only chapters that render need" in problems[1]
    assert colab_check.changed_by_setup("11.ipynb", bare, with_render, renders=True) == [problems[0]]
    # the default chapters: one of each paper, renders and not
    papers = [Path(c).name.split("_")[1] for c in colab_check.DEFAULT_CHAPTERS]
    assert sorted(papers[1:]) == ["choice", "samp"] and papers[0] == "synthetic"  # 03: NIFTY's data
    assert [colab_check._renders(REPO_ROOT / c) for c in colab_check.DEFAULT_CHAPTERS] == [True, False, True]


def test_a_failure_without_a_notebook_falls_back_to_the_log():
    log = "Traceback ...\nModuleNotFoundError: No module named 'filterpy'\n"
    assert "'filterpy'" in colab_check.diagnose("18.ipynb", None, log)
    assert "last output" in colab_check.diagnose("18.ipynb", None, "kernel died\n")


# --------------------------------------------------------------------------------------------------
# Declared dependencies cover what the chapters and the library import


def _top_level_imports(source):
    found = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.split(".")[0])
    return found


def _imported_modules():
    from IPython.core.inputtransformer2 import TransformerManager

    transform = TransformerManager().transform_cell
    modules = {}
    for path in sorted((REPO_ROOT / "src" / "hoi_tutorial").rglob("*.py")):
        for module in _top_level_imports(path.read_text()):
            modules.setdefault(module, set()).add(path.name)
    for path in sorted((REPO_ROOT / "notebooks").glob("*.ipynb")):
        for cell in nbformat.read(path, as_version=4).cells:
            if cell.cell_type == "code":
                for module in _top_level_imports(transform(cell.source)):
                    modules.setdefault(module, set()).add(path.name)
    return {m: where for m, where in modules.items() if m not in sys.stdlib_module_names and m != "hoi_tutorial"}


def _normalise(name):
    return name.lower().replace("_", "-").replace(".", "-")


def _installed_closure(names):
    """The declared distributions and everything they require (without extras), as installed."""
    from packaging.requirements import Requirement

    seen, todo = set(), [_normalise(n) for n in names]
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        try:
            requires = importlib.metadata.requires(name) or []
        except importlib.metadata.PackageNotFoundError:
            continue
        for line in requires:
            requirement = Requirement(line)
            if requirement.marker is None or requirement.marker.evaluate({"extra": ""}):
                todo.append(_normalise(requirement.name))
    return seen


def test_declared_dependencies_cover_every_import():
    tomllib = pytest.importorskip("tomllib")
    from packaging.requirements import Requirement

    project = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())["project"]
    declared = _installed_closure(Requirement(r).name for r in project["dependencies"])
    # the render extra's packages (pyvista, VTK) only in the module whose renders need them
    render = _installed_closure(Requirement(r).name for r in project["optional-dependencies"]["render"])
    providers = importlib.metadata.packages_distributions()
    missing = []
    for module, where in sorted(_imported_modules().items()):
        distributions = {_normalise(d) for d in providers.get(module, [])}
        if not distributions & declared and not (distributions & render and where == {"render.py"}):
            missing.append(f"{module} (imported in {', '.join(sorted(where))}; provided by "
                           f"{sorted(distributions) or 'nothing installed'})")
    assert not missing, "imported but not in [project] dependencies: " + "; ".join(missing)


# --------------------------------------------------------------------------------------------------
# The check itself (minutes): only when asked


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("HOI_COLAB_CHECK") != "1",
                    reason="builds a fresh environment and runs a chapter; set HOI_COLAB_CHECK=1")
def test_chapter_1_runs_from_its_setup_cell_alone():
    result = subprocess.run([sys.executable, str(REPO_ROOT / "scripts" / "colab_check.py"),
                             str(REPO_ROOT / "notebooks" / "01_toy_world.ipynb")],
                            text=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    assert result.returncode == 0, result.stdout[-4000:]
    assert "colab-check passed" in result.stdout
