# Learned routes by AODV's rules (the table of acomm.transport.routing):
# fresher sequence numbers win, equal ones only when cheaper, invalidation
# raises the number so stale news cannot restore a broken route, and the
# route error names it, expiry, the bounded table's eviction, across the
# 2**30 tick wrap.

from acomm.compat import TICKS_MAX, ticks_add
from acomm.errors import AcommError
from acomm.transport.routing import Routing, decode, seq_newer
from checks import raises

T0 = TICKS_MAX - 1000
LIFE = 30000


def _table(capacity=32):
    # the routing part alone: no links of a node, and errors queued on one routing link
    rt = Routing(1, None, {}, None, capacity=capacity)
    rt.links = ("acoustic",)
    return rt


def _errors(rt):
    # the destinations the route errors queued since the last call name (the queue is emptied)
    out = []
    for _, link, to, payload in rt._held:
        m = decode(payload)
        assert m[0] == "error" and link == "acoustic" and to == 255
        out += m[1]
    rt._held = []
    return out


def test_sequence_numbers_compare_modulo():
    assert seq_newer(5, 4) and not seq_newer(4, 5) and not seq_newer(4, 4)
    assert seq_newer(2, 65530) and not seq_newer(65530, 2)  # across the wrap
    assert seq_newer(0, -1) and not seq_newer(-1, 0) and not seq_newer(-1, -1)


def test_fresher_wins_equal_only_when_cheaper_older_never():
    rt = _table()
    assert rt.offer(T0, 9, 2, "acoustic", 48, 10, LIFE)
    assert rt.lookup(T0, 9) == (2, "acoustic", 48)
    assert not rt.offer(T0, 9, 3, "acoustic", 32, 9, LIFE)  # older, however cheap
    assert not rt.offer(T0, 9, 3, "acoustic", 48, 10, LIFE)  # as new, not cheaper
    assert rt.offer(T0, 9, 3, "acoustic", 40, 10, LIFE)  # as new and cheaper
    assert rt.offer(T0, 9, 4, "satellite", 400, 11, LIFE)  # newer, even if dearer
    assert rt.lookup(T0, 9) == (4, "satellite", 400)
    assert not rt.offer(T0, 9, 5, "acoustic", 16, -1, LIFE)  # no number: never over a known one


def test_routes_expire_and_the_same_route_heard_again_lives_longer():
    rt = _table()
    rt.offer(T0, 7, 2, "acoustic", 16, 1, LIFE)
    t = ticks_add(T0, LIFE - 10)
    assert not rt.offer(t, 7, 2, "acoustic", 16, 1, LIFE)  # not news, but it refreshes
    assert rt.lookup(ticks_add(T0, LIFE + 5000), 7) is not None
    assert rt.lookup(ticks_add(t, LIFE), 7) is None  # expired
    assert rt.offer(ticks_add(t, LIFE), 7, 3, "acoustic", 99, 1, LIFE)  # an expired route takes anything as new


def test_a_broken_hop_invalidates_its_routes_and_stale_news_cannot_restore_them():
    rt = _table()
    rt.offer(T0, 7, 2, "acoustic", 16, 4, LIFE)
    rt.offer(T0, 8, 2, "acoustic", 32, 65534, LIFE)
    rt.offer(T0, 9, 3, "acoustic", 16, 1, LIFE)
    rt.offer(T0, 10, 2, "satellite", 16, 1, LIFE)
    rt.offer(T0, 11, 2, "acoustic", 16, -1, LIFE)  # no number: broken too
    rt.broken(T0, 2, "acoustic")
    # a hop of this node's own: no error goes out (a packet for them searches from here)
    assert _errors(rt) == [] and rt.stats["errors"] == 0
    assert (rt.routes[7][3], rt.routes[8][3], rt.routes[11][3]) == (5, 0, -1)  # raised by one, modulo
    assert rt.lookup(T0, 7) is None and rt.lookup(T0, 8) is None and rt.lookup(T0, 11) is None
    assert rt.lookup(T0, 9) is not None and rt.lookup(T0, 10) is not None
    assert not rt.offer(T0, 7, 2, "acoustic", 16, 4, LIFE)  # the news from before the break
    assert rt.offer(T0, 7, 6, "acoustic", 64, 5, LIFE)  # as fresh as the raised number: restores
    rt.broken(T0, 2, "acoustic")
    assert _errors(rt) == [] and rt.routes[7][3] == 5  # nothing live through 2 any more


def test_an_error_breaks_only_the_routes_it_names_through_its_sender():
    rt = _table()
    rt.offer(T0, 7, 2, "acoustic", 16, 4, LIFE)
    rt.offer(T0, 8, 2, "acoustic", 16, 4, LIFE)
    rt.offer(T0, 9, 3, "acoustic", 16, 4, LIFE)
    rt.broken(T0, 2, "acoustic", [(7, 5), (9, 5), (7, 5)])  # 9 goes through 3: it stands
    assert _errors(rt) == [(7, 5)]
    assert rt.lookup(T0, 7) is None and rt.lookup(T0, 8) is not None and rt.lookup(T0, 9) is not None


def test_the_table_is_bounded_dead_routes_go_first():
    rt = _table(capacity=3)
    for d in (1, 2, 3):
        rt.offer(T0, d, 50, "acoustic", 16, 1, LIFE)
    assert not rt.offer(ticks_add(T0, 100), 4, 50, "acoustic", 16, 1, LIFE)  # all live, all recent
    assert rt.stats["refused"] == 1
    rt.broken(T0, 50, "acoustic")
    rt.offer(T0, 2, 51, "acoustic", 16, 2, LIFE)  # 2 alive again via another hop
    assert rt.offer(ticks_add(T0, 200), 4, 50, "acoustic", 16, 1, LIFE)
    assert 2 in rt.routes and 4 in rt.routes and len(rt.routes) == 3
    # all live: the one used longest ago goes, once it was last used a minute ago or more
    t = ticks_add(T0, 70000)
    rt2 = _table(capacity=2)
    rt2.offer(T0, 1, 9, "acoustic", 16, 1, 10 ** 6)
    rt2.offer(T0, 2, 9, "acoustic", 16, 1, 10 ** 6)
    rt2.lookup(ticks_add(T0, 65000), 2)
    assert not rt2.offer(ticks_add(T0, 59000), 3, 9, "acoustic", 16, 1, 10 ** 6)  # 1 used 59 s ago: kept
    assert rt2.offer(t, 3, 9, "acoustic", 16, 1, 10 ** 6)
    assert sorted(rt2.routes) == [2, 3]


def test_bad_offers_raise():
    rt = _table()
    assert raises(AcommError, rt.offer, T0, 255, 1, "acoustic", 16, 1, LIFE)
    assert raises(AcommError, rt.offer, T0, 5, 1, "acoustic", -1, 1, LIFE)
    assert raises(AcommError, rt.offer, T0, 5, 1, "acoustic", 16, 65535, LIFE)  # unknown on the water


class _Link:
    # a routing link as attempt() sees it: its name and medium, and the neighbour table's evidence
    name = medium = "acoustic"

    def __init__(self, name="acoustic"):
        self.name = name
        self.neighbours = self

    def attempt(self, now, hop, answered):
        pass


def test_an_answer_keeps_the_routes_through_the_hop_alive():
    t = _table()
    t.media = ("acoustic", "satellite")
    t.lifetime_ms = 1000  # what an answer adds
    t.offer(0, 9, 2, "acoustic", 100, 5, 1000)
    t.offer(0, 8, 3, "acoustic", 100, 5, 1000)
    t.offer(0, 7, 2, "satellite", 100, 5, 1000)
    t.attempt(900, _Link(), 2, True)
    assert t.lookup(1500, 9) is not None  # refreshed to 1900
    assert t.lookup(1500, 8) is None and t.lookup(1500, 7) is None  # another hop, another link
    t.attempt(3000, _Link(), 2, True)  # dead routes stay dead
    assert t.lookup(3100, 9) is None
    t.offer(3100, 6, 2, "satellite", 100, 5, 1000)
    t.attempt(3900, _Link("satellite"), 2, False)  # no answer: no longer life
    assert t.lookup(4200, 6) is None
