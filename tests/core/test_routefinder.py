# Route discovery without I/O (the searches of acomm.transport.routing) on
# small networks of nodes joined by a fake medium: a chain found hop by hop,
# every request rebroadcast at most once per node, a broken hop repaired
# where it broke (or brought back when its hop is heard again), the error
# of a repair that failed and the way round it,
# retries backing off, a search given up, bad bytes dropped, no loops in
# any table after random breaks and searches, and a shortcut offered by a
# node that overhears a packet going the long way round.

from acomm.compat import TICKS_MAX, ticks_add, ticks_diff
from acomm.prng import Prng
from acomm.transport import routing as W
from acomm.transport.routing import BROADCAST, Routing, encode_error
from checks import adjacency

T0 = TICKS_MAX - 20000
HOP = 16  # every hop ETX 1


class _Node(Routing):
    # a node's routing with every hop costing HOP
    def hop_cost(self, now, link_name, hop):
        return HOP


class _Names:
    def name_of(self, node_id):
        return str(node_id)


class _Heard:
    # the part of a link's discovery that Routing reads: when each neighbour was last heard
    def __init__(self):
        self.last = {}

    def last_heard(self, node_id):
        return self.last.get(node_id)

    def state(self, node_id):
        return 1 if node_id in self.last else 0  # available once heard (acomm.events)


class _Link:
    # a routing link as Routing sees it: its name and medium, no neighbour table yet, when each
    # neighbour was last heard, and its requests put on the fake medium as (sender, to, payload)
    name = medium = "acoustic"
    neighbours = None

    def __init__(self, sent, node_id):
        self.sent = sent
        self.node_id = node_id
        self.discovery = _Heard()

    def request(self, now, rid, dst, payload, lifespan_s, priority, ack=False, ftype=0):
        self.sent.append((self.node_id, BROADCAST if dst == "*" else int(dst), payload))
        return True


def _node(n, sent=None, jitter_ms=0, seed=1, **opts):
    link = _Link([] if sent is None else sent, n)
    return _Node(n, _Names(), {"acoustic": link}, lambda: 1, jitter_ms=jitter_ms, seed=seed, **opts), link


class Net:
    def __init__(self, edges, jitter_ms=500, seed=1):
        self.adj = adjacency(edges)
        self.now = T0
        self.f = {}
        self.link = {}
        self.sent = []  # (sender, to, payload) on the medium now
        for n in self.adj:
            self.f[n], self.link[n] = _node(n, self.sent, jitter_ms, seed + n, search_ms=20000, tries=2, ring=0, hold_ms=0)

    def cut(self, a, b):
        self.adj[a].discard(b)
        self.adj[b].discard(a)

    def run(self, ms, step=100):
        end = ticks_add(self.now, ms)
        while ticks_diff(end, self.now) > 0:
            for f in self.f.values():
                f.poll(self.now)  # what is due goes on the medium
            due, self.sent[:] = self.sent[:], []
            for n, to, payload in due:
                for m in sorted(self.adj[n]):
                    self.link[m].discovery.last[n] = self.now  # every frame in range is heard
                    if to == BROADCAST or to == m:
                        self.f[m].heard(self.now, self.link[m], n, payload)
            self.now = ticks_add(self.now, step)

    def found(self, a, b):
        # a's search for b is over and a holds a live route to b
        return not self.f[a].searching(b) and self.f[a].lookup(self.now, b) is not None

    def path(self, a, b):
        # follow next hops from a to b; None when a route is missing; AssertionError on a loop
        seen = [a]
        while a != b:
            r = self.f[a].lookup(self.now, b)
            if r is None:
                return None
            a = r[0]
            assert a not in seen, "loop %r" % (seen + [a],)
            seen.append(a)
        return seen


def test_a_chain_is_found_hop_by_hop_and_each_node_rebroadcasts_once():
    net = Net([(1, 2), (2, 3), (3, 4), (4, 5), (5, 6)])
    net.f[1].search(net.now, 6)
    assert net.f[1].searching(6)
    net.run(15000)
    assert net.found(1, 6) and net.f[1].lookup(net.now, 6)[2] == 5 * HOP
    assert net.path(1, 6) == [1, 2, 3, 4, 5, 6]
    assert net.path(6, 1) == [6, 5, 4, 3, 2, 1]  # the reverse routes, learned on the way
    assert [net.f[n].stats["rebroadcasts"] for n in (2, 3, 4, 5)] == [1, 1, 1, 1]
    assert net.f[6].stats["replies"] == 1 and net.f[6].stats["rebroadcasts"] == 0
    net.f[1].search(net.now, 6)  # known now: nothing sent
    net.f[1].poll(net.now)
    assert net.sent == [] and not net.f[1].searching(6) and net.f[1].stats["requests"] == 1


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
    net.f[1].search(net.now, 16)
    net.run(20000)
    assert net.found(1, 16)
    p = net.path(1, 16)
    assert p is not None and p[0] == 1 and p[-1] == 16 and len(p) >= 7
    assert all(net.f[n].stats["rebroadcasts"] <= 1 for n in net.f)


def test_a_broken_hop_is_repaired_where_it_broke_and_sends_no_error():
    # two ways from 1 to 4: 1-2-3-4 and 1-5-6-7-4; custody keeps 3's packets at 3, so 3 searches
    # itself, and the reply that comes back to it teaches the nodes on its way the fresh route
    net = Net([(1, 2), (2, 3), (3, 4), (1, 5), (5, 6), (6, 7), (7, 4)], jitter_ms=0)
    net.f[1].search(net.now, 4)
    net.run(10000)
    assert net.path(1, 4) == [1, 2, 3, 4]
    net.cut(3, 4)
    net.f[3].broken(net.now, 4, "acoustic")
    net.run(5000)
    assert all(f.stats["errors"] == 0 for f in net.f.values())
    assert net.f[3].lookup(net.now, 4) is None and net.f[1].lookup(net.now, 4)[0] == 2  # still sent to 3
    net.f[3].search(net.now, 4)
    net.run(15000)
    assert net.path(3, 4) == [3, 2, 1, 5, 6, 7, 4]
    assert net.path(1, 4) == [1, 5, 6, 7, 4]  # the fresher reply moved 1's route, with no loop
    assert all(f.stats["errors"] == 0 for f in net.f.values())


def test_an_own_hop_heard_again_gets_its_routes_back_and_the_search_stops():
    # 1-2-3-4: 2 calls 3 broken (its answers were lost), 3 is alive: a frame of it is heard (an
    # advert, or its rebroadcast of 2's request), and the next search() call (the waiting
    # packet's next poll) brings the route back as it was, number included: no more tries, no
    # error
    net = Net([(1, 2), (2, 3), (3, 4)], jitter_ms=0)
    net.f[1].search(net.now, 4)
    net.run(10000)
    f = net.f[2]
    before = f.routes[4][:]
    assert f.lookup(net.now, 4)[0] == 3
    f.broken(net.now, 3, "acoustic")
    assert f.lookup(net.now, 4) is None and f.routes[4][3] == (before[3] + 1) % 65535
    f.search(net.now, 4)  # the first try, sent at the next poll
    assert f.searching(4) and f.stats["requests"] == 1
    net.now = ticks_add(net.now, 100)
    f.search(net.now, 4)  # nothing heard of 3 since: still broken
    assert f.searching(4) and f.lookup(net.now, 4) is None
    net.link[2].discovery.last[3] = net.now
    net.now = ticks_add(net.now, 100)
    f.search(net.now, 4)
    assert not f.searching(4) and f.stats["revived"] == 1
    r = f.lookup(net.now, 4)
    assert r is not None and r[0] == 3 and f.routes[4][3] == before[3]
    net.run(60000)
    assert f.stats["requests"] == 1 and all(x.stats["errors"] == 0 for x in net.f.values())
    assert net.path(1, 4) == [1, 2, 3, 4]


def test_a_hop_not_heard_again_or_named_by_an_error_is_not_revived():
    net = Net([(1, 2), (2, 3), (3, 4)], jitter_ms=0)
    net.f[1].search(net.now, 4)
    net.run(10000)
    f = net.f[2]
    f.broken(net.now, 3, "acoustic")
    net.cut(2, 3)  # 3 is gone: nothing from it is heard
    f.search(net.now, 4)
    net.run(5000)
    f.search(net.now, 4)
    assert f.lookup(net.now, 4) is None and f.stats["revived"] == 0
    # 1's route to 4 through 2, turned invalid by 2's error (not 1's own hop): 2 is heard again
    # and again, but only news of 4 brings it back
    g = net.f[1]
    seq = g.routes[4][3]
    g.heard(net.now, net.link[1], 2, encode_error([(4, (seq + 1) % 65535)]))
    assert g.lookup(net.now, 4) is None
    net.link[1].discovery.last[2] = ticks_add(net.now, 10)
    net.now = ticks_add(net.now, 100)
    g.search(net.now, 4)
    assert g.lookup(net.now, 4) is None and g.stats["revived"] == 0


def test_a_repair_that_gives_up_sends_the_error_and_the_source_goes_around():
    # 1-2-3-4 and 1-5-6-7-4; 3 loses 4 and cannot find it (2 is cut off from 1 too)
    net = Net([(1, 2), (2, 3), (3, 4), (1, 5), (5, 6), (6, 7), (7, 4)], jitter_ms=0)
    net.f[1].search(net.now, 4)
    net.run(10000)
    net.cut(3, 4)
    net.cut(2, 1)
    net.f[3].broken(net.now, 4, "acoustic")
    net.f[3].search(net.now, 4)
    net.run(70000)  # two tries, 20 s and then 40 s apart
    assert not net.f[3].searching(4) and net.f[3].lookup(net.now, 4) is None
    assert net.f[3].stats["errors"] == 1 and net.f[2].stats["errors"] == 1  # 2 routed 4 through 3
    assert net.f[2].lookup(net.now, 4) is None
    # 1 was cut from 2 before the error came: it routes by 2 until its own hop fails
    assert net.f[1].lookup(net.now, 4)[0] == 2
    net.f[1].broken(net.now, 2, "acoustic")
    net.f[1].search(net.now, 4)
    net.run(15000)
    assert net.path(1, 4) == [1, 5, 6, 7, 4]


def test_whole_network_tries_back_off_twice_as_long_each_time():
    sent = []
    f, link = _node(1, sent, search_ms=10000, tries=4, ring=0)
    f.search(T0, 4)
    times = [T0]
    now = T0
    while len(times) < 4:
        now = ticks_add(now, 500)
        before = f.stats["requests"]
        f.poll(now)
        if f.stats["requests"] > before:
            times.append(now)
    gaps = [ticks_diff(b, a) for a, b in zip(times, times[1:])]
    assert gaps == [10000, 20000, 40000], gaps
    # with a ring the ring's try is the short one, and the first whole-network try waits search_ms
    f, link = _node(1, sent, search_ms=10000, tries=3, ring=3)
    f.search(T0, 4)
    assert f._searches[4][1] == ticks_add(T0, 3000)
    f.poll(ticks_add(T0, 3000))
    assert f._searches[4][1] == ticks_add(T0, 13000)
    f.poll(ticks_add(T0, 13000))
    assert f._searches[4][1] == ticks_add(T0, 33000)


def test_an_unreachable_destination_is_given_up_after_its_tries():
    net = Net([(1, 2), (3, 4)])
    net.f[1].search(net.now, 4)
    net.run(65000)  # 20 s, then twice that
    assert not net.f[1].searching(4) and net.f[1].lookup(net.now, 4) is None
    assert net.f[1].stats["requests"] == 2


def test_a_search_given_up_is_held_off():
    sent = []
    f, link = _node(1, sent, search_ms=10000, tries=1, hold_ms=30000, ring=0)
    f.search(T0, 4)
    assert f.stats["requests"] == 1
    f.poll(ticks_add(T0, 10000))  # given up
    assert not f.searching(4)
    f.search(ticks_add(T0, 20000), 4)  # held off: nothing asked
    assert f.stats["requests"] == 1
    f.poll(ticks_add(T0, 40000))
    f.search(ticks_add(T0, 40000), 4)  # over: asked again
    assert f.stats["requests"] == 2 and f.searching(4)


def test_bad_bytes_are_counted_and_dropped():
    f, link = _node(1)
    for junk in (b"", b"\x40", b"\xff" * 10, b"\x40" + bytes(3), b"\x80" + bytes(8)):
        assert f.heard(T0, link, 2, junk) == ()
    f.heard(T0, link, 2, b"\x00")  # a flood's kind: the flooder counts it
    f.poll(T0)
    assert f.stats["bad"] == 5 and f.flooder.stats["bad"] == 1 and link.sent == [] and f.routes == {}


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
                net.f[a].search(net.now, b)
            net.run(8000)
            if a != b and net.found(a, b):
                found += 1
            x = rng.range(1, 12)
            if net.adj[x]:
                y = sorted(net.adj[x])[rng.below(len(net.adj[x]))]
                net.cut(x, y)
                net.f[x].broken(net.now, y, "acoustic")
                net.f[y].broken(net.now, x, "acoustic")
            net.run(4000)
            for s in net.f:
                for d in net.f:
                    if s != d and net.path(s, d) is not None:  # raises on a loop
                        routed += 1
    assert found >= 12 and routed >= 200  # the searches did find routes, and many stood


def test_a_cheaper_later_copy_of_a_request_moves_the_reverse_route():
    from acomm.transport import routing as W

    f, link = _node(5)
    f.heard(0, link, 2, W.encode_request(1, 9, 3, 7, W.UNKNOWN_SEQ, 4, 900))  # first, a detour
    assert f.lookup(0, 9)[:2] == (2, "acoustic") and f.stats["rebroadcasts"] == 1
    f.heard(10, link, 3, W.encode_request(1, 9, 3, 7, W.UNKNOWN_SEQ, 1, 100))  # a copy, cheaper
    assert f.lookup(10, 9) == (3, "acoustic", 116)  # the reply will go back the cheap way
    assert f.stats["rebroadcasts"] == 1 and f.stats["duplicates"] == 1  # still passed on once
    f.heard(20, link, 4, W.encode_request(1, 9, 3, 7, W.UNKNOWN_SEQ, 2, 500))  # dearer: no change
    assert f.lookup(20, 9)[0] == 3


def test_a_flood_payload_is_not_taken_for_route_control():
    from acomm.transport.flood import encode_flood

    f, link = _node(5)
    assert f.heard(0, link, 2, encode_flood(9, 1, 0, b"all up")) == [(9, b"all up")]
    assert f.stats["bad"] == 0 and not f.routes and not f._held


def test_a_ring_search_asks_the_near_nodes_first_then_the_whole_network():
    # a chain 1-2-...-8; ring 2: the first request stops 3 nodes out (it starts at MAX_HOPS - 2)
    net = Net([(i, i + 1) for i in range(1, 8)])
    for f in net.f.values():
        f.ring = 2
    f1 = net.f[1]
    f1.search(net.now, 8)
    net.run(3500)  # the ring's wait is 2/10 of search_ms (20 s): 4 s
    assert f1.stats["requests"] == 1 and f1.lookup(net.now, 8) is None
    reached = [n for n in net.f if n != 1 and net.f[n].stats["rebroadcasts"]]
    assert reached == [2, 3], reached  # 2 and 3 passed it on; 4 heard it at MAX_HOPS and stopped
    assert net.f[4].lookup(net.now, 1) is not None and net.f[5].lookup(net.now, 1) is None
    net.run(20000)  # the next try floods the chain
    assert f1.lookup(net.now, 8) is not None and f1.stats["requests"] == 2


def test_a_node_that_overhears_the_long_way_offers_a_shortcut_and_the_origin_takes_it():
    # 1-4-5-3 is the way 1 found while 2 was away; 2 is back, hears 1 and 3 themselves, and
    # overhears 1's packet for 3 going from 4 to 5: 2 hops through it against 3
    net = Net([(1, 4), (4, 5), (5, 3), (1, 2), (2, 3), (2, 4), (2, 5)], jitter_ms=0)
    for n in (1, 3, 4, 5):
        net.cut(2, n)
    net.f[1].search(net.now, 3)
    net.run(10000)
    assert net.path(1, 3) == [1, 4, 5, 3]
    seq = net.f[1].routes[3][3]
    for n in (1, 3, 4, 5):
        net.adj[2].add(n)
        net.adj[n].add(2)
    f, link = net.f[2], net.link[2]
    f.overheard(net.now, link, 1, 4, 1, 3)  # from the origin itself: its first hop, no detour seen
    f.overheard(net.now, link, 5, 3, 1, 3)  # to the destination itself: the last hop
    f.overheard(net.now, link, 4, 5, 1, 3)  # 2 has heard neither 1 nor 3 yet
    assert f.stats["shortcuts"] == 0
    link.discovery.last[1] = link.discovery.last[3] = net.now
    f.overheard(net.now, link, 4, 5, 1, 3)
    f.overheard(net.now, link, 4, 5, 1, 3)  # the next fragment: offered once a lifetime
    assert f.stats["shortcuts"] == 1
    net.run(2000)
    g = net.f[1]
    # (2 sends to 3 straight: a node heard is its own hop, acomm.transport.route)
    assert g.stats["shortened"] == 1 and g.lookup(net.now, 3)[0] == 2
    assert g.routes[3][3] == seq  # the route keeps its own number: the offer's (0) is older
    # a route already as short is not moved, and an older number from further away never wins
    f._cuts.clear()
    f.overheard(net.now, link, 4, 5, 1, 3)
    net.run(2000)
    assert g.stats["shortened"] == 1 and g.lookup(net.now, 3)[0] == 2
    g.heard(net.now, net.link[1], 4, W.encode_reply(3, 0, 1, 2, 0, 60000))
    assert g.stats["shortened"] == 1 and g.lookup(net.now, 3)[0] == 2
    assert all(x.stats["errors"] == 0 for x in net.f.values())


def test_no_shortcut_is_offered_by_a_node_that_would_not_send_straight():
    # 2 hears 3, but holds a learned route to it that is cheaper than the direct hop (the
    # router's rule: it would send that way): its offer would not be the 2 hops it claims
    f, link = _node(2)
    link.discovery.last[1] = link.discovery.last[3] = T0
    f.offer(T0, 3, 5, "acoustic", HOP - 1, 7, 60000)
    f.overheard(T0, link, 4, 5, 1, 3)
    assert f.stats["shortcuts"] == 0
    f.broken(T0, 5, "acoustic")  # that route gone: the direct hop is its way, and it offers
    f.overheard(T0, link, 4, 5, 1, 3)
    assert f.stats["shortcuts"] == 1
