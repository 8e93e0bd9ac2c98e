"""Shared test set-up: headless plotting, a fast hypothesis profile, an isolated artifact cache."""
import os

# Set before any test imports matplotlib or pyvista, so nothing tries to open a window.
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")

import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

# Property tests must stay fast on two CPU cores; torch's first call is slow, so no deadline.
settings.register_profile("fast", deadline=None, max_examples=25)
# CI (HYPOTHESIS_PROFILE=ci): the same examples on every run, so a rare example cannot fail a submission at random.
settings.register_profile("ci", parent=settings.get_profile("fast"), derandomize=True, database=None,
                          print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "fast"))


@pytest.fixture
def tmp_cache(tmp_path, monkeypatch):
    """Point the artifact cache (``HOI_CACHE``) at an empty per-test folder and return it."""
    cache_dir = tmp_path / "hoi_cache"
    cache_dir.mkdir()
    monkeypatch.setenv("HOI_CACHE", str(cache_dir))
    return cache_dir


def _assert_same_motion(a, b):
    import numpy as np
    import torch

    for name in ("local_rotations", "root_position", "betas", "joints"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and torch.equal(x, y), name
    for name in ("actions", "contacts"):
        x, y = getattr(a, name), getattr(b, name)
        assert (x is None and y is None) or np.array_equal(x, y), name
    assert a.fps == b.fps and repr(a.meta) == repr(b.meta)


@pytest.fixture
def assert_same_motion():
    """A check that two ``Motion``s are the same field by field: rotations, root, body shape and joints (dtype and
    bits), action and contact labels, frame rate and meta."""
    return _assert_same_motion


@pytest.fixture(scope="module")
def one_cpu_thread():
    """Run a module's tests on one torch thread (``infra.one_thread``): tiny models run fastest
    there, and more threads stall when the cores are shared."""
    from hoi_tutorial.infra import one_thread

    with one_thread():
        yield


@pytest.fixture(scope="module")
def module_cache(tmp_path_factory):
    """An empty artifact cache (``HOI_CACHE``) shared by one test module's tests, restored afterwards."""
    patch = pytest.MonkeyPatch()
    cache_dir = tmp_path_factory.mktemp("hoi_cache")
    patch.setenv("HOI_CACHE", str(cache_dir))
    yield cache_dir
    patch.undo()


@pytest.fixture
def derived_package(tmp_path, monkeypatch):
    """A factory: ``derived_package(name, {relative path: source})`` writes a package of its own under ``tmp_path``,
    puts it on ``sys.path`` and among the packages whose imports the artifact cache follows
    (``cache.DERIVED_PACKAGES``), as it does ``hoi_tutorial``'s, and forgets any module of that name imported before.
    Returns the folder it was written in (edit files there to change the package)."""
    import sys

    from hoi_tutorial.infra import cache

    def make(name: str, files: dict):
        for relative, text in files.items():
            path = tmp_path / relative
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        monkeypatch.syspath_prepend(str(tmp_path))
        monkeypatch.setattr(cache, "DERIVED_PACKAGES", cache.DERIVED_PACKAGES | {name})
        for module in [m for m in sys.modules if m == name or m.startswith(name + ".")]:
            monkeypatch.delitem(sys.modules, module)
        return tmp_path

    return make
