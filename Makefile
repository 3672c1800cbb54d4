# Every target creates .venv when absent and installs what it needs, so on a
# fresh machine `make demo` or `make test` is the only command to run.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test bench lint clean system-deps

$(BIN)/activate:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# the fast extra (numba): the simulated sensor's compiled engine, which the README's
# demo times are measured with (without it the simulator runs its numpy engine, slower)
$(VENV)/.installed: pyproject.toml $(BIN)/activate
	$(BIN)/python -m pip install --quiet -e '.[fast]'
	touch $@

$(VENV)/.installed-dev: pyproject.toml $(BIN)/activate
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $(VENV)/.installed $@

demo: $(VENV)/.installed
	$(BIN)/ppaloc demo

# Debian packages some tests use (chromium, g++), installed only when missing; where they
# cannot be installed the script says why and those tests skip.
system-deps:
	bash tools/system-deps.sh

test: $(VENV)/.installed-dev system-deps
	$(BIN)/python -m pytest -n 2 -q --doctest-modules src tests

bench: $(VENV)/.installed-dev
	$(BIN)/python -m pytest benchmarks -q -p no:xdist --benchmark-columns=min,median,max,rounds

lint: $(VENV)/.installed-dev
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks

clean:
	rm -rf $(VENV) ppaloc-report .pytest_cache .hypothesis
