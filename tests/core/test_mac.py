# Medium access (acomm.drivers.mac): the TDMA slot table and its guard, ALOHA's
# random backoff, and the wrapper that gates a driver's ready() for the Link
# (whose default wait for an ack covers the peer's backoff).
from acomm.compat import TICKS_MAX, ticks_add
from acomm.errors import AcommError
from acomm.drivers.mac import Aloha, MacDriver, Tdma
from acomm.link import Link
from acomm.link.names import NameTable
from checks import raises
from scripted_driver import ScriptedDriver

SCHEDULE = ((1, 3000, 200), (2, 2000, 200), (3, 3000, 200))  # 8 s cycle


def test_tdma_slots_guards_and_next_start():
    t = Tdma(SCHEDULE, 2, epoch=1000, tx_ms=1000)
    assert t.cycle_ms == 8000
    assert t.slot_at(1000) == (0, 0) and t.slot_at(4000) == (1, 0) and t.slot_at(8999) == (2, 2999)
    assert t.slot_at(500) == (2, 2500)  # before the epoch: the previous cycle
    # slot 2 runs 4000..6000: start from 4200 (guard) to 4800 (6000 - 200 - 1000)
    assert not t.may_start(4199) and t.may_start(4200) and t.may_start(4800) and not t.may_start(4801)
    assert not t.may_start(2000) and t.may_start(12500)
    assert t.next_start(2000) == 4200 and t.next_start(4500) == 4500 and t.next_start(5000) == 12200
    # across the tick wrap
    w = Tdma(SCHEDULE, 1, epoch=TICKS_MAX - 100, tx_ms=0)
    assert w.may_start(ticks_add(TICKS_MAX, 200)) and not w.may_start(ticks_add(TICKS_MAX, 5000))
    assert raises(AcommError, Tdma, SCHEDULE, 9)
    assert raises(AcommError, Tdma, ((1, 300, 200),), 1)
    assert raises(AcommError, Tdma, (), 1)


def test_tdma_nodes_with_skewed_clocks_never_overlap():
    # Three nodes whose clocks disagree by up to 150 ms (< the 200 ms guard)
    # each transmit 1 s whenever allowed: no two transmissions overlap.
    skews = {1: 0, 2: 150, 3: -150}
    macs = {n: Tdma(SCHEDULE, n, epoch=0, tx_ms=1000) for n in skews}
    busy = []  # (start, end) true time
    ends = {n: -1 for n in skews}
    for t in range(0, 40000, 10):
        for n, skew in skews.items():
            if t >= ends[n] and macs[n].may_start(t + skew):
                ends[n] = t + 1000
                busy.append((t, t + 1000, n))
    assert len(busy) >= 15
    busy.sort()
    for a, b in zip(busy, busy[1:]):
        assert a[1] <= b[0], (a, b)
    assert {b[2] for b in busy} == {1, 2, 3}


def test_aloha_waits_a_random_backoff_before_each_frame():
    a = Aloha(1000, seed=3)
    waits = []
    t = 0
    for _ in range(50):
        start = t
        while not a.may_start(t):
            t += 10
        waits.append(t - start)
        a.sent(t)
        t += 5000  # the frame's airtime: then the next one is ready
    assert max(waits) <= 1000 and min(waits) >= 0 and len(set(waits)) > 10
    # an idle link: a stale backoff is drawn again, so a late frame waits too
    b = Aloha(1000, seed=3)
    assert b.backoffs == 0
    b.may_start(0)
    b.may_start(100000)
    assert b.backoffs == 2
    z = Aloha(0)
    assert z.may_start(5)


def test_mac_driver_gates_ready_and_passes_everything_else():
    d = ScriptedDriver()
    m = MacDriver(d, Tdma(((1, 1000, 100), (2, 1000, 100)), 1))
    assert m.caps is d.caps and m.broadcast_addr == d.broadcast_addr
    assert m.ready(150) and not m.ready(1500) and m.held == 1
    h = m.send(150, 2, b"x", True)
    assert d.sent == [(h, 2, b"x", True)] and not m.ready(200)  # the driver is busy
    d.finish(h)
    assert m.take_events()[0][1] == h
    assert m.sent is d.sent  # other attributes are the driver's


def test_mac_driver_without_a_mac_is_the_driver_and_a_schedule_can_be_swapped_in():
    d = ScriptedDriver()
    m = MacDriver(d, None)
    assert m.ready(1500)  # nothing gates it
    h = m.send(1500, 2, b"x", False)
    d.finish(h)
    m.take_events()
    m.mac = Tdma(((1, 1000, 100), (2, 1000, 100)), 1)
    assert not m.ready(1500) and m.ready(2150)


def test_a_link_behind_aloha_waits_for_an_ack_through_the_peers_backoff():
    # the peer's ack is a frame like any other there: it waits its own random backoff first, so
    # the default wait covers the largest one (a shorter wait resends into the late ack)
    d = ScriptedDriver()
    names = NameTable()
    plain = Link("a", d, 1, names)
    behind = Link("a", MacDriver(d, Aloha(3000)), 1, names)
    assert behind.ack_timeout_ms == plain.ack_timeout_ms + 3000
    assert Link("a", MacDriver(d, Aloha(3000)), 1, names, ack_timeout_ms=500).ack_timeout_ms == 500
