# Node discovery (seed 000, the WHOI Micro-Modem scheme): a node that has had
# nothing to send for one advert period broadcasts a compact advert; any frame
# heard refreshes its source; a node not heard for `lost_after` of its own
# advert periods becomes unavailable.
#
# Advert payload, 2 bytes: node id (0..254; 256..65534 take 3 bytes, as in
# acomm.frame's addr_bytes), then the sender's advert period in units of 4 s
# (1..255, so up to 17 minutes), which tells listeners how long silence may
# last before the node counts as lost.

from ..compat import const, ticks_add, ticks_diff
from ..errors import DecodeError
from ..frame import get_addr
from ..prng import Prng

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_AVAILABLE = const(1)
_UNAVAILABLE = const(2)
_UNKNOWN = const(0)

_PERIOD_UNIT_MS = const(4000)


def encode_advert(node_id, period_ms):
    """The advert's bytes: node_id (a node id, see acomm.frame), then
    period_ms in 4 s units, 1..255."""
    units = (period_ms + _PERIOD_UNIT_MS - 1) // _PERIOD_UNIT_MS
    if units < 1:
        units = 1
    elif units > 255:
        units = 255
    return bytes((node_id, units) if node_id < 255 else (255, node_id >> 8, node_id & 0xFF, units))  # acomm.frame.addr_bytes


def decode_advert(data):
    """-> (node id, period in ms). Raises DecodeError."""
    if len(data) == 2 and data[0] != 255:
        node_id, i = data[0], 1  # no get_addr: its tuple on every advert heard
    else:
        node_id, i = get_addr(data, 0)
    if len(data) != i + 1:
        raise DecodeError("advert of %d bytes, expected %d" % (len(data), i + 1))
    if data[i] == 0:
        raise DecodeError("advert with zero period")
    return node_id, data[i] * _PERIOD_UNIT_MS


class Discovery:
    # Availability of the remote nodes heard on one link. Bounded: at most
    # `capacity` nodes are tracked; further nodes are ignored (and counted)
    # until a tracked one is lost and forgotten.
    def __init__(self, period_ms, lost_after=3, capacity=32, seed=1, jitter=0.1):
        self.period_ms = period_ms
        # Adverts go after `period_ms` of silence less a random part of up
        # to `jitter` of it, drawn again after each advert: two nodes that
        # start together would otherwise advertise together for ever, and a
        # half-duplex modem does not hear while it transmits.
        self.jitter = jitter
        self._rng = Prng(seed)
        self._wait = period_ms
        self.lost_after = lost_after
        self._cap = capacity
        # node id -> [last heard, the period it announced, state]; read by
        # the console, changed only here
        self.nodes = {}
        self.ignored = 0
        # no node can be lost before this time (None: nobody to watch); a
        # lower bound, so poll() scans the table only when something may
        # be due instead of on every call
        self._next = None

    def heard(self, node_id, now, period_ms=None):
        # Returns AVAILABLE when the node just became available, else None.
        e = self.nodes.get(node_id)
        if e is None:
            if len(self.nodes) >= self._cap and not self._forget_one():
                self.ignored += 1
                return None
            e = [now, period_ms or self.period_ms, _UNKNOWN]
            self.nodes[node_id] = e
        e[0] = now
        if period_ms:
            e[1] = period_ms
        due = ticks_add(now, e[1] * self.lost_after)
        if self._next is None or ticks_diff(due, self._next) < 0:
            self._next = due
        if e[2] != _AVAILABLE:
            e[2] = _AVAILABLE
            return _AVAILABLE
        return None

    def _forget_one(self):
        for k in self.nodes:
            if self.nodes[k][2] == _UNAVAILABLE:
                del self.nodes[k]
                return True
        return False

    def poll(self, now):
        # Node ids that just became unavailable.
        if self._next is None or ticks_diff(now, self._next) < 0:
            return ()
        lost = None
        nxt = None
        for k in self.nodes:
            e = self.nodes[k]
            if e[2] != _AVAILABLE:
                continue
            left = e[1] * self.lost_after - ticks_diff(now, e[0])
            if left <= 0:
                e[2] = _UNAVAILABLE
                if lost is None:
                    lost = []
                lost.append(k)
            elif nxt is None or left < nxt:
                nxt = left
        self._next = None if nxt is None else ticks_add(now, nxt)
        return lost or ()

    def loss_due(self, now):
        # whether poll(now) may have a node to declare lost
        return self._next is not None and ticks_diff(now, self._next) >= 0

    def state(self, node_id):
        e = self.nodes.get(node_id)
        return _UNKNOWN if e is None else e[2]

    def last_heard(self, node_id):
        # ticks when a frame from node_id was last heard, or None
        e = self.nodes.get(node_id)
        return None if e is None else e[0]

    def available(self):
        return [k for k in self.nodes if self.nodes[k][2] == _AVAILABLE]

    def advert_due(self, now, last_tx):
        return last_tx is None or ticks_diff(now, last_tx) >= self._wait

    def advert_sent(self):
        spread = int(self.period_ms * self.jitter)
        self._wait = self.period_ms - (self._rng.below(spread + 1) if spread > 0 else 0)
