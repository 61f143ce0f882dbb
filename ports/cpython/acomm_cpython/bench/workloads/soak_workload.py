# `acomm bench soak`: the fault injection soak. The demo
# network (docs/demo.md: buoy, diver and AUV on SeaTrac beacons, their
# places, the channel's loss curve) runs 24 simulated hours of transport
# packets, each node with a Transport on a store file in a temporary
# directory, while faults come at random (acomm_sim.soakfaults.FaultPlan):
#
#   modem_reboot   the beacon restarts and forgets what was in flight
#   unplug         the serial cable is out for 10 s..5 min: reads raise
#                  OSError or return nothing, what the modem sends is lost
#   noise          a noise burst of 10 s..10 min, everywhere or at one node
#   power_loss     the node loses power (its beacon too): its Node, links,
#                  driver and Transport are dropped and rebuilt from its
#                  store file, as a board's boot would
#   store_fill     a burst of low-priority packets until the store refuses
#                  one; the AUV's store is small (3 KiB) all the time
#   clock_jump     the node's port clock jumps up to a day either way (ticks run on),
#                  and its GPS gives one bad fix, 1 h..1 day off either way
#                  (the node's wall clock, acomm.wallclock, takes neither:
#                  a good fix from its GPS comes every 10 min)
#   outage         the node goes out of acoustic range for 30..90 min: what
#                  is on its way to it waits in the senders' and relays'
#                  stores and comes an hour late
#   restart_pair   the two ends of a transfer or of a command waiting for
#                  its acknowledgement both lose power in the middle of it
#                  (any node when nothing is under way)
#
# Every node has the network key (strict mode, its counters in a file that
# a power loss leaves behind, as a board's flash would), and every 3 min one
# node sends another an acknowledged teleop command on the link, with 10 min
# to live: the link resends it, sealed, for as long as it takes.
#
# Every node learns its routes (routing on, docs/routing.md): route requests,
# replies and errors go through the same faults as the packets.
#
# Then the traffic stops and the run goes on until every packet has a final
# status and no relay holds one in custody (at most until the longest
# lifespan and clock jump have passed).
# Figures (acomm_sim.ledger says how packets are counted):
#   packets_accepted       send() took it (queued)
#   packets_lost           accepted, not delivered, not reported expired or
#                          failed, at its origin or at the relay that had it
#                          in custody (target 0)
#   packets_expired_at_relay, packets_failed_at_relay: of those reported, the
#                          ones only their relay could report (EV_RELAY_STATUS)
#   duplicates_delivered   deliveries to an application beyond the first (0)
#                          (also as soak_packets_delivered_twice)
#   soak_commands_executed_twice  commands handed to the receiving
#                          application more than once, counted per extra copy (0)
#   soak_commands_lost     reported delivered and never handed over (0)
#   soak_commands_modem_acked_host_unplugged  the same while the receiver's
#                          cable was out: its SeaTrac acknowledged by itself
#   peak_memory_bytes      tracemalloc's peak over the whole run: the whole
#                          process's Python allocations, the three nodes,
#                          the emulators, the World and this harness
#   task_deaths            exceptions that escaped a node's step (0)
# and the faults that happened, per kind. The schedule in the demo's TDMA
# cycle has longer slots for the AUV and the buoy (7 s): the demo's 3 s
# AUV slot holds only one-way telemetry, not 30-byte fragments and SACKs.
import os
import shutil
import tempfile
import time
import tracemalloc

from acomm.apps.policy import commands
from acomm.catalog import teleop
from acomm.errors import AcommError
from acomm.events import DELIVERED, EV_PACKET, EV_PACKET_STATUS, EV_RECEIVED, EV_RELAY_STATUS, EV_STATUS, is_final
from acomm.frame.auth import Auth
from acomm.wallclock import WallClock as NodeClock
from acomm.drivers.mac import MacDriver, Tdma
from acomm.node import Node
from acomm.prng import Prng
from acomm.transport.store import Store
from acomm.transport import Transport
from acomm_sim.channel import Channel
from acomm_sim.ledger import Ledger
from acomm_sim.soakfaults import Cable, FaultPlan, WallClock, exp_gap
from acomm_sim.world import MODEMS, World

from ...demo.places import ADDR, AUV, BUOY, DIVER, LOSS_CURVE, START

PER_RUNTIME = ()
NAMES = (BUOY, DIVER, AUV)
GUARD_MS = 300
SLOTS = ((BUOY, 7000, GUARD_MS), (DIVER, 10000, GUARD_MS), (AUV, 7000, GUARD_MS))
TX_MS = 3000  # a full SeaTrac frame: 500 ms + 80 ms a byte for 30 bytes
LINK_OPTS = {"advert_period_ms": 60000, "queue_capacity": 64, "max_retries": 100}
STORE_BYTES = {BUOY: 32768, DIVER: 16384, AUV: 3072}
SMALL_STORE = AUV
LIFESPANS = (300, 900, 1800, 3600)
# faults per simulated hour (the 24 h run); the test's short soak multiplies them
RATES = {"modem_reboot": 2, "unplug": 2, "noise": 2, "power_loss": 1, "store_fill": 0.5, "clock_jump": 1,
         "outage": 0.25, "restart_pair": 1}
PACKETS_PER_HOUR = 12  # per node
FAR = (5000.0, 0.0, 6.0)  # out of every other node's range
KEY = bytes(range(101, 133))  # the soak's network key (32 bytes)
EPOCH_2020 = 1577836800  # the port's (Unix) seconds at 2020-01-01, where the clock's fixes count from
GOOD_FIX_MS = 600000  # every node's GPS gives a good fix this often
COMMAND_PERIOD_MS = 180000
COMMAND_LIFESPAN_S = 600


def _param(kind):
    if kind == "unplug":
        return lambda r: (r.range(10, 300) * 1000, r.chance(0.5))  # (ms, raises)
    if kind == "noise":
        return lambda r: (r.range(10, 600) * 1000, r.below(4))  # (ms, receiver index; 3: everywhere)
    if kind == "clock_jump":
        return lambda r: (r.range(-86400, 86400), r.range(3600, 86400) * (1 if r.chance(0.5) else -1))
    if kind == "outage":
        return lambda r: r.range(1800, 5400) * 1000
    return lambda r: 0


def payload(seq, n):
    # 4 bytes of seq, then bytes that seq and n fix (half of them text, so
    # that some packets compress)
    body = Prng(seq * 7919 + n).bytes(n - 4)
    if seq % 2:
        body = (b"depth 12.5 m, heading 270, air 150 bar; " * 8)[: n - 4]
    return seq.to_bytes(4, "big") + body


class Soak:
    def __init__(self, seed=1, hours=24.0, rate_scale=1.0, traffic_scale=1.0, tmpdir=None, routing=True):
        self.seed = seed
        self.routing = {"seed": seed} if routing else None
        self.duration_ms = int(hours * 3600000)
        self.dir = tmpdir or tempfile.mkdtemp(prefix="acomm-soak-")
        self._own_dir = tmpdir is None
        self.channel = Channel(seed=seed, loss_curve=LOSS_CURVE)
        # 20 ms steps (the World's default is 10): half the steps for 24 h;
        # the SeaTrac lines and slots are hundreds of ms, so nothing is missed
        self.w = w = World(seed=seed, channel=self.channel, step_ms=20, max_quiet_ms=200)
        self.ledger = Ledger()
        self.deaths = {}  # exception type -> count
        self.walls = {}
        self.cables = {}
        self.ends = {}
        self.sn = {}
        self.rebuilt = 0
        self._counted = {"relayed": 0, "route_requests": 0}  # the counters of transports a power loss dropped
        for name in NAMES:
            ends = w.modem_ends("seatrac", ADDR[name], {"part": 843 if name == DIVER else 795,
                                                      "seed": seed * 10 + ADDR[name]}, START[name])
            self.ends[name] = ends
            self.cables[name] = Cable(ends[1])
            self.walls[name] = WallClock(w.clock, base=1767225600)  # the port's clock, from 2026-01-01
            node = self._build(name)
            self.sn[name] = w.adopt(name, node, [ends], step=self._stepper(name))
        rates = dict((k, (v * rate_scale, _param(k))) for k, v in RATES.items())
        self.faults = FaultPlan(seed * 31 + 7, w.now(), self.duration_ms, rates, NAMES, self._fault)
        self.rng = Prng(seed * 101 + 3)
        self.traffic_period_ms = int(3600000 / (PACKETS_PER_HOUR * traffic_scale * len(NAMES)))
        self._traffic_until = w.now() + self.duration_ms
        self.stores_full = 0
        # thrust payload -> [sender, receiver, request id, final status or None, times handed over,
        # the receiver's cable was out at the final status]
        self.commands = {}
        self.cmd_rids = {}  # (sender, request id) -> the entry above
        self.cmd_seq = 0
        self._next_command = w.now() + COMMAND_PERIOD_MS // 2
        self._next_fix = w.now()
        self.bad_fixes = [0, 0, 0, 0]  # offered, taken; the same to a clock with no fix since its boot

    # -- the nodes -----------------------------------------------------------
    def _build(self, name):
        # a node as its boot makes it: new objects, the store from its file
        w = self.w
        # the node's wall clock on the port's, its last good time in a file beside the store
        wc = NodeClock(self.walls[name], w.clock, os.path.join(self.dir, name + ".clock"), epoch_s=EPOCH_2020)
        node = Node(name, ADDR[name], w.clock, listener=self._listener(name), wallclock=wc)
        for other in NAMES:
            node.names.add(other, ADDR[other])
        driver = MODEMS["seatrac"][0](ADDR[name], {})
        node.add_link("acoustic", MacDriver(driver, Tdma(SLOTS, name, 0, TX_MS)), self.cables[name], **LINK_OPTS)
        # sync=False: flushed to the OS at every put, which is what survives
        # here (the process lives on; a power cut of the host is the crash
        # tests' business), and 24 h of fsyncs would cost minutes
        store = Store(os.path.join(self.dir, name + ".store"), capacity_bytes=STORE_BYTES[name], max_record=256,
                      sync=False)
        # learned routes (docs/routing.md): the nodes find their ways themselves, and a rebuilt
        # node starts with an empty route table, as a board's boot would
        Transport.of(node, store=store, wall=wc.wall, routing=self.routing)
        # the key, its counters reloaded from their file as at a boot
        node.set_auth(Auth(KEY, path=os.path.join(self.dir, name + ".counters"), wall=wc.wall),
                      commands(), strict=True)
        return node

    def _stepper(self, name):
        def step(now):
            try:
                self.sn[name].node.step(now)
            except Exception as e:  # a task died: count it, the soak goes on
                k = type(e).__name__
                self.deaths[k] = self.deaths.get(k, 0) + 1
        return step

    def _listener(self, name):
        me = ADDR[name]
        led = self.ledger

        def on_event(ev):
            code = ev[0]
            if code == EV_PACKET_STATUS:
                led.status(me, ev[1], ev[2])
            elif code == EV_RELAY_STATUS:
                led.relay_status(ADDR.get(ev[1], -1), ev[2], ev[3])
            elif code == EV_RECEIVED:
                c = self.commands.get(bytes(ev[4]))
                if c is not None and c[1] == name:
                    c[4] += 1
            elif code == EV_STATUS and is_final(ev[3]):
                c = self.cmd_rids.pop((name, ev[2]), None)
                if c is not None:
                    c[3] = ev[3]
                    # a SeaTrac acknowledges by itself (docs/wire-format.md): with its cable out
                    # the receiver's modem says delivered and its host never sees the command
                    c[5] = self.cables[c[1]].out
            elif code == EV_PACKET:
                data = ev[3]
                if ev[2] != name or len(data) < 4:
                    led.delivered(-1, False)
                    return
                seq = int.from_bytes(data[:4], "big")
                led.delivered(seq, data == payload(seq, len(data)))
        return on_event

    def _power_loss(self, name, now):
        sn = self.sn[name]
        for k in [k for k in self.cmd_rids if k[0] == name]:
            # the link's queue is in RAM: a command not yet final dies with it, unreported
            self.cmd_rids.pop(k)[3] = "sender restarted"
        old = sn.node.transport
        self._counted["relayed"] += old.stats["relayed"]
        if old.router.routing is not None:
            self._counted["route_requests"] += old.router.routing.finder.stats["requests"]
        old.store.close()  # what was flushed stays in the file; the rest is gone
        sn.host_end.read()  # and so is what waited in the UART
        self.ends[name][0].reboot(now)  # the beacon is on the same supply
        node = self._build(name)
        sn.node = node
        sn.driver = node.links["acoustic"].driver
        sn.wake = None
        self.rebuilt += 1

    # -- faults --------------------------------------------------------------
    def _fault(self, now, kind, name, param):
        if kind == "modem_reboot":
            self.ends[name][0].reboot(now)
        elif kind == "unplug":
            ms, raises = param
            self.cables[name].unplug(raises)
            self.faults.later(now + ms, "plug", name, None)
        elif kind == "plug":
            self.cables[name].plug()
        elif kind == "noise":
            ms, who = param
            self.channel.noise_burst(now, ms, receiver=None if who >= len(NAMES) else ADDR[NAMES[who]])
        elif kind == "power_loss":
            self._power_loss(name, now)
        elif kind == "restart_pair":
            a, b = self._under_way(name)
            self._power_loss(a, now)
            if b is not None:
                self._power_loss(b, now)
        elif kind == "outage":
            self.channel.set_position(ADDR[name], FAR[0], FAR[1], FAR[2])
            self.faults.later(now + param, "back", name, None)
        elif kind == "back":
            p = START[name]
            self.channel.set_position(ADDR[name], p[0], p[1], p[2])
        elif kind == "clock_jump":
            self.walls[name].jump(param[0])
            wc = self.sn[name].node.wallclock
            fresh = wc.source == "none"  # no fix since its boot: the first is taken as it comes
            self.bad_fixes[2 if fresh else 0] += 1
            if wc.fix(now, "gps", self._true_s(now) + param[1], 0, 1000):
                self.bad_fixes[3 if fresh else 1] += 1
        elif kind == "store_fill":
            self._fill(name, now)

    def _true_s(self, now):
        # the true time in seconds from 2020-01-01 (every port clock starts right)
        return self.walls[NAMES[0]].base + now // 1000 - EPOCH_2020

    def _under_way(self, name):
        # (sender, receiver) of a command waiting for its acknowledgement or
        # of a transfer on the air, else (name, None)
        for c in self.cmd_rids.values():
            return c[0], c[1]
        for n in NAMES:
            for p in self.sn[n].node.transport._out:
                if p.out is not None and p.hop is not None:
                    for other in NAMES:
                        if ADDR[other] == p.hop:
                            return n, other
        return name, None

    def _command(self, now):
        # an acknowledged thrust command, distinct from every other one
        i = self.cmd_seq
        self.cmd_seq += 1
        v = ((i % 41 - 20) / 20, (i // 41 % 41 - 20) / 20, 0, 0, 0, 0)
        data = teleop.CATALOG.pack([(teleop.THRUST, teleop.thrust_values(v, i % teleop.SEQ_MOD))])
        src = NAMES[self.rng.below(len(NAMES))]
        dst = self._other(src)
        rid = self.sn[src].node.send("acoustic", dst, data, COMMAND_LIFESPAN_S, 2, ack=True, now=now)
        c = self.commands.setdefault(data, [src, dst, rid, None, 0, False])
        self.cmd_rids[(src, rid)] = c

    def _fill(self, name, now):
        # low-priority 200-byte packets until the store refuses one; always
        # on the node with the small store: filling a 32 KiB store takes
        # hours of SeaTrac airtime to drain, and this is about what a full
        # store does, not about a backlog
        name = SMALL_STORE
        for _ in range(200):
            if self._send(name, self._other(name), 200, 3600, 14, now) is None:
                self.stores_full += 1
                return

    # -- traffic -------------------------------------------------------------
    def _other(self, name):
        others = [n for n in NAMES if n != name]
        return others[self.rng.below(len(others))]

    def _send(self, src, dst, size, life, prio, now):
        # -> pid, or None when the store refused the packet
        led = self.ledger
        seq = led.begin(ADDR[src])
        t = self.sn[src].node.transport
        try:
            pid = t.send(now, dst, payload(seq, size), life, prio)
        except AcommError:
            led.not_sent(seq)
            raise
        led.sent(seq, ADDR[src], pid)
        return None if led.final[seq] else pid

    def poll(self, now):
        # the traffic task: one packet now, the next after an exponential gap
        if now >= self._traffic_until:
            return now + 3600000
        if now >= self._next_fix:
            # every node's GPS: the true time
            self._next_fix = now + GOOD_FIX_MS
            for name in NAMES:
                self.sn[name].node.wallclock.fix(now, "gps", self._true_s(now), now % 1000, 1000)
        if now >= self._next_command:
            self._next_command = now + COMMAND_PERIOD_MS
            self._command(now)
        r = self.rng
        src = NAMES[r.below(len(NAMES))]
        big = r.chance(0.3)
        size = r.range(40, 240) if big else r.range(6, 26)
        self._send(src, self._other(src), size, LIFESPANS[r.below(len(LIFESPANS))], r.range(1, 14), now)
        return now + 1000 + int(exp_gap(r) * self.traffic_period_ms)

    # -- running -------------------------------------------------------------
    def run(self, drain_ms=3 * 3600000, chunk_ms=600000):
        w = self.w
        w.add_task(self)
        w.add_task(self.faults)
        end = w.now() + self.duration_ms
        while w.now() < end:
            w.run(min(chunk_ms, end - w.now()))
        for c in self.cables.values():
            c.plug()  # a cable the plan would plug back after the end
        led = self.ledger

        def busy():
            # a packet without its final status at its origin, or one a relay holds in custody
            # (its origin was told `transmitted`: the relay delivers it or lets it expire)
            return led.pending() or self.cmd_rids or any(p.relayed for sn in self.sn.values()
                                                         for p in sn.node.transport._out)

        limit = w.now() + drain_ms
        while busy() and w.now() < limit:
            w.run(min(chunk_ms, limit - w.now()), until=lambda: not busy())
        return self

    def figures(self):
        c = self.ledger.counts
        f = {
            "packets_accepted": c["accepted"],
            "packets_refused_store_full": c["refused_store_full"],
            "packets_lost": self.ledger.lost(),
            "duplicates_delivered": c["duplicates"],
            "packets_delivered": c["delivered"],
            "packets_expired": c["status_expired"],
            "packets_failed": c["status_failed"],
            "packets_expired_at_relay": c["expired_at_relay"],
            "packets_failed_at_relay": c["failed_at_relay"],
            "relay_statuses_unknown": c["relay_unknown"],
            "packets_corrupt": c["corrupt"],
            "extra_final_statuses": c["extra_final"],
            "packets_pending_at_end": self.ledger.pending(),
            # the live transports' counters, and those of the ones power losses dropped
            "packets_relayed": self._counted["relayed"] + sum(sn.node.transport.stats["relayed"]
                                                              for sn in self.sn.values()),
            "route_requests": self._counted["route_requests"] + sum(
                sn.node.transport.router.routing.finder.stats["requests"]
                for sn in self.sn.values() if sn.node.transport.router.routing is not None),
            "task_deaths": sum(self.deaths.values()),
            "packets_delivered_twice": c["duplicates"],
            "clock_bad_fixes_offered": self.bad_fixes[0],
            "clock_bad_fixes_taken": self.bad_fixes[1],
            "clock_bad_first_fixes_offered": self.bad_fixes[2],
            "clock_bad_first_fixes_taken": self.bad_fixes[3],
            "commands_sent": len(self.commands),
            "commands_executed_twice": sum(x[4] - 1 for x in self.commands.values() if x[4] > 1),
            "commands_lost": sum(1 for x in self.commands.values() if x[3] == DELIVERED and not x[4] and not x[5]),
            "commands_modem_acked_host_unplugged": sum(1 for x in self.commands.values()
                                                       if x[3] == DELIVERED and not x[4] and x[5]),
            "commands_not_delivered": sum(1 for x in self.commands.values() if x[3] not in (DELIVERED, None)),
            "commands_without_status": sum(1 for x in self.commands.values() if x[3] is None),
            "stores_filled": self.stores_full,
            "simulated_s": self.w.now() // 1000,
        }
        for k, v in self.faults.counts.items():
            if k not in ("plug", "back"):
                f["faults_" + k] = v
        return f

    def close(self):
        for sn in self.sn.values():
            sn.node.transport.store.close()
        if self._own_dir:
            shutil.rmtree(self.dir, ignore_errors=True)


def soak(seed=1, hours=24.0, rate_scale=1.0, traffic_scale=1.0, trace=True, routing=True):
    # -> (figures, wall seconds)
    if trace:
        tracemalloc.start()
    t0 = time.perf_counter()
    s = Soak(seed, hours, rate_scale, traffic_scale, routing=routing)
    try:
        s.run()
        f = s.figures()
    finally:
        s.close()
    wall = time.perf_counter() - t0
    if trace:
        f["peak_memory_bytes"] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return f, wall, s


UNITS = {"peak_memory_bytes": "B", "simulated_s": "s", "packets_delivered_twice": "packets"}


def run(emit, quick=False):
    # quick: 6 simulated minutes with every fault kind at 10 times its rate
    f, wall, s = soak(hours=0.1, rate_scale=10) if quick else soak()
    for k in ("packets_accepted", "packets_lost", "duplicates_delivered", "peak_memory_bytes"):
        emit(k, f.pop(k), UNITS.get(k, "packets" if k.startswith("packets") or k.startswith("dup") else "count"))
    for k in sorted(f):
        emit("soak_" + k if not k.startswith("packets") or k == "packets_delivered_twice" else k, f[k],
             UNITS.get(k, "commands" if k.startswith("commands") else "count"))
    emit("soak_wall_s", wall, "s")
