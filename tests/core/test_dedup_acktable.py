from acomm.link.acktable import AckTable
from acomm.compat import TICKS_MAX, ticks_add
from acomm.link.dedup import DuplicateFilter
from acomm.link.txqueue import TxRequest


def test_duplicates_within_window_only():
    d = DuplicateFilter(window_ms=1000, slots=3)
    t = TICKS_MAX - 100
    assert not d.seen(5, 1, t)
    assert d.seen(5, 1, ticks_add(t, 500))
    assert not d.seen(6, 1, t)  # another source
    # refreshed at 500: still a copy at 1400, new data at 2500
    assert d.seen(5, 1, ticks_add(t, 1400))
    assert not d.seen(5, 1, ticks_add(t, 2500))


def test_duplicate_memory_is_bounded():
    d = DuplicateFilter(window_ms=1000, slots=2, max_sources=3)
    for s in range(10):
        d.seen(1, s, 0)
    assert not d.seen(1, 0, 0)  # only the last two are remembered
    for src in range(10):
        d.seen(src, 0, 0)
    # at most 3 sources: the table started afresh at the 4th, the 7th and
    # the 10th (9), so 8 is forgotten (a copy from it would pass) and 9 is not
    assert not d.seen(8, 0, 0)
    assert d.seen(9, 0, 0)


def test_ack_table_matching_and_deadlines():
    t = AckTable(window=2)
    r1 = TxRequest(1, 2, 2, 10000, b"a")
    r2 = TxRequest(2, 3, 2, 500, b"b")
    t.add(r1, 11, 2, 5, 2000)
    assert not t.full()
    t.add(r2, 12, 3, 5, 2000)
    assert t.full() and t.seq_in_use(3, 5) and not t.seq_in_use(3, 6)
    assert t.by_ack(3, 6) is None
    assert t.due(100) == ()
    assert t.due(500) == [(r2, True)]  # lifespan over
    assert t.due(2000) == [(r1, False)]  # ack time over
    t.add(r1, 11, 2, 5, 2000)
    assert t.by_handle(99) is None and t.by_handle(11) is r1
    t.add(r1, 11, 2, 5, 2000)
    assert t.by_req_id(1) is r1 and len(t) == 0
