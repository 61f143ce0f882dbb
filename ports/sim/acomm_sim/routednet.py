# Multi-hop networks for the routing figures (issue 36): the real stack on
# seed 004's BPSK packet modem (400 bit/s, raw frames: node ids of 256 and
# more take 3 bytes on the water, and 255 is no node's), an Aloha MAC, a loss curve that cuts hearing off at RANGE_M, and
# end-to-end flows of numbered packets. One run is a scenario, a way to
# route, a seed and a length; it returns what it measured.
#
# Scenarios (nodes RANGE_M apart at most to hear each other):
#   chain      6 nodes in a line, 5 hops end to end; flows both ways
#   grid       8 x 8 (or `nodes` rounded down to a square), each node hearing
#              only its 4 neighbours; random pairs (a pair per 8 nodes)
#   random     64 nodes at random in a square of constant density (about 5
#              neighbours each), plus two AUVs crossing it; random pairs
#              within the largest part that can reach itself, and the AUVs
#              to and from a node of it
#   partition  two ends joined by a relay (2 hops) and a longer way round
#              (3 hops); the relay dies at minute 10 and comes back at 20
#   large      `nodes` (default 256) at random, at the random scenario's
#              density: the simulator's cost as networks grow (1,024 too)
#
# Ways to route:
#   learned    acomm.transport's route discovery (routing=True)
#   flooding   every packet flooded to every node (Transport.flood): the
#              destination takes it, everyone else only passes it on
#   oracle     static routes from the simulator's geometry (shortest path
#              in hops over the links in range, a tree towards each flow's
#              destination), updated every 10 s, so they follow the AUVs and
#              the dying relay at once
#
# Measured: pdr (delivered / sent, each packet counted once), latency
# quantiles (send to first delivery), overhead (every byte of route control
# on the air, modem framing included, over the payload bytes delivered;
# for flooding every flooded copy is route control, since the data rides
# in it), the same over the second half of the traffic (steady: the route
# control on the air then, over the payload of the packets sent then), and
# for the partition the recoveries: from the relay's death to the first
# transfer frame (fragment or SACK) sent by the way round, and from its
# return to the first one it sends again.

import math

from acomm.drivers.mac import Aloha
from acomm.errors import DecodeError
from acomm.events import EV_PACKET
from acomm.frame import CONTROL, SEGMENT, decode_raw
from acomm.prng import Prng
from acomm.transport import Transport

from .channel import Channel, Track
from .packetmodem import PROFILES
from .world import World

RANGE_M = 200.0
SPACING_M = 150.0
# certain within RANGE_M but for 2 %, never beyond it
LOSS_CURVE = ((0.0, 0.02), (RANGE_M, 0.05), (RANGE_M + 1.0, 1.0))
DENSITY_M2 = math.pi * RANGE_M * RANGE_M / 5  # area per node: about 5 neighbours each
PAYLOAD = 16  # a flood carries 18 bytes at most: every way to route gets the same packets
MODEM = "bpsk"
ADVERT_MS = 60000
SCENARIOS = ("chain", "grid", "random", "partition", "large")
MODES = ("learned", "flooding", "oracle")
MAX_NODES = 4096


def node_id(i):
    """The node id of node index i: i + 1, skipping 255 (the broadcast address, no node's)."""
    return i + 1 if i < 254 else i + 2
_EPOCH_MS = 1000  # the simulator's clock starts here


class _Flows:
    # numbered packets from src to dst every period_ms (first at offset), carrying (flow, seq)
    def __init__(self, net, flows, period_ms, rng):
        self.net = net
        self.flows = flows
        self.period_ms = period_ms
        self.rng = rng
        self.next = [net.w.now() + rng.below(period_ms) for _ in flows]
        self.seq = [0] * len(flows)

    def poll(self, now):
        net = self.net
        for i, (src, dst) in enumerate(self.flows):
            if now - self.next[i] >= 0:
                self.next[i] = now + self.period_ms - self.period_ms // 4 + self.rng.below(self.period_ms // 2)
                if net.stop_at is not None and now >= net.stop_at:
                    continue
                self.seq[i] += 1
                net.send(now, i, self.seq[i], src, dst)
        return min(self.next)


class _Oracle:
    # static routes from geometry, every 10 s
    def __init__(self, net):
        self.net = net

    def poll(self, now):
        self.net.oracle_routes(now)
        return now + 10000


class _Script:
    # (time, callable) pairs, in order
    def __init__(self, items):
        self.items = sorted(items, key=lambda x: x[0])

    def poll(self, now):
        while self.items and now >= self.items[0][0]:
            self.items.pop(0)[1](now)
        return self.items[0][0] if self.items else now + 3600000


class RoutedNet:
    def __init__(self, scenario, mode, seed=1, nodes=None, flow_period_ms=None, fast=True):
        if scenario not in SCENARIOS:
            raise ValueError("scenario is one of %s, not %r" % (", ".join(SCENARIOS), scenario))
        if mode not in MODES:
            raise ValueError("mode is one of %s, not %r" % (", ".join(MODES), mode))
        self.scenario = scenario
        self.mode = mode
        self.seed = seed
        self.rng = Prng(seed * 7919 + SCENARIOS.index(scenario))
        self.ch = Channel(seed=seed, loss_curve=LOSS_CURVE)
        self.w = World(seed=seed, channel=self.ch, fast=fast)  # fast=False: every step taken (tests)
        self.w.names_capacity = max(255, (nodes or 0) + 8)
        self.names = []
        self.tracks = {}
        self.sent = {}  # (flow, seq) -> (time, dst name)
        self.got = {}  # (flow, seq) -> latency ms
        self.delivered_bytes = 0
        self.control_bytes = 0
        self.control_frames = 0
        self.air_bytes = 0
        self.stop_at = None
        self.steady_at = None  # the second half of the traffic: routes known, steady state
        self.steady_control = self.steady_delivered = 0
        self.marks = []  # (time, what): the partition's death and return
        self.relay_frames = []  # (time, address): transfer frames sent by the partition's relays
        bitrate, self.modem_overhead, _ = PROFILES[MODEM]
        self.airtime = ((PAYLOAD + 20 + self.modem_overhead) * 8000 + bitrate - 1) // bitrate
        places, flows, period = getattr(self, "_" + scenario)(nodes)
        for i, pos in enumerate(places):
            self._add(i, pos)
        self._tap()
        self.flows = _Flows(self, flows, flow_period_ms or period, self.rng)
        if mode == "oracle":
            self.oracle_routes(self.w.now())
            self.w.add_task(_Oracle(self))

    # -- topologies ------------------------------------------------------------------------
    def _chain(self, _):
        places = [(SPACING_M * i, 0.0) for i in range(6)]
        return places, [(0, 5), (5, 0)], 60000

    def _grid(self, n):
        side = int(math.sqrt(n or 64))
        n = side * side
        places = [(SPACING_M * (i % side), SPACING_M * (i // side)) for i in range(n)]
        return places, self._pairs(list(range(n)), max(2, n // 8)), 120000

    def _scatter(self, n):
        # uniform in a square of constant density; -> (places, side, the largest set of nodes that
        # can all reach each other: the flows stay within it, since a pair cut off by the geometry
        # would measure the geometry, not the routing)
        side = math.sqrt(n * DENSITY_M2)
        places = [(self.rng.below(int(side)) * 1.0, self.rng.below(int(side)) * 1.0) for _ in range(n)]
        return places, side, _largest_component(places)

    def _random(self, _):
        places, side, reach = self._scatter(64)
        # two AUVs (ids 65, 66) crossing the square at 1.5 m/s, corner to corner and back
        self.tracks[64] = Track((0.0, 0.0, 10.0), t0=_EPOCH_MS, waypoints=[(side, side, 10.0), (0.0, 0.0, 10.0)] * 3,
                                speed=1.5)
        self.tracks[65] = Track((side, 0.0, 10.0), t0=_EPOCH_MS, waypoints=[(0.0, side, 10.0), (side, 0.0, 10.0)] * 3,
                                speed=1.5)
        places += [(0.0, 0.0), (side, 0.0)]
        hub = reach[0]  # the AUVs talk to a node of the connected part
        # a packet per flow every 4 minutes: at 2 minutes even the oracle lost half of them to collisions
        return places, self._pairs(reach, 8) + [(64, hub), (hub, 65)], 240000

    def _large(self, n):
        n = n or 256
        if not 16 <= n <= MAX_NODES:
            raise ValueError("large: 16..%d nodes" % MAX_NODES)
        places, _, reach = self._scatter(n)
        return places, self._pairs(reach, 16), 360000

    def _partition(self, _):
        # n1 (0,0) - n2 relay (150,0) - n3 (300,0); round: n1 - n4 (100,150) - n5 (200,150) - n3
        places = [(0.0, 0.0), (150.0, 0.0), (300.0, 0.0), (100.0, 150.0), (200.0, 150.0)]

        def die(now):
            self.ch.set_position(2, 50000.0, 50000.0, 10.0)
            self.marks.append((now, "death"))

        def back(now):
            self.ch.set_position(2, 150.0, 0.0, 10.0)
            self.marks.append((now, "return"))

        self.w.add_task(_Script([(self.w.now() + 600000, die), (self.w.now() + 1200000, back)]))
        return places, [(0, 2), (2, 0)], 60000

    def _pairs(self, nodes, k):
        # k distinct (source, destination) pairs among the node indices given
        out = []
        while len(out) < k:
            a, b = nodes[self.rng.below(len(nodes))], nodes[self.rng.below(len(nodes))]
            if a != b and (a, b) not in out:
                out.append((a, b))
        return out

    # -- the nodes ---------------------------------------------------------------------------
    def _add(self, i, pos):
        name = "n%d" % (i + 1)
        self.names.append(name)
        mac = Aloha(4 * self.airtime, seed=self.seed * 1000 + i)
        sn = self.w.add(name, node_id(i), MODEM, position=(pos[0], pos[1], 10.0), mac=mac,
                        link_opts={"advert_period_ms": ADVERT_MS, "queue_capacity": 16},
                        listener=self._listener(name))
        if i in self.tracks:
            self.ch.set_track(node_id(i), self.tracks[i])
        # the route finder's and flooder's random draws differ per seed, not only per node id
        routing = None if self.mode == "oracle" else {"seed": self.seed * 1000 + i}
        sn.t = Transport.of(sn.node, wall=lambda: self.w.now() // 1000, routing=routing)
        sn.wall_unit_ms = 1000  # that wall clock, for the World (idlesteps)

    def _listener(self, me):
        def on_event(ev):
            if ev[0] != EV_PACKET:
                return
            data = ev[3]
            if self.mode == "flooding":
                if len(data) < 8 or (data[6] << 8 | data[7]) != int(me[1:]):
                    return  # a flood for someone else
            if len(data) < 6:
                return
            key = (data[0] << 8 | data[1], int.from_bytes(data[2:6], "big"))
            s = self.sent.get(key)
            if s is None or key in self.got or s[1] != me:
                return
            self.got[key] = self.w.now() - s[0]
            self.delivered_bytes += PAYLOAD
            if self.steady_at is not None and s[0] >= self.steady_at:
                self.steady_delivered += PAYLOAD

        return on_event

    def _tap(self):
        # every frame on the water, classified from its raw header
        ch = self.ch
        inner = ch.transmit
        oh = self.modem_overhead

        def transmit(now, src, packet, airtime_ms):
            n = len(packet) + oh
            self.air_bytes += n
            try:
                t = decode_raw(bytes(packet)).ftype
            except DecodeError:
                t = None
            if t == CONTROL:
                self.control_bytes += n
                self.control_frames += 1
                if self.steady_at is not None and now >= self.steady_at:
                    self.steady_control += n
            elif t == SEGMENT and self.scenario == "partition" and src in (2, 4, 5):
                self.relay_frames.append((now, src))
            return inner(now, src, packet, airtime_ms)

        ch.transmit = transmit

    def node(self, i):
        return self.w.nodes[self.names[i]]

    def send(self, now, flow, seq, src, dst):
        """One numbered packet of a flow, src and dst node indices."""
        body = bytes([flow >> 8, flow & 0xFF]) + seq.to_bytes(4, "big") + (dst + 1).to_bytes(2, "big")
        body += bytes(PAYLOAD - len(body))
        t = self.node(src).t
        self.sent[(flow, seq)] = (now, self.names[dst])
        if self.mode == "flooding":
            t.flood(now, body)
        else:
            t.send(now, self.names[dst], body, 600, 10)

    # -- the oracle -----------------------------------------------------------------------------
    def oracle_routes(self, now):
        n = len(self.names)
        pos = [self.ch.position(node_id(i)) for i in range(n)]
        near = _in_range(pos)
        for i in range(n):
            self.node(i).t.router.routes.clear()
        for d in sorted(set(f[1] for f in self.flows.flows)):
            # breadth first from each flow's destination: a node's parent in that tree is its
            # first hop on a shortest path there (hearing is symmetric); only the flows'
            # destinations are ever sent to, and n trees of 1,024 nodes every 10 s cost minutes
            parent = {d: d}
            frontier = [d]
            while frontier:
                nxt = []
                for a in frontier:
                    for b in near[a]:
                        if b not in parent:
                            parent[b] = a
                            nxt.append(b)
                frontier = nxt
            name = self.names[d]
            for i, hop in parent.items():
                if hop != d:
                    self.node(i).t.router.routes[name] = self.names[hop]

    # -- running and measuring -------------------------------------------------------------------
    def run(self, minutes, drain_minutes=5):
        """Traffic for `minutes`, then `drain_minutes` more with none sent; -> measures()."""
        w = self.w
        w.run(2 * ADVERT_MS + 5000)  # neighbours known before the first packet
        self.control_bytes = self.control_frames = self.air_bytes = 0
        start = w.now()
        w.add_task(self.flows)
        self.stop_at = start + int(minutes * 60000)
        self.steady_at = start + int(minutes * 30000)
        w.run(int(minutes * 60000) + int(drain_minutes * 60000))
        return self.measures()

    def measures(self):
        lat = sorted(self.got.values())
        out = {
            "sent": len(self.sent),
            "delivered": len(lat),
            "pdr": len(lat) / len(self.sent) if self.sent else 0.0,
            "latency_p50_ms": _quantile(lat, 0.5),
            "latency_p95_ms": _quantile(lat, 0.95),
            "overhead_ratio": self.control_bytes / self.delivered_bytes if self.delivered_bytes else None,
            "steady_control_bytes": self.steady_control,
            "steady_delivered_bytes": self.steady_delivered,
            "overhead_ratio_steady": self.steady_control / self.steady_delivered if self.steady_delivered else None,
            "control_frames": self.control_frames,
            "air_bytes": self.air_bytes,
        }
        if self.scenario == "partition":
            out.update(self._recoveries())
        return out

    def _recoveries(self):
        # death: to the first transfer frame (a fragment or a SACK) from the way round (n4, n5);
        # return: to the first from the relay (n2) again
        marks = dict((what, t) for t, what in self.marks)
        out = {"recovery_death_s": None, "recovery_return_s": None}
        for what, who, key in (("death", (4, 5), "recovery_death_s"), ("return", (2,), "recovery_return_s")):
            t0 = marks.get(what)
            if t0 is None:
                continue
            end = marks.get("return") if what == "death" else None
            hits = [t for t, a in self.relay_frames if a in who and t > t0 and (end is None or t < end)]
            if hits:
                out[key] = (hits[0] - t0) / 1000
        return out


def _largest_component(places):
    # the node indices of the largest set that can all reach each other within RANGE_M, sorted
    left = set(range(len(places)))
    best = []
    while left:
        start = min(left)
        seen = {start}
        todo = [start]
        while todo:
            a = todo.pop()
            for b in list(left):
                if b not in seen and math.hypot(places[a][0] - places[b][0], places[a][1] - places[b][1]) <= RANGE_M:
                    seen.add(b)
                    todo.append(b)
        left -= seen
        if len(seen) > len(best):
            best = sorted(seen)
    return best


def _in_range(pos):
    # -> for each node index, the indices within RANGE_M: cells of RANGE_M on a side, so that
    # each node is measured against its own cell and the 8 around it, not against every node
    cells = {}
    for i, p in enumerate(pos):
        cells.setdefault((int(p[0] // RANGE_M), int(p[1] // RANGE_M)), []).append(i)
    near = []
    for i, p in enumerate(pos):
        cx, cy = int(p[0] // RANGE_M), int(p[1] // RANGE_M)
        near.append([j for dx in (-1, 0, 1) for dy in (-1, 0, 1) for j in cells.get((cx + dx, cy + dy), ())
                     if j != i and _dist(p, pos[j]) <= RANGE_M])
    return near


def _dist(a, b):
    return math.sqrt((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2)


def _quantile(xs, q):
    if not xs:
        return None
    k = int(q * len(xs) + 0.5) - 1
    return xs[min(len(xs) - 1, max(0, k))]
