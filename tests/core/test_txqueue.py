import gc

from acomm_sim.clock import ManualClock
from acomm.compat import TICKS_MAX, ticks_add, ticks_diff
from acomm.prng import Prng
from acomm.link.txqueue import (
    MAX_LIFESPAN_MS,
    PRIO_ALARM,
    PRIO_GESTURE,
    PRIO_MULTIMEDIA,
    PRIO_TELEMETRY,
    TxQueue,
    TxRequest,
)


def _req(rid, prio, now, life, data=b"x"):
    return TxRequest(rid, 3, prio, ticks_add(now, life), data)


def _ids(reqs):
    return sorted(r.req_id for r in reqs)


def _drain(q, now):
    out = []
    while True:
        r = q.pop(now)
        if r is None:
            return out
        out.append(r.req_id)


def test_request_validation():
    r = TxRequest(65535, "buoy", 16, 100, b"abc")
    assert r.seq == -1 and r.meta is None and r.dst == "buoy"
    for bad in ((-1, 1), (65536, 1), (0, 0), (0, 17)):
        try:
            TxRequest(bad[0], 1, bad[1], 0)
            assert False, bad
        except ValueError:
            pass
    try:
        TxQueue(0)
        assert False
    except ValueError:
        pass


def test_order_class_then_deadline_then_fifo():
    clk = ManualClock(5000)
    q = TxQueue(32)
    now = clk()
    # (req_id, class, lifespan)
    for rid, prio, life in (
        (1, 16, 100),
        (2, 10, 5000),
        (3, 10, 1000),
        (4, 2, 9000),
        (5, 1, 9000),
        (6, 10, 1000),  # same class and deadline as 3: FIFO after it
        (7, 2, 500),
        (8, 1, 8000),
        (9, 10, 1000),
    ):
        assert q.push(_req(rid, prio, now, life), now) is None
    assert len(q) == 9
    assert q.peek(now).req_id == 8
    assert len(q) == 9
    assert _drain(q, now) == [8, 5, 7, 4, 3, 6, 9, 2, 1]
    assert len(q) == 0 and q.pop(now) is None and q.peek() is None


def test_pop_skips_expired_and_expire_reports_each_once():
    clk = ManualClock(0)
    q = TxQueue(8)
    now = clk()
    q.push(_req(1, 2, now, 100), now)
    q.push(_req(2, 2, now, 300), now)
    q.push(_req(3, 10, now, 150), now)
    clk.advance(99)
    assert list(q.expire(clk())) == []
    clk.advance(1)  # deadline of 1 reached: expired (ticks_diff(now, dl) >= 0)
    r = q.pop(clk())
    assert r.req_id == 2
    assert len(q) == 2  # 1 is held until expire() hands it back
    clk.advance(50)
    assert _ids(q.expire(clk())) == [1, 3]
    assert list(q.expire(clk())) == []
    assert len(q) == 0 and q.pop(clk()) is None


def test_expiry_across_ticks_wrap():
    clk = ManualClock(TICKS_MAX - 1000)
    q = TxQueue(8)
    now = clk()
    a = _req(1, 10, now, 500)  # before the wrap
    b = _req(2, 10, now, 1500)  # after the wrap: deadline is a small number
    c = _req(3, 10, now, 3000)
    assert b.deadline < a.deadline  # raw comparison would get this wrong
    for r in (c, b, a):
        assert q.push(r, now) is None
    assert q.peek(now) is a
    clk.advance(999)
    assert _ids(q.expire(clk())) == [1]
    clk.advance(2)  # now past the wrap
    assert clk() < 1000
    assert list(q.expire(clk())) == []
    assert q.pop(clk()) is b
    clk.advance(2000)
    assert q.pop(clk()) is None
    assert _ids(q.expire(clk())) == [3]


def test_lifespan_limits():
    clk = ManualClock(TICKS_MAX - 10)
    q = TxQueue(4)
    now = clk()
    for life in (MAX_LIFESPAN_MS + 1, -MAX_LIFESPAN_MS - 1, (1 << 29) + 5):
        # in steps: ticks_add refuses half a period (2**29) at once
        deadline = now
        left = life
        while left:
            step = max(-(1 << 28), min(1 << 28, left))
            deadline = ticks_add(deadline, step)
            left -= step
        try:
            q.push(TxRequest(1, 3, 2, deadline, b"x"), now)
            assert False, life
        except ValueError:
            pass
    assert len(q) == 0
    assert q.push(_req(2, 2, now, MAX_LIFESPAN_MS), now) is None
    # a deadline already passed is accepted and reported by expire()
    dead = _req(3, 1, now, 0)
    assert q.push(dead, now) is None
    assert q.pop(now).req_id == 2
    assert list(q.expire(now)) == [dead]


def test_long_lifespans_survive_rebase_and_wrap():
    clk = ManualClock(TICKS_MAX - 1000)
    q = TxQueue(16)
    now = clk()
    far = _req(1, 16, now, MAX_LIFESPAN_MS)
    mid = _req(2, 10, now, 1 << 27)
    near = _req(3, 10, now, (1 << 26) + 7)
    for r in (far, mid, near):
        q.push(r, now)
    step = 1 << 22
    t = 0
    rid = 10
    while t + step < (1 << 26):
        clk.advance(step)
        t += step
        # keep traffic flowing so the queue rebases with entries inside
        q.push(_req(rid, 2, clk(), 1000), clk())
        assert q.pop(clk()).req_id == rid
        rid += 1
        assert list(q.expire(clk())) == []
    assert q.peek(clk()) is near
    clk.advance((1 << 26) + 7 - t)
    t = (1 << 26) + 7
    assert list(q.expire(clk())) == [near]
    clk.advance((1 << 27) - 1 - t)
    t = (1 << 27) - 1
    assert q.pop(clk()) is mid
    while t + step < MAX_LIFESPAN_MS:
        clk.advance(step)
        t += step
        assert list(q.expire(clk())) == []
    clk.advance(MAX_LIFESPAN_MS - 1 - t)
    assert q.peek(clk()) is far
    clk.advance(1)
    assert q.pop(clk()) is None
    assert list(q.expire(clk())) == [far]


def test_cancel():
    clk = ManualClock(100)
    q = TxQueue(8)
    now = clk()
    for rid, prio in ((1, 2), (2, 2), (3, 16), (4, 1), (5, 2)):
        q.push(_req(rid, prio, now, 1000 + rid), now)
    assert q.cancel(2).req_id == 2
    assert q.cancel(2) is None
    assert q.cancel(4).req_id == 4
    assert q.cancel(999) is None
    assert len(q) == 3
    assert _drain(q, now) == [1, 5, 3]
    # cancelling an expired request that pop stepped over
    q.push(_req(7, 2, now, 10), now)
    q.push(_req(8, 3, now, 1000), now)
    clk.advance(10)
    assert q.pop(clk()).req_id == 8
    assert q.cancel(7).req_id == 7
    assert list(q.expire(clk())) == []


def test_capacity_refuses_and_evicts():
    clk = ManualClock(0)
    q = TxQueue(3)
    now = clk()
    a = _req(1, 10, now, 1000)
    b = _req(2, 10, now, 2000)
    c = _req(3, 3, now, 500)
    for r in (a, b, c):
        assert q.push(r, now) is None
    assert q.is_full() and len(q) == 3
    # lower class: refused
    d = _req(4, 16, now, 100)
    assert q.push(d, now) is d
    # same class, same deadline as the worst: ranks below it (FIFO): refused
    e = _req(5, 10, now, 2000)
    assert q.push(e, now) is e
    # same class, earlier deadline: evicts the latest deadline of that class
    f = _req(6, 10, now, 1500)
    assert q.push(f, now) is b
    # better class: evicts the worst
    g = _req(7, 1, now, 5000)
    assert q.push(g, now) is f
    assert len(q) == 3
    assert _drain(q, now) == [7, 3, 1]


def test_full_queue_reports_expired_not_evicted():
    clk = ManualClock(0)
    q = TxQueue(2)
    now = clk()
    a = _req(1, 16, now, 10)
    b = _req(2, 16, now, 1000)
    q.push(a, now)
    q.push(b, now)
    clk.advance(20)
    # a has expired: it must come back from expire(), not as an eviction
    n = _req(3, 2, clk(), 1000)
    assert q.push(n, clk()) is b
    assert list(q.expire(clk())) == [a]
    assert len(q) == 1
    # expired-but-unreported requests occupy capacity; an expired newcomer
    # on a full queue is refused
    q2 = TxQueue(1)
    x = _req(4, 2, clk(), 0)
    assert q2.push(x, clk()) is None
    y = _req(5, 2, clk(), -5)
    assert q2.push(y, clk()) is y
    z = _req(6, 1, clk(), 100)
    assert q2.push(z, clk()) is z  # nothing live to evict
    assert list(q2.expire(clk())) == [x]


def test_iteration_len_and_meta():
    clk = ManualClock(0)
    q = TxQueue(10)
    now = clk()
    for rid in range(5):
        r = _req(rid, 1 + rid * 3, now, 100 + rid)
        r.meta = "m%d" % rid
        q.push(r, now)
    assert sorted(r.req_id for r in q) == [0, 1, 2, 3, 4]
    assert sorted(r.meta for r in q) == ["m0", "m1", "m2", "m3", "m4"]
    first = q.pop(now)
    assert first.req_id == 0 and first.enq == now and first.seq >= 0
    assert len(q) == 4 and not q.is_full()


def _flood_then_alarm(cap):
    # 10,000 requests take about 1.7 MB on the 64-bit unix port (168 bytes per
    # request, 8 per heap slot) out of its default 2 MB heap: free first.
    gc.collect()
    clk = ManualClock(TICKS_MAX - 3000)
    q = TxQueue(cap)
    now = clk()
    for i in range(10000):
        r = TxRequest(i, 3, PRIO_MULTIMEDIA, ticks_add(now, 60000 + (i % 97)))
        assert q.push(r, now) is None
    clk.advance(10)
    alarm = _req(50000, PRIO_ALARM, clk(), 5000)
    out = q.push(alarm, clk())
    assert q.pop(clk()) is alarm
    assert q.pop(clk()).priority == PRIO_MULTIMEDIA
    return q, out, now


def test_flood_then_alarm_is_next():
    q, out, _ = _flood_then_alarm(10001)
    assert out is None
    assert len(q) == 9999


def test_flood_full_queue_alarm_evicts_and_is_next():
    q, out, t0 = _flood_then_alarm(10000)
    assert out is not None and out.priority == PRIO_MULTIMEDIA
    assert ticks_diff(out.deadline, t0) == 60000 + 96  # the latest deadline
    assert len(q) == 9998


def _starvation(aging_ms, frames):
    # Class 2 always has traffic; one class-16 request waits. Returns the
    # frame index at which class 16 went on the air, or -1.
    clk = ManualClock(TICKS_MAX - 5000)
    q = TxQueue(64, aging_ms)
    now = clk()
    low = _req(1, PRIO_MULTIMEDIA, now, 10 * 60000)
    q.push(low, now)
    rid = 100
    for _ in range(3):
        q.push(_req(rid, PRIO_TELEMETRY, now, 60000), now)
        rid += 1
    for f in range(frames):
        r = q.pop(clk())
        if r is low:
            return f
        assert r.priority == PRIO_TELEMETRY
        q.push(_req(rid, PRIO_TELEMETRY, clk(), 60000), clk())
        rid += 1
        clk.advance(100)  # one 100 ms frame on the air
    return -1


def test_aging_off_is_strict_priority():
    assert _starvation(0, 1000) == -1


def test_aging_on_serves_starving_class():
    f = _starvation(1000, 1000)
    # class 16 ties with class 2 after 14 s and wins outright after 15 s
    assert 140 <= f <= 151, f


def test_aging_never_overtakes_alarms_and_restarts():
    clk = ManualClock(0)
    q = TxQueue(64, aging_ms=100)
    now = clk()
    a = _req(1, PRIO_MULTIMEDIA, now, 600000)
    b = _req(2, PRIO_MULTIMEDIA, now, 600000)
    q.push(a, now)
    q.push(b, now)
    clk.advance(100000)  # class 16 has starved for a long time
    alarm = _req(3, PRIO_ALARM, clk(), 1000)
    q.push(alarm, clk())
    q.push(_req(4, PRIO_TELEMETRY, clk(), 1000), clk())
    assert q.pop(clk()) is alarm
    assert q.pop(clk()) is a  # aged class 16 before class 2
    # class 16 was just served: its waiting time restarts
    assert q.pop(clk()).req_id == 4
    assert q.pop(clk()) is b


def test_aging_tie_breaks_by_deadline_across_wrap():
    clk = ManualClock(TICKS_MAX - 10000)
    q = TxQueue(16, aging_ms=1000)
    a = _req(1, PRIO_GESTURE, clk(), 20000)  # deadline after the wrap
    q.push(a, clk())
    clk.advance(1000)  # class 3 has waited 1 s: competes as class 2
    b = _req(2, PRIO_TELEMETRY, clk(), 5000)  # before the wrap: earlier
    c = _req(3, PRIO_TELEMETRY, clk(), 30000)  # later than a
    q.push(c, clk())
    q.push(b, clk())
    assert q.pop(clk()) is b  # tie on class 2, earliest deadline first
    assert q.pop(clk()) is a  # tie again: a's deadline is before c's
    assert q.pop(clk()) is c


def _model_run(seed, nops, capacity):
    rng = Prng(seed)
    clk = ManualClock(TICKS_MAX - 2000 - rng.below(3000))
    q = TxQueue(capacity)
    t = 0  # unwrapped time of the model
    synced = 0
    entries = []  # model: [prio, unwrapped deadline, serial, req] in the queue
    # what became of each request, by serial (0: still queued or never
    # pushed). A bytearray made once, not a dict that grows: on a 32-bit
    # board a dict of thousands of entries needs a block of 13 KB at its
    # last resize, which a 2 MiB heap holding requests scattered through
    # it by the model's garbage may not have (MemoryError)
    fate = bytearray(nops)
    serial = 0
    lifes = (0, 1, 50, 100, 100, 1000, 5000)
    for _ in range(nops):
        op = rng.below(100)
        now = clk()
        if op < 40:  # push
            prio = (1, 2, 3, 10, 16, 16)[rng.below(6)] if rng.chance(0.7) else rng.range(1, 16)
            k = rng.below(10)
            if k < 6:
                life = lifes[rng.below(len(lifes))]
            elif k < 8:
                life = rng.range(1, 20000)
            elif k < 9:
                life = rng.range(1, 1 << 27)  # lives across rebases and wraps
            elif rng.chance(0.5):
                life = -rng.below(200)
            else:
                life = MAX_LIFESPAN_MS + 1 + rng.below(1000)
            r = TxRequest(serial & 0xFFFF, 0, prio, ticks_add(now, life))
            r.meta = serial
            if life > MAX_LIFESPAN_MS:
                try:
                    q.push(r, now)
                    assert False
                except ValueError:
                    pass
                continue
            synced = t
            e = [prio, t + life, serial, r]
            serial += 1
            if len(entries) < capacity:
                expect = None
            elif life <= 0:
                expect = r
            else:
                live = [x for x in entries if x[1] > t]
                if not live:
                    expect = r
                else:
                    w = max(live, key=lambda x: (x[0], x[1], x[2]))
                    expect = w[3] if (prio, t + life) < (w[0], w[1]) else r
            out = q.push(r, now)
            assert out is expect, (out, expect)
            if out is None:
                entries.append(e)
            elif out is r:
                fate[r.meta] = 1  # refused
            else:
                assert not fate[out.meta]
                fate[out.meta] = 2  # evicted
                entries = [x for x in entries if x[3] is not out]
                entries.append(e)
        elif op < 70:  # pop
            synced = t
            live = [x for x in entries if x[1] > t]
            expect = min(live, key=lambda x: (x[0], x[1], x[2]))[3] if live else None
            r = q.pop(now)
            assert r is expect, (r, expect)
            if r is not None:
                assert not fate[r.meta]
                fate[r.meta] = 3  # popped
                entries = [x for x in entries if x[3] is not r]
        elif op < 80:  # expire
            synced = t
            out = q.expire(now)
            got = sorted(r.meta for r in out)
            want = sorted(x[2] for x in entries if x[1] <= t)
            assert got == want, (got, want)
            for r in out:
                assert not fate[r.meta]
                fate[r.meta] = 4  # expired
            entries = [x for x in entries if x[1] > t]
        elif op < 88:  # cancel
            if serial == 0:
                continue
            if entries and rng.chance(0.7):
                s = entries[rng.below(len(entries))][2]
            else:
                s = rng.below(serial)
            r = q.cancel(s & 0xFFFF)
            match = [x for x in entries if x[2] == s]
            if match:
                assert r is match[0][3]
                assert not fate[r.meta]
                fate[r.meta] = 5  # cancelled
                entries = [x for x in entries if x[2] != s]
            else:
                assert r is None
        else:  # advance time
            k = rng.below(20)
            if k < 15:
                dt = rng.below(60)
            elif k < 19:
                dt = rng.below(5000)
            else:
                dt = rng.below(1 << 26)  # crosses rebases and ticks wraps
            if t + dt - synced > (1 << 27):
                dt = 0
            clk.advance(dt)
            t += dt
        assert len(q) == len(entries)
        assert len(q) <= capacity
    # drain: everything still queued leaves exactly once
    while True:
        r = q.pop(clk())
        if r is None:
            break
        assert not fate[r.meta]
        fate[r.meta] = 3  # popped
    for r in q.expire(clk()):
        assert not fate[r.meta]
        fate[r.meta] = 4  # expired
    assert len(q) == 0
    names = ("", "refused", "evicted", "popped", "expired", "cancelled")
    kinds = {}
    for v in fate[:serial]:
        assert v, "a request left without a fate"
        kinds[names[v]] = kinds.get(names[v], 0) + 1
    return kinds


def test_model_random_small_capacity():
    total = {}
    for seed in (1, 2, 3):
        for k, v in _model_run(seed, 2500, 6).items():
            total[k] = total.get(k, 0) + v
    for k in ("popped", "expired", "cancelled", "evicted", "refused"):
        assert total.get(k, 0) > 0, (k, total)


def test_model_random_large_capacity():
    kinds = _model_run(12345, 4000, 200)
    assert kinds.get("popped", 0) > 0 and kinds.get("expired", 0) > 0
