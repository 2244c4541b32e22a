# Two commands on a fresh machine: `make demo` and `make test` (each installs first).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: install install-train demo test test-quick test-train lint bench planner-data planner bench-planner clean

install: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,g1,eval]'
	$(BIN)/g1ctl assets fetch
	touch $(STAMP)

# Training extra: torch==2.13.0 (a CPU wheel on the team's machines; elsewhere pip may fetch a large build).
install-train: install
	$(BIN)/python -c 'import torch' 2>/dev/null || $(BIN)/python -m pip install --quiet -e '.[dev,g1,eval,train]'

demo: install
	$(BIN)/g1ctl sim --scenario walk_turn_stop --video runs/demo.mp4 --report runs/demo.json --progress

# `make test` runs every test on the base install; the ones that need torch skip, naming the train extra.
# `make test-quick` leaves out the tests marked `slow` (measured; the threshold is in pyproject.toml); `make test-train`
# installs the train extra and runs the tests that need it. PYTEST_ARGS passes more options (CI: --durations=15).
PYTEST_ARGS ?=
test: install
	$(BIN)/python -m pytest -q $(PYTEST_ARGS)

test-quick: install
	$(BIN)/python -m pytest -q -m "not slow" $(PYTEST_ARGS)

test-train: install-train
	$(BIN)/python -m pytest -q -m train $(PYTEST_ARGS)

lint: install
	$(BIN)/ruff check controller hw sim tests examples
	$(BIN)/ruff format --check controller hw sim tests examples
	$(BIN)/mypy

bench: install
	$(BIN)/g1ctl bench loop --report runs/bench_loop.json

# The shipped planner, reproduced: record and import the data, train, benchmark (see models/planner/MODEL_CARD.md).
G1_MOVES ?= ../shared/data/g1-moves
DATA := data
planner-data: install
	test -f $(DATA)/rec/manifest.json || $(BIN)/g1ctl dataset record --out $(DATA)/rec --minutes 40 --seed 1 --progress
	test -f $(DATA)/rec2/manifest.json || $(BIN)/g1ctl dataset record --out $(DATA)/rec2 --minutes 80 --seed 2 --progress
	test -f $(DATA)/g1-moves/manifest.json || $(BIN)/g1ctl dataset import --csv $(G1_MOVES) --out $(DATA)/g1-moves

planner: install-train planner-data
	$(BIN)/g1ctl train planner --data $(DATA)/rec --data $(DATA)/rec2 --data $(DATA)/g1-moves --data-weights 1,1,2 --out runs/planner

bench-planner: install
	$(BIN)/g1ctl bench inbetween --data $(DATA)/rec --report runs/bench_inbetween.json
	$(BIN)/g1ctl bench inbetween --data $(DATA)/g1-moves --report runs/bench_inbetween_g1moves.json
	$(BIN)/g1ctl bench caption --data $(DATA)/rec --report runs/bench_caption.json

clean:
	rm -rf runs $(VENV)
