# Two entry points for newcomers: `make demo` and `make test`. Both create
# .venv and install what they need from PyPI by name.

PYTHON ?= python3
VENV ?= .venv
BIN = $(VENV)/bin

.PHONY: demo test test-cpython test-micropython test-firmware firmware bench clean

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

# The firmware (tools/firmware.py): MicroPython's qemu Cortex-M3 port and
# the i386 unix port with acomm frozen in, into build/firmware/, rebuilt
# only when a source that goes into it changed. It installs the Debian
# packages it needs when it runs as root; otherwise, or with no MicroPython
# source (MPY_DIR, ../shared/vendor, a git clone), it says what is missing
# and fails.
firmware: $(VENV)/.dev
	$(BIN)/python tools/firmware.py build

# Every runtime runs and prints its own closing line: pytest on CPython,
# then the core suite on the MicroPython unix port, on the Cortex-M3
# firmware under qemu and on the i386 build. The target fails if any fails.
# tools/browser.py installs Debian's chromium for the console's browser
# test when it is missing and this runs as root (else the test skips).
# When the firmware cannot be built on this machine (exit 3), its two
# runtimes are skipped with one line saying how to enable them; a firmware
# build that fails is a failure.
I386_HEAP = 2M
test: $(VENV)/.dev
	@$(BIN)/python tools/firmware.py build; f=$$?; \
	$(BIN)/python tools/browser.py; \
	$(BIN)/python -m pytest -q tests; a=$$?; \
	PATH="$(CURDIR)/$(BIN):$$PATH" $(BIN)/micropython tools/mp_runtests.py tests/core; b=$$?; \
	c=0; d=0; \
	if [ $$f -eq 0 ]; then \
	  $(BIN)/python tools/board_runtests.py; c=$$?; \
	  build/firmware/micropython-i386 -X heapsize=$(I386_HEAP) tools/mp_runtests.py --frozen --name micropython-i386 tests/core; d=$$?; \
	elif [ $$f -eq 3 ]; then \
	  echo "micropython-cortex-m3, micropython-i386: skipped: the firmware cannot be built here (the firmware: line above says what is missing; then run make firmware)"; \
	else \
	  echo "micropython-cortex-m3, micropython-i386: not run: the firmware build failed (above)"; \
	fi; \
	test $$a -eq 0 && test $$b -eq 0 && test $$c -eq 0 && test $$d -eq 0 && test $$f -ne 1

test-firmware: firmware
	$(BIN)/python tools/board_runtests.py
	build/firmware/micropython-i386 -X heapsize=$(I386_HEAP) tools/mp_runtests.py --frozen --name micropython-i386 tests/core

test-cpython: $(VENV)/.dev
	$(BIN)/python -m pytest -q tests

test-micropython: $(VENV)/.dev
	$(BIN)/micropython tools/mp_runtests.py tests/core

bench: $(VENV)/.dev
	$(BIN)/acomm bench all --json

clean:
	rm -rf $(VENV) build *.egg-info
