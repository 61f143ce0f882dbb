#!/usr/bin/env python3
# `make test`: every runtime's tests, side by side on a 2-core machine.
#
# What runs (each prints its own closing line, and the run fails if any fails):
#   pytest on CPython, as two processes: the tests that boot emulated boards
#       (EMULATOR_TESTS) and all the others;
#   the core suite on the MicroPython unix port;
#   with the firmware built (tools/firmware.py build): the core suite
#       on the Cortex-M3 firmware under qemu, on the i386 build and on the
#       RP2040 firmware in its emulator (the list of tools/rp2040_tests.txt).
#
# How it is laid out, and why. Four of these are long and each holds one
# core while it runs: the emulated boards' pytest, the RP2040's and the
# Cortex-M3's core tests and the other pytest (some of it waiting on
# real-time ptys and sockets). One after the other on two cores they took
# 2,262 s on a slow 2-core machine and 2,378 s in CI, with a core idle for
# minutes, so they start together, by priority:
#   - both pytests at normal priority: a board there keeps real time only
#     with the CPU it needs (its Iridium session missed its window once
#     beside the MAVLink bridges' real-time tests), and so do the other's
#     drivers and emulators on ptys (at nice 10 beside the emulated boards,
#     whose runner and ocean take a core each, they starved: a SeaTrac ping
#     and an Iridium mailbox check on ptys ran out of their time);
#   - the i386 build's suite at nice 10. The unix port's suite needs no
#     firmware: it starts with the build, at nice 10, and soaks up what the
#     build's single-threaded steps (cmake, links) leave;
#   - the Cortex-M3's core tests at nice 15 and the RP2040's at nice 19:
#     they keep simulated time (each test has minutes of limit) and take the
#     CPU the others leave, all of it once those end. They should end
#     together: the one that ends last runs alone, a core idle. The
#     Cortex-M3's has more work (800 tests against the RP2040's 350 since
#     the idle board loop made the Pico's cheaper: 1,400 against 1,257 s at
#     nice 17 both), and it starts as soon as its firmware is built, before
#     the i386 and rp2 builds.
# What runs in the background goes to a log under build/ that is printed
# when it ends, so that the output reads in one piece per runtime. Each
# part's line gives its wall time and the CPU time it and its children
# used, and the last line how busy the machine's CPUs were over the run:
# what to look at when the total grows.
#
#   python3 tools/testall.py [--i386-heap 2M]
import argparse
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.path.join(ROOT, "build")
BIN = os.path.dirname(sys.executable)
PY = sys.executable
EMULATOR_TESTS = ["tests/cpython/" + f for f in (
    "test_buoy_on_pico.py", "test_buoy_faults_on_pico.py", "test_footprint_pico.py",
    "test_board_on_qemu.py", "test_footprint_qemu.py", "test_rp2040_runner.py")]


def _niced(n):
    # a child's preexec_fn that lowers its priority by n (None: as ours)
    return (lambda: os.nice(n)) if n else None


def _wait(proc):
    # (exit status, CPU seconds of the process and its children), from wait4
    _, status, ru = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, ru.ru_utime + ru.ru_stime


def _cpu_times():
    # (busy, all) jiffies of the machine's CPUs so far, or None off Linux
    try:
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
    except (OSError, ValueError):
        return None
    return sum(v) - v[3] - v[4], sum(v)  # less idle and iowait


class Job:
    """A command run in the background with its output in a log under build/."""

    def __init__(self, name, cmd, log, nice=0, env=None):
        self.name, self.log = name, os.path.join(BUILD, log)
        self.t0 = time.monotonic()
        self._f = open(self.log, "wb")
        self.proc = subprocess.Popen(cmd, cwd=ROOT, stdout=self._f, stderr=subprocess.STDOUT,
                                     preexec_fn=_niced(nice), env=env)

    def finish(self, header=None):
        """Waits for the command, prints its log (after header) -> its exit status."""
        rc, cpu = _wait(self.proc)
        self._f.close()
        if header:
            print(header)
        with open(self.log, "rb") as f:
            sys.stdout.write(f.read().decode(errors="replace"))
        print("(%s: %d s, CPU %d s)" % (self.name, time.monotonic() - self.t0, cpu))
        sys.stdout.flush()
        return rc


def run(name, cmd, nice=0, env=None):
    """Runs cmd in the foreground, its output on ours, then a line with its time -> its exit status."""
    sys.stdout.flush()
    t0 = time.monotonic()
    rc, cpu = _wait(subprocess.Popen(cmd, cwd=ROOT, preexec_fn=_niced(nice), env=env))
    print("(%s: %d s, CPU %d s)" % (name, time.monotonic() - t0, cpu))
    sys.stdout.flush()
    return rc


def main(argv=None):
    p = argparse.ArgumentParser(description="every runtime's tests, side by side (make test)")
    p.add_argument("--i386-heap", default="2M", help="the i386 build's GC heap (default %(default)s)")
    a = p.parse_args(argv)
    os.makedirs(BUILD, exist_ok=True)
    t0, cpu0 = time.monotonic(), _cpu_times()
    path = dict(os.environ, PATH=BIN + os.pathsep + os.environ.get("PATH", ""))
    unix = Job("micropython", [os.path.join(BIN, "micropython"), "tools/mp_runtests.py", "tests/core"],
               "unix-tests.log", nice=10, env=path)
    # the Cortex-M3's firmware first, so that its suite starts while the rest builds
    cm3 = rp2040 = None
    if run("firmware, cm3-full", [PY, "tools/firmware.py", "build", "--only", "cm3-full"]) == 0:
        cm3 = Job("micropython-cortex-m3", [PY, "tools/board_runtests.py"], "cortex-m3-tests.log", nice=15)
    fw = run("firmware", [PY, "tools/firmware.py", "build"])
    run("browser", [PY, "tools/browser.py"])
    env = dict(os.environ, ACOMM_WORK_DIR=os.path.join(BUILD, "emulator-tests"))
    boards_pytest = Job("pytest, the emulated boards", [PY, "-m", "pytest", "-q", "-p", "no:cacheprovider"]
                        + EMULATOR_TESTS, "pytest-emulators.log", env=env)
    if fw == 0:
        rp2040 = Job("micropython-rp2040", [PY, "tools/board_runtests.py", "--target", "rp2040"],
                     "rp2040-tests.log", nice=19)
    failed = []
    if run("pytest", [PY, "-m", "pytest", "-q", "tests"] + ["--ignore=" + t for t in EMULATOR_TESTS]):
        failed.append("pytest")
    if unix.finish():
        failed.append("micropython")
    if fw == 0 and run("micropython-i386", [os.path.join(BUILD, "firmware", "micropython-i386"), "-X",
                                            "heapsize=" + a.i386_heap, "tools/mp_runtests.py", "--frozen", "--name",
                                            "micropython-i386", "tests/core"], nice=10):
        failed.append("micropython-i386")
    if boards_pytest.finish("pytest, the emulated boards' tests:"):
        failed.append("pytest (emulated boards)")
    if rp2040 is not None and rp2040.finish() not in (0, 3):  # 3: no emulator here, said in its one line
        failed.append("micropython-rp2040")
    if cm3 is not None and cm3.finish():
        failed.append("micropython-cortex-m3")
    if fw == 3:
        print("micropython-cortex-m3, micropython-i386, micropython-rp2040: skipped: the firmware cannot be "
              "built here (the firmware: line above says what is missing; then run make firmware)")
    elif fw != 0:
        print("micropython-i386, micropython-rp2040%s: not run: the firmware build failed (above)"
              % ("" if cm3 is not None else ", micropython-cortex-m3"))
        failed.append("firmware")
    cpu1 = _cpu_times()
    busy = "" if cpu0 is None or cpu1 is None or cpu1[1] == cpu0[1] else \
        "; the CPUs busy %d %%" % round(100.0 * (cpu1[0] - cpu0[0]) / (cpu1[1] - cpu0[1]))
    print("(make test: %d s%s)" % (time.monotonic() - t0, busy))
    if failed:
        print("make test: failed: %s" % ", ".join(failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
