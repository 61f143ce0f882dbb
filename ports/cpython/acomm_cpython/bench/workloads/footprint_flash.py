# The buoy's writes to flash (`acomm bench footprint --only flash_writes`):
# its node as the board builds it (acomm_mp.assemble, boards/buoy_pico's
# config, a store file and, with a network key, the counter file beside
# it) runs an hour in the simulated ocean with the demo's traffic, and
# every file write it makes is counted.
#
#   flash_writes_per_hour_buoy   commits to flash in the hour: each flush or
#       close of a file with new bytes (on littlefs one commit programs the
#       file's blocks and its metadata): store records (packets, tombstones,
#       the packet id limit, the delivered pairs), compactions, counter-file
#       saves, and any other file the node keeps (a wall clock's file)
#   flash_bytes_per_hour_buoy    the bytes those writes carried
#
# The demo's traffic (acomm_cpython.demo.mission, its 20-minute mission
# three times an hour): the telemetry as the demo sends it, one link frame
# each (the diver's status to the buoy every 20 s, acknowledged; the AUV's
# state every 20 s and the buoy's fix of the diver every 30 s, one-way),
# and what goes through the store-and-forward transport: the diver's log
# (16 lines queued at once, for the buoy) and one alarm for shore, which
# the buoy keeps in its store until Iridium takes it. The network is
# sealed (a key on every node): the counter file's saves are counted.
# (Every telemetry message through the transport instead is more than
# one shared SeaTrac channel carries without a schedule: most expire.)
import builtins
import io
import os
import shutil
import sys
import tempfile

HOUR_MS = 3600000
MISSION_MS = 1200000
KEY = "00112233445566778899aabbccddeeff"


class Counter:
    """Counts what opened files write: commits (a flush or close after new bytes) and bytes, per file name."""

    def __init__(self):
        self.commits = {}
        self.bytes = {}

    def open(self, path, mode="r", *args, **kw):
        f = io.open(path, mode, *args, **kw)
        if not any(c in mode for c in "wa+"):
            return f
        return _Counted(self, os.path.basename(str(path)), f)

    def add(self, name, commits, n):
        self.commits[name] = self.commits.get(name, 0) + commits
        self.bytes[name] = self.bytes.get(name, 0) + n


class _Counted:
    def __init__(self, counter, name, f):
        self._c, self._name, self._f = counter, name, f
        self._dirty = 0

    def write(self, b):
        n = self._f.write(b)
        self._dirty += len(b)
        return n

    def flush(self):
        self._f.flush()
        self._commit()

    def close(self):
        self._f.close()
        self._commit()

    def _commit(self):
        if self._dirty:
            self._c.add(self._name, 1, self._dirty)
            self._dirty = 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __getattr__(self, name):
        return getattr(self._f, name)


def _kind(name):
    # which of the buoy's files a name is
    if name.endswith(".store"):
        return "store"
    if name.endswith(".store.tmp"):
        return "compaction"
    if ".auth" in name:
        return "auth"
    return "other"


def buoy_hour(hours=1, seed=1, say=None):
    """The buoy's writes to flash over `hours` simulated hours of the demo's traffic -> dict of figures."""
    from acomm.catalog import caddy
    from acomm.prng import Prng
    from acomm.transport.store import Store
    from acomm_cpython.board import boardfiles
    from acomm_mp.assemble import build
    from acomm_mp.boardconfig import check
    from acomm_sim.boardsim import add_peers, board_ends
    from acomm_sim.world import World

    tmp = tempfile.mkdtemp(prefix="acomm-flash-")
    counter = Counter()
    real_open = builtins.open
    try:
        raw = dict(boardfiles.load_config(boardfiles.board_path("buoy_pico")))
        raw["auth"] = {"key": KEY}
        cfg = check(raw)
        cfg["storage"]["path"] = os.path.join(tmp, "acomm.store")
        w = World(seed=seed)
        wall = lambda: 1000000 + w.now() // 1000  # noqa: E731
        ends = []

        def open_uart(lk):
            ends.append(board_ends(w, lk, (0.0, 0.0, 0.0) if not ends else None))
            return ends[-1][1]

        def open_store(st):
            return Store(st["path"], capacity_bytes=st["capacity"], max_record=st["max_record"], opener=counter.open)

        # every other file the node writes (its counter file, a clock file)
        # goes through the counter too
        builtins.open = counter.open
        events = []
        board = build(cfg, open_uart, w.clock, wall, open_store, listener=events.append, say=lambda s: None)
        w.adopt(cfg["name"], board.node, ends, step=board.tick, events=events)
        others = add_peers(w, cfg, {"diver": "seatrac", "auv": "seatrac", "shore": "iridium"}, {"diver": "shore"},
                           wall)
        from acomm.apps.policy import commands
        from acomm.frame.auth import Auth

        for name in others:
            others[name][0].node.set_auth(Auth(bytes.fromhex(KEY)), commands())
        diver = others["diver"][1]
        diver_node, auv_node = others["diver"][0].node, others["auv"][0].node
        sent = {"status": 0, "auv_state": 0, "position": 0, "log": 0, "alarm": 0}

        def status(now):
            return caddy.CATALOG.pack([(caddy.DIVER_STATUS, {"heart_rate": 80 + now // 20000 % 25,
                                                             "breathing_rate": 14, "body_temp": 36.5})])

        def auv_state(now):
            return caddy.CATALOG.pack([(caddy.BUDDY_PING, {"depth": 6.0, "course": now // 1000 % 360, "speed": 0.2})])

        def position(now):
            return caddy.CATALOG.pack([(caddy.DIVER_POSITION, {"diver": {"x": 45.0, "y": 30.0}})])

        class Traffic:
            # the demo's streams and the mission's one-off packets, every 20-minute mission
            def __init__(self):
                self.next = {"status": 0, "auv_state": 5000, "position": 10000}

            def poll(self, now):
                t = now - t0
                for k, period, src, dst, make, prio, life, ack in (
                        ("status", 20000, diver_node, "buoy", status, 4, 300, True),
                        ("auv_state", 20000, auv_node, "buoy", auv_state, 5, 60, False),
                        ("position", 30000, board.node, "diver", position, 5, 60, False)):
                    if t >= self.next[k]:
                        src.send("acoustic", dst, make(now), life, prio, ack, now=now)
                        sent[k] += 1
                        self.next[k] += period
                m = t % MISSION_MS
                if m >= 300000 and sent["log"] < 16 * (t // MISSION_MS + 1):
                    for i in range(16):  # the dive log, queued at once, low priority
                        diver.send(now, "buoy", caddy.CATALOG.pack([(caddy.CHAT, {"text": "log line %d" % i})]),
                                   1500, 12)
                    sent["log"] += 16
                if m >= 390000 and sent["alarm"] < t // MISSION_MS + 1:
                    diver.send(now, "shore", Prng(t).bytes(20), 600, 1)  # the alarm, for shore via the buoy
                    sent["alarm"] += 1
                return now + 1000

        w.run(15000)
        t0 = w.now()
        w.add_task(Traffic())
        # the counts start with the traffic: the board's first files (a new
        # store, a new counter file) are written once, not every hour
        counter.commits.clear()
        counter.bytes.clear()
        w.run(int(hours * HOUR_MS))
        delivered = board.transport.stats.get("received", 0)
        relayed = board.transport.stats.get("relayed", 0)
        frames = board.node.links["acoustic"].stats.get("rx_frames", 0)
    finally:
        builtins.open = real_open
        shutil.rmtree(tmp, ignore_errors=True)
    by = {}
    for name in counter.commits:
        k = _kind(name)
        c, b = by.get(k, (0, 0))
        by[k] = (c + counter.commits[name], b + counter.bytes[name])
    out = {"writes": sum(counter.commits.values()) / hours, "bytes": sum(counter.bytes.values()) / hours,
           "by_kind": dict((k, (by[k][0] / hours, by[k][1] / hours)) for k in by), "sent": sent,
           "received": delivered, "relayed": relayed, "rx_frames": frames / hours}
    if say:
        say("flash writes per hour: %s; traffic %s; the buoy's transport received %d packets, relayed %d; "
            "acoustic frames heard per hour %d"
            % (", ".join("%s %d (%d bytes)" % (k, v[0], v[1]) for k, v in sorted(out["by_kind"].items())), sent,
               delivered, relayed, out["rx_frames"]))
    return out


def figures(emit, hours=1):
    """flash_writes_per_hour_buoy and flash_bytes_per_hour_buoy through emit(name, value, unit)."""
    r = buoy_hour(hours, say=lambda m: print("footprint: " + m, file=sys.stderr, flush=True))
    emit("flash_writes_per_hour_buoy", int(round(r["writes"])), "writes/hour")
    emit("flash_bytes_per_hour_buoy", int(round(r["bytes"])), "bytes/hour")
    return r
