"""Small helpers several test files share (importable because pytest puts tests/ on the path)."""
import importlib.util
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]


def counting(build):
    """``(wrapped, calls)``: ``build`` wrapped so that each call appends to ``calls`` (how often a cache built it)."""
    calls = []

    def wrapped():
        calls.append(1)
        return build()

    return wrapped, calls


def load_script(name: str):
    """The module ``scripts/<name>.py``, loaded by path (scripts/ is not a package)."""
    spec = importlib.util.spec_from_file_location(name, REPO_ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
