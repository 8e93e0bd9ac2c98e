"""The code an artifact runs: a module and every module of its package that it imports, transitively.

The artifact cache keys an artifact by its configuration and by the source text of the code that built it
(``cache.artifact_key``). Listing that code by hand misses what a builder reaches only through another module
(an edit there would leave a stale artifact that no test notices); this module derives it from the imports
instead. The import statements are read from the source (``ast``), so an import inside a function counts as
well as one at the top, and nothing is executed to find them:

- ``import a.b`` names ``a.b``; ``from a.b import c`` names ``a.b.c`` when that is a module, else the module
  of ``a.b`` that defines ``c`` when ``a.b`` is a package re-exporting it (``from .cache import load_or_build`` in
  its ``__init__``), else ``a.b`` itself;
- a package stands for its ``__init__.py``, whose own imports are followed like any module's; the packages
  Python runs on the way to a module (``a/__init__`` for ``a.b``) are not counted unless a name comes from them,
  so a sub-package's artifacts do not depend on the siblings its parent's ``__init__`` happens to import;
- only modules of the same top-level package are followed (``hoi_tutorial``: numpy, torch and the standard
  library are the environment, not the code);
- the result over-approximates what runs (a module imported for one constant counts whole): a key changes
  more often than strictly needed, never less.
"""
from __future__ import annotations

import ast
import hashlib
import importlib.util
import pathlib
import sys
import threading
import types
from typing import Optional

__all__ = ["module_file", "imported_modules", "code_closure"]

_LOCK = threading.Lock()
_PARSED: dict = {}  # per (module name, sha256 of its file): what its import statements name, or re-export


def module_file(name: str) -> Optional[pathlib.Path]:
    """The source file of the module ``name`` (a package's ``__init__.py``), or ``None`` when it has none."""
    module = sys.modules.get(name)
    filename = getattr(module, "__file__", None) if module is not None else None
    if filename is None:
        try:
            spec = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            return None
        filename = getattr(spec, "origin", None) if spec is not None else None
    if not filename or not filename.endswith(".py"):
        return None
    path = pathlib.Path(filename)
    return path if path.exists() else None


def _exists(name: str) -> bool:
    return module_file(name) is not None


def _named_imports(name: str, source: bytes, is_package: bool) -> list[tuple[str, str]]:
    """Per imported name in ``source`` (the module ``name``): ``(the name as a module, the module it is taken
    from otherwise)``, absolute."""
    package = name if is_package else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(source, filename=name)):
        if isinstance(node, ast.Import):
            found.extend((alias.name, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            try:  # a relative import resolved against the module's package, as the import system does
                target = importlib.util.resolve_name("." * node.level + (node.module or ""), package)
            except (ImportError, ValueError):
                continue  # above the top-level package
            for alias in node.names:  # a module of the package where it is one, else the package's own name
                found.append((f"{target}.{alias.name}", target) if alias.name != "*" else (target, target))
    return found


def _defining_module(package: str, attribute: str) -> str:
    """The submodule of ``package`` whose ``attribute`` its ``__init__`` re-exports (``from .x import attribute``),
    else ``package`` (``attribute`` is its own, or ``package`` is a plain module)."""
    path = module_file(package)
    if path is None or path.name != "__init__.py":
        return package
    source = path.read_bytes()
    key = ("exports", package, hashlib.sha256(source).hexdigest())
    with _LOCK:
        exports = _PARSED.get(key)
    if exports is None:
        exports = {}
        for node in ast.parse(source, filename=package).body:
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
                for alias in node.names:
                    exports[alias.asname or alias.name] = f"{package}.{node.module}"
        with _LOCK:
            _PARSED[key] = exports
    target = exports.get(attribute)
    return target if target is not None and _exists(target) else package


def imported_modules(name: str) -> list[str]:
    """The module names that the module ``name`` imports directly (as its source text says), existing ones of
    its own top-level package only, sorted."""
    path = module_file(name)
    if path is None:
        return []
    source = path.read_bytes()
    key = (name, hashlib.sha256(source).hexdigest())
    with _LOCK:
        cached = _PARSED.get(key)
    if cached is None:
        top = name.split(".")[0]
        names = set()
        for as_module, otherwise in _named_imports(name, source, path.name == "__init__.py"):
            if as_module.split(".")[0] != top:
                continue
            names.add(as_module if _exists(as_module) else _defining_module(otherwise, as_module.rpartition(".")[2]))
        cached = sorted(n for n in names if n != name and _exists(n))
        with _LOCK:
            _PARSED[key] = cached
    return list(cached)


def code_closure(module, package: Optional[str] = None) -> list[str]:
    """``module`` (a module or its name) and every module it imports, transitively, within ``package`` (default:
    its own top-level package), sorted. A module with no source file (a notebook's ``__main__``) gives ``[]``.
    """
    name = module.__name__ if isinstance(module, types.ModuleType) else str(module)
    top = package or name.split(".")[0]
    if name.split(".")[0] != top or module_file(name) is None:
        return []
    seen, stack = {name}, [name]
    while stack:
        for nxt in imported_modules(stack.pop()):
            if nxt not in seen and nxt.split(".")[0] == top:
                seen.add(nxt)
                stack.append(nxt)
    return sorted(seen)
