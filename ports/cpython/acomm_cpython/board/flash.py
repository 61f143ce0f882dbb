# `acomm flash --board NAME --port DEVICE`: put a board's program on a
# MicroPython board with mpremote. What goes there is worked out by
# acomm_cpython.board.boardfiles (only the modules the board imports, compiled
# with mpy-cross for its MCU); main.py and config.py go as source to / so
# they can be read and edited on the board, modules to /lib/acomm/... and
# /lib/acomm_mp/....
#
# The board is asked for its free space first. Files of earlier flashes
# under /lib/acomm and /lib/acomm_mp that this board no longer needs are
# removed: MicroPython imports x.py before x.mpy, so an old source copy
# (from `mip install`, --no-compile) would shadow the new compiled module.
# The copy is a few mpremote calls of `fs cp` chained with `+`, each with a
# time limit that grows with the bytes it carries.
#
# A board whose firmware has acomm frozen in (its modules are found under
# .frozen, which comes before /lib on sys.path) gets only main.py and
# config.py: the board is asked for acomm.__path__ (.frozen/acomm; a frozen
# module's __file__ is only its name, acomm/link/__init__.py) and __version__ and
# imports every module the board needs from its firmware. A version other
# than the host's, or a module the firmware lacks, stops the flash (exit
# 2; --force flashes past a version mismatch). Copies of acomm left in
# /lib by an earlier flash are removed: they would never run, and would
# confuse whoever reads the board's files.
#
# --reset: a hard reset once the copy is done (mpremote's `reset`), so the
# board starts its new main.py as a freshly flashed Pico does. Without it the
# board stays at its REPL, where a test or the user may still look at it.

import os
import shutil
import subprocess
import sys

from .boardfiles import MPY_ARCHES, FlashError, board_path, device_dirs, load_config, modules, plan

TIMEOUT_S = 30  # one mpremote call, plus 1 s per KiB it copies
_BATCH_FILES = 32  # `fs cp` per mpremote call
_BATCH_BYTES = 48 * 1024


# --- the device ----------------------------------------------------------------


def mpremote_command():
    exe = os.path.join(os.path.dirname(sys.executable), "mpremote")
    if os.access(exe, os.X_OK):
        return [exe]
    exe = shutil.which("mpremote")
    if exe:
        return [exe]
    try:
        import mpremote  # noqa: F401

        return [sys.executable, "-m", "mpremote"]
    except ImportError:
        raise FlashError("mpremote not found (pip install mpremote)")


def _mpremote(device, args, what, timeout=TIMEOUT_S):
    cmd = mpremote_command() + ["connect", device] + args
    try:
        r = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True, errors="replace", timeout=timeout)
    except subprocess.TimeoutExpired:
        raise FlashError("%s: mpremote gave no answer within %d s" % (what, timeout))
    if r.returncode:
        lines = [ln.strip() for ln in r.stdout.splitlines() if ln.strip()]
        raise FlashError("%s: %s" % (what, lines[-1] if lines else "mpremote exit status %d" % r.returncode))
    return r.stdout


# Runs on the board: free space, block size, and the blocks held by the files
# a flash replaces (those trees and files are rewritten); then where acomm
# comes from and, when it is frozen, which of the needed modules the
# firmware lacks (a frozen package's submodules come only from .frozen).
_DF = """import os
def _b(p, bs):
    try:
        s = os.stat(p)
    except OSError:
        return 0
    if s[0] & 0x4000:
        return sum(_b(p + '/' + e[0], bs) for e in os.ilistdir(p))
    return (s[6] + bs - 1) // bs * bs
_v = os.statvfs('/')
print('ACOMM-DF', _v[0], _v[0] * _v[3], sum(_b(p, _v[0]) for p in %r))
try:
    import acomm
    _f, _r = str(getattr(acomm, '__path__', '?')), str(getattr(acomm, '__version__', '?'))
except Exception:
    _f = _r = '-'
_miss = []
if _f.startswith('.frozen'):
    for _m in %r:
        try:
            __import__(_m)
        except Exception:
            _miss.append(_m)
print('ACOMM-FROZEN', _f.replace(' ', '_'), _r.replace(' ', '_'), ' '.join(_miss) or '-')
"""

# Runs on the board: remove what an earlier flash left under the trees it
# owns and this board does not need, then make the folders.
_PREPARE = """import os
_keep = set(%r)
def _clean(p):
    try:
        es = list(os.ilistdir(p))
    except OSError:
        return
    for e in es:
        q = p + '/' + e[0]
        if e[1] & 0x4000:
            _clean(q)
            if q not in _keep:
                try:
                    os.rmdir(q)
                except OSError:
                    pass
        elif q not in _keep:
            os.remove(q)
for _p in %r:
    _clean(_p)
    if _p not in _keep:
        try:
            os.rmdir(_p)
        except OSError:
            pass
for _d in %r:
    try:
        os.mkdir(_d)
    except OSError:
        pass
print('ACOMM-READY')
"""


def _blocks(n, bs):
    return (n + bs - 1) // bs * bs


OWNED = ("/lib/acomm", "/lib/acomm_mp")


class Device:
    """What the board said: block size, free bytes, bytes in the files a flash
    replaces, acomm's __path__ and __version__ there ('-' when none), and the
    needed modules its frozen acomm lacks."""

    def __init__(self, bs, free, replaced, acomm_file, version, missing):
        self.bs, self.free, self.replaced = bs, free, replaced
        self.acomm_file, self.version, self.missing = acomm_file, version, missing

    @property
    def frozen(self):
        return self.acomm_file.startswith(".frozen")


def probe(device, needed=()):
    """Asks the board for its free space and whether acomm is frozen in its firmware."""
    replaced = ["/main.py", "/config.py"] + list(OWNED)
    try:
        out = _mpremote(device, ["exec", _DF % (replaced, sorted(needed))], "no answer from %s" % device)
    except FlashError as e:
        raise FlashError(str(e), 1)
    df = fz = None
    for ln in out.splitlines():
        p = ln.split()
        if len(p) == 4 and p[0] == "ACOMM-DF":
            df = int(p[1]), int(p[2]), int(p[3])
        elif len(p) == 4 and p[0] == "ACOMM-FROZEN":
            fz = p[1], p[2], [] if p[3] == "-" else p[3].split()
    if df is None or fz is None:
        raise FlashError("no answer from %s: unexpected reply to statvfs: %r" % (device, out.strip()[-200:]))
    return Device(*(df + fz))


def device_space(device, entries):
    """(block size, free bytes, bytes in files the flash replaces) on the device."""
    d = probe(device)
    return d.bs, d.free, d.replaced


def _batches(entries):
    cur, size = [], 0
    for e in entries:
        if cur and (len(cur) >= _BATCH_FILES or size + e.size > _BATCH_BYTES):
            yield cur
            cur, size = [], 0
        cur.append(e)
        size += e.size
    if cur:
        yield cur


def flash(device, entries, log=print, dev=None):
    """Copy the planned files to the device; returns (files, bytes). dev: its probe() answer."""
    dev = dev or probe(device)
    bs, free, replaced = dev.bs or 1, dev.free, dev.replaced
    need = sum(_blocks(e.size, bs) for e in entries)
    if need > free + replaced:
        raise FlashError("not enough space on %s: %d bytes needed (%d files in %d-byte blocks), %d free "
                         "(%d now + %d in files it replaces)" % (device, need, len(entries), bs, free + replaced,
                                                                   free, replaced))
    keep = [e.device for e in entries] + device_dirs(entries)
    out = _mpremote(device, ["exec", _PREPARE % (sorted(keep), list(OWNED), device_dirs(entries))],
                    "preparing folders on %s" % device)
    if "ACOMM-READY" not in out:
        raise FlashError("preparing folders on %s: unexpected reply %r" % (device, out.strip()[-200:]))
    done = 0
    for batch in _batches(entries):
        args = []
        for e in batch:
            if args:
                args.append("+")
            args += ["fs", "cp", e.host, ":" + e.device]
        _mpremote(device, args, "copying to %s" % device, TIMEOUT_S + sum(e.size for e in batch) // 1024)
        done += len(batch)
        log("  %d/%d files" % (done, len(entries)))
    return len(entries), sum(e.size for e in entries)


# --- the command -------------------------------------------------------------


def run(args, log=print):
    board_dir = board_path(args.board, args.boards)
    if not args.dry_run and not args.port:
        raise FlashError("--port DEVICE is needed (or --dry-run)", 2)
    if args.arch and args.arch not in MPY_ARCHES:
        raise FlashError("--arch %r: one of %s" % (args.arch, ", ".join(MPY_ARCHES)), 2)
    cfg = load_config(board_dir)
    arch = args.arch or cfg["arch"]
    entries = plan(board_dir, arch, compile=not args.no_compile)
    total = sum(e.size for e in entries)
    kind = "source .py" if args.no_compile else ".mpy for " + arch
    if args.frozen:
        entries = [e for e in entries if not e.device.startswith("/lib/")]
        kind = "main.py and config.py only, acomm frozen in the firmware"
        total = sum(e.size for e in entries)
    if args.dry_run:
        w = max(len(e.device) for e in entries)
        for e in entries:
            log("%-*s %8d" % (w, e.device, e.size))
        log("%-*s %8d" % (w, "total (%d files, %s)" % (len(entries), kind), total))
        return 0
    dev = probe(args.port, modules(board_dir, cfg))
    if args.frozen and not dev.frozen:
        raise FlashError("--frozen: %s has no acomm frozen in its firmware (acomm there: %s)"
                         % (args.port, "none" if dev.acomm_file == "-" else dev.acomm_file), 2)
    if dev.frozen:
        import acomm

        log("%s has acomm %s frozen in its firmware (%s): copying only main.py and config.py"
            % (args.port, dev.version, dev.acomm_file))
        if dev.missing:
            raise FlashError("the firmware on %s lacks modules board %s needs: %s; build a firmware with its "
                             "manifest (ports/micropython/manifests/), or one without acomm frozen"
                             % (args.port, args.board, " ".join(dev.missing)), 2)
        if dev.version != acomm.__version__:
            msg = "the frozen acomm on %s is version %s, this host's is %s" % (args.port, dev.version,
                                                                             acomm.__version__)
            if not args.force:
                raise FlashError(msg + "; rebuild the firmware, or --force to flash the board's files anyway", 2)
            log("warning: " + msg + " (--force)")
        entries = [e for e in entries if not e.device.startswith("/lib/")]
        kind = "main.py and config.py"
    log("flashing board %s (%s) to %s" % (args.board, kind, args.port))
    n, b = flash(args.port, entries, log, dev)
    if not args.reset:
        log("flashed %d files, %d bytes to %s; reset the board to start it" % (n, b, args.port))
        return 0
    log("flashed %d files, %d bytes to %s" % (n, b, args.port))
    reset(args.port)
    log("reset %s: main.py starts the board" % args.port)
    return 0


def reset(device):
    """Hard-resets the board (mpremote's `reset`: machine.reset() sent without
    waiting for an answer, since the USB link goes down with the board)."""
    _mpremote(device, ["reset"], "resetting %s" % device)
