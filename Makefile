# make demo: the paper's scenarios on built-in data; make test: ruff (lint, format check), then the
# whole suite; make bench: benchmarks; make figures: the paper's figures and docs/paper-reproduction.md.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
DEMO_STAMP := $(VENV)/.installed-demo

.PHONY: demo test bench bench-peers figures clean

$(VENV)/bin/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# the demo needs deik and matplotlib only; the tests also need the test tools and numba-cuda
$(DEMO_STAMP): pyproject.toml | $(VENV)/bin/python
	$(BIN)/python -m pip install --quiet -e ".[viz]"
	touch $(DEMO_STAMP)

$(STAMP): pyproject.toml | $(VENV)/bin/python
	$(BIN)/python -m pip install --quiet -e ".[test,viz]"
	touch $(STAMP)

demo: $(DEMO_STAMP)
	$(BIN)/deik warmup
	$(BIN)/deik demo --out demo_output

# the suite on every core, four workers at most, a test module to a worker (pytest-xdist; tests/conftest.py
# puts the modules with slow tests first); TEST_WORKERS=0: one process
TEST_WORKERS ?= logical
test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --maxprocesses 4 --dist loadfile --no-loadscope-reorder

figures: $(STAMP)
	$(BIN)/deik experiments all --out figures --doc docs/paper-reproduction.md

bench: $(STAMP)
	$(BIN)/python -m benchmarks.run_all

# make bench-peers: deik against peer IK and DE libraries, which live in their own venv.
PEERS_VENV := .venv-peers
PEERS_STAMP := $(PEERS_VENV)/.installed

$(PEERS_STAMP): benchmarks/peers/requirements.txt
	$(PYTHON) -m venv $(PEERS_VENV)
	$(PEERS_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(PEERS_VENV)/bin/python -m pip install --quiet -r benchmarks/peers/requirements.txt
	touch $(PEERS_STAMP)

bench-peers: $(STAMP) $(PEERS_STAMP)
	$(BIN)/python -m benchmarks.robots --targets 500
	$(BIN)/python -m benchmarks.de_peers

clean:
	rm -rf $(VENV) demo_output .pytest_cache
