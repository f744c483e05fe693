# Every target bootstraps its own virtual environment (.venv) on a fresh machine.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export MPLBACKEND := Agg

.PHONY: demo test check lint typecheck pytest pytest-fast bench soak clean

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[all,dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/velfence demo --out out/demo

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples

typecheck: $(STAMP)
	$(BIN)/mypy

pytest: $(STAMP)
	$(BIN)/python -m pytest

test: lint typecheck pytest

# The quick loop (under 2 minutes here): lint, types and every test not marked `slow` (the whole
# reproductions, the soak smoke runs, the hostile-input catalogue, the benchmarks). `make test`
# runs everything.
pytest-fast: $(STAMP)
	$(BIN)/python -m pytest -m "not slow"

check: lint typecheck pytest-fast

bench: $(STAMP)
	$(BIN)/velfence bench --out docs/benchmarks.md

# Randomised closed-loop containment campaign, 10^6 steps per shaper (minutes, not part of
# `make test`; its 10^4-step smoke version is tests/sim/test_soak.py).
soak: $(STAMP)
	$(BIN)/python -m velfence.sim.soak --steps 1000000 --out docs/reliability.md

clean:
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache
