# make demo: the paper's scenarios on built-in data; make test: the whole suite; make bench: benchmarks;
# make figures: the paper's figures and docs/paper-reproduction.md.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test bench figures clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,viz]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/deik demo --out demo_output

test: $(STAMP)
	$(BIN)/python -m pytest -q

figures: $(STAMP)
	$(BIN)/deik experiments all --out figures --doc docs/paper-reproduction.md

bench: $(STAMP)
	$(BIN)/python -m benchmarks.serial_vs_parallel

clean:
	rm -rf $(VENV) demo_output .pytest_cache
