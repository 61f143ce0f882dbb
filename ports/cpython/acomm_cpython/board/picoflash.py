# The buoy flashed onto an emulated stock Pico (acomm_cpython.board.picoboard) as
# a user flashes a real one, for the footprint figures
# (acomm_cpython.bench.workloads.footprint_pico):
#
#   flash_image(stock_uf2, out, harness=True)  `acomm flash --board buoy_pico`
#       onto the stock firmware; the 2 MiB flash image written to `out`
#   boot_free(stock_uf2, image, store=None)    the free heap the buoy's
#       ready line reports when that image boots (holding `store`)
#   heap_free(lines)                           the free heap of each ready
#       line among a board's console lines
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

from . import boardfiles

BOARD = "buoy_pico"
HARNESS = os.path.join(boardfiles.repo_root(), "tools", "lockstep", "acomm_lockstep.py")


def flash_image(stock_uf2, out, log=None, harness=True):
    """Writes `out`: the Pico's 2 MiB flash after `acomm flash --board buoy_pico` onto `stock_uf2`, plus the harness.

    The real command runs against the emulated board's USB port (armv6m
    .mpy files under /lib, main.py and config.py at /). With harness, the
    harness goes beside them as /acomm_lockstep.mpy, outside /lib, and
    /main.py is removed: the harness builds the node itself, and a main.py
    would start a second one at boot. -> seconds the flash took.
    """
    from .flash import mpremote_command
    from .picoboard import PicoBoard

    tmp = tempfile.mkdtemp(prefix="acomm-footprint-flash-")
    try:
        if os.path.exists(out):
            os.remove(out)
        with PicoBoard(stock_uf2, flash=out) as b:
            t0 = time.monotonic()
            r = subprocess.run([sys.executable, "-c", "import sys\nfrom acomm_cpython.cli import main\nsys.exit(main())",
                                "flash", "--board", BOARD, "--port", b.usb],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
            took = time.monotonic() - t0
            if r.returncode:
                raise RuntimeError("acomm flash to the emulated Pico failed: %s" % r.stdout[-800:])
            if log:
                log(r.stdout.strip().splitlines()[-1])
            if harness:
                h = os.path.join(tmp, "acomm_lockstep.mpy")
                boardfiles.compile_mpy(HARNESS, h, "armv6m", "acomm_lockstep.py")
                r = subprocess.run(mpremote_command() + ["connect", b.usb, "fs", "cp", h, ":acomm_lockstep.mpy", "+",
                                                         "fs", "rm", ":main.py"],
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=120)
                if r.returncode:
                    raise RuntimeError("copying the harness to the emulated Pico failed: %s" % r.stdout[-800:])
            b.save()
        return took
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


# The Pico's clock at power-up with no RTC set is 2021-01-01, which the
# board's wall clock (acomm_mp.start.wall, from 2020) counts as this: the
# store seeded for a boot holds packets that have not expired yet
PICO_WALL0 = 31622400
# a board's ready line (acomm_mp.start): "acomm buoy: node 1, links
# acoustic, satellite; 132544 B heap free"
_READY_FREE = re.compile(r": node \d+, links [^;\r\n]*; (\d+) B heap free")


def heap_free(lines):
    """The free heap (bytes) each ready line among a board's console `lines` reports, in order."""
    return [int(m.group(1)) for m in (_READY_FREE.search(x) for x in lines) if m]


def boot_free(stock_uf2, image, store=None, limit_s=120):
    """The free heap (bytes) the buoy's ready line reports when the Pico boots `image` (flash_image with harness=False).

    store: the buoy's store file (seed_store, wall0=PICO_WALL0) put at its
    config's path first, so the buoy boots holding its packets. The figure is
    the buoy's own, after a collection: main.py and the node as flashed,
    machine.UART's rings, nothing of a harness.
    """
    from .picoboard import PicoBoard

    tmp = tempfile.mkdtemp(prefix="acomm-footprint-boot-")
    try:
        flash = os.path.join(tmp, "flash.img")
        shutil.copyfile(image, flash)
        with PicoBoard(stock_uf2, flash=flash) as b:
            if store is not None:
                # main.py is running: Ctrl-C stops it (the watchdog resets the
                # board 8 s later, after the copy and the save)
                t = b.transport()
                t.enter_raw_repl(soft_reset=False)
                path = boardfiles.load_config(boardfiles.board_path(BOARD))["storage"]["path"]
                t.exec("import os\ntry:\n    os.mkdir(%r)\nexcept OSError:\n    pass" % path.rsplit("/", 1)[0])
                t.fs_writefile(path, store)
                t.close()
                b.save()
            ser = _serial_for(b)
            text = ""
            free = []
            try:
                b.reset()
                end = time.monotonic() + limit_s
                while not free and time.monotonic() < end:
                    text += ser.read(max(1, ser.in_waiting)).decode(errors="replace")
                    free = heap_free([text])
            finally:
                ser.close()
        if not free:
            raise RuntimeError("the buoy gave no ready line within %d s: %r" % (limit_s, text[-600:]))
        return free[0]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _serial_for(board):
    """The emulated Pico's USB REPL as a pyserial port."""
    import serial

    return serial.Serial(board.usb, 115200, timeout=0.05)
