#!/usr/bin/env python3
# Runs acomm's core tests (tests/core) on a firmware board:
#
#   --target cortex-m3 (default)  build/firmware/cm3-full.elf, MicroPython's
#       qemu port for MPS2-AN385 with acomm and acomm_mp frozen in, under
#       qemu-system-arm; every test module
#   --target rp2040   build/firmware/rp2040-full.uf2, MicroPython's own
#       RPI_PICO firmware with the same modules frozen in, in the RP2040
#       emulator (tools/rp2040/runner.mjs, through acomm_cpython.board.picoboard);
#       the tests listed in tools/rp2040_tests.txt (why a list: see there)
#
# (both built by tools/firmware.py). What the tests need and the firmware
# does not hold goes to the board's littlefs filesystem over its REPL
# (mpremote's raw REPL; the Cortex-M3's UART, the Pico's USB CDC): the test
# modules and their helpers, the simulator's emulators (ports/sim/acomm_sim),
# the few files tests read (docs tables, board configs) and the device half
# of this runner (tools/board_device.py), laid out under /t as in the
# repository. Python files go as .mpy compiled here by the firmware's
# mpy-cross for the board's architecture: compiling on the emulated board
# is the slow part of an upload otherwise.
#
# Each test module runs after a soft reset (a clean heap, the files stay);
# each test has its own time limit, and one that overruns is reported as a
# failure by name, the board is restarted (its filesystem with it, so the
# files are sent again) and the run goes on with the next test. acomm must
# come from the frozen firmware: the run stops if it is found on the
# filesystem. The last line is "micropython-cortex-m3: N passed, N failed"
# (micropython-rp2040: for the Pico); the exit status is 1 when anything
# failed, 2 when the run could not be made at all (no firmware, the board
# does not start), 3 when the target's emulator is not installed here (the
# line says how to install it).
#
#   python3 tools/board_runtests.py [--target T] [-k SUBSTRING] [--timeout S] [--source]
import argparse
import glob
import os
import subprocess
import sys
import tempfile
import time
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "ports", "cpython"))

from acomm_cpython.board.qemuboard import QemuBoard, QemuError  # noqa: E402

FW = os.path.join(ROOT, "build", "firmware")


class Target:
    """A kind of firmware board: its runtime's name, firmware, .mpy arch and per-test time limit."""

    def __init__(self, name, firmware, arch, timeout, select=None, compress=True):
        self.name, self.firmware, self.arch, self.timeout, self.select = name, firmware, arch, timeout, select
        self.compress = compress


TARGETS = {
    # the slowest core test takes about a tenth of the limit on a quiet machine
    "cortex-m3": Target("micropython-cortex-m3", os.path.join(FW, "cm3-full.elf"), "armv7m", 240),
    # a test runs about 150 times slower in simulated time than on the unix
    # port, and the emulator at about 0.57 of real time (less beside other
    # work): test_board's garbage-and-silence minutes took 300 s on a loaded
    # machine
    "rp2040": Target("micropython-rp2040", os.path.join(FW, "rp2040-full.uf2"), "armv6m", 900,
                     os.path.join(ROOT, "tools", "rp2040_tests.txt"), compress=False),
}
HEAP = 2 * 1024 * 1024  # the most the qemu firmware is built for
DEV = "/t"  # the repository's place on the board's filesystem
# what tests read besides modules, relative to ROOT
DATA = ("docs/codec.md", "docs/wire-format.md", "boards/*/config.py")
UPLOAD_TIMEOUT_S = 600
# the board's end of the upload: creates the folders, reads the zlib stream
# from the UART and writes each file; prints how many and their CRC-32
UNPACK = """import sys, os, io, micropython, deflate, binascii
micropython.kbd_intr(-1)
for d in %r:
    try:
        os.mkdir(d)
    except OSError:
        pass
nz = %d
if nz:
    buf = bytearray(nz)
    mv = memoryview(buf)
    n = 0
    print("GO")
    while n < nz:
        n += sys.stdin.buffer.readinto(mv[n:])
    z = deflate.DeflateIO(io.BytesIO(buf), deflate.ZLIB)
else:
    z = sys.stdin.buffer
    print("GO")
count = crc = 0
while True:
    path = z.readline()
    if len(path) < 2:
        break
    left = int(z.readline())
    f = open(path[:-1].decode(), "wb")
    while left:
        b = z.read(min(left, 1024))
        if not b:
            raise OSError("short")
        crc = binascii.crc32(b, crc)
        f.write(b)
        left -= len(b)
    f.close()
    count += 1
micropython.kbd_intr(3)
print(count, crc)
"""


class RunError(Exception):
    """The run cannot go on (the board will not start, the upload fails, acomm is not frozen)."""


class NoEmulator(Exception):
    """The target's emulator is not installed here: one line says how to install it."""


def payload(mpy_cross, work, source=False, arch="armv7m", tests=None):
    """[(device path, bytes)] to upload: modules as .mpy (or .py with source=True), data files as they are.

    tests: the test modules to send (None: all); the helpers always go."""
    mods = [(p, DEV + "/tests/core/") for p in sorted(glob.glob(os.path.join(ROOT, "tests", "core", "*.py")))
            if tests is None or not os.path.basename(p).startswith("test_") or os.path.basename(p)[:-3] in tests]
    mods += [(p, DEV + "/ports/sim/acomm_sim/") for p in sorted(glob.glob(os.path.join(ROOT, "ports", "sim", "acomm_sim", "*.py")))]
    mods.append((os.path.join(ROOT, "tools", "board_device.py"), DEV + "/"))
    out = []
    for src, d in mods:
        base = os.path.basename(src)[:-3]
        if source:
            with open(src, "rb") as f:
                out.append((d + base + ".py", f.read()))
            continue
        dst = os.path.join(work, d.strip("/").replace("/", "_") + base + ".mpy")
        r = subprocess.run([mpy_cross, "-march=" + arch, "-s", base + ".py", "-o", dst, src], capture_output=True,
                           text=True)
        if r.returncode != 0:
            raise RunError("mpy-cross %s: %s" % (os.path.relpath(src, ROOT), (r.stderr or r.stdout).strip()))
        with open(dst, "rb") as f:
            out.append((d + base + ".mpy", f.read()))
    for pat in DATA:
        for src in sorted(glob.glob(os.path.join(ROOT, pat))):
            with open(src, "rb") as f:
                out.append((DEV + "/" + os.path.relpath(src, ROOT).replace(os.sep, "/"), f.read()))
    return out


def test_modules():
    return sorted(os.path.basename(p)[:-3] for p in glob.glob(os.path.join(ROOT, "tests", "core", "test_*.py")))


def select(path):
    """{test module: None (all its tests) or [test names]} from a list file: a line each, 'module' or
    'module.test', '#' comments."""
    out = {}
    with open(path) as f:
        for line in f:
            line = line.split("#")[0].strip()
            if not line:
                continue
            mod, _, test = line.partition(".")
            if test:
                if out.get(mod, []) is not None:
                    out.setdefault(mod, []).append(test)
            else:
                out[mod] = None
    return out


def _start_board(target, heap):
    if target.name == TARGETS["rp2040"].name:
        from acomm_cpython.board.picoboard import PicoBoard, PicoError

        try:
            return PicoBoard(target.firmware)
        except PicoError as e:
            raise RunError(str(e))
    try:
        return QemuBoard(target.firmware, heap=heap)
    except QemuError as e:
        raise RunError(str(e))


class Board:
    """The firmware board (qemu or the RP2040 emulator) with the payload on its filesystem; restarted after a hang."""

    def __init__(self, target, files, heap):
        self.target, self.files, self.heap = target, files, heap
        self.qemu = None
        self.t = None
        self.starts = 0
        self.upload_s = 0.0
        self.upload_bytes = 0

    def start(self):
        self.stop()
        self.qemu = _start_board(self.target, self.heap)
        self.starts += 1
        t0 = time.monotonic()
        try:
            self.t = self.qemu.transport()
            self.t.enter_raw_repl(soft_reset=False, timeout_overall=60)
            self._upload()
            where = self.t.exec("import acomm, acomm_mp\nprint(acomm.__file__, acomm_mp.__file__)").decode().split()
        except Exception as e:  # noqa: BLE001 - mpremote raises several kinds
            raise RunError("upload to the board failed: %r\nemulator stderr: %s" % (e, self.stop().strip()))
        self.upload_s += time.monotonic() - t0
        # frozen modules have a __file__ relative to the frozen root; ones
        # on the filesystem an absolute path
        if where != ["acomm/__init__.py", "acomm_mp/__init__.py"]:
            raise RunError("acomm is not the frozen one: __file__ %s" % " ".join(where))
        return where

    def _upload(self):
        # One zlib stream of "path\nsize\n" + bytes per file, sent as raw
        # bytes while the board reads its UART with Ctrl-C off, inflated and
        # written out there, and checked with a CRC-32 of what was written.
        # mpremote's fs_writefile sends each 256-byte chunk as Python source
        # to compile on the board: 20 KB took 16 s here (the UART of qemu's
        # MPS2 board moves about 4 KB/s); this sends half the bytes, once.
        # On the Pico the bytes go over USB CDC, paced by the emulator's
        # runner.
        dirs = set()
        archive = []
        for path, data in self.files:
            parts = path.split("/")[1:-1]
            for i in range(1, len(parts) + 1):
                dirs.add("/" + "/".join(parts[:i]))
            archive.append(b"%s\n%d\n" % (path.encode(), len(data)) + data)
        archive = b"".join(archive) + b"\n"  # an empty path ends it
        # the slow UART gets it compressed, whole into the board's big heap;
        # the Pico's USB gets it as it is, streamed (its heap would not
        # hold it)
        z = zlib.compress(archive, 9) if self.target.compress else archive
        self.upload_bytes = len(z)
        self.t.exec_raw_no_follow(UNPACK % (sorted(dirs), len(z) if self.target.compress else 0))
        # not before the board has turned Ctrl-C off: a 0x03 in the stream
        # would interrupt it (a fast link, the Pico's USB, gets there first)
        self.t.read_until(1, b"GO\r\n", timeout=60)
        self.t.serial.write(z)
        out, err = self.t.follow(UPLOAD_TIMEOUT_S)
        want = "%d %d" % (len(self.files), zlib.crc32(b"".join(d for _, d in self.files)))
        if err or out.decode().strip() != want:
            raise RunError("the board did not get the files: %r %r (wanted %s)" % (out, err, want))

    def stop(self):
        err = ""
        if self.qemu is not None:
            err = self.qemu.stop()
        self.qemu = self.t = None
        return err

    def alive(self):
        return self.qemu is not None and self.qemu.alive()

    def run_module(self, mod, start, timeout, k, report, only=None):
        """Runs mod's tests from index start; report(kind, i, name, text). Returns (count, next index, how it ended)."""
        t = self.t
        t.enter_raw_repl(soft_reset=True, timeout_overall=60)  # a clean heap; the files stay
        t.exec_raw_no_follow("import sys\nsys.path.append(%r)\nsys.path.append(%r)\nsys.path.append(%r)\n"
                             "import board_device\nboard_device.run(%r, %d, %r, %r)"
                             % (DEV, DEV + "/tests/core", DEV + "/ports/sim", mod, start, k, only))
        count = None
        cur = None  # (i, name) of the test running
        last = None  # the last marker line, for the text that follows it
        text = []
        buf = b""
        tail = b""  # what follows the second EOF: the raw REPL's prompt
        eofs = 0
        err = b""
        deadline = time.monotonic() + timeout
        ser = t.serial

        def flush_text():
            if last is not None and last[0] in ("FAIL", "IMPORT"):
                report(last[0], last[1], last[2], "\n".join(text))

        while eofs < 2:
            if time.monotonic() > deadline:
                flush_text()
                return count, cur, "timeout"
            n = ser.in_waiting
            if not n:
                if not self.alive():
                    flush_text()
                    return count, cur, "died"
                time.sleep(0.02)
                continue
            chunk = ser.read(n)
            for b in chunk:
                if eofs >= 2:
                    tail += bytes([b])
                elif b == 4:
                    eofs += 1
                elif eofs == 1:
                    err += bytes([b])
                else:
                    buf += bytes([b])
            while b"\n" in buf:
                line, buf = buf.split(b"\n", 1)
                line = line.decode(errors="replace").rstrip("\r")
                if line.startswith("@@"):
                    flush_text()
                    text = []
                    f = line[2:].split()
                    kind = f[0]
                    if kind == "N":
                        count = int(f[1])
                        last = None
                    elif kind == "START":
                        cur = (int(f[1]), f[2])
                        last = None
                        deadline = time.monotonic() + timeout
                    elif kind in ("PASS", "FAIL", "SKIP"):
                        cur = None
                        last = (kind, int(f[1]), f[2])
                        if kind != "FAIL":
                            report(kind, int(f[1]), f[2], " ".join(f[3:]))
                    elif kind == "IMPORT":
                        last = ("IMPORT", -1, mod)
                        text.append(" ".join(f[1:]))
                    elif kind == "DONE":
                        last = None
                else:
                    text.append(line)
        # the raw REPL's prompt follows (perhaps in the last chunk already):
        # read it here so that the next command does not take it for its own
        # (pyserial's read on qemu's pty has no timeout of its own)
        end = time.monotonic() + 5
        while b">" not in tail and time.monotonic() < end:
            if ser.in_waiting:
                tail += ser.read(ser.in_waiting)
            else:
                time.sleep(0.01)
        if buf:
            text.append(buf.decode(errors="replace"))
        flush_text()
        if err.strip():
            # something escaped the device runner (a MemoryError while
            # printing, an interrupt): the test running is a failure
            return count, cur, "error: " + err.decode(errors="replace").strip()
        return count, cur, "done"


def main(argv=None):
    p = argparse.ArgumentParser(description="acomm's core tests on a firmware board (Cortex-M3 under QEMU, RP2040 "
                                            "in its emulator)")
    p.add_argument("--target", choices=sorted(TARGETS), default="cortex-m3")
    p.add_argument("-k", help="only test modules/functions whose 'module.function' contains this")
    p.add_argument("--timeout", type=float, help="seconds per test (default: the target's)")
    p.add_argument("--heap", type=int, default=HEAP, help="GC heap in bytes, qemu only (default %(default)s)")
    p.add_argument("--firmware", help="the firmware image (default: the target's in build/firmware/)")
    p.add_argument("--all", action="store_true", help="every core test, not only the target's list")
    p.add_argument("--source", action="store_true", help="upload .py sources instead of .mpy (compiled on the board)")
    p.add_argument("-v", "--verbose", action="store_true", help="a line per test")
    a = p.parse_args(argv)
    target = TARGETS[a.target]
    if a.firmware:
        target.firmware = os.path.abspath(a.firmware)
    NAME = target.name
    timeout = a.timeout or target.timeout
    t_all = time.monotonic()
    if a.target == "rp2040":
        from acomm_cpython.board.picoboard import runner_available

        why = runner_available()
        if why:
            print("%s: skipped: %s" % (NAME, why))
            return 3
    mpy_cross = os.path.join(FW, "mpy-cross")
    for need in (target.firmware, mpy_cross):
        if not os.path.isfile(need):
            print("%s: cannot run: %s is not built (make firmware)" % (NAME, os.path.relpath(need, ROOT)))
            return 2
    chosen = None if a.all or not target.select else select(target.select)
    passed = failed = skipped = 0
    failures = []

    def report(kind, i, name, text):
        nonlocal passed, failed, skipped
        if kind == "SKIP":
            skipped += 1
            print("skip %s.%s: %s" % (mod, name, text), flush=True)
            return
        if kind == "PASS":
            passed += 1
            if a.verbose:
                print("pass %s.%s %s ms" % (mod, name, text), flush=True)
            return
        failed += 1
        failures.append("%s.%s" % (mod, name) if kind != "IMPORT" else "%s (import)" % mod)
        print("FAIL %s" % failures[-1] if kind == "FAIL" else "ERROR importing %s" % mod)
        if text:
            print(text)
        sys.stdout.flush()

    with tempfile.TemporaryDirectory(prefix="acomm-board-") as work:
        try:
            files = payload(mpy_cross, work, a.source, target.arch, chosen)
        except RunError as e:
            print("%s: cannot run: %s" % (NAME, e))
            return 2
        board = Board(target, files, a.heap)
        try:
            board.start()
        except RunError as e:
            print("%s: cannot run: %s" % (NAME, e))
            return 2
        print("%s: %d files (%d bytes, %d sent) uploaded in %.1f s; acomm frozen in %s"
              % (NAME, len(files), sum(len(d) for _, d in files), board.upload_bytes, board.upload_s,
                 os.path.relpath(target.firmware, ROOT)),
              flush=True)
        try:
            for mod in test_modules():
                if chosen is not None and mod not in chosen:
                    continue
                only = chosen and chosen[mod]
                if a.k and a.k not in mod and not any(a.k in n for n in _test_names(mod)):
                    continue
                start = 0
                if a.verbose:
                    print("module", mod, flush=True)
                while True:
                    if not board.alive():
                        board.start()
                    count, cur, how = board.run_module(mod, start, timeout, a.k, report, only)
                    if how == "done":
                        break
                    if how == "timeout":
                        msg = "no result after %.0f s: killed, the board restarted" % timeout
                    elif how == "died":
                        msg = "the emulator exited: %s" % board.stop().strip()
                    else:
                        msg = how  # something escaped the device runner
                    if how in ("timeout", "died"):
                        board.stop()
                    if cur is None:
                        report("IMPORT", -1, mod, msg)
                        break
                    report("FAIL", cur[0], cur[1], msg)
                    start = cur[0] + 1
                    if count is not None and start >= count:
                        break
        except RunError as e:
            print("%s: cannot go on: %s" % (NAME, e))
            failed += 1
            failures.append("(run stopped)")
        finally:
            board.stop()
    for f in failures:
        print("FAILED", f)
    print("%s: %.0f s wall, %d board start(s), %.1f s uploading" % (NAME, time.monotonic() - t_all, board.starts,
                                                                     board.upload_s))
    print("%s: %d passed, %d failed%s" % (NAME, passed, failed, ", %d skipped" % skipped if skipped else ""),
          flush=True)
    return 1 if failed else 0


def _test_names(mod):
    # names of a module's tests, read from its source (for -k)
    out = []
    with open(os.path.join(ROOT, "tests", "core", mod + ".py")) as f:
        for line in f:
            if line.startswith("def test_"):
                out.append(mod + "." + line[4:].split("(")[0])
    return out


if __name__ == "__main__":
    sys.exit(main())
