# Two entry points for newcomers: `make demo` and `make test`. Both create
# .venv and install what they need from PyPI by name.

PYTHON ?= python3
VENV ?= .venv
BIN = $(VENV)/bin

.PHONY: demo test test-cpython test-micropython test-firmware test-rp2040 firmware rp2040-emulator bench clean

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

# The firmware (tools/firmware.py), all from MicroPython v1.28.0: the qemu
# Cortex-M3 port and the i386 unix port with acomm frozen in, and the
# Pico's (RP2040) stock, buoy and full images as UF2 files, into
# build/firmware/, each rebuilt only when a source that goes into it
# changed. It installs the Debian packages it needs when it runs as root;
# otherwise, or with no MicroPython source (MPY_DIR, ../shared/vendor, a
# git clone), it says what is missing and fails.
firmware: $(VENV)/.dev
	$(BIN)/python tools/firmware.py build

# The RP2040 emulator (tools/rp2040: rp2040js, pinned by its lock file, and
# the runner around it), installed with npm ci when the lock file is newer
# than what is installed. Node.js, npm and socat (a pty in front of each of
# the emulated Pico's ports) come from Debian when missing and this runs as
# root; without them the RP2040 runtime is skipped with a line saying so
# (tools/board_runtests.py --target rp2040).
RP2040_JS = tools/rp2040/node_modules/.package-lock.json
rp2040-emulator:
	@miss=""; for t in node:nodejs npm:npm socat:socat; do command -v $${t%%:*} >/dev/null 2>&1 || miss="$$miss $${t#*:}"; done; \
	if [ -n "$$miss" ] && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  echo "rp2040: installing$$miss"; \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$miss >/dev/null 2>&1 || \
	  { apt-get update -q >/dev/null 2>&1; DEBIAN_FRONTEND=noninteractive apt-get install -y -q $$miss >/dev/null 2>&1; }; \
	fi; \
	if ! command -v npm >/dev/null 2>&1; then echo "rp2040: no npm here (apt-get install nodejs npm)"; \
	elif [ ! $(RP2040_JS) -nt tools/rp2040/package-lock.json ]; then \
	  npm ci --prefix tools/rp2040 --no-audit --no-fund --loglevel=error >/dev/null || echo "rp2040: npm ci failed"; \
	fi

# Every runtime runs and prints its own closing line: pytest on CPython,
# the core suite on the MicroPython unix port, on the Cortex-M3 firmware
# under qemu, on the i386 build and on the RP2040 firmware in its
# emulator. The target fails if any fails. tools/testall.py starts them
# side by side by priority, each as soon as what it needs is built (why
# and how: its header). tools/browser.py installs Debian's chromium for the
# console's browser test when it is missing and this runs as root (else
# the test skips). When the firmware cannot be built on this machine (exit
# 3), its three runtimes are skipped with one line saying how to enable
# them; a firmware build that fails is a failure. Without Node.js (no
# emulator) the RP2040 alone is skipped, with one line (exit 3 of
# board_runtests.py).
I386_HEAP = 2M
test: $(VENV)/.dev rp2040-emulator
	@$(BIN)/python tools/testall.py --i386-heap $(I386_HEAP)

test-firmware: firmware
	$(BIN)/python tools/board_runtests.py
	build/firmware/micropython-i386 -X heapsize=$(I386_HEAP) tools/mp_runtests.py --frozen --name micropython-i386 tests/core

test-rp2040: firmware rp2040-emulator
	$(BIN)/python tools/board_runtests.py --target rp2040

test-cpython: $(VENV)/.dev
	$(BIN)/python -m pytest -q tests

test-micropython: $(VENV)/.dev
	$(BIN)/micropython tools/mp_runtests.py tests/core

bench: $(VENV)/.dev
	$(BIN)/acomm bench all --json

clean:
	rm -rf $(VENV) build *.egg-info
