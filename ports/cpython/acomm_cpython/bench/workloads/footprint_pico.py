# The buoy's minute (footprint_minute) on its own chip: a Raspberry Pi Pico
# (RP2040, Cortex-M0+) running MicroPython v1.28.0's rp2 firmware in the
# rp2040js emulator (acomm_cpython.board.picoboard). The lockstep harness is
# started through the raw REPL on the USB CDC port and speaks the protocol
# over it, as run_qemu's does over the Cortex-M3's UART.
#
#   run_pico(uf2, heap=None, store=None, mpy=None, info=False, peak=True) -> run_qemu's dict
#   (flash_image, boot_free: acomm_cpython.board.picoflash)
#   image_bytes(uf2)                   a firmware's size in flash
#   pool_of(region) / region_of(pool)  the GC's table overhead
#
# A smaller heap on a fixed one. The rp2 port's heap is fixed by its linker
# script (a GC pool of 245,888 bytes), so heap=T is made from Python. T
# stands for a GC *region* of T bytes, tables included, as MICROPY_HEAP_SIZE
# is on the qemu board. Its pool P = pool_of(T) is what gc_setup_area
# (py/gc.c, v1.28.0) carves out of T bytes: 16-byte blocks, one byte of
# allocation table per 4 blocks, one byte of finaliser table per 8 blocks
# (rp2 and qemu both have finalisers and no weakrefs), and a gap byte.
# First thing at the raw REPL, after gc.collect(), the GC's own bounds are
# cut to P (_FIND, _CUT, with machine.mem32): its allocation table's length
# and the pool's end, in the mp_state_mem_area_t that gc_init filled, found
# by five words (table start, table length n, finaliser table at start +
# n + 1, pool start, pool end = start + 64 n). The blocks keep their places,
# so what was allocated at boot stays in P, as in the qemu board's
# heap_min; nothing may live past the new end (checked: the REPL's
# commands sit near 30 KB, so a pool below that cannot be made, and the
# run fails, as the buoy would). The heap then acts as a T-byte region's:
# the same blocks, collections over P alone. (A blocker bytearray
# allocated first gave the same figure, 49,408 frozen, but each
# gc.collect() scanned its 190 KB: 13.3 ms a collection against 0.5 ms, so
# a minute near the edge, collecting every few allocations, took 25
# minutes.) The command that starts the harness prints the heap around the
# import: it holds 48 bytes more than run_qemu's (measured on the qemu
# board), within the 256-byte step.
#
# peak=False: the harness's heap peak is not sampled each step (the
# bisection only asks pass or fail): gc.mem_alloc() scans the whole
# allocation table, 9 ms a call on the whole Pico heap, three times the
# node's own step. A small stand-in for the gc module takes its place in
# the harness; made before the cut, its heap is measured (the same command
# before and after), given back to the pool (to the 64-byte step) and taken
# off the figures, so it is not charged to the buoy.
import os
import re
import shutil
import tempfile
import time

from acomm_cpython.board import boardfiles
from acomm_cpython.board.picoflash import PICO_WALL0, boot_free, flash_image
from acomm_cpython.bench.workloads.footprint_minute import (BOARD, LOAD_PACKETS, SIM_MS, SerialPipe, judge, minute, result,
                                                       seed_store)
from acomm_cpython.bench.workloads.footprint_runners import _read_until, put_files

# A Pico minute takes 1-2.5 minutes of wall time on a quiet machine, and
# past 10 near the heap's edge (a collection at every few steps) with other
# emulators beside it. A hung board is caught by the serial port's 30 s
# timeout on each step's answer; this bound on the whole run is only a
# backstop, far enough that a slow run is never taken for a heap too small
RUN_LIMIT_S = 3600
BLOCK = 16  # MICROPY_BYTES_PER_GC_BLOCK on both 32-bit ports


def pool_of(region):
    """The GC pool (bytes) that gc_init(start, start + region) makes on rp2 and qemu (finalisers, no weakrefs)."""
    atb = (region - 1) * 8 // (8 + 8 * 4 // 8 + 8 * 4 * BLOCK)
    return atb * 4 * BLOCK


def region_of(pool):
    """The smallest GC region (bytes, tables included) whose pool holds `pool` bytes."""
    atb = -(-pool // (4 * BLOCK))
    return atb * 4 * BLOCK + atb + 1 + (atb * 4 + 7) // 8


def image_bytes(uf2):
    """The size in flash of the image a UF2 file writes (its highest address less its lowest), by tools/uf2.py."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("acomm_uf2", os.path.join(boardfiles.repo_root(), "tools", "uf2.py"))
    uf2mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(uf2mod)
    with open(uf2, "rb") as f:
        return len(uf2mod.read(f.read())[1])


# the stand-in for gc in the harness: the real mem_alloc() for its two
# figures (after the imports, after the build), 0 for each step's peak
_STAND_IN = """class _G:
    collect = gc.collect
    mem_free = gc.mem_free
    k = 2
    @staticmethod
    def mem_alloc():
        if _G.k:
            _G.k -= 1
            return gc.mem_alloc()
        return 0
"""
_ALLOC = "gc.collect()\nprint('ALLOC', gc.mem_alloc())"

# finds the GC's mp_state_mem_area_t (see the header) -> its address, or 0
_FIND = """import machine
m = machine.mem32
n = (gc.mem_alloc() + gc.mem_free()) // 64
a = 0x20000004
while a < 0x20042000 and not (m[a] == n and m[a + 4] == m[a - 4] + n + 1 and m[a + 12] - m[a + 8] == n * 64):
    a += 4
print('AREA', a - 4 if a < 0x20042000 else 0)
m = n = a = None
"""
# cuts the pool to k * 64 bytes: table length and pool end; the next free
# table index back to 0 if it lies past the end. Short, so that its bytecode
# (which lives while it runs, above what its parsing took) sits low in the
# pool: nothing allocated may lie past the new end (the highest used block,
# from the last collection, is checked)
_CUT = """gc.collect()
m = machine.mem32
a = %d
k = %d
if m[a + 24] < k * 4 and m[a + 16] - m[a + 12] == m[a + 4] * 64:
    m[a + 4] = k
    m[a + 16] = m[a + 12] + k * 64
    if m[a + 20] >= k:
        m[a + 20] = 0
m = a = k = None
gc.collect()
print('SHRUNK', gc.mem_alloc() + gc.mem_free())
"""


class SetupError(RuntimeError):
    """The run could not be set up as asked: not a pass, nor a heap too small."""


def _alloc(t):
    return int(re.search(rb"ALLOC (\d+)", t.exec(_ALLOC)).group(1))


def _shrink(t, pool):
    # -> None once the pool is `pool` bytes, else why not (something lives
    # past the new end: a heap too small). SetupError when
    # the GC's bounds are not where gc_init leaves them (another firmware)
    addr = int(re.search(rb"AREA (\d+)", t.exec(_FIND)).group(1))
    if not addr:
        raise SetupError("the Pico's GC heap bounds were not found: not MicroPython v1.28's rp2 layout?")
    got = int(re.search(rb"SHRUNK (\d+)", t.exec(_CUT % (addr, pool // 64))).group(1))
    if got != pool:
        # the REPL compiles each command above what it parsed: at about 30 KB
        # on this firmware, far below any heap the buoy fits in
        return "what the board holds before the harness (its firmware's and its REPL's) reaches past a %d-byte pool" % pool
    return None


def _command(info):
    # the raw REPL command that starts the harness (run_qemu's, with the heap
    # printed around the import: what the harness took)
    return "\n".join(["gc.collect()", "print('HAR', gc.mem_alloc())", "import acomm_lockstep", "gc.collect()",
                      "print('HAR', gc.mem_alloc(), gc.mem_free())", "acomm_lockstep.gc = _G",
                      "acomm_lockstep.main('/config.py', '/store', None, %r)" % bool(info)])


def run_pico(uf2, heap=None, store=None, mpy=None, info=False, peak=True, seed=1, limit_s=RUN_LIMIT_S):
    """One buoy minute on the emulated Pico running `uf2`.

    heap: None for the Pico's whole heap, else a GC region of that many
    bytes (see the header). store: the buoy's store file to start from
    (seed_store), with Iridium down for the minute. mpy: a flash image
    (flash_image) with the buoy's .mpy files under /lib and the harness as
    /acomm_lockstep.mpy, for the stock firmware; each run starts from a copy
    of it. peak=False: no peak sampled (see the header). -> run_qemu's dict,
    plus "pool" (the heap's pool in bytes, see the header) and "harness"
    (what importing the harness took).
    """
    from acomm_cpython.board.picoboard import PicoBoard

    cfg = boardfiles.load_config(boardfiles.board_path(BOARD))
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-pico-")
    flash = None
    if mpy:
        flash = os.path.join(tmp, "flash.img")
        shutil.copyfile(mpy, flash)
    text = b""
    r = None
    stand_in = 0
    deadline = time.monotonic() + limit_s
    board = None
    try:
        board = PicoBoard(uf2, flash=flash)
        t = board.transport()
        t.serial.timeout = 30
        t.enter_raw_repl(soft_reset=False)
        # the heap is cut first, while only what the firmware allocated at
        # boot lives (low in the pool: nothing above the new end); only the
        # stand-in comes before, so its heap can be given back
        t.exec("import gc\n_G = gc")
        if not peak:
            a0 = _alloc(t)
            t.exec(_STAND_IN)
            stand_in = _alloc(t) - a0
        if heap is not None:
            # the GC's pool comes in 64-byte steps: the stand-in gets back
            # what fits in them, and the buoy is short of the rest (< 64 B)
            cut = _shrink(t, pool_of(heap) + stand_in // 64 * 64)
            if cut:
                raise EOFError(cut)
        put_files(t, store)
        t.exec_raw_no_follow(_command(info))
        pre = _read_until(t.serial, (b"LOCK", b"\x04>"), 120)
        text = pre
        if not pre.endswith(b"LOCK"):
            raise EOFError("the harness did not start")
        text = pre[:-4]
        minute(SerialPipe(t.serial), cfg, seed, SIM_MS, deadline, iridium_down=store is not None)
        t.serial.write(b"Q")
        tail = _read_until(t.serial, (b"\x04>",), 60)
        text += tail
        r = result(tail.split(b"\x04")[0].decode(errors="replace"))
        if b"\x04" in tail and tail.split(b"\x04")[1].strip():
            r = None  # a traceback after the figures
    except SetupError:
        raise
    except Exception as e:  # noqa: BLE001 - any failure of the board is a failed run
        text += ("\n[host] %s: %s" % (type(e).__name__, e)).encode()
    finally:
        if board is not None:
            board.stop()
        shutil.rmtree(tmp, ignore_errors=True)
    s = text.decode(errors="replace")
    out = dict(r or {})
    out.update(_board_figures(s, r, stand_in))
    out["heap"] = heap
    why = judge(r)
    if why and "MemoryError" in s:
        why = "MemoryError (%s)" % why
    elif r is None and "[host]" in s:
        why += ": " + s.rsplit("[host]", 1)[1].strip()  # the board hung or a port failed: say so
    if why is None and store is not None and r["stored"] != LOAD_PACKETS + 1:
        why = "the store holds %d packets (%d expected)" % (r["stored"], LOAD_PACKETS + 1)
    out["fail"] = why
    out["text"] = s
    return out


def _board_figures(s, r, stand_in):
    # the figures the command printed before the harness's (see _command):
    # the stand-in is not the buoy's, nor is it in the pool it was given
    out = {}
    har = re.findall(r"HAR (\d+)(?: (\d+))?", s)
    if len(har) == 2:
        out["harness"] = int(har[1][0]) - int(har[0][0])
        out["pool"] = int(har[1][0]) + int(har[1][1]) - stand_in
        if r:
            for k in ("peak", "after_build", "code"):
                out[k] = r[k] - stand_in
    if r and stand_in:
        out["peak"] = None  # not sampled
    return out


# --- the bench's RP2040 groups (footprint_workload --only NAME) ----------------

ROOMY = 128 * 1024  # the roomy run's GC region, as the Cortex-M3's (footprint_workload.ROOMY)


def need(name):
    """build/firmware/NAME.uf2, else RuntimeError with the one line that says how to get it."""
    from acomm_cpython.board.picoboard import firmware

    p = firmware(name)
    if p is None:
        raise RuntimeError("no build/firmware/%s.uf2: build it with python3 tools/firmware.py build" % name)
    return p


def missing():
    """None when the emulated Pico can run here, else one line saying what is missing."""
    from acomm_cpython.board.picoboard import runner_available

    return runner_available()


def boot_figures(emit):
    # cheap (one boot): the images' sizes in flash, and the heap the stock
    # firmware leaves free at its REPL (littlefs formatted and mounted by its
    # _boot.py; the raw REPL command's own bytecode counts as used)
    from acomm_cpython.board.picoboard import PicoBoard

    stock = need("rp2040-stock")
    emit("flash_image_rp2040_stock_bytes", image_bytes(stock), "bytes")
    emit("flash_image_buoy_pico_bytes", image_bytes(need("buoy_pico")), "bytes")
    with PicoBoard(stock) as b:
        t = b.transport()
        t.enter_raw_repl(soft_reset=False)
        free, alloc = (int(x) for x in t.exec("import gc\ngc.collect()\nprint(gc.mem_free(), gc.mem_alloc())").split())
    emit("heap_free_boot_rp2040_stock_bytes", free, "bytes")
    emit("heap_pool_rp2040_bytes", free + alloc, "bytes")


# the first size the bisection tries: what the node holds once built and
# this much more. The minimum was 6.8-8.1 KB above it on every board
# measured (Cortex-M3 frozen and loaded, RP2040 frozen), so this one
# passes and leaves a bracket of a few steps instead of a wide one
FIRST_ABOVE_BUILD = 12 * 1024


def frozen_figures(emit, bisect, say=None, store=None):
    # rp2040-full (acomm and the harness frozen): a roomy run, then the
    # bisection between what the node holds once built (a pool that cannot
    # work) and the roomy run's peak with 2 KiB of room (a pool that never
    # needs to collect), trying FIRST_ABOVE_BUILD first. With the store
    # loaded the peak is not sampled: reading it makes garbage up to the
    # roomy heap's limit (127 KB of 128 on the Cortex-M3), no bound at all,
    # and sampling doubles the run's time. -> the roomy run's dict
    full = need("rp2040-full")
    name = "frozen_rp2040" + ("_loaded" if store is not None else "")
    roomy = run_pico(full, ROOMY, store=store, peak=store is None)
    if roomy["fail"]:
        raise RuntimeError("%s: the buoy's minute failed even at %d bytes: %s\n%s"
                           % (name, ROOMY, roomy["fail"], roomy["text"][-1500:]))
    hi = min(ROOMY, region_of(roomy["peak"]) + 2048) if roomy["peak"] else ROOMY
    first = region_of(roomy["after_build"] + FIRST_ABOVE_BUILD)
    emit("heap_min_%s_bytes" % name, bisect(lambda h: run_pico(full, h, store=store, peak=False),
                                            roomy["after_build"], hi, say, first), "bytes")
    if store is None:
        emit("heap_after_imports_%s_bytes" % name, roomy["code"], "bytes")
    emit("heap_after_build_%s_bytes" % name, roomy["after_build"], "bytes")
    if roomy["peak"]:
        emit("heap_peak_%s_bytes" % name, roomy["peak"], "bytes")
    return roomy


def mpy_figures(emit, tmp, store, say=None):
    # the buoy as `acomm flash` installs it on the stock firmware. The free
    # heap is read off the buoy's own ready line at boot, empty and with the
    # seeded store (the harness's stand-ins for machine.UART and the clocks
    # are not the board's, and its import order is not start()'s: a module
    # loaded again by start()'s order once hid 6.4 KB from it). The harness
    # runs give the heap after the imports and the build, on the whole heap;
    # what importing the harness's .mpy took is measured apart and taken off
    stock = need("rp2040-stock")
    img = os.path.join(tmp, "pico-flash.img")
    took = flash_image(stock, img)
    if say:
        say("acomm flash to the emulated Pico: %.0f s" % took)
    board = boardfiles.board_path(BOARD)
    emit("mpy_total_armv6m_bytes", boardfiles.mpy_total_bytes(board, "armv6m", os.path.join(tmp, "armv6m")), "bytes")
    for loaded in (False, True):
        r = run_pico(stock, None, store=store if loaded else None, mpy=img, peak=False)
        if r["fail"]:
            raise RuntimeError("mpy_rp2040: the buoy's minute failed on the whole heap: %s\n%s"
                               % (r["fail"], r["text"][-1500:]))
        if not loaded:
            emit("heap_after_imports_mpy_rp2040_bytes", r["code"] - r["harness"], "bytes")
            emit("heap_after_build_mpy_rp2040_bytes", r["after_build"] - r["harness"], "bytes")
            emit("heap_harness_mpy_rp2040_bytes", r["harness"], "bytes")
        else:
            emit("heap_after_build_mpy_rp2040_loaded_bytes", r["after_build"] - r["harness"], "bytes")
    booted = os.path.join(tmp, "pico-flash-main.img")
    flash_image(stock, booted, harness=False)
    emit("heap_free_mpy_rp2040_bytes", boot_free(stock, booted), "bytes")
    seeded = os.path.join(tmp, "store-pico")
    with open(seed_store(seeded, wall0=PICO_WALL0), "rb") as f:
        emit("heap_free_mpy_rp2040_loaded_bytes", boot_free(stock, booted, f.read()), "bytes")
