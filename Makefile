# Two entry points for newcomers: `make demo` and `make test`. Both create
# .venv and install what they need from PyPI by name.

PYTHON ?= python3
VENV ?= .venv
BIN = $(VENV)/bin

.PHONY: demo test test-cpython test-micropython bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV) || { echo "python3 -m venv failed: on Debian run 'apt-get install python3-venv' (trying it now)"; \
	  apt-get install -y python3-venv >/dev/null && $(PYTHON) -m venv $(VENV); }
	$(BIN)/python -m pip install -q --upgrade pip

$(VENV)/.dev: $(BIN)/python setup.cfg pyproject.toml
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $@

# the demo draws its plots with matplotlib (the `plot` extra)
$(VENV)/.run: $(BIN)/python setup.cfg pyproject.toml
	$(BIN)/python -m pip install -q -e '.[plot]'
	touch $@

demo: $(VENV)/.run
	$(BIN)/acomm demo

# Both runtimes always run; the target fails if either suite fails. The last
# two lines of output are the counts of each runtime.
test: $(VENV)/.dev
	@$(BIN)/python -m pytest -q tests; a=$$?; \
	PATH="$(CURDIR)/$(BIN):$$PATH" $(BIN)/micropython tools/mp_runtests.py tests/core; b=$$?; \
	test $$a -eq 0 && test $$b -eq 0

test-cpython: $(VENV)/.dev
	$(BIN)/python -m pytest -q tests

test-micropython: $(VENV)/.dev
	$(BIN)/micropython tools/mp_runtests.py tests/core

bench: $(VENV)/.dev
	$(BIN)/acomm bench all --json

clean:
	rm -rf $(VENV) build *.egg-info
