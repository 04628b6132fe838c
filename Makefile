# erosim — `make demo` and `make test` set everything up from scratch (.venv) and run.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test test-slow test-cuda test-browser test-regression test-multiprocess bench mutation lint clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/erosim demo

test: $(STAMP)
	$(BIN)/python -m pytest -q -n 2 --dist loadfile

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

test-cuda: $(STAMP)
	$(BIN)/python -m pytest -q -m cuda -n 2 --dist loadfile

test-browser: $(STAMP)
	$(BIN)/python -m pytest -q -m browser

test-regression: $(STAMP)
	$(BIN)/python -m pytest -q -m regression -n 2 --dist load

test-multiprocess: $(STAMP)
	$(BIN)/python -m pytest -q -m 'multiprocess and not slow' -n 2 --dist loadfile

bench: $(STAMP)
	$(BIN)/erosim bench sph --particles 100000
	$(BIN)/erosim bench sph --particles 1000000 --steps 20
	$(BIN)/erosim bench sph-terrain --particles 100000
	$(BIN)/erosim bench hydrology --size 256
	$(BIN)/erosim bench hydrology --size 512
	$(BIN)/erosim bench stream
	$(BIN)/erosim bench sweep

mutation: $(STAMP)
	$(BIN)/python benchmarks/mutation_check.py

lint: $(STAMP)
	$(BIN)/ruff check src tests

clean:
	rm -rf $(VENV) runs .pytest_cache
