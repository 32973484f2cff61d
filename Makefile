# Luxel: two commands on a fresh machine.
#   make bake   installs the solver into .venv and bakes the Cornell box into out/cornell
#   make test   installs the solver and pytest into .venv and runs the tests
PYTHON ?= python3.11
DEVICE ?= llvmpipe
VENV := .venv
BIN := $(VENV)/bin

.PHONY: bake test bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(VENV)/.runtime: requirements.txt | $(BIN)/python
	$(BIN)/python -m pip install --quiet -r requirements.txt
	touch $@

$(VENV)/.dev: requirements-dev.txt $(VENV)/.runtime
	$(BIN)/python -m pip install --quiet -r requirements-dev.txt
	touch $@

$(VENV)/.bench: requirements-bench.txt $(VENV)/.runtime
	$(BIN)/python -m pip install --quiet -r requirements-bench.txt
	touch $@

bake: $(VENV)/.runtime
	$(BIN)/python -m native --output out/cornell

test: $(VENV)/.dev
	$(BIN)/python -m pytest -q tests

bench: $(VENV)/.bench
	$(BIN)/python bench/bench_core.py --shoot-level 0 --json bench/results/core-$(DEVICE).json
	$(BIN)/python bench/plot.py

clean:
	rm -rf $(VENV) out
