# Route discovery without I/O (acomm.transport.routefinder) on small
# networks of finders joined by a fake medium: a chain found hop by hop,
# every request rebroadcast at most once per node, a broken hop's error and
# the new route around it, a search given up, bad bytes dropped, and no
# loops in any table after random breaks and searches.

from acomm.compat import TICKS_MAX, ticks_add, ticks_diff
from acomm.prng import Prng
from acomm.transport.routefinder import BROADCAST, RouteFinder
from acomm.transport.routetable import RouteTable
from checks import adjacency

T0 = TICKS_MAX - 20000
HOP = 16  # every hop ETX 1


class Net:
    def __init__(self, edges, jitter_ms=500, seed=1):
        self.adj = adjacency(edges)
        self.now = T0
        self.f = {}
        for n in self.adj:
            self.f[n] = RouteFinder(n, RouteTable(), lambda now, link, hop: HOP, jitter_ms=jitter_ms,
                                    search_ms=20000, tries=2, seed=seed + n)
        self.pending = []  # (when, sender, link, to, payload)
        self.events = []

    def cut(self, a, b):
        self.adj[a].discard(b)
        self.adj[b].discard(a)

    def run(self, ms, step=100):
        end = ticks_add(self.now, ms)
        while ticks_diff(end, self.now) > 0:
            for n, f in self.f.items():
                f.poll(self.now)
                for when, link, to, payload in f.take():
                    self.pending.append((when, n, link, to, payload))
                self.events += [(n,) + e for e in f.take_events()]
            due = [p for p in self.pending if ticks_diff(self.now, p[0]) >= 0]
            self.pending = [p for p in self.pending if ticks_diff(self.now, p[0]) < 0]
            for _, n, link, to, payload in due:
                for m in sorted(self.adj[n]):
                    if to == BROADCAST or to == m:
                        self.f[m].heard(self.now, link, n, payload)
            self.now = ticks_add(self.now, step)

    def path(self, a, b):
        # follow next hops from a to b; None when a route is missing; AssertionError on a loop
        seen = [a]
        while a != b:
            r = self.f[a].table.lookup(self.now, b)
            if r is None:
                return None
            a = r[0]
            assert a not in seen, "loop %r" % (seen + [a],)
            seen.append(a)
        return seen


def test_a_chain_is_found_hop_by_hop_and_each_node_rebroadcasts_once():
    net = Net([(1, 2), (2, 3), (3, 4), (4, 5), (5, 6)])
    net.f[1].find(net.now, 6)
    net.run(15000)
    assert (1, "found", 6, 5 * HOP) in net.events
    assert net.path(1, 6) == [1, 2, 3, 4, 5, 6]
    assert net.path(6, 1) == [6, 5, 4, 3, 2, 1]  # the reverse routes, learned on the way
    assert [net.f[n].stats["rebroadcasts"] for n in (2, 3, 4, 5)] == [1, 1, 1, 1]
    assert net.f[6].stats["replies"] == 1 and net.f[6].stats["rebroadcasts"] == 0
    net.f[1].find(net.now, 6)  # known now: found at once, nothing sent
    assert net.f[1].take() == [] and net.f[1].take_events() == [("found", 6, 5 * HOP)]


def test_a_grid_floods_each_request_once_per_node_and_finds_a_loop_free_route():
    edges = []
    for r in range(4):
        for c in range(4):
            n = r * 4 + c + 1
            if c < 3:
                edges.append((n, n + 1))
            if r < 3:
                edges.append((n, n + 4))
    net = Net(edges)
    net.f[1].find(net.now, 16)
    net.run(20000)
    assert any(e[:3] == (1, "found", 16) for e in net.events)
    p = net.path(1, 16)
    assert p is not None and p[0] == 1 and p[-1] == 16 and len(p) >= 7
    assert all(net.f[n].stats["rebroadcasts"] <= 1 for n in net.f)


def test_a_broken_hop_sends_an_error_and_a_new_search_goes_around():
    # two ways from 1 to 4: 1-2-3-4 and 1-5-6-7-4
    net = Net([(1, 2), (2, 3), (3, 4), (1, 5), (5, 6), (6, 7), (7, 4)], jitter_ms=0)
    net.f[1].find(net.now, 4)
    net.run(10000)
    assert net.path(1, 4) == [1, 2, 3, 4]
    net.cut(3, 4)
    net.f[3].hop_failed(net.now, 4, "acoustic")
    net.run(5000)
    assert net.path(1, 4) is None  # the error reached the source
    assert net.f[2].stats["errors"] == 1 and net.f[1].stats["errors"] == 1
    net.f[1].find(net.now, 4)
    net.run(10000)
    assert net.path(1, 4) == [1, 5, 6, 7, 4]


def test_an_unreachable_destination_is_given_up_after_its_tries():
    net = Net([(1, 2), (3, 4)])
    net.f[1].find(net.now, 4)
    net.run(45000)
    assert (1, "unreachable", 4) in net.events
    assert net.f[1].stats["requests"] == 2


def test_bad_bytes_are_counted_and_dropped():
    f = RouteFinder(1, RouteTable(), lambda now, link, hop: None)
    for junk in (b"", b"\x00", b"\xff" * 10, b"\x40" + bytes(3)):
        f.heard(T0, "acoustic", 2, junk)
    assert f.stats["bad"] == 4 and f.take() == [] and f.table.routes == {}


def test_no_loops_after_random_breaks_and_searches():
    rng = Prng(36)
    found = routed = 0
    for trial in range(4):
        edges = set()
        for n in range(2, 13):
            edges.add((rng.range(1, n - 1), n))  # a tree over 1..12, so everything is connected
        for _ in range(8):
            a, b = rng.range(1, 12), rng.range(1, 12)
            if a != b:
                edges.add((min(a, b), max(a, b)))
        net = Net(sorted(edges), seed=trial)
        for _ in range(6):
            a, b = rng.range(1, 12), rng.range(1, 12)
            if a != b:
                net.f[a].find(net.now, b)
            net.run(8000)
            x = rng.range(1, 12)
            if net.adj[x]:
                y = sorted(net.adj[x])[rng.below(len(net.adj[x]))]
                net.cut(x, y)
                net.f[x].hop_failed(net.now, y, "acoustic")
                net.f[y].hop_failed(net.now, x, "acoustic")
            net.run(4000)
            for s in net.f:
                for d in net.f:
                    if s != d and net.path(s, d) is not None:  # raises on a loop
                        routed += 1
        found += sum(1 for e in net.events if e[1] == "found")
    assert found >= 12 and routed >= 200  # the searches did find routes, and many stood


def test_a_cheaper_later_copy_of_a_request_moves_the_reverse_route():
    from acomm.transport import routewire as W

    t = RouteTable()
    f = RouteFinder(5, t, lambda now, link, hop: 16, jitter_ms=0)
    f.heard(0, "acoustic", 2, W.encode_request(1, 9, 3, 7, W.UNKNOWN_SEQ, 4, 900))  # first, a detour
    assert t.lookup(0, 9)[:2] == (2, "acoustic") and f.stats["rebroadcasts"] == 1
    f.heard(10, "acoustic", 3, W.encode_request(1, 9, 3, 7, W.UNKNOWN_SEQ, 1, 100))  # a copy, cheaper
    assert t.lookup(10, 9) == (3, "acoustic", 116)  # the reply will go back the cheap way
    assert f.stats["rebroadcasts"] == 1 and f.stats["duplicates"] == 1  # still passed on once
    f.heard(20, "acoustic", 4, W.encode_request(1, 9, 3, 7, W.UNKNOWN_SEQ, 2, 500))  # dearer: no change
    assert t.lookup(20, 9)[0] == 3


def test_a_flood_payload_is_not_taken_for_route_control():
    from acomm.transport import routewire as W

    t = RouteTable()
    f = RouteFinder(5, t, lambda now, link, hop: 16)
    f.heard(0, "acoustic", 2, W.encode_flood(9, 1, 0, b"all up"))
    assert f.stats["bad"] == 1 and not f.take() and not t.routes


def test_a_ring_search_asks_the_near_nodes_first_then_the_whole_network():
    # a chain 1-2-...-8; ring 2: the first request stops 3 nodes out (it starts at MAX_HOPS - 2)
    net = Net([(i, i + 1) for i in range(1, 8)])
    for f in net.f.values():
        f.ring = 2
    f1 = net.f[1]
    f1.find(net.now, 8)
    net.run(3500)  # the ring's wait is 2/10 of search_ms (20 s): 4 s
    assert f1.stats["requests"] == 1 and not [e for e in f1.take_events() if e[0] == "found"]
    reached = [n for n in net.f if n != 1 and net.f[n].stats["rebroadcasts"]]
    assert reached == [2, 3], reached  # 2 and 3 passed it on; 4 heard it at MAX_HOPS and stopped
    assert net.f[4].table.lookup(net.now, 1) is not None and net.f[5].table.lookup(net.now, 1) is None
    net.run(20000)  # the next try floods the chain
    assert f1.table.lookup(net.now, 8) is not None and f1.stats["requests"] == 2
