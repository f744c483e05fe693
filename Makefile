# Every target bootstraps its own virtual environment (.venv) on a fresh machine.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export MPLBACKEND := Agg
# Byte-code caches on: with PYTHONDONTWRITEBYTECODE set (some CI images and shells set it) every
# pytest worker re-compiles and re-rewrites every test module's assertions on each run, which
# doubled the collection time of `make check` (measured: 18 s -> 8 s of CPU per worker).
unexport PYTHONDONTWRITEBYTECODE

.PHONY: demo test check lint typecheck docs pytest pytest-fast bench bench-docs soak soak-filter clean

# The compiled core (core/: C99 + CPython binding, scikit-build-core) is a separate distribution
# built with the machine's C compiler; velfence itself stays pure Python (hatchling).
$(STAMP): pyproject.toml core/pyproject.toml core/CMakeLists.txt core/src/*.c core/src/*.h core/include/*.h
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[all,dev]'
	$(BIN)/python -m pip install --quiet ./core
	# numba's kernels (the Python route's batch loops) compiled once, into numba's on-disk cache
	# beside the sources: otherwise the first process of every `make test`, `make demo` or
	# benchmark to call them compiles them again (about a minute of CPU).
	$(BIN)/python -c "import velfence.shaping.accelerate as a; print('numba kernels ready:', len(a.precompile()))"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/velfence demo --out out/demo

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples
	$(BIN)/lint-imports

typecheck: $(STAMP)
	$(BIN)/mypy

# HTML site (Markdown pages + API reference) in out/docs; any Sphinx warning fails the build.
docs: $(STAMP)
	$(BIN)/sphinx-build -W --keep-going -q -b html docs out/docs

# Tests run on every core (pytest-xdist). --dist loadgroup is scheduled by tests/conftest.py
# (scope_of): each test file is one unit of work (its module- and session-scoped fixtures are
# built once, on one worker), the tests that inspect one shared run (GROUPS: a reproduction, a
# MuJoCo scenario) are one unit, and the files in SPREAD spread test by test; the files with
# slow tests start first. JOBS=1 runs in-process.
JOBS ?= auto
PYTEST := $(BIN)/python -m pytest $(if $(filter 1,$(JOBS)),,-n $(JOBS) --dist loadgroup)

pytest: $(STAMP)
	$(PYTEST)

test: lint typecheck docs pytest

# The quick loop: lint, types and every test not marked `slow` (the whole reproductions, the soak
# smoke runs, the hostile-input catalogue, the sanitizer builds, and the tests measured slow one
# by one in tests/slow_tests.txt). `make test` runs everything;
# the measured durations are in CONTRIBUTING.md.
pytest-fast: $(STAMP)
	$(PYTEST) -m "not slow"

check: lint typecheck pytest-fast

# Benchmarks (minutes; never part of `make test`). `make bench` writes out/benchmarks.md
# (untracked) and leaves the published numbers alone; `make bench-docs` regenerates the part of
# docs/benchmarks.md below its marker line (the hand-written preamble is kept).
bench: $(STAMP)
	$(BIN)/velfence bench --out out/benchmarks.md --json out/benchmarks.json

bench-docs: $(STAMP)
	$(BIN)/velfence bench --out docs/benchmarks.md

# Randomised closed-loop containment campaign, 10^6 steps per shaper (minutes, not part of
# `make test`; its 10^4-step smoke version is tests/apps/soak/test_soak.py).
soak: $(STAMP)
	$(BIN)/python -m velfence.apps.soak --steps 1000000 --out docs/reliability.md

# The evidence campaigns of the n-D shaper and the safety filter: 10^6 vertex/edge states of 3-D
# to 7-D polytopes and 10^6 closed-loop UR5e/Panda steps at 1 kHz, 500 Hz and 100 Hz (tens of
# minutes; smoke versions in tests/apps/soak_filter/test_soak_filter.py). Writes its section of reliability.md.
soak-filter: $(STAMP)
	$(BIN)/python -m velfence.apps.soak_filter --vertex-states 1000000 --filter-states 1000000 \
		--steps 1000000 --out docs/reliability.md

clean:
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache
