# A minimal shared acoustic medium for the modem emulators, on injected time.
# The simulator issue replaces it with a full channel model; until then it
# gives what emulated modems need to talk to each other:
#
# - stations attach with their modem address (a SeaTrac beacon id, say);
# - transmit(now, src, packet, airtime_ms) hands `packet` (opaque here) to
#   every other station when its last bit arrives: airtime + distance / c;
# - distances are per pair (default 100 m), or come from positions;
# - optional random loss (acomm.prng.Prng, so runs repeat on both runtimes);
# - half-duplex: a station that transmits during any part of a reception
#   does not hear it.
# Collisions between two senders at one receiver are not modelled.
#
# A station is any object with receive(t, src, packet, distance_m); t is the
# arrival time of the packet's end, which may be a little before `now` when
# poll() runs in steps. Portable Python: runs on the MicroPython unix port.

from acomm.compat import TICKS_MAX, ticks_add, ticks_diff
from acomm.prng import Prng

_MAX = TICKS_MAX
_HALF = (TICKS_MAX + 1) >> 1  # compat.ticks_diff's half period

_TX_HISTORY = 4  # transmissions remembered per station, for half-duplex


class Medium:
    def __init__(self, default_distance=100.0, loss=0.0, seed=1, sound_speed=1500.0):
        self.default_distance = default_distance
        self.loss = loss
        self.sound_speed = sound_speed
        self.rng = Prng(seed)
        self._stations = {}
        self._dist = {}
        self._pos = {}
        self._tx = {}  # addr -> [(start, end), ...] newest last
        self._flight = []  # [end, seq, dst, src, packet, start, distance] by end
        # the same copies by receiver: dst -> {seq: item}, so that what is
        # on its way to one station is found without scanning them all
        self._bound = {}
        self._seq = 0
        self.delivered = 0
        self.lost = 0
        self.deaf = 0  # lost because the receiver was transmitting
        # a list to which poll() appends every station it delivered to (the
        # World wakes their nodes), or None
        self.receivers = None

    def attach(self, addr, station):
        if addr in self._stations and self._stations[addr] is not station:
            raise ValueError("address %r already attached" % (addr,))
        self._stations[addr] = station
        self._tx[addr] = []

    def detach(self, addr):
        self._stations.pop(addr, None)
        self._tx.pop(addr, None)

    def set_distance(self, a, b, metres):
        self._dist[(a, b) if a < b else (b, a)] = metres

    def set_position(self, addr, east, north, depth):
        self._pos[addr] = (east, north, depth)

    def offset(self, a, b):
        # (east, north, down) of b as seen from a, or None without positions
        pa = self._pos.get(a)
        pb = self._pos.get(b)
        if pa is None or pb is None:
            return None
        return (pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2])

    def distance(self, a, b):
        d = self._dist.get((a, b) if a < b else (b, a))
        if d is not None:
            return d
        o = self.offset(a, b)
        if o is not None:
            return (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) ** 0.5
        return self.default_distance

    def transmitting(self, addr, now):
        for s, e in self._tx.get(addr, ()):
            if ticks_diff(now, s) >= 0 and ticks_diff(e, now) > 0:
                return True
        return False

    def transmit(self, now, src, packet, airtime_ms):
        end = self._start(now, src, airtime_ms)
        for dst in self._stations:
            if dst == src:
                continue
            d = self.distance(src, dst)
            if self._lost_on_the_way(d):
                continue
            self._fly(now, end, src, dst, packet, d)
        return end

    def _start(self, now, src, airtime_ms):
        # the sender's half-duplex history; -> when its last bit leaves
        end = ticks_add(now, airtime_ms)
        hist = self._tx.setdefault(src, [])
        hist.append((now, end))
        if len(hist) > _TX_HISTORY:
            hist.pop(0)
        return end

    def _fly(self, now, end, src, dst, packet, d):
        # a copy on its way to dst, in arrival order
        prop = int(d * 1000 / self.sound_speed)
        self._seq += 1
        item = [ticks_add(end, prop), self._seq, dst, src, packet, ticks_add(now, prop), d]
        b = self._bound.get(dst)
        if b is None:
            b = self._bound[dst] = {}
        b[self._seq] = item
        f = self._flight
        # after every copy arriving at or before it: most often the last
        # (copies sent later arrive later, give or take the distance), else
        # found by a binary search (a large network has many copies on
        # their way), with ticks_diff(a, t) > 0 as its arithmetic
        t = item[0]
        if not f or ((f[-1][0] - t + _HALF) & _MAX) - _HALF <= 0:
            f.append(item)
            return
        lo, hi = 0, len(f) - 1
        while lo < hi:
            mid = (lo + hi) >> 1
            if ((f[mid][0] - t + _HALF) & _MAX) - _HALF > 0:
                hi = mid
            else:
                lo = mid + 1
        f.insert(lo, item)

    def _lost_on_the_way(self, distance):
        # decided when the packet leaves (the acoustic channel adds range)
        if self.loss and self.rng.chance(self.loss):
            self.lost += 1
            return True
        return False

    def cancel(self, src, now):
        # src stops transmitting at `now` (a modem that restarts mid-packet):
        # packets whose last bit had not left yet never arrive anywhere
        hist = self._tx.get(src, ())
        for i in range(len(hist)):
            s, e = hist[i]
            if ticks_diff(e, now) > 0:
                hist[i] = (s, now)
        keep = []
        for item in self._flight:
            sent_end = ticks_add(item[0], -int(item[6] * 1000 / self.sound_speed))
            if item[3] == src and ticks_diff(sent_end, now) > 0:
                del self._bound[item[2]][item[1]]
                continue
            keep.append(item)
        self._flight = keep

    def _overlaps(self, addr, start, end):
        for s, e in self._tx.get(addr, ()):
            if ticks_diff(s, end) < 0 and ticks_diff(e, start) > 0:
                return True
        return False

    def poll(self, now):
        f = self._flight
        while f and ticks_diff(f[0][0], now) <= 0:
            item = f.pop(0)
            end, seq, dst, src, packet, start, d = item
            del self._bound[dst][seq]
            st = self._stations.get(dst)
            if st is None:
                continue
            if self._lost_on_arrival(item):
                continue
            if self._overlaps(dst, start, end):
                self.deaf += 1
                continue
            self.delivered += 1
            st.receive(end, src, self._damaged(packet), d)
            if self.receivers is not None:
                self.receivers.append(st)

    def _lost_on_arrival(self, item):
        # what the acoustic channel decides at the receiver (collisions,
        # noise); the plain medium loses nothing there
        return False

    def _damaged(self, packet):
        # what the channel does to the bytes of a packet it delivers
        return packet

    def arriving(self, dst, src):
        # when the first bit of a packet from src in flight to dst arrives
        # (or arrived), or None: a modem may wait for a reply it has begun to hear
        first = None
        for item in self._bound.get(dst, {}).values():
            if item[3] == src and (first is None or ticks_diff(item[0], first[0]) < 0):
                first = item
        return None if first is None else first[5]

    def in_flight(self):
        return len(self._flight)

    def next_arrival(self):
        # when the next packet's last bit arrives somewhere, or None
        return self._flight[0][0] if self._flight else None
