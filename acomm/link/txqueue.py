# The link's transmit queue: bounded, ordered by priority class and deadline.
#
# DUNE's low-level transports put frame requests "into a priority queue with
# ascending order of lifespan"; CADDY (seed 003, 4.2) adds classes of service
# (1 alarms, 2 telemetry, 3 gestures, ... 10 environmental, ... 16 multimedia)
# and asks that low-priority traffic, even when it floods the link, never
# delays high-priority messages. TxQueue does both:
#
#   order   priority class first (1 before 2 ... before 16), then earliest
#           deadline, then first come first served.
#   bound   at most `capacity` requests. A request that arrives when the
#           queue is full takes the place of the worst queued one (highest
#           class number, then latest deadline, then newest) only if it ranks
#           strictly above it; otherwise it is refused.
#   expiry  a request whose deadline has passed (ticks_diff(now, deadline)
#           >= 0) is never returned by pop(); expire(now) hands each such
#           request back exactly once so the link can report `expired`
#           before it wastes airtime.
#
# The link owns the statuses. The queue only says which request leaves and
# how, so that every request accepted by push() leaves through exactly one of:
#
#   push()    returns None when the request was accepted. Otherwise it returns
#             the request that leaves the queue instead: either the new one
#             itself (refused: "failed: queue full") or an older one that was
#             evicted to make room ("evicted by higher priority"). Tell them
#             apart with `out is req`.
#   pop()     the best unexpired request, to put on the air; None when none.
#   expire()  the requests whose deadline passed (a list, or an empty tuple
#             when there are none), including those pop() stepped over since
#             the last call. Call it every loop iteration, before pop().
#   cancel()  the request with that req_id, removed; None when not queued.
#
# A request that pop() finds expired is moved aside (not lost) until the next
# expire(); until then it still occupies capacity, so memory stays bounded at
# `capacity` requests whatever the caller does. A request pushed with a
# deadline that has already passed is accepted (when there is room) and comes
# back from the next expire().
#
# Time. `now` and deadlines are ticks in acomm's 2**30 wrapping millisecond
# domain and are never compared with < directly. The heaps order requests by
# their distance from a reference time `ref`, (deadline - ref) mod 2**30. The
# queue keeps every queued deadline after `ref` and less than 2**29 ms beyond
# it, so that distance is exact. When `now` gets 2**24 ms (4.7 h) past `ref`, it
# moves everything expired aside and sets `ref = now`. Every distance then
# drops by the same amount, so no entry needs rewriting. Two limits follow
# from the 2**30 domain:
#
#   * a lifespan (ticks_diff(deadline, now) at push) must be within
#     +-MAX_LIFESPAN_MS = 2**28 ms (74.6 h, about 3 days). A deadline 2**29 ms
#     or more ahead cannot be told from one in the past, so push() raises
#     ValueError for anything beyond +-2**28: that catches lifespans up to
#     1.5 * 2**29 ms that a caller got wrong, instead of silently expiring them.
#   * the queue must see a `now` (any of push/pop/peek/expire) at least every
#     2**28 ms; a running link does so many times a second.
#
# Aging (off by default, aging_ms=0). CADDY allows "a certain amount of
# queuing fairness" if its cost in real-time performance is known. As in
# goby-acomms' dynamic buffer, aging works per class, not per request: a class
# that has had requests waiting without sending any of them for `w` ms
# competes as class (c - w // aging_ms); its waiting time restarts whenever one
# of its requests is popped, and when it becomes non-empty. The queue pops the
# head (earliest deadline) of the class with the lowest such value; ties go to
# the earlier head deadline, then to the older head. Aging never lifts a class
# above alarms: while any class-1 request is queued, pop() returns one, so an
# alarm waits at most for the frame already on the air plus earlier alarms.
# Per-class aging costs O(16) per pop (per-request aging would need a scan of
# the queue) and after a flood it promotes one frame per starving class rather
# than every old request at once, so its effect on real time is bounded: a
# non-empty class c >= 2 is served within about (c - 1) * aging_ms plus one
# frame, when no more than one class is starving (more starving classes each
# get their turn) and no alarm is queued. Eviction ignores aging: it ranks by
# base class.
#
# Cost: push and pop are O(log n) with one binary heap per class, written here
# because MicroPython's heapq cannot take a key. They allocate nothing: a
# queued request costs its own object plus one list slot (about 90 bytes on a
# 32-bit MCU). expire is O(k log n) for k expired requests; cancel and
# eviction are O(n).

from ..compat import const, ticks_diff

# CADDY classes of service (priority 1..16, lower is more urgent).
PRIO_ALARM = const(1)
PRIO_TELEMETRY = const(2)
PRIO_GESTURE = const(3)
PRIO_ENVIRONMENT = const(10)
PRIO_MULTIMEDIA = const(16)
PRIO_LOWEST = const(16)

MAX_LIFESPAN_MS = const(1 << 28)
_MAX_AGING_MS = const(1 << 23)  # 2.3 h: aging over 16 classes stays < 2**27 ms

_NCLASS = const(16)
_MASK = const((1 << 30) - 1)  # compat.TICKS_MAX
_REBASE_MS = const(1 << 24)
_SINCE_FLOOR = const(1 << 28)

_NONE = ()

# The heaps hold the requests themselves (no per-entry tuple: a queued
# request costs its own object plus one list slot, and push/pop allocate
# nothing). An entry's key is (deadline - ref) & _MASK, then seq. TxQueue
# keeps every queued deadline strictly after `ref` and less than 2**29 ms
# beyond it (see _rel), so the masked difference is the exact distance and
# moving `ref` forward lowers every key by the same amount: heap order holds.
# A request's deadline must not be changed while it is queued.


def _sift_up(h, i, ref):
    e = h[i]
    k = (e.deadline - ref) & _MASK
    s = e.seq
    while i > 0:
        p = (i - 1) >> 1
        q = h[p]
        qk = (q.deadline - ref) & _MASK
        if k < qk or (k == qk and s < q.seq):
            h[i] = q
            i = p
        else:
            break
    h[i] = e
    return i


def _sift_down(h, i, ref):
    n = len(h)
    e = h[i]
    k = (e.deadline - ref) & _MASK
    s = e.seq
    while True:
        c = 2 * i + 1
        if c >= n:
            break
        x = h[c]
        xk = (x.deadline - ref) & _MASK
        r = c + 1
        if r < n:
            y = h[r]
            yk = (y.deadline - ref) & _MASK
            if yk < xk or (yk == xk and y.seq < x.seq):
                c = r
                x = y
                xk = yk
        if xk < k or (xk == k and x.seq < s):
            h[i] = x
            i = c
        else:
            break
    h[i] = e


def _heap_push(h, e, ref):
    h.append(e)
    _sift_up(h, len(h) - 1, ref)


def _heap_remove(h, i, ref):
    # Remove and return h[i] in O(log n).
    e = h[i]
    last = h.pop()
    if i < len(h):
        h[i] = last
        if _sift_up(h, i, ref) == i:
            _sift_down(h, i, ref)
    return e


class TxRequest:
    # One frame transmission request (DUNE's frame transmission request plus
    # a CADDY class). The queue fills in enq and seq; meta is the link's.
    # fields: req_id, dst, priority, deadline, data, enq, seq, meta

    def __init__(self, req_id, dst, priority, deadline, data=b"", meta=None):
        if not 0 <= req_id <= 0xFFFF:
            raise ValueError("req_id must be 0..65535")
        if not 1 <= priority <= _NCLASS:
            raise ValueError("priority must be 1..16")
        self.req_id = req_id
        self.dst = dst  # node address or name: opaque to the queue
        self.priority = priority
        self.deadline = deadline  # ticks ms, absolute
        self.data = data
        self.enq = 0  # ticks when queued
        self.seq = -1  # insertion counter, FIFO tie-break
        self.meta = meta

    def __repr__(self):
        return "TxRequest(%d, %r, p%d, dl=%d, %dB)" % (
            self.req_id,
            self.dst,
            self.priority,
            self.deadline,
            len(self.data),
        )


class TxQueue:
    def __init__(self, capacity, aging_ms=0):
        if capacity < 1:
            raise ValueError("capacity must be >= 1")
        if not 0 <= aging_ms <= _MAX_AGING_MS:
            raise ValueError("aging_ms must be 0..2**23")
        self.capacity = capacity
        self._aging = aging_ms
        # one heap per class, made when the class is first used: 16 empty
        # lists would cost a board 512 bytes per link for classes it never uses
        self._heaps = [None] * _NCLASS
        # Per class: time (relative to _ref) since which it has waited unserved.
        self._since = [0] * _NCLASS
        self._n = 0  # requests in the heaps
        self._held = []  # expired, not yet handed back by expire()
        self._seq = 0
        self._ref = 0
        self._last = None  # last `now` seen, for peek()

    # -- time ------------------------------------------------------------------

    def _rel(self, now):
        # `now` relative to _ref. Moves _ref up to `now` when it has fallen
        # 2**24 ms behind, after moving aside everything that has expired, so
        # that every queued deadline stays after _ref (O(1) besides the sweep).
        self._last = now
        if self._n == 0:
            self._ref = now
            return 0
        d = ticks_diff(now, self._ref)
        if d < _REBASE_MS:
            return d
        self._sweep(d)
        since = self._since
        for c in range(_NCLASS):
            s = since[c] - d
            since[c] = s if s > -_SINCE_FLOOR else -_SINCE_FLOOR
        self._ref = now
        return 0

    def _sweep(self, rel):
        # Move every expired request aside. Expired requests have the smallest
        # keys of their class, so they are exactly the ones at the top.
        held = self._held
        ref = self._ref
        for h in self._heaps:
            while h and (h[0].deadline - ref) & _MASK <= rel:
                held.append(_heap_remove(h, 0, ref))
                self._n -= 1

    # -- selection -------------------------------------------------------------

    def _select(self, rel):
        # Index of the class whose head goes next, or -1. Moves aside the
        # expired requests it meets.
        heaps = self._heaps
        ref = self._ref
        if not self._aging:
            held = self._held
            for c in range(_NCLASS):
                h = heaps[c]
                while h and (h[0].deadline - ref) & _MASK <= rel:
                    held.append(_heap_remove(h, 0, ref))
                    self._n -= 1
                if h:
                    return c
            return -1
        self._sweep(rel)
        if heaps[0]:
            return 0  # alarms are never overtaken
        aging = self._aging
        since = self._since
        best = -1
        be = bd = bs = 0
        for c in range(1, _NCLASS):
            h = heaps[c]
            if not h:
                continue
            w = rel - since[c]
            eff = c - (w // aging if w > 0 else 0)
            top = h[0]
            k = (top.deadline - ref) & _MASK
            if best < 0 or eff < be or (eff == be and (k < bd or (k == bd and top.seq < bs))):
                best = c
                be = eff
                bd = k
                bs = top.seq
        return best

    # -- API ---------------------------------------------------------------------

    def push(self, req, now):
        # None: accepted. Otherwise the request that leaves instead: `req`
        # itself (refused, queue full) or the evicted worst entry. Raises
        # ValueError for a bad class or a deadline beyond +-MAX_LIFESPAN_MS.
        p = req.priority
        if not 1 <= p <= _NCLASS:
            raise ValueError("priority must be 1..16")
        life = ticks_diff(req.deadline, now)
        if life > MAX_LIFESPAN_MS or life < -MAX_LIFESPAN_MS:
            raise ValueError("deadline beyond MAX_LIFESPAN_MS")
        rel = self._rel(now)
        req.enq = now
        req.seq = self._seq
        self._seq += 1
        full = self._n + len(self._held) >= self.capacity
        if life <= 0 or ticks_diff(req.deadline, self._ref) <= 0:
            # Already expired (the second test catches a `now` older than
            # one seen before): hand it back through expire(), if there is room.
            if full:
                return req
            self._held.append(req)
            return None
        out = None
        if full:
            self._sweep(rel)  # an expired request must be reported as expired
            out = self._evict_for(p, (req.deadline - self._ref) & _MASK)
            if out is None:
                return req
        h = self._heaps[p - 1]
        if h is None:
            h = self._heaps[p - 1] = []
        if not h:
            self._since[p - 1] = rel
        _heap_push(h, req, self._ref)
        self._n += 1
        return out

    def _evict_for(self, p, k):
        # Remove and return the worst request if one of class p with key k
        # (and the newest seq) ranks strictly above it, else None.
        c = _NCLASS - 1
        heaps = self._heaps
        while c >= 0 and not heaps[c]:
            c -= 1
        if c < 0 or c + 1 < p:
            return None
        h = heaps[c]
        ref = self._ref
        # The maximum of a min-heap is one of its leaves.
        n = len(h)
        j = n >> 1
        w = h[j]
        wk = (w.deadline - ref) & _MASK
        for i in range(j + 1, n):
            x = h[i]
            xk = (x.deadline - ref) & _MASK
            if xk > wk or (xk == wk and x.seq > w.seq):
                w = x
                wk = xk
                j = i
        if c + 1 == p and not k < wk:
            return None  # same class, not earlier: the new one ranks below
        _heap_remove(h, j, ref)
        self._n -= 1
        return w

    def pop(self, now):
        # The best unexpired request, removed; None when there is none.
        # Expired requests met on the way wait for the next expire().
        rel = self._rel(now)
        if self._n == 0:
            return None
        c = self._select(rel)
        if c < 0:
            return None
        self._n -= 1
        self._since[c] = rel
        return _heap_remove(self._heaps[c], 0, self._ref)

    def peek(self, now=None):
        # What pop(now) would return, without removing it. now=None uses the
        # last time the queue was given. May move expired requests aside.
        if now is None:
            now = self._ref if self._last is None else self._last
        rel = self._rel(now)
        if self._n == 0:
            return None
        c = self._select(rel)
        return self._heaps[c][0] if c >= 0 else None

    def expire(self, now):
        # Requests whose deadline has passed, removed; each one exactly once.
        # A list, or an empty tuple when there are none.
        self._sweep(self._rel(now))
        held = self._held
        if not held:
            return _NONE
        self._held = []
        return held

    def cancel(self, req_id):
        # Remove and return the queued request with this req_id (the first
        # found if the caller reused one), or None.
        for h in self._heaps:
            for i in range(len(h) if h else 0):
                if h[i].req_id == req_id:
                    self._n -= 1
                    return _heap_remove(h, i, self._ref)
        held = self._held
        for i in range(len(held)):
            if held[i].req_id == req_id:
                return held.pop(i)
        return None

    def __len__(self):
        return self._n + len(self._held)

    def is_full(self):
        return self._n + len(self._held) >= self.capacity

    def __iter__(self):
        # Every request the queue holds, in no particular order (for status
        # queries). Do not push/pop/cancel while iterating.
        for h in self._heaps:
            for r in h or _NONE:
                yield r
        for r in self._held:
            yield r
