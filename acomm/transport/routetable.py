# Learned routes, the second part of routing (issue 36): what a node knows
# of the way to each destination it has heard of, by the rules AODV gives
# for loop freedom (RFC 3561, section 6.2), in a bounded table, which
# acomm.transport.route.Router consults after the static routes (those
# still win) and acomm.transport.routefinder fills.
#
# A route: destination -> (next hop, link, cost, destination sequence
# number, expiry). An offer replaces what is there when
#   - there is no route, or it expired or was invalidated, or
#   - the offer's sequence number is newer (modulo 65,535, RFC 1982 style), or
#   - it is as new and cheaper.
# An older sequence number never wins: that is what keeps routes free of
# loops when nodes learn from stale replies. Costs are integers: the sum
# over the hops of ETX x 16 (acomm.link.neighbours) x the hop's airtime
# factor, so an Iridium hop and an acoustic hop compare.
#
# invalidate(next_hop) is the broken-link case: every route through that
# hop is marked invalid (kept, with its sequence number raised by one, as
# RFC 3561 does, so that only fresher news restores it) and returned for
# the route error to name. Bounded: at most `capacity` destinations; a new
# one takes the place of an expired or invalid route first, else of the one
# used longest ago; refused (and counted) when every route is valid and
# used within keep_ms.

from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError

# numbers 0..65534: 0xFFFF is "unknown" on the water (acomm.transport.routewire)
SEQ_MOD = const(65535)
_HALF = const(32767)

# entry fields
NEXT = const(0)  # next hop's node id
LINK = const(1)  # the link's name
COST = const(2)
SEQ = const(3)  # destination sequence number, or -1 unknown
EXPIRES = const(4)  # ticks
VALID = const(5)
USED = const(6)  # ticks last looked up or refreshed


def seq_newer(a, b):
    """True when sequence number a is newer than b (modulo SEQ_MOD; -1 is older than any)."""
    if b < 0:
        return a >= 0
    if a < 0:
        return False
    d = (a - b) % SEQ_MOD
    return 0 < d < _HALF


class RouteTable:
    """Destination id -> route, by AODV's rules (see the module's notes). Times are ticks (ms)."""

    def __init__(self, capacity=32, keep_ms=60000):
        self.capacity = capacity
        self.keep_ms = keep_ms
        self.routes = {}
        self.refused = 0

    def offer(self, now, dest, next_hop, link, cost, seq, lifetime_ms):
        """A route heard of (a reply, a request's reverse path, traffic passing through). -> True
        when it is now the route to dest."""
        if not (0 <= dest <= 254 and 0 <= next_hop <= 254) or cost < 0 or seq >= SEQ_MOD:
            raise AcommError("route to %r via %r: bad id, cost or sequence number" % (dest, next_hop))
        r = self.routes.get(dest)
        if r is not None and self._live(now, r):
            if seq_newer(r[SEQ], seq) or (r[SEQ] == seq and cost >= r[COST]) or (seq < 0 <= r[SEQ]):
                if r[NEXT] == next_hop and r[SEQ] == seq and cost == r[COST]:
                    r[EXPIRES] = _later(r[EXPIRES], ticks_add(now, lifetime_ms))  # the same route, heard again
                return False
        elif r is not None and r[SEQ] >= 0 and seq_newer(r[SEQ], seq):
            return False  # an invalid route's raised number: only fresher news restores it
        if r is None:
            if len(self.routes) >= self.capacity and not self._evict(now):
                self.refused += 1
                return False
            r = [0, None, 0, -1, now, False, now]
            self.routes[dest] = r
        r[NEXT] = next_hop
        r[LINK] = link
        r[COST] = cost
        r[SEQ] = seq
        r[EXPIRES] = ticks_add(now, lifetime_ms)
        r[VALID] = True
        r[USED] = now
        return True

    def _live(self, now, r):
        return r[VALID] and ticks_diff(r[EXPIRES], now) > 0

    def _evict(self, now):
        victim = None
        score = None
        for d in self.routes:
            r = self.routes[d]
            # dead routes first (score below every live one), then the least recently used
            s = ticks_diff(now, r[USED]) + (1 << 29 if not self._live(now, r) else 0)
            if score is None or s > score:
                victim, score = d, s
        if victim is None or (score < (1 << 29) and score < self.keep_ms):
            return False
        del self.routes[victim]
        return True

    def lookup(self, now, dest):
        """-> (next hop, link name, cost) of a live route to dest, or None."""
        r = self.routes.get(dest)
        if r is None or not self._live(now, r):
            return None
        r[USED] = now
        return r[NEXT], r[LINK], r[COST]

    def seq(self, dest):
        """The newest destination sequence number known for dest, or -1."""
        r = self.routes.get(dest)
        return -1 if r is None else r[SEQ]

    def invalidate_dest(self, now, dest):
        """dest's route turns invalid (a route error named it). -> (dest, raised seq), or None when
        there was no live route."""
        r = self.routes.get(dest)
        if r is None or not self._live(now, r):
            return None
        r[VALID] = False
        if r[SEQ] >= 0:
            r[SEQ] = (r[SEQ] + 1) % SEQ_MOD
        return dest, r[SEQ]

    def refresh(self, now, next_hop, link, lifetime_ms):
        """The hop answered on link: its live routes last lifetime_ms from now at least (AODV's
        active routes: a route in use does not expire under its traffic)."""
        t = ticks_add(now, lifetime_ms)
        for d in self.routes:
            r = self.routes[d]
            if r[NEXT] == next_hop and r[LINK] == link and self._live(now, r):
                r[EXPIRES] = _later(r[EXPIRES], t)

    def invalidate(self, now, next_hop, link=None):
        """The hop is gone (on `link`, or on any): its routes turn invalid. -> [(dest, seq)] to
        name in a route error."""
        out = []
        for d in self.routes:
            r = self.routes[d]
            if r[NEXT] == next_hop and (link is None or r[LINK] == link) and self._live(now, r):
                r[VALID] = False
                if r[SEQ] >= 0:
                    r[SEQ] = (r[SEQ] + 1) % SEQ_MOD
                out.append((d, r[SEQ]))
        return out


def _later(a, b):
    return b if ticks_diff(b, a) > 0 else a
