# Set-up, tests, book and benchmark. Every target creates or reuses the virtual environment
# $(VENV) itself, so `make book` and `make test` are the whole set-up.

VENV ?= .venv
PYTHON3 ?= python3
# Installed only when the environment has no importable torch, so an existing build is kept.
TORCH_SPEC ?= torch==2.13.0
# Optional extra index for torch, e.g. https://download.pytorch.org/whl/cpu for the CPU build.
TORCH_INDEX_URL ?=
# Extra flags for `jupyter-book build`, e.g. BOOK_FLAGS=--all for a full rebuild.
BOOK_FLAGS ?=
# Extra flags for pytest in `make unit-test` and `make unit-test-other-kernels`, e.g. PYTEST_ARGS="-x".
PYTEST_ARGS ?=
# Extra flags for scripts/bench.py, e.g. BENCH_ARGS="--notebooks 01_toy_world --isolated".
BENCH_ARGS ?=
# The exact versions `make venv` installs (a pip constraints file; `make lock` regenerates it), used where the
# environment's Python is the lock's (its header says which). Empty: resolve requirements.txt's lower bounds afresh.
LOCK ?= requirements.lock
# Extra flags for scripts/make_pack.py (`make artifacts`), e.g. ARTIFACTS_ARGS="--seed 1".
ARTIFACTS_ARGS ?=
# Extra flags for scripts/prune_cache.py (`make prune-cache`), e.g. PRUNE_ARGS=--dry-run.
PRUNE_ARGS ?=
# Chapters scripts/colab_check.py executes in a Colab-like runtime (empty: its default, chapters 03, 11 and 15).
COLAB_CHAPTERS ?=
# Seconds one cell of a chapter may run in `make book` and `make test`. A chapter's first code cell builds what
# the chapter needs, and on a machine half as fast as CI's the longest take over 10 min: readers get 30 min.
# CI keeps 600 s (.ci/run), so a chapter that grows slower fails there first.
CELL_TIMEOUT ?= 1800

VENV_DIR := $(abspath $(VENV))
VENV_BIN := $(VENV_DIR)/bin
PY := $(VENV_BIN)/python
STAMP := $(VENV_DIR)/.installed

# The artifact cache folder is taken from the caller's environment when set.
ifdef HOI_CACHE
export HOI_CACHE
endif

# Hypothesis draws the same examples on every run (tests/conftest.py's "ci" profile), so `make test` passes or
# fails as CI does; `make test-fresh` draws new examples to look for counterexamples.
HYPOTHESIS_PROFILE ?= ci
export HYPOTHESIS_PROFILE

.PHONY: venv lock lock-pythons test unit-test unit-test-other-kernels test-fresh book bench artifacts colab-check clean strip \
	prune-cache

venv: $(STAMP)

$(STAMP): requirements.txt pyproject.toml $(LOCK)
	@test -x $(PY) || $(PYTHON3) -m venv $(VENV_DIR)
	@if $(PY) -c "import torch" >/dev/null 2>&1; then \
		echo "torch already present in $(VENV_DIR): keeping it"; \
	else \
		$(PY) -m pip install "$(TORCH_SPEC)" $(if $(TORCH_INDEX_URL),--extra-index-url $(TORCH_INDEX_URL)); \
	fi
	@lock="$(LOCK)"; minor=$$($(PY) -c 'import sys; print("%d.%d" % sys.version_info[:2])'); \
	hashed="locks/py$$minor-manylinux_x86_64.txt"; \
	if [ -n "$$lock" ] && ! grep -q "^# Python $$minor\." "$$lock"; then \
		if [ "$$(uname -sm)" = "Linux x86_64" ] && [ -f "$$hashed" ]; then \
			echo "$$lock was resolved on another Python than $$minor: installing $$hashed, hash-checked"; \
			$(PY) -m pip install --require-hashes -r "$$hashed" || exit 1; \
		else \
			echo "$$lock was resolved on another Python than $$minor: installing requirements.txt's lower bounds"; \
		fi; \
		lock=""; \
	fi; \
	echo "$(PY) -m pip install -r requirements.txt $${lock:+-c $$lock}"; \
	$(PY) -m pip install -r requirements.txt $${lock:+-c $$lock}
	$(PY) -m pip install -e .
	$(PY) -m ipykernel install --sys-prefix --name python3
	@touch $(STAMP)

# Regenerate requirements.lock from requirements.txt in a fresh environment (scripts/lock_requirements.sh).
lock:
	PYTHON3=$(PYTHON3) TORCH_SPEC="$(TORCH_SPEC)" TORCH_INDEX_URL="$(TORCH_INDEX_URL)" bash scripts/lock_requirements.sh

# Resolve requirements.txt for Python 3.10-3.13 on manylinux x86_64 (Colab's platform) and write locks/, one hashed
# lock per Python (scripts/lock_pythons.py: pip resolves for a Python it does not run on; needs the package index).
lock-pythons:
	$(PY) scripts/lock_pythons.py

# Unit tests, then every chapter executed as a test with nbval in lax mode (a cell fails on an
# exception or a failed assert). pytest exits with 5 when it collects no tests: not a failure.
test: venv
	@PATH="$(VENV_BIN):$$PATH" HOI_PROGRESS=0 $(PY) -m pytest tests notebooks --nbval-lax --nbval-cell-timeout=$(CELL_TIMEOUT); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "pytest collected no tests (treated as success)"; rc=0; fi; \
	exit $$rc

# The library's tests alone, without executing the chapters (CI executes each chapter once, in the
# book build, which fails on any error or failed assert).
unit-test: venv
	@PATH="$(VENV_BIN):$$PATH" $(PY) scripts/numeric_env.py --show
	@PATH="$(VENV_BIN):$$PATH" $(PY) -m pytest tests $(PYTEST_ARGS)

# The library's tests again, with other BLAS and vector kernels than this CPU's own (scripts/numeric_env.py):
# what another machine does to the last bits. A test that depends on them fails here.
unit-test-other-kernels: venv
	@eval "$$($(PY) scripts/numeric_env.py --other)"; \
	PATH="$(VENV_BIN):$$PATH" $(PY) scripts/numeric_env.py --show && PATH="$(VENV_BIN):$$PATH" $(PY) -m pytest tests $(PYTEST_ARGS)

# The library's tests with fresh hypothesis examples (a new draw every run), to look for counterexamples; a
# failure prints the example to pin down with @example.
test-fresh: venv
	@PATH="$(VENV_BIN):$$PATH" HYPOTHESIS_PROFILE=fast $(PY) -m pytest tests

# MPLBACKEND is cleared so that the kernels draw figures inline into the pages; HOI_PROGRESS=0: a page shows
# results, not training's progress bars (a reader's kernel shows them: hoi_tutorial.infra.progress).
# A chapter that raises fails the build (execute.raise_on_error in _config.yml).
# The build reads _config.yml with its cell timeout set to CELL_TIMEOUT (a copy in _build; nothing else differs).
book: venv
	@mkdir -p _build
	@sed 's/^  timeout: [0-9][0-9]*$$/  timeout: $(CELL_TIMEOUT)/' _config.yml > _build/_config.yml
	@grep -q '^  timeout: $(CELL_TIMEOUT)$$' _build/_config.yml || { echo "_config.yml: expected a line '  timeout: N' under execute"; exit 1; }
	@echo "book: cells may run $(CELL_TIMEOUT) s (CELL_TIMEOUT)"
	PATH="$(VENV_BIN):$$PATH" HOI_PROGRESS=0 env -u MPLBACKEND $(VENV_BIN)/jupyter-book build . --config _build/_config.yml $(BOOK_FLAGS)
	@echo "book: _build/html/index.html"

bench: venv
	PATH="$(VENV_BIN):$$PATH" $(PY) scripts/bench.py $(BENCH_ARGS)

# A pretrained pack: every chapter run into build/artifacts/cache (toy scale, seed 0; a second run resumes), then
# packed with its manifest into build/artifacts/hoi_tutorial-<version>-toy-seed0.zip (scripts/make_pack.py).
# A chapter unpacks it with PRETRAINED = "<the pack's path or URL>"; `make bench BENCH_ARGS="--pretrained <pack>"`
# times every chapter from it.
artifacts: venv
	PATH="$(VENV_BIN):$$PATH" $(PY) scripts/make_pack.py --timeout $(CELL_TIMEOUT) $(ARTIFACTS_ARGS)

# Each chapter run the way a bare Colab runtime runs it: a fresh environment with only Colab's
# packages, the library installed by the chapter's own set-up cell (from this checkout).
# Select chapters with COLAB_CHAPTERS="notebooks/01_toy_world.ipynb ...".
colab-check: venv
	PATH="$(VENV_BIN):$$PATH" $(PY) scripts/colab_check.py $(COLAB_CHAPTERS)

# Removes from the artifact cache what the installed code can no longer use (artifacts and downloaded packs built by
# other code, leftovers of killed runs) and prints it; PRUNE_ARGS=--dry-run only prints (scripts/prune_cache.py).
prune-cache: venv
	$(PY) scripts/prune_cache.py $(PRUNE_ARGS)

clean:
	rm -rf _build .jupyter_cache jupyter_execute .pytest_cache .hypothesis
	find notebooks book -name .ipynb_checkpoints -type d -prune -exec rm -rf {} +

# Notebooks are stored without outputs.
define STRIP_NOTEBOOKS
import glob
import nbformat
for path in sorted(glob.glob("notebooks/*.ipynb")):
    nb = nbformat.read(path, as_version=4)
    for cell in nb.cells:
        cell.metadata.pop("execution", None)
        cell.metadata.pop("papermill", None)
        if cell.cell_type == "code":
            cell.outputs = []
            cell.execution_count = None
    nb.metadata.pop("papermill", None)
    nbformat.write(nb, path)
    print("stripped", path)
endef
export STRIP_NOTEBOOKS

strip: venv
	@$(PY) -c "$$STRIP_NOTEBOOKS"
