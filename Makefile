# Two commands on a fresh machine: `make demo` and `make test` (each installs first).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install install-train demo test lint bench clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	$(BIN)/g1ctl assets fetch
	touch $(STAMP)

# Training extra: torch==2.13.0 (a CPU wheel on the team's machines; elsewhere pip may fetch a large build).
install-train: install
	$(BIN)/python -c 'import torch' 2>/dev/null || $(BIN)/python -m pip install --quiet -e '.[dev,train]'

demo: install
	$(BIN)/g1ctl sim --scenario walk_turn_stop --video runs/demo.mp4 --report runs/demo.json --progress

test: install
	$(BIN)/python -m pytest -q

lint: install
	$(BIN)/ruff check controller hw sim tests
	$(BIN)/ruff format --check controller hw sim tests
	$(BIN)/mypy

bench: install
	$(BIN)/g1ctl bench loop --report runs/bench_loop.json

clean:
	rm -rf runs $(VENV)
