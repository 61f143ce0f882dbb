# The boards the footprint bench (footprint_workload) runs the buoy's
# minute (footprint_minute) on, one run each -> the board's figures:
#
#   run_qemu   the Cortex-M3 board (MicroPython's qemu MPS2-AN385 port under
#              qemu-system-arm): the harness is started through the raw REPL
#              and the protocol runs over the UART (a pty)
#   run_i386   the i386 unix build, the protocol over stdin/stdout
#   run_once   the 64-bit pip unix port, over stdin/stdout (estimates only)
#
# and what they run the buoy from: its files as on its flash (stage_flash),
# a ROMFS image (build_romfs), a littlefs image (littlefs_image), the lot
# built once per bench run (Staged). The 32-bit builds come from
# tools/firmware.py build -> build/firmware/.
import os
import shutil
import subprocess
import tempfile
import time

from acomm_cpython.board import boardfiles
from acomm_cpython.bench.workloads.footprint_minute import (BOARD, LOAD_PACKETS, ROUTING_CONFIG, SIM_MS, ProcPipe, SerialPipe,
                                                      judge, minute, result)


def stage_flash(tmp):
    # the board's files laid out as on its flash: tmp/lib/acomm/..., x64 .mpy
    board = boardfiles.board_path(BOARD)
    for e in boardfiles.plan(board, arch="x64", stage_dir=os.path.join(tmp, "stage")):
        dst = os.path.join(tmp, "flash", e.device.lstrip("/"))
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        shutil.copyfile(e.host, dst)
    return os.path.join(tmp, "flash")


def micropython_unix64():
    from acomm_cpython.bench.runtime import find_micropython

    return find_micropython()


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


def run_once(flash_dir, heap, seed=1, rom=None):
    # the 64-bit pip unix port (`-X heapsize=Nw`): -> the board's JSON
    # figures, or None when it failed at this heap. rom: a ROMFS image of
    # flash_dir/lib to import the modules from
    cfg = boardfiles.load_config(flash_dir)
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-store-")
    env = dict(os.environ)
    env["MICROPYPATH"] = ".frozen" if rom else ".frozen:" + os.path.join(flash_dir, "lib")
    args = [micropython_unix64(), "-X", _heap_flag(heap, rom and os.path.getsize(rom)), boardfiles.repo_root() + "/tools/lockstep/acomm_lockstep.py",
            os.path.join(flash_dir, "config.py"), os.path.join(tmp, "store")]
    proc = subprocess.Popen(args + ([rom] if rom else []),
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    r = _run_proc(proc, cfg, seed, tmp)
    return r if judge(r) is None else None


def _run_proc(proc, cfg, seed, tmp, limit_s=None):
    # a board process speaking the lockstep protocol on its stdin/stdout
    pipe = ProcPipe(proc)
    try:
        if pipe.read(4) != b"LOCK":
            raise EOFError("no LOCK")
        minute(pipe, cfg, seed, SIM_MS, time.monotonic() + (limit_s or RUN_LIMIT_S))
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
    return result(out.decode(errors="replace"))


# --- 32-bit builds (tools/firmware.py): the Cortex-M3 board under QEMU and
# the i386 unix port -----------------------------------------------------------

RUN_LIMIT_S = 120  # a run that takes longer is killed: it hung (a qemu minute takes 4-10 s)


def _config_text(routing=False):
    # routing: the buoy's config with routing on (footprint_minute.ROUTING_CONFIG)
    with open(os.path.join(boardfiles.board_path(BOARD), "config.py")) as f:
        return f.read() + (ROUTING_CONFIG if routing else "")


def put_files(t, store=None, routing=False):
    # the buoy's config (and store) onto a board at its raw REPL. mpremote's
    # fs_writefile leaves its file object in __main__ as f (and f.write as
    # w): closed, but holding its littlefs cache (1 KiB on a Pico, whose
    # flash is written 256 bytes at a time; 128 bytes on the qemu board)
    # for the whole minute. It is not the buoy's, so it goes
    t.fs_writefile("/config.py", _config_text(routing).encode())
    if store is not None:
        t.fs_writefile("/store", store)
    t.exec("del f, w")


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


def run_qemu(elf, heap, rom=None, flash=None, seed=1, info=False, limit_s=RUN_LIMIT_S, store=None, routing=False):
    """One buoy minute on the qemu Cortex-M3 board with a GC heap of `heap` bytes.

    The harness (frozen as acomm_lockstep in elf) is
    started through the raw REPL and speaks the lockstep protocol on the
    UART. rom: a ROMFS image (mounted at /rom); flash: a littlefs image of
    the board's filesystem (the .mpy files under /lib); store: the contents
    of the buoy's store file (seed_store) to start from, with Iridium down
    for the minute; routing: the routing minute (the buoy's config with
    routing on, footprint_minute.ROUTING_CONFIG). -> dict: the board's
    figures, "fail" (None on a pass, else why) and "text" (what the board
    printed besides the protocol: mem_info with info, tracebacks).
    """
    from acomm_cpython.board.qemuboard import QemuBoard

    cfg = boardfiles.load_config(boardfiles.board_path(BOARD))
    if routing:
        cfg["routing"] = True
    deadline = time.monotonic() + limit_s
    text = b""
    r = None
    board = QemuBoard(elf, heap=heap, rom=rom, flash=flash)
    try:
        t = board.transport()
        t.serial.timeout = 15
        t.enter_raw_repl(soft_reset=False)
        put_files(t, store, routing)
        t.exec_raw_no_follow("import acomm_lockstep\nacomm_lockstep.main('/config.py', '/store', None, %r)" % bool(info))
        pre = _read_until(t.serial, (b"LOCK", b"\x04>"), 60)
        if not pre.endswith(b"LOCK"):
            text = pre
            raise EOFError("the harness did not start")
        text = pre[:-4]
        minute(SerialPipe(t.serial), cfg, seed, SIM_MS, deadline, iridium_down=store is not None, routing=routing)
        t.serial.write(b"Q")
        tail = _read_until(t.serial, (b"\x04>",), 30)
        text += tail
        r = result(tail.split(b"\x04")[0].decode(errors="replace"))
        if b"\x04" in tail and tail.split(b"\x04")[1].strip():
            r = None  # a traceback after the figures
    except Exception as e:  # noqa: BLE001 - any failure of the board is a failed run
        text += ("\n[host] %s: %s" % (type(e).__name__, e)).encode()
    finally:
        board.stop()
    out = dict(r or {})
    out["heap"] = heap
    why = judge(r, routing)
    if why and b"MemoryError" in text:
        why = "MemoryError (%s)" % why
    if why is None and store is not None and r["stored"] != LOAD_PACKETS + 1:
        why = "the store holds %d packets (%d expected)" % (r["stored"], LOAD_PACKETS + 1)
    out["fail"] = why
    out["text"] = text.decode(errors="replace")
    return out


def micropython_i386():
    from acomm_cpython.board.qemuboard import firmware

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
    # the harness is frozen in the build; in the other modes acomm comes
    # from the files, which stand before .frozen on the path
    if mode == "frozen":
        env["MICROPYPATH"] = ".frozen"
        code = "import acomm_lockstep\n" + call
    elif mode == "mpy":
        env["MICROPYPATH"] = lib + ":.frozen"
        code = "import acomm_lockstep\n" + call
    else:
        env["MICROPYPATH"] = tmp + ":.frozen"
        n = os.path.getsize(rom)
        # 16-byte blocks, 3 bits of tables each; 64 bytes of alignment
        size = heap + n + n * 3 // 128 + 64
        code = ("import os, sys, vfs\nr = bytearray(os.stat(%r)[6])\nf = open(%r, 'rb')\nf.readinto(r)\nf.close()\n"
                "vfs.mount(vfs.VfsRom(r), '/rom')\nsys.path.insert(0, '/rom')\nimport acomm_lockstep\n"
                "acomm_lockstep._ROM = r\nr = f = None\n%s" % (rom, rom, call))
    proc = subprocess.Popen([micropython_i386(), "-X", "heapsize=%d" % size, "-c", code], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=tmp)
    # cwd: the unix port looks in the current folder too, which must not
    # hold acomm's sources (they would be compiled on the heap)
    pipe = ProcPipe(proc)
    text = ""
    r = None
    try:
        pre = b""
        while not pre.endswith(b"LOCK"):
            pre += pipe.read(1)
        text = pre[:-4].decode(errors="replace")
        minute(pipe, cfg, seed, SIM_MS, time.monotonic() + limit_s)
        pipe.write(b"Q")
        out, err = proc.communicate(timeout=30)
        text += out.decode(errors="replace") + err.decode(errors="replace")
        if proc.returncode == 0:
            r = result(out.decode(errors="replace"))
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
    why = judge(r)
    if why and "MemoryError" in text:
        why = "MemoryError (%s)" % why
    res["fail"] = why
    res["text"] = text
    return res


class Staged:
    # the board's modules compiled for an arch, a ROMFS image of them and a
    # littlefs image with them under /lib: built once per bench run. The
    # harness is not among them: the boards run it frozen (cm3-harness, the
    # i386 build's .frozen), so the figures count the buoy's files alone.
    def __init__(self, tmp, arch):
        self.tmp, self.arch = tmp, arch
        self.lib = os.path.join(tmp, arch, "lib")
        for e in boardfiles.plan(boardfiles.board_path(BOARD), arch=arch, stage_dir=os.path.join(tmp, arch)):
            pass
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
    r = subprocess.run([micropython_i386(), "-X", "heapsize=16M", "-c", code], stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    if r.returncode or not os.path.exists(out):
        raise RuntimeError("littlefs image: %s" % r.stdout.decode(errors="replace")[-400:])
    return out
