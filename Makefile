# Two entry points that work on a fresh machine with only Python and make.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test test-all bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

# Reinstall only when the dependency list changes.
$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

run: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m experiments.main

test: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -n 2

test-all: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -n 2 -m ''

bench: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m benchmarks

clean:
	rm -rf $(VENV) results .pytest_cache
