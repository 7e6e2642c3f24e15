# Two entry points that work on a fresh machine with only Python and make.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run run-all lint test test-all bench docs doctest-docs clean

$(BIN)/python:
	@echo "== creating the virtual environment $(VENV)"
	$(PYTHON) -m venv $(VENV)

# Reinstall only when the dependency list changes.
$(STAMP): pyproject.toml | $(BIN)/python
	@echo "== installing netcosim and its dependencies into $(VENV) (about a minute and a half the first time)"
	$(BIN)/python -m pip install --progress-bar on --upgrade pip
	$(BIN)/python -m pip install --progress-bar on -e '.[dev]'
	@# SimSo 0.8.5, the tests' reference for global multicore schedules, needs SimPy 2, whose
	@# distribution name is SimPy 4's: it goes into a folder of its own, which only the
	@# comparison's subprocess puts on its path (benchmarks/simso_global.py)
	$(BIN)/python -m pip install --quiet --no-deps --upgrade --target $(VENV)/simso simso==0.8.5 SimPy==2.3.1
	rm -rf $(VENV)/simso/simpy-*.dist-info
	touch $(STAMP)

# The main job: the networked Fly-crane of the thesis (§4.6.1, Fig. 4.11) over lossy 802.11b,
# offline vs online strategy, as a loss sweep on the sweep engine (about a minute on 2 cores).
run: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m netcosim.experiments.flycrane_network --outdir results/flycrane_network

# Every experiment (TrueTime examples and thesis reproductions), each in its own process; see experiments/main.py.
run-all: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m netcosim.experiments.main --outdir results
	$(BIN)/python -m netcosim.experiments.fidelity --measure --outdir results

# Style of the whole tree and types of the library (configured in pyproject.toml); a finding fails `make test`.
lint: $(STAMP)
	$(BIN)/ruff check --quiet --output-format concise .
	$(BIN)/mypy --no-error-summary

test: lint
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -n 2

test-all: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -n 2 -m ''

bench: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m benchmarks

# The documentation site (Sphinx, docs/conf.py) into build/docs/html, offline, warnings as errors.
# The tutorial and the gallery run during the build; GALLERY=quick (default) runs each gallery
# experiment's --quick mode, GALLERY=full their full runs, GALLERY=off none of them.
GALLERY ?= quick
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): pyproject.toml $(STAMP)
	$(BIN)/python -m pip install --progress-bar on -e '.[dev,docs]'
	touch $(DOCS_STAMP)

docs: $(DOCS_STAMP)
	NETCOSIM_DOCS_GALLERY=$(GALLERY) MPLBACKEND=Agg $(BIN)/python -m sphinx -W --keep-going -n -q -b html \
		-d build/docs/doctrees docs build/docs/html
	@echo "== built build/docs/html/index.html"

# The executable documentation: docstring examples (doctest) and the code blocks of docs/*.md
# and README.md; then the checks of the built site (tutorial figures present and non-trivial).
doctest-docs: $(DOCS_STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -p no:cacheprovider --doctest-modules netcosim plants controllers \
		--ignore=netcosim/transport/ncsm_wire.h
	NETCOSIM_DOCS_BUILD=1 MPLBACKEND=Agg $(BIN)/python -m pytest -q -m docs tests/test_docs.py

clean:
	rm -rf $(VENV) results .pytest_cache build/docs docs/api/generated docs/tutorial_built docs/gallery
