# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: demo handoff-demo test lint install install-test clean bench

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# An editable install leaves src/ without byte code, and where PYTHONDONTWRITEBYTECODE is set
# (as on our CI machines) every command then compiles ~100 modules again: ~100 ms of each
# `aerosurvey plan`. pip compiles a normal install; compileall does it for ours.
install: $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	$(BIN)/python -m compileall -q src >/dev/null

install-test: $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test]"
	$(BIN)/python -m compileall -q src >/dev/null

demo: install
	$(BIN)/aerosurvey plan missions/obratan-72ha.toml -o out/obratan
	@echo "outputs written to out/obratan (open out/obratan/preview.svg)"

# every hand-off format (GeoPackage, rally points, control points, camera poses for ODM, Pix4D and
# Metashape, GCP predictions, gcp_list.txt) from the fixed-wing example and its SITL flight log
handoff-demo: install
	$(BIN)/python missions/tools/handoff_example.py out/handoff

test: install-test lint
	$(BIN)/python -m pytest

# ruff (with bugbear) and mypy (strict in plan/, mission/ and rules/): zero errors, or make test fails
lint: install-test
	$(BIN)/ruff check src tests benchmarks missions/tools
	$(BIN)/mypy

bench: install
	$(BIN)/python benchmarks/plan_bench.py
	$(BIN)/python benchmarks/repro_bench.py
	$(BIN)/python benchmarks/log_bench.py
	$(BIN)/python benchmarks/upload_bench.py
	$(BIN)/python benchmarks/inprocess_bench.py
	$(BIN)/python benchmarks/manifest_bench.py
	$(BIN)/python benchmarks/safety_bench.py
	$(BIN)/python benchmarks/program_bench.py

clean:
	rm -rf out build dist src/*.egg-info .pytest_cache .hypothesis
