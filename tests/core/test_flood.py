# Flooding without I/O (acomm.transport.flood) on networks of flooders
# joined by a fake broadcast medium: every node delivers a flood exactly
# once on a chain, a grid and random connected graphs; counter suppression
# cuts the rebroadcasts of a dense cluster; the duplicate cache, the held
# rebroadcasts and the hop count stay within their bounds; times wrap.

from acomm.compat import TICKS_MAX, ticks_add, ticks_diff
from acomm.errors import AcommError, EncodeError
from acomm.prng import Prng
from acomm.transport import routing as W
from acomm.transport.flood import BROADCAST, MAX_DATA, Flooder, encode_flood
from checks import adjacency, raises

T0 = TICKS_MAX - 3000  # every network run crosses the wrap


class Net:
    # Each node's broadcasts reach exactly its neighbours, step ms after
    # poll() hands them out (no losses, no collisions: the rules, not the channel).
    def __init__(self, edges, seed=1, **kw):
        self.adj = adjacency(edges)
        self.now = T0
        self.f = {}
        for n in sorted(self.adj):
            self.f[n] = Flooder(n, seed=seed * 1000 + n, **kw)
        self.got = {}  # node -> [(origin, data)]
        self.sent = {}  # node -> broadcasts made

    def run(self, ms, step=50):
        end = ticks_add(self.now, ms)
        while ticks_diff(end, self.now) > 0:
            air = []
            for n, f in self.f.items():
                f.poll(self.now)
                for link, to, payload in f.take():
                    assert to == BROADCAST and link == "acoustic"
                    air.append((n, payload))
                    self.sent[n] = self.sent.get(n, 0) + 1
                for e in f.take_events():
                    assert e[0] == "flood"
                    self.got.setdefault(n, []).append(e[1:])
            for n, payload in air:
                for m in sorted(self.adj[n]):
                    assert self.f[m].heard(self.now, "acoustic", n, payload)
            self.now = ticks_add(self.now, step)

    def once_each(self, origin, data):
        # every node but the origin delivered (origin, data), and exactly once
        for n in self.f:
            want = [] if n == origin else [(origin, data)]
            assert self.got.get(n, []) == want, (n, self.got.get(n))


def grid(rows, cols):
    edges = []
    for r in range(rows):
        for c in range(cols):
            n = r * cols + c + 1
            if c < cols - 1:
                edges.append((n, n + 1))
            if r < rows - 1:
                edges.append((n, n + cols))
    return edges


def test_a_chain_of_six_delivers_once_everywhere():
    net = Net([(1, 2), (2, 3), (3, 4), (4, 5), (5, 6)])
    net.f[1].send(net.now, b"all divers surface")
    net.run(20000)
    net.once_each(1, b"all divers surface")
    # on a chain each copy is heard once before it is due: every relay sends once, 6 does too
    assert [net.sent.get(n, 0) for n in range(1, 7)] == [1, 1, 1, 1, 1, 1]
    assert net.f[1].next_ms(net.now) is None


def test_an_8x8_grid_delivers_once_to_every_node():
    for seed in (1, 2, 3):
        net = Net(grid(8, 8), seed=seed)
        net.f[28].send(net.now, b"rendezvous 14:00")
        net.run(60000)
        net.once_each(28, b"rendezvous 14:00")
        assert all(v == 1 for v in net.sent.values())  # nobody sends twice
        assert sum(net.f[n].stats["suppressed"] for n in net.f) > 0


def test_an_8x8_grid_from_a_corner_and_why_the_counter_is_not_2():
    net = Net(grid(8, 8), seed=4)
    net.f[1].send(net.now, b"up")
    net.run(60000)
    net.once_each(1, b"up")
    # with max_copies=2 a node often hears one copy too many before its turn:
    # here some node is never reached (19 floods of 50 stranded one when measured)
    stranded = 0
    for seed in range(8):
        net = Net(grid(8, 8), seed=seed, max_copies=2)
        net.f[1 + seed].send(net.now, b"up")
        net.run(60000)
        assert all(len(v) == 1 for v in net.got.values())
        stranded += len(net.got) < 63
    assert stranded >= 1


def test_counter_suppression_on_a_dense_cluster():
    edges = [(a, b) for a in range(1, 11) for b in range(a + 1, 11)]
    plain = Net(edges, max_copies=0)
    plain.f[1].send(plain.now, b"x")
    plain.run(10000)
    plain.once_each(1, b"x")
    assert sum(plain.sent.values()) == 10  # pure flooding: everyone once
    for seed in (1, 2, 3, 4):
        net = Net(edges, seed=seed)
        net.f[1].send(net.now, b"x")
        net.run(10000)
        net.once_each(1, b"x")
        relays = sum(net.f[n].stats["rebroadcasts"] for n in net.f)
        assert relays <= 2, relays  # the first relay silences the other eight
        assert sum(net.f[n].stats["suppressed"] for n in net.f) >= 7


def test_random_connected_graphs_deliver_once_everywhere():
    # plain flooding (max_copies 0) reaches every node of a connected graph,
    # once; with the counter no node delivers twice, a few may be missed
    rng = Prng(36)
    reached = total = 0
    for trial in range(12):
        n = 8 + rng.below(17)
        edges = set()
        for b in range(2, n + 1):
            a = rng.range(1, b - 1)
            edges.add((a, b))  # a tree over 1..n: connected
        for _ in range(n):
            a, b = rng.range(1, n), rng.range(1, n)
            if a != b:
                edges.add((min(a, b), max(a, b)))
        plain = trial % 2 == 0
        net = Net(sorted(edges), seed=trial, max_copies=0 if plain else 3)
        origin = rng.range(1, n)
        data = bytes((trial,)) * (1 + trial % MAX_DATA)
        net.f[origin].send(net.now, data)
        net.run(n * 2500)
        if plain:
            net.once_each(origin, data)
        else:
            assert all(v == [(origin, data)] for v in net.got.values())
            reached += len(net.got)
            total += n - 1
    assert reached * 10 >= total * 9, (reached, total)  # 97 % over 200 graphs when measured


def test_the_hop_limit_and_max_hops():
    net = Net([(1, 2), (2, 3), (3, 4), (4, 5), (5, 6)])
    net.f[1].send(net.now, b"near", hops_limit=2)
    net.run(20000)
    assert sorted(net.got) == [2, 3]  # two hops: 3 delivers and stops
    assert net.sent.get(3, 0) == 0 and net.sent.get(2) == 1
    net = Net([(1, 2), (2, 3), (3, 4), (4, 5), (5, 6)], max_hops=4)
    net.f[1].send(net.now, b"far")
    net.run(20000)
    assert sorted(net.got) == [2, 3, 4, 5]
    f = Flooder(1, max_hops=4)
    assert raises(AcommError, f.send, T0, b"x", 5) and raises(AcommError, f.send, T0, b"x", 0)
    assert raises(AcommError, Flooder, 1, ("acoustic",), 2000, 2, 32, 64)
    # a copy that arrives with its count at the limit is delivered, not passed on
    f.heard(T0, "acoustic", 2, encode_flood(9, 1, 3, b"edge"))
    assert f.take_events() == [("flood", 9, b"edge")] and f.next_ms(T0) is None


def test_duplicate_cache_is_bounded():
    f = Flooder(1, seen_cap=4, jitter_ms=0)
    for i in range(6):
        f.heard(T0, "acoustic", 2, encode_flood(7, i, 0, b"m"))
    assert len(f._seen) == 4 and len(f.take_events()) == 6
    f.heard(T0, "acoustic", 3, encode_flood(7, 5, 1, b"m"))  # still remembered
    assert f.take_events() == [] and f.stats["duplicates"] == 1
    f.heard(T0, "acoustic", 3, encode_flood(7, 0, 1, b"m"))  # forgotten: delivered again
    assert f.take_events() == [("flood", 7, b"m")]


def test_held_rebroadcasts_are_bounded_and_own_sends_come_first():
    f = Flooder(1, jitter_ms=1000, pending_cap=3, links=("acoustic", "radio"))
    for i in range(5):
        f.heard(T0, "acoustic", 2, encode_flood(7, i, 0, b"r"))
    assert len(f._pending) == 3 and f.stats["dropped"] == 2 and len(f.take_events()) == 5
    ids = [f.send(T0, b"mine") for _ in range(3)]  # each takes a relay's place
    assert f.stats["dropped"] == 5 and len(f._pending) == 3
    assert raises(AcommError, f.send, T0, b"more")  # nothing of others' left to give up
    f.poll(T0)
    out = f.take()
    assert len(out) == 6 and [W.decode(p)[2] for _, _, p in out[::2]] == ids
    assert [x[0] for x in out[:2]] == ["acoustic", "radio"] and f.stats["rebroadcasts"] == 0
    assert f.send(T0, b"again") == (ids[-1] + 1) & 0xFF


def test_send_refuses_bad_data_and_ids_wrap():
    f = Flooder(5, pending_cap=300)
    assert raises(EncodeError, f.send, T0, b"")
    assert raises(EncodeError, f.send, T0, bytes(MAX_DATA + 1))
    assert f._pending == []
    ids = [f.send(T0, bytes(MAX_DATA)) for _ in range(300)]
    assert ids[256:] == ids[:44] and len(set(ids)) == 256 and all(0 <= i <= 255 for i in ids)


def test_own_floods_coming_back_and_bad_bytes():
    f = Flooder(1, jitter_ms=0)
    mid = f.send(T0, b"hi")
    f.poll(T0)
    (_, _, p), = f.take()
    assert W.decode(p) == ("flood", 1, mid, 0, b"hi")
    assert f.heard(T0, "acoustic", 2, encode_flood(1, mid, 1, b"hi"))
    assert f.take_events() == [] and f.take() == [] and f.stats["duplicates"] == 0
    for junk in (b"", b"\x00", b"\x00\x02\x01", b"\x00\xff\x01x", b"\x01\x02\x03" + bytes(MAX_DATA + 1)):
        assert f.heard(T0, "acoustic", 2, junk)
    assert f.stats["bad"] == 5 and f.take_events() == []
    # route discovery's kinds are not the flooder's
    assert not f.heard(T0, "acoustic", 2, W.encode_error([(3, 4)]))
    assert not f.heard(T0, "acoustic", 2, b"\x40")
    assert f.stats["bad"] == 5


def test_ticks_wrap_and_next_ms():
    now = TICKS_MAX - 100
    f = Flooder(1, jitter_ms=1000, seed=3)
    f.heard(now, "acoustic", 2, encode_flood(9, 4, 0, b"w"))
    wait = f.next_ms(now)
    assert 100 < wait <= 1000  # due after the wrap
    due = ticks_add(now, wait)
    if wait:
        f.poll(ticks_add(due, -1))
        assert f.take() == []
        assert f.next_ms(ticks_add(due, -1)) == 1
    f.poll(due)
    (link, to, p), = f.take()
    assert (link, to) == ("acoustic", 255) and W.decode(p) == ("flood", 9, 4, 1, b"w")
    # a copy heard while the rebroadcast waits, past the wrap, cancels it
    f.heard(TICKS_MAX - 10, "acoustic", 2, encode_flood(9, 5, 0, b"v"))
    f.heard(2, "acoustic", 3, encode_flood(9, 5, 2, b"v"))
    assert f.stats["suppressed"] == 0 and f.next_ms(2) is not None
    f.heard(5, "acoustic", 4, encode_flood(9, 5, 1, b"v"))  # the third copy: max_copies
    assert f.stats["suppressed"] == 1 and f.next_ms(5) is None
    f.poll(ticks_add(5, 2000))
    assert f.take() == []
