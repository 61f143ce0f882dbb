# The neighbours of one link and how good each link to them is: the first
# part of routing (issue 36, docs/routing.md). A transport that learns
# routes gives each routing link one (Link.neighbours); the link feeds it
# the adverts and frames it hears, the transport its polls' outcomes.
#
# The figure is ETX, the expected number of transmissions for one frame to
# get through and be acknowledged (De Couto et al.; the metric UnetStack's
# and many mesh routers' costs start from): 1 / (forward delivery ratio x
# reverse delivery ratio). It is estimated from two kinds of evidence:
#
#   attempts  each transmission towards the neighbour that asked for an
#             acknowledgement, and whether one came (ARQ outcomes, link ACKs,
#             SACKs): that measures both directions at once;
#   adverts   a neighbour announces its advert period, so the adverts that
#             did not arrive between two that did are known losses on the
#             way from it; without attempts the link is taken as symmetric
#             (ETX = 1 / ratio^2), as a node that has not yet sent anything
#             there can only guess.
#
# Each ratio is an exponentially weighted average, in integers (Q16, weight
# 1/8 per outcome: about the last 8 outcomes count), so a board does no
# float work per frame. Attempts, once there are RECENT_ATTEMPTS of them,
# are the figure; adverts fill in before that.
#
# Ageing: a neighbour not heard for max_age_ms has no figure (etx() -> None),
# since the sea it was measured in has moved on; it keeps its place only
# until the table needs room, and when heard again it starts afresh. The
# table holds at most `capacity` neighbours; a newcomer takes the place of
# the one heard longest ago, but not of one
# heard within keep_ms (so a burst of new ids, a noise pattern or a forger
# without the key, cannot wipe an established table); it is then refused
# and counted. Signal figures the modem reports (RSSI, SNR: SeaTrac,
# EvoLogics, Micro-Modem) are kept per neighbour as an average, for the
# console and for ties; they do not enter ETX, since no two modems report
# them on one scale.

from ..compat import const, ticks_diff
from ..errors import AcommError

_ONE = const(65536)  # ratio 1.0 in Q16
_SHIFT = const(3)  # weight 1/8 per outcome
_FLOOR = const(655)  # ratio just under 0.01: with the clamp, ETX at most 100 ("never delivers")
RECENT_ATTEMPTS = const(4)  # attempts before they alone make the figure
_MAX_ETX16 = const(1600)  # ETX 100
_MAX_MISSED = const(16)  # adverts counted missed per gap at most: a long gap says "gone", ageing says it
NO_SIGNAL = None

# entry fields (a list per neighbour: one allocation, indexed)
_HEARD = const(0)  # ticks last heard
_ADV = const(1)  # Q16 ratio from adverts, or -1 before the first advert
_ADV_AT = const(2)  # ticks of the last advert, or None
_PERIOD = const(3)  # its advertised period, ms
_TRY = const(4)  # Q16 ratio from attempts, or -1
_TRIES = const(5)  # attempts seen, saturating at RECENT_ATTEMPTS
_RSSI = const(6)  # average, or None
_SNR = const(7)


def _ewma(avg, sample):
    # sample is _ONE (delivered) or 0 (lost)
    return avg + ((sample - avg) >> _SHIFT)


class Neighbours:
    """The neighbours heard on one link with an ETX each (see the module's notes). Bounded by
    capacity; ids are node ids (0..254, 256..65534). Times are ticks (ms)."""

    def __init__(self, capacity=32, max_age_ms=600000, keep_ms=60000):
        self.capacity = capacity
        self.max_age_ms = max_age_ms
        self.keep_ms = keep_ms
        self.table = {}  # node id -> entry list
        self.refused = 0  # newcomers refused for want of room

    def _entry(self, now, node_id):
        if not 0 <= node_id <= 65534 or node_id == 255:
            raise AcommError("neighbour id %r is not a node id" % (node_id,))
        e = self.table.get(node_id)
        if e is not None:
            return e
        if len(self.table) >= self.capacity and not self._evict(now):
            self.refused += 1
            return None
        e = [now, -1, None, 0, -1, 0, None, None]
        self.table[node_id] = e
        return e

    def _evict(self, now):
        oldest = None
        age = -1
        for k in self.table:
            a = ticks_diff(now, self.table[k][_HEARD])
            if a > age:
                oldest, age = k, a
        if oldest is None or age < self.keep_ms:
            return False
        del self.table[oldest]
        return True

    def heard(self, now, node_id, advert_period_ms=0, rssi=None, snr=None):
        """A frame from node_id (an advert when advert_period_ms is its announced period). -> False
        when the table had no room for a newcomer."""
        e = self._entry(now, node_id)
        if e is None:
            return False
        if ticks_diff(now, e[_HEARD]) >= self.max_age_ms:
            # back after a silence past the age limit: what was measured before it (the polls
            # that went unanswered while it was away) is of another sea, and would keep it
            # unused now that it is back
            e[_ADV] = e[_TRY] = -1
            e[_ADV_AT] = None
            e[_TRIES] = 0
        e[_HEARD] = now
        if advert_period_ms > 0:
            last = e[_ADV_AT]
            avg = e[_ADV]
            if last is None or avg < 0:
                avg = _ONE  # the first advert: nothing known to be missed yet
            else:
                # the adverts that should have come in between and did not
                missed = (ticks_diff(now, last) + advert_period_ms // 2) // advert_period_ms - 1
                if missed > _MAX_MISSED:
                    missed = _MAX_MISSED
                while missed > 0:
                    avg = _ewma(avg, 0)
                    missed -= 1
                avg = _ewma(avg, _ONE)
            e[_ADV] = avg
            e[_ADV_AT] = now
            e[_PERIOD] = advert_period_ms
        if rssi is not None:
            e[_RSSI] = rssi if e[_RSSI] is None else e[_RSSI] + (rssi - e[_RSSI]) / 4
        if snr is not None:
            e[_SNR] = snr if e[_SNR] is None else e[_SNR] + (snr - e[_SNR]) / 4
        return True

    def attempt(self, now, node_id, delivered):
        """One transmission to node_id that asked for an acknowledgement, and whether one came."""
        e = self._entry(now, node_id)
        if e is None:
            return
        sample = _ONE if delivered else 0
        e[_TRY] = sample if e[_TRY] < 0 else _ewma(e[_TRY], sample)
        if e[_TRIES] < RECENT_ATTEMPTS:
            e[_TRIES] += 1
        if delivered:
            e[_HEARD] = now  # an acknowledgement is a frame from it

    def etx16(self, now, node_id):
        """ETX x 16 as an integer (16: one transmission does it; 1600 at most), or None when there is
        no figure: never heard, aged out, or nothing to estimate from."""
        e = self.table.get(node_id)
        if e is None or ticks_diff(now, e[_HEARD]) >= self.max_age_ms:
            return None
        if e[_TRIES] >= RECENT_ATTEMPTS or (e[_TRIES] and e[_ADV] < 0):
            p = e[_TRY]
            if p < _FLOOR:
                p = _FLOOR
            t = (16 * _ONE + p // 2) // p
            return t if t < _MAX_ETX16 else _MAX_ETX16
        if e[_ADV] < 0:
            return None
        p = e[_ADV]
        if p < _FLOOR:
            p = _FLOOR
        # 1 / p^2 in two divisions, each within a 32-bit board's small ints
        t = ((16 * _ONE + p // 2) // p * _ONE + p // 2) // p
        return t if t < _MAX_ETX16 else _MAX_ETX16

    def etx(self, now, node_id):
        """ETX as a float (1.0 best), or None (see etx16)."""
        v = self.etx16(now, node_id)
        return None if v is None else v / 16

    def signal(self, node_id):
        """(average RSSI, average SNR) as the modem reported them, each None when it did not."""
        e = self.table.get(node_id)
        return (None, None) if e is None else (e[_RSSI], e[_SNR])

    def usable(self, now):
        """Ids with a figure, best ETX first (then the most recently heard)."""
        out = []
        for k in self.table:
            v = self.etx16(now, k)
            if v is not None:
                out.append((v, -ticks_diff(self.table[k][_HEARD], now), k))
        out.sort()
        return [k for _, _, k in out]
