# The buoy's minute, the one run the footprint bench (footprint_workload)
# measures, and the host side of the lockstep protocol that drives it.
#
# The buoy's node (boards/buoy_pico: node, links, SeaTrac and Iridium
# drivers, transport, a store on a file) runs alone on the board
# (tools/lockstep/acomm_lockstep.py), stepped in lock with a simulated ocean
# in this process with the buoy's peers and traffic of acomm_sim.boardsim:
# a diver's SeaTrac beacon, whose packet for shore the buoy relays, and
# shore on Iridium. A simulated minute each run. Here: the ocean, the
# minute over a pipe to the board (minute), the buoy's store as it is after
# relaying with Iridium down (seed_store), the board's closing figures
# (result) and whether the minute passed (judge). Starting a board is
# footprint_runners' job.
import json
import os
import time

from acomm_cpython.board import boardfiles
from acomm_sim.boardsim import add_peers, fast_options, send_traffic
from acomm_sim.world import World

BOARD = "buoy_pico"
SIM_MS = 60000
# the buoy's peers (acomm_sim.boardsim): the diver's packet for shore is
# relayed by the buoy
PEERS = {"diver": "seatrac", "shore": "iridium"}
VIA = {"diver": "shore"}

# The routing minute (footprint_heap_min_frozen_cortex_m_routing_bytes): the
# buoy's config with "routing": True (ROUTING_CONFIG, appended to its
# config.py), and a diver that routes too and also sends a packet to the
# AUV, a peer of the buoy's that is not in the water: the diver floods
# route requests for it (retried every DIVER_ROUTING search_ms), which the
# buoy hears, rebroadcasts once each after its jitter and learns the route
# back to the diver from; the diver's searches for the buoy itself, before
# it heard the buoy's advert, are answered with the buoy's route replies.
# So the buoy's route finder (its seen cache, held rebroadcasts, control
# requests), route table and neighbour table are live, not just imported.
# A whole discovery through the buoy (an AUV only the buoy hears, the
# reply coming back through it) did not finish within a simulated minute
# beside the diver's other traffic on one SeaTrac channel, so the minute
# has the requests heard and the routes offered; the board's closing line
# counts them (judge: at least one request heard, one route held, one
# control frame sent).
ROUTING_CONFIG = '\nCONFIG["routing"] = True\n'
DIVER_ROUTING = {"search_ms": 10000}
ROUTING_TARGET = "auv"


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


class ProcPipe:
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


class SerialPipe:
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


def _ocean(cfg, seed, routing=False):
    # the simulated ocean around the buoy: its modems (driven by the board
    # process) and its peers; -> (world, the buoy's modem ends, peers).
    # routing: the peers route too (the routing minute)
    w = World(seed=seed)
    ends = [w.add_loose(w.modem_ends(lk["modem"], lk["address"], fast_options(lk["modem"])[1],
                                     (0.0, 0.0, 0.0) if i == 0 else None))
            for i, lk in enumerate(cfg["links"])]
    wall = lambda: 1000000 + w.now() // 1000  # noqa: E731
    others = add_peers(w, cfg, PEERS, VIA, wall, routing=DIVER_ROUTING if routing else None)
    return w, ends, others


def minute(pipe, cfg, seed=1, ms=SIM_MS, deadline=None, iridium_down=False, routing=False):
    # the buoy's minute: 15 s of quiet, then each peer's traffic (the
    # diver's packet for shore, relayed by the buoy). iridium_down: the
    # buoy's satellite modem has no signal, so nothing leaves its store.
    # routing: the routing minute (ROUTING_CONFIG's notes)
    w, ends, others = _ocean(cfg, seed, routing)
    if iridium_down:
        _satellite(cfg, ends).set_bars(0)
        # the diver sent the seeded packets (seed_store) before: its packet
        # ids go on from there, as its own store keeps them, or the buoy
        # would take its new packet for one it already holds
        others["diver"][1].packets.pid = LOAD_PACKETS
    w.add_task(_Lockstep(pipe, [e[1] for e in ends], deadline))
    w.run(15000)
    send_traffic(w, cfg, others, VIA)
    if routing:
        others["diver"][1].send(w.now(), ROUTING_TARGET, b"from diver, routed", 3600, 6)
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


def seed_store(path, n=LOAD_PACKETS, size=LOAD_BYTES, seed=1, wall0=1000000):
    """Writes the buoy's store file as its transport leaves it after relaying n packets of `size` bytes for shore while Iridium is down.

    The buoy's own node (acomm_mp.assemble.build, its config, a Store on a
    file) runs here in the simulated ocean, and the diver sends the packets
    through it: the file holds exactly what the buoy's transport stored
    (random bodies: nothing compresses them). Then the board starts from
    that file, as a buoy does after a reset with packets waiting. wall0:
    the wall clock (s) at the start, as the board that reads it counts.
    """
    from acomm.prng import Prng
    from acomm.transport.store import Store
    from acomm_mp.assemble import build
    from acomm_sim.boardsim import board_ends

    cfg = boardfiles.load_config(boardfiles.board_path(BOARD))
    # a fresh store: one left at `path` holds the packets and the delivered
    # pairs of a seeding before, and the diver's ids, the same again, are
    # then duplicates the buoy no longer relays
    if os.path.exists(path):
        os.remove(path)
    w = World(seed=seed)
    wall = lambda: wall0 + w.now() // 1000  # noqa: E731
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


def result(out_text):
    # the harness's closing JSON line (and, with info, its mem_info text)
    r = None
    for line in out_text.splitlines():
        line = line.strip()
        if line.startswith("{") and '"peak"' in line:
            r = json.loads(line)
    return r


def judge(r, routing=False):
    # -> None when the minute counts as a pass, else why it failed. A
    # MemoryError anywhere is a failure, never a pass. routing: the routing
    # minute, whose route control must have reached the buoy's router
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
    if routing and (r.get("route_requests", 0) < 1 or r.get("routes", 0) < 1 or r.get("control_sent", 0) < 1):
        return "routing not exercised (requests heard %s, routes %s, control frames sent %s)" % (
            r.get("route_requests"), r.get("routes"), r.get("control_sent"))
    return None
