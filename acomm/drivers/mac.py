# Medium access: when a node may start a transmission on a shared acoustic
# channel. A MAC wraps a driver and offers the same driver interface to the
# Link (acomm.drivers), so neither the link nor the driver changes: the MAC
# only holds ready() false outside the node's turn.
#
#   Tdma   a slot table [(owner, duration_ms, guard_ms), ...] repeated from a
#          common epoch. A node starts transmissions only inside its own
#          slots, after the guard and early enough that its longest
#          transmission (tx_ms) plus the guard still ends in the slot. The
#          guard absorbs clock skew between nodes and propagation: with a
#          skew of at most s ms and a range of at most r m, guard >= s + r/c
#          keeps slots apart at every receiver.
#   Aloha  random access: before each transmission the node waits a random
#          backoff of 0..max_backoff_ms (acomm.prng, so runs repeat). The
#          link asks ready() whether or not it has a frame, so a backoff that
#          ran out long ago (an idle link) is drawn again: a frame that comes
#          at an idle moment still waits a random time.
#   MacDriver(driver, mac)   the wrapper the Link is given. Its `mac` may be
#          swapped at run time (a mission that changes schedule), or set to
#          None while something else orders the channel (a scripted
#          interrogation cycle): then ready() is the driver's own.
#
# A modem's automatic replies (a SeaTrac beacon answering a REQ, a
# Micro-Modem acking a frame) are not under the MAC: size the slot of the
# node that asks so that the answer fits in it.

from ..compat import ticks_add, ticks_diff
from ..errors import AcommError
from ..prng import Prng


class Tdma:
    def __init__(self, slots, me, epoch=0, tx_ms=0):
        if not slots:
            raise AcommError("a TDMA schedule needs at least one slot")
        self.slots = []
        t = 0
        for owner, duration, guard in slots:
            if duration <= 2 * guard:
                raise AcommError("slot of %d ms cannot hold two guards of %d ms" % (duration, guard))
            self.slots.append((owner, t, duration, guard))
            t += duration
        self.cycle_ms = t
        self.me = me
        self.epoch = epoch
        self.tx_ms = tx_ms
        if not any(s[0] == me for s in self.slots):
            raise AcommError("node %r has no slot in the schedule" % (me,))

    def slot_at(self, now):
        # -> (index, ms since that slot began)
        k = ticks_diff(now, self.epoch) % self.cycle_ms  # Python % is never negative
        for i in range(len(self.slots)):
            s = self.slots[i]
            if k < s[1] + s[2]:
                return i, k - s[1]
        return len(self.slots) - 1, k - self.slots[-1][1]  # not reached

    def may_start(self, now):
        i, into = self.slot_at(now)
        owner, _, duration, guard = self.slots[i]
        return owner == self.me and guard <= into <= duration - guard - self.tx_ms

    def next_start(self, now):
        # the next time at or after `now` when this node may start
        k = ticks_diff(now, self.epoch) % self.cycle_ms
        best = None
        for owner, start, duration, guard in self.slots:
            if owner != self.me:
                continue
            lo = start + guard
            hi = start + duration - guard - self.tx_ms
            if hi < lo:
                continue
            if k <= hi:
                wait = lo - k if k < lo else 0
            else:
                wait = self.cycle_ms - k + lo
            if best is None or wait < best:
                best = wait
        return None if best is None else ticks_add(now, best)

    def sent(self, now):
        pass


class Aloha:
    def __init__(self, max_backoff_ms, seed=1):
        self.max_backoff_ms = max_backoff_ms
        self.rng = Prng(seed)
        self.until = None  # ticks when the backoff drawn for the next frame ends; None: none drawn
        self.backoffs = 0

    def may_start(self, now):
        u = self.until
        if u is None or ticks_diff(now, u) > self.max_backoff_ms:
            wait = self.rng.below(self.max_backoff_ms + 1) if self.max_backoff_ms > 0 else 0
            self.until = u = ticks_add(now, wait)
            self.backoffs += 1
        return ticks_diff(now, u) >= 0

    def next_start(self, now):
        return now if self.until is None else self.until

    def sent(self, now):
        self.until = None  # the next frame draws a new backoff


class MacDriver:
    """The driver interface of the driver it wraps, with ready() gated by a medium access rule."""

    def __init__(self, driver, mac):
        self.driver = driver
        self.mac = mac
        self.held = 0  # ready() calls answered "not your turn"
        q = getattr(driver, "queue_reply", None)
        if q is not None:  # a modem's automatic reply is not under the MAC
            self.queue_reply = q

    @property
    def caps(self):
        return self.driver.caps

    @property
    def broadcast_addr(self):
        return self.driver.broadcast_addr

    def ready(self, now):
        if not self.driver.ready(now):
            return False
        m = self.mac
        if m is None or m.may_start(now):
            return True
        self.held += 1
        return False

    def send(self, now, addr, data, ack=False):
        h = self.driver.send(now, addr, data, ack)
        if self.mac is not None:
            self.mac.sent(now)
        return h

    def ping(self, now, addr):
        h = self.driver.ping(now, addr)
        if self.mac is not None:
            self.mac.sent(now)
        return h

    def feed(self, now, data):
        self.driver.feed(now, data)

    def poll(self, now):
        self.driver.poll(now)

    def take_events(self):
        return self.driver.take_events()

    def take_output(self):
        return self.driver.take_output()

    def __getattr__(self, name):
        # anything else (stats, airtime_ms, last_fix ...) is the driver's
        return getattr(self.driver, name)
