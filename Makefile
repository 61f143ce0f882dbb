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
# then the core suite on the MicroPython unix port, on the Cortex-M3
# firmware under qemu, on the i386 build and on the RP2040 firmware in its
# emulator. The target fails if any fails. The RP2040's run is the longest
# and needs one core of its own: it runs beside the Cortex-M3 and i386
# runs, its output printed when it ends.
# tools/browser.py installs Debian's chromium for the console's browser
# test when it is missing and this runs as root (else the test skips).
# When the firmware cannot be built on this machine (exit 3), its three
# runtimes are skipped with one line saying how to enable them; a firmware
# build that fails is a failure. Without Node.js (no emulator) the RP2040
# alone is skipped, with one line (exit 3 of board_runtests.py).
# pytest runs as two processes side by side: the tests that boot emulated
# boards (EMULATOR_TESTS: two thirds of its time, each on one core) and
# all the others (mostly waiting on real-time ptys and sockets); the
# emulators' output is printed when both end. They stage `acomm flash`
# files apart (ACOMM_WORK_DIR), so the two never share a folder. The
# others run at a lower priority: an emulated board keeps real time only
# with the CPU it needs (its Iridium session missed its window once while
# the MAVLink bridges' real-time tests ran beside it), and they have
# minutes of slack before the boards' tests end.
I386_HEAP = 2M
EMULATOR_TESTS = $(addprefix tests/cpython/,test_buoy_on_pico.py test_buoy_faults_on_pico.py \
	test_footprint_pico.py test_board_on_qemu.py test_footprint_qemu.py test_rp2040_runner.py)
test: $(VENV)/.dev rp2040-emulator
	@$(BIN)/python tools/firmware.py build; f=$$?; \
	$(BIN)/python tools/browser.py; \
	mkdir -p build; \
	ACOMM_WORK_DIR=$(CURDIR)/build/emulator-tests $(BIN)/python -m pytest -q -p no:cacheprovider \
	  $(EMULATOR_TESTS) > build/pytest-emulators.log 2>&1 & q=$$!; \
	nice -n 10 $(BIN)/python -m pytest -q tests $(addprefix --ignore=,$(EMULATOR_TESTS)); a=$$?; \
	wait $$q; g=$$?; echo "pytest, the emulated boards' tests:"; cat build/pytest-emulators.log; \
	test $$g -eq 0 || a=1; \
	PATH="$(CURDIR)/$(BIN):$$PATH" $(BIN)/micropython tools/mp_runtests.py tests/core; b=$$?; \
	c=0; d=0; e=0; \
	if [ $$f -eq 0 ]; then \
	  $(BIN)/python tools/board_runtests.py --target rp2040 > build/rp2040-tests.log 2>&1 & p=$$!; \
	  $(BIN)/python tools/board_runtests.py; c=$$?; \
	  build/firmware/micropython-i386 -X heapsize=$(I386_HEAP) tools/mp_runtests.py --frozen --name micropython-i386 tests/core; d=$$?; \
	  wait $$p; e=$$?; cat build/rp2040-tests.log; test $$e -eq 3 && e=0; \
	elif [ $$f -eq 3 ]; then \
	  echo "micropython-cortex-m3, micropython-i386, micropython-rp2040: skipped: the firmware cannot be built here (the firmware: line above says what is missing; then run make firmware)"; \
	else \
	  echo "micropython-cortex-m3, micropython-i386, micropython-rp2040: not run: the firmware build failed (above)"; \
	fi; \
	test $$a -eq 0 && test $$b -eq 0 && test $$c -eq 0 && test $$d -eq 0 && test $$e -eq 0 && test $$f -ne 1

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
