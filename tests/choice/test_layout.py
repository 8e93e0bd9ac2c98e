"""choice/'s layout: three sub-packages by the paper's sections, a later one importing an earlier one and never the
reverse, no module importing its caller, and every module-level name defined once within choice."""
import ast
import pathlib
from collections import defaultdict

import hoi_tutorial.choice as choice
from hoi_tutorial.infra.code_closure import imported_modules

ROOT = pathlib.Path(choice.__file__).parent
ORDER = ("planner", "controller", "pick_and_place")  # §4, §5, §6


def _modules():
    """{dotted name relative to choice: parsed module} for every file of the package."""
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).with_suffix("")
        parts = [p for p in rel.parts if p != "__init__"]
        out[".".join(parts)] = ast.parse(path.read_text(), str(path))
    return out


def _imports(name: str) -> set:
    """The choice modules ``name`` imports (dotted, relative to choice), at any depth of the file
    (``infra.code_closure``, which the artifact keys use too)."""
    prefix = "hoi_tutorial.choice."
    full = (prefix + name) if name else prefix[:-1]
    return {m[len(prefix):] for m in imported_modules(full) if m.startswith(prefix)} & set(MODULES) - {name}


MODULES = _modules()


def test_the_three_sections_are_sub_packages():
    assert set(ORDER) <= set(MODULES)
    flat = [m for m in MODULES if "." not in m and m not in ORDER and m != ""]
    assert flat == ["paper_numbers"], f"modules outside the three sections: {flat}"


def test_a_section_imports_only_earlier_sections():
    for name in MODULES:
        if "." not in name:
            continue
        section = ORDER.index(name.split(".")[0])
        for imported in _imports(name):
            top = imported.split(".")[0]
            if top in ORDER:
                assert ORDER.index(top) <= section, f"{name} (§{section + 4}) imports {imported}, a later section"


def test_no_module_imports_its_caller():
    graph = {name: _imports(name) for name in MODULES if name and name not in ORDER}
    graph = {k: {v for v in vs if v in graph} for k, vs in graph.items()}
    state = {}

    def visit(node, path):
        state[node] = "open"
        for nxt in graph[node]:
            assert state.get(nxt) != "open", f"import cycle: {' -> '.join(path + [nxt])}"
            if nxt not in state:
                visit(nxt, path + [nxt])
        state[node] = "done"

    for node in graph:
        if node not in state:
            visit(node, [node])


def test_module_level_names_are_defined_once_within_choice():
    where = defaultdict(list)
    for name, tree in MODULES.items():
        for node in tree.body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                where[node.name].append(name)
            elif isinstance(node, ast.Assign):
                for target in node.targets:
                    if isinstance(target, ast.Name) and target.id not in ("__all__",):
                        where[target.id].append(name)
    twice = {n: ms for n, ms in where.items() if len(ms) > 1}
    assert not twice, f"defined in more than one module of choice: {twice}"
