# Network-wide flooding without I/O (issue 36, part 3): a node's side of
# sending a short message to every node ("all divers surface", a rendezvous
# schedule) over acomm.transport.routing's flood message, a CONTROL frame.
# acomm.transport.routing runs it on a node (Transport.flood, docs/routing.md).
#
#   send(now, data, hops_limit=None) -> id   originate a flood
#   heard(now, link, hop, payload)   a CONTROL frame's payload from neighbour hop
#   poll(now); take() -> [(link, BROADCAST, payload)]   what is due at now
#   next_ms(now)                     ms until the next is due (None: nothing held)
#   events: ("flood", origin, data) in take_events(), once per (origin, id)
#
# Rules: a node delivers each (origin, id) once, remembering the last
# seen_cap of them (oldest forgotten first), and schedules one rebroadcast
# after a random 0..jitter_ms, so that neighbours that heard the same copy do
# not all transmit at once. Counter-based suppression (Ni, Tseng et al., "The
# broadcast storm problem in a mobile ad hoc network", 1999): a node that
# hears the same flood max_copies times in all before its rebroadcast is due
# cancels it, as its neighbours have most likely heard it already; on a dense
# cluster most of the rebroadcasts, and the collisions they cause on a
# half-duplex acoustic channel, go away. The price is coverage: a node whose
# only way in is a neighbour that was silenced never hears the flood. 3 is
# the default because 2 stranded a node in 19 of 50 floods on an 8x8 grid
# (3: none; tests/core/test_flood.py); 0 turns suppression off, and only then
# is every node of a connected network sure to be reached.
#
# The hop count rises by one per relay; a copy whose count reaches max_hops is
# delivered and not passed on. An origin limits its flood to hops_limit hops by
# starting the count at max_hops - hops_limit, so every node must share
# max_hops (as AODV's nodes share the network diameter).
#
# Bounds: the duplicate cache holds seen_cap keys, and at most pending_cap
# broadcasts wait to be taken (each for 0..jitter_ms). When they are full, a relay heard is delivered but not
# passed on (stats["dropped"]), while an origin's own send takes the place of
# the relay due last, and raises AcommError only when every place holds one of
# its own sends not yet taken.

from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError, DecodeError, EncodeError
from ..frame import addr_bytes, get_addr
from ..prng import Prng

BROADCAST = const(255)
# the flood message on the water (docs/wire-format.md, "Route control"), kept here and not with
# routing's messages in acomm.transport.routing, which loads this module: an import back would be
# a cycle. routing.decode() hands a flood's bytes to decode_flood, so both read it one way.
#   kind 0 (top 2 bits) | hops (6 bits)   origin   id   data (1..MAX_DATA bytes)
# A flood's data fits a sealed elided frame on a 30-byte SeaTrac packet, the smallest acoustic MTU
# acomm drives: 30 - 2 (link byte, flags byte) - 7 (counter and 4-byte tag) - 3 (its header) = 18.
MAX_DATA = const(18)
MAX_HOPS = const(63)  # acomm.transport.routing.MAX_HOPS


def encode_flood(origin, mid, hops, data):
    """A flood message: origin (a node id: 0..254 in one byte, 256..65534 in three), its id
    0..255, hops 0..63, then 1..MAX_DATA bytes of data."""
    if not isinstance(data, (bytes, bytearray, memoryview)) or not 1 <= len(data) <= MAX_DATA:
        raise EncodeError("flood data must be 1..%d bytes" % MAX_DATA)
    for v, top, what in ((hops, MAX_HOPS, "count"), (origin, 65534, "origin"), (mid, 255, "flood id")):
        if not isinstance(v, int) or not 0 <= v <= top or (v == 255 and top == 65534):
            raise EncodeError("%s %r outside 0..%d" % (what, v, top))
    # kind 0: the top bits of hops stay clear
    if origin < 255:
        return bytes((hops, origin, mid)) + bytes(data)
    return bytes((hops,)) + addr_bytes(origin) + bytes((mid,)) + bytes(data)


def decode_flood(data):
    """A flood message (kind 0) -> ("flood", origin, id, hops, data); DecodeError for a wrong
    length or the broadcast id as its origin."""
    if not data or data[0] >> 6:
        raise DecodeError("not a flood")
    if len(data) > 1 and data[1] != 255:
        origin, i = data[1], 2
    else:
        origin, i = get_addr(data, 1)
    if not i + 2 <= len(data) <= i + 1 + MAX_DATA:
        raise DecodeError("flood of %d bytes" % len(data))
    return ("flood", origin, data[i], data[0], bytes(data[i + 1 :]))


class Flooder:
    def __init__(self, node_id, links=("acoustic",), jitter_ms=2000, max_copies=3, seen_cap=32,
                 max_hops=MAX_HOPS, pending_cap=8, seed=1):
        if not 1 <= max_hops <= MAX_HOPS:
            raise AcommError("max_hops %r outside 1..%d" % (max_hops, MAX_HOPS))
        self.node_id = node_id
        self.links = tuple(links)
        self.jitter_ms = jitter_ms
        self.max_copies = max_copies
        self.seen_cap = seen_cap
        self.max_hops = max_hops
        self.pending_cap = pending_cap
        self._rng = Prng(seed)
        # a random first id: a node that restarts (with a new seed) is less
        # likely to reuse ids its neighbours still hold as seen
        self._mid = self._rng.below(256)
        self._seen = []  # (origin, id), oldest first
        # [due, origin, id, hops to send, data, copies heard]; origin == node_id: our own send
        self._pending = []
        self._now = None
        self._events = []
        self.stats = {"sent": 0, "delivered": 0, "rebroadcasts": 0, "suppressed": 0, "duplicates": 0,
                      "dropped": 0, "bad": 0}

    def send(self, now, data, hops_limit=None):
        """Flood data (1..MAX_DATA bytes) to every node within hops_limit (max_hops) hops; -> its id."""
        limit = self.max_hops if hops_limit is None else hops_limit
        if not isinstance(limit, int) or not 1 <= limit <= self.max_hops:
            raise AcommError("hops_limit %r outside 1..%d" % (hops_limit, self.max_hops))
        mid = (self._mid + 1) & 0xFF
        encode_flood(self.node_id, mid, 0, data)  # EncodeError now, not at take()
        if len(self._pending) >= self.pending_cap:
            relays = [p for p in self._pending if p[1] != self.node_id]
            if not relays:
                raise AcommError("flood queue full: %d sends not taken" % len(self._pending))
            last = relays[0]
            for p in relays:
                if ticks_diff(p[0], last[0]) > 0:
                    last = p
            self._pending.remove(last)
            self.stats["dropped"] += 1
        self._mid = mid
        self._pending.append([now, self.node_id, mid, self.max_hops - limit, bytes(data), 0])
        self.stats["sent"] += 1
        return mid

    def heard(self, now, link, hop, payload):
        """A CONTROL payload from neighbour hop; True when it was a flood's (bad bytes counted, dropped)."""
        if payload and payload[0] >> 6 != 0:  # not a flood (kind 0)
            return False  # route discovery's
        try:
            _, origin, mid, hops, data = decode_flood(payload)
        except DecodeError:
            self.stats["bad"] += 1
            return True
        if origin == self.node_id:
            return True  # our own, come back
        key = (origin, mid)
        if key in self._seen:
            self.stats["duplicates"] += 1
            for p in self._pending:
                if p[1] == origin and p[2] == mid:
                    p[5] += 1
                    if self.max_copies and p[5] >= self.max_copies:
                        self._pending.remove(p)  # enough neighbours sent it: ours adds little
                        self.stats["suppressed"] += 1
                    break
            return True
        self._seen.append(key)
        if len(self._seen) > self.seen_cap:
            self._seen.pop(0)
        self._events.append(("flood", origin, data))
        self.stats["delivered"] += 1
        if hops + 1 >= self.max_hops:
            return True  # this node is the last hop the flood may reach
        if len(self._pending) >= self.pending_cap:
            self.stats["dropped"] += 1  # the held ones were promised first
            return True
        due = ticks_add(now, self._rng.below(self.jitter_ms + 1)) if self.jitter_ms else now
        self._pending.append([due, origin, mid, hops + 1, data, 1])
        return True

    def poll(self, now):
        """Sets the time take() sends by."""
        self._now = now

    def take(self):
        """The broadcasts due at the time poll() was given: [(link, BROADCAST, payload)]."""
        out = []
        if self._now is None:
            return out
        keep = []
        for p in self._pending:
            if ticks_diff(self._now, p[0]) < 0:
                keep.append(p)
                continue
            payload = encode_flood(p[1], p[2], p[3], p[4])
            for link in self.links:
                out.append((link, BROADCAST, payload))
            if p[1] != self.node_id:
                self.stats["rebroadcasts"] += 1
        self._pending = keep
        return out

    def next_ms(self, now):
        """Milliseconds until the next broadcast is due (0: now), None when none is held."""
        best = None
        for p in self._pending:
            d = ticks_diff(p[0], now)
            if best is None or d < best:
                best = d
        return None if best is None else (0 if best < 0 else best)

    def take_events(self):
        """The ("flood", origin, data) deliveries since the last call."""
        out, self._events = self._events, []
        return out
