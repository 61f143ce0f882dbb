# The acoustic channel of the simulated ocean: the shared Medium of the modem
# emulators (same interface, so every emulator runs on it unchanged) with
# what a real channel adds:
#
# - motion: a node moves along waypoints at a speed, or drifts at a constant
#   velocity; distances are taken when a packet leaves;
# - collisions: two packets whose arrivals overlap at a receiver corrupt each
#   other there (both are lost at that receiver, not elsewhere);
# - loss that grows with range, from a piecewise-linear curve of
#   (metres, probability) points, beyond its last point certain loss unless
#   the curve says otherwise, plus a fixed probability (Medium's `loss`);
# - noise bursts: intervals in which nothing is heard (everywhere, or at one
#   receiver);
# - byte errors: damaged bytes in the packets that do arrive, for modems
#   that hand up what they demodulated (the link's FEC repairs them).
#
# Half-duplex comes from Medium: a station that transmits during any part
# of a reception does not hear it. Counters say why each copy was lost.
# Portable Python (runs on the MicroPython unix port with the core tests).

from acomm.compat import ticks_add, ticks_diff

from .medium import Medium
from .prngskip import skip


def interpolate(curve, x):
    # curve: ((x0, y0), (x1, y1), ...) with x increasing
    if not curve:
        return 0.0
    if x <= curve[0][0]:
        return curve[0][1]
    for i in range(1, len(curve)):
        x1, y1 = curve[i]
        if x <= x1:
            x0, y0 = curve[i - 1]
            return y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    return curve[-1][1]


class Track:
    # Where a node is at time t (ms, ticks): still, drifting, or following
    # waypoints at a constant speed (and staying at the last one).
    def __init__(self, start, t0=0, velocity=None, waypoints=None, speed=1.0):
        self.start = start  # (east, north, depth) m
        self.t0 = t0
        self.velocity = velocity  # (ve, vn, vd) m/s
        self.legs = []  # (t_start_ms, t_end_ms, from, to)
        if waypoints:
            t = 0
            here = start
            for wp in waypoints:
                d = _dist(here, wp)
                dt = int(d * 1000 / speed) if speed > 0 else 0
                self.legs.append((t, t + dt, here, wp))
                t += dt
                here = wp

    def at(self, t):
        el = ticks_diff(t, self.t0)
        if el < 0:
            el = 0
        if self.legs:
            for t1, t2, a, b in self.legs:
                if el < t2:
                    f = (el - t1) / (t2 - t1) if t2 > t1 else 1.0
                    return (a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f)
            return self.legs[-1][3]
        if self.velocity:
            s = el / 1000
            v = self.velocity
            return (self.start[0] + v[0] * s, self.start[1] + v[1] * s, self.start[2] + v[2] * s)
        return self.start


def _dist(a, b):
    return ((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2) ** 0.5


class Channel(Medium):
    def __init__(self, default_distance=100.0, loss=0.0, seed=1, sound_speed=1500.0, loss_curve=None,
                 collisions=True, now=0, byte_errors=0.0):
        Medium.__init__(self, default_distance, loss, seed, sound_speed)
        self.loss_curve = loss_curve  # ((metres, p), ...) or None
        self.collisions = collisions
        self._now = now
        self._tracks = {}
        self._near = {}  # src -> (stations in reach that stay put, their reach) (_near_of)
        self._near_curve = None  # the loss curve _near was worked out for
        self._grid = None  # (square east, square north) -> [addr] (_candidates)
        self._place = None  # addr -> its place in the stations' order (_near_of)
        self._bursts = []  # (start, end, receiver or None)
        self._collided = {}  # flight seq -> True (lost at its receiver)
        self.collided = 0  # copies lost to a collision
        self.range_lost = 0  # copies lost to the loss curve
        self.noise_lost = 0  # copies lost in a noise burst
        self.sent = 0  # packets put on the channel
        # chance that a byte of a delivered packet arrives damaged (one bit
        # flipped): a modem that hands up what it demodulated, errors and
        # all, as the seed 004 software modems do; modem models whose packets
        # are not bytes keep theirs whole
        self.byte_errors = byte_errors
        self.damaged = 0  # bytes damaged

    # -- geometry ----------------------------------------------------------------
    def set_position(self, addr, east, north, depth):
        self._tracks.pop(addr, None)
        self._near = {}
        self._grid = None
        Medium.set_position(self, addr, east, north, depth)

    def set_track(self, addr, track):
        self._tracks[addr] = track
        self._near = {}
        self._grid = None

    def set_distance(self, a, b, metres):
        self._near = {}
        self._grid = None
        Medium.set_distance(self, a, b, metres)

    def attach(self, addr, station):
        self._near = {}
        self._grid = None
        self._place = None
        Medium.attach(self, addr, station)

    def detach(self, addr):
        self._near = {}
        self._grid = None
        self._place = None
        Medium.detach(self, addr)

    def _near_of(self, src):
        # The stations closer to src than where the loss curve becomes
        # certain (its last point, when that point's loss is 1), or None
        # when that cannot be known (no such curve, or src moves: its
        # transmissions reach every station the slow way). Every other
        # station loses src's packets for sure. -> ({dst: distance} within
        # reach, ((stations out of reach before it, dst, distance, the
        # curve's loss as Prng.chance compares it), ...) in the stations'
        # order, out of reach after the last, out of reach in all). The
        # stations that stay put are kept per source until a position,
        # distance or station changes (a distance and its loss then stay
        # what they were); those that move (tracks, a few AUVs) are placed
        # at each transmission, where they are then.
        curve = self.loss_curve
        if curve is None or curve[-1][1] < 1.0 or src in self._tracks:
            return None
        if curve is not self._near_curve:
            # a curve assigned since: what was kept holds the old one's reach and losses
            self._near = {}
            self._grid = None
            self._near_curve = curve
        tracks = self._tracks
        lim = curve[-1][0]
        near = self._near.get(src)
        if near is None:
            place = self._places()
            found = []  # (place, dst, distance, loss) of the stations in reach that stay put
            for dst in self._candidates(src, lim):
                if dst != src and dst not in tracks:
                    d = self.distance(src, dst)
                    if d < lim:
                        found.append((place[dst], dst, d, int(interpolate(curve, d) * 0x100000000)))
            found.sort()
            # the stations that stay put, and their reach, which is the answer while no mover is near
            near = self._near[src] = (found, self._reach(src, found))
        if not tracks:
            return near[1]
        place = self._places()
        moving = []
        for dst in tracks:
            if dst != src and dst in place:
                d = self.distance(src, dst)
                if d < lim:
                    moving.append((place[dst], dst, d, int(interpolate(curve, d) * 0x100000000)))
        if not moving:
            return near[1]
        moving.extend(near[0])
        moving.sort()
        return self._reach(src, moving)

    def _places(self):
        # addr -> its place in the stations' order
        place = self._place
        if place is None:
            place = self._place = {a: i for i, a in enumerate(self._stations)}
        return place

    def _reach(self, src, found):
        # _near_of's answer from the stations in reach, (place, dst,
        # distance, loss) in the stations' order: how many out of reach
        # come before each one, and after the last, from the places alone
        me = self._place[src]
        dist = {}
        steps = []
        prev = -1
        for i, dst, d, p in found:
            dist[dst] = d
            steps.append((i - prev - 1 - (1 if prev < me < i else 0), dst, d, p))
            prev = i
        last = len(self._stations) - prev - 2 + (1 if me < prev else 0)
        return (dist, tuple(steps), last, len(self._stations) - 1 - len(steps))

    def _candidates(self, src, lim):
        # the stations that may be within lim metres of src: those in the
        # 3 x 3 squares of side lim around it, when every station has a
        # position and no pair a distance of its own (else all of them)
        if self._dist or lim <= 0:
            return self._stations
        grid = self._grid
        if grid is None:
            grid = {}
            for a in self._stations:
                p = self._pos.get(a)
                if p is None:
                    return self._stations
                grid.setdefault((int(p[0] // lim), int(p[1] // lim)), []).append(a)
            self._grid = grid
        p = self._pos.get(src)
        if p is None:
            return self._stations
        gx, gy = int(p[0] // lim), int(p[1] // lim)
        out = []
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                out.extend(grid.get((gx + dx, gy + dy), ()))
        return out

    def position(self, addr, t=None):
        tr = self._tracks.get(addr)
        if tr is not None:
            return tr.at(self._now if t is None else t)
        return self._pos.get(addr)

    def offset(self, a, b):
        # Medium.distance falls back to this, so tracks count there too
        pa = self.position(a)
        pb = self.position(b)
        if pa is None or pb is None:
            return None
        return (pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2])

    # -- impairments ---------------------------------------------------------------
    def noise_burst(self, start, duration_ms, receiver=None):
        self._bursts.append((start, ticks_add(start, duration_ms), receiver))

    def _in_burst(self, dst, start, end):
        for s, e, r in self._bursts:
            if (r is None or r == dst) and ticks_diff(s, end) < 0 and ticks_diff(e, start) > 0:
                return True
        return False

    def loss_at(self, metres):
        # probability that a packet sent over `metres` is lost on the way
        p = self.loss
        if self.loss_curve is not None:
            p = 1 - (1 - p) * (1 - interpolate(self.loss_curve, metres))
        return p

    # -- the Medium hooks ------------------------------------------------------------
    def transmit(self, now, src, packet, airtime_ms):
        self._now = now
        self.sent += 1
        near = self._near_of(src)
        if near is None:
            return Medium.transmit(self, now, src, packet, airtime_ms)
        # Stations out of reach take the same draws from the generator as
        # Medium.transmit gives them (the fixed loss's, then the curve's,
        # certain), without working out their distance: a large network's
        # transmission costs little per station it cannot reach.
        end = self._start(now, src, airtime_ms)
        rng = self.rng
        if not self.loss:
            # out of reach: one draw each (the curve's, certain), skipped
            # (prngskip) and counted; in reach: _lost_on_the_way without a
            # fixed loss (the curve's draw, rng.chance(p) as next32() < p
            # * 2**32), on the distance and loss kept with the reach
            nxt = rng.next32
            for k, dst, d, p in near[1]:
                if k:
                    skip(rng, k)
                if nxt() < p:
                    self.range_lost += 1
                    continue
                self._fly(now, end, src, dst, packet, d)
            if near[2]:
                skip(rng, near[2])
            self.range_lost += near[3]
            return end
        within = near[0]
        for dst in self._stations:
            if dst == src:
                continue
            if dst not in within:
                if self.loss and rng.chance(self.loss):
                    self.lost += 1
                else:
                    rng.next32()
                    self.range_lost += 1
                continue
            d = within[dst]  # kept with the reach
            if self._lost_on_the_way(d):
                continue
            self._fly(now, end, src, dst, packet, d)
        return end

    def _lost_on_the_way(self, distance):
        if Medium._lost_on_the_way(self, distance):
            return True
        if self.loss_curve is not None and self.rng.chance(interpolate(self.loss_curve, distance)):
            self.range_lost += 1
            return True
        return False

    def poll(self, now):
        self._now = now
        Medium.poll(self, now)
        if self._bursts:  # forget bursts long past
            self._bursts = [b for b in self._bursts if ticks_diff(now, b[1]) < 600000]

    def _damaged(self, packet):
        p = self.byte_errors
        if not p or not isinstance(packet, (bytes, bytearray)):
            return packet
        out = None
        for i in range(len(packet)):
            if self.rng.chance(p):
                if out is None:
                    out = bytearray(packet)
                out[i] ^= 1 << self.rng.below(8)
                self.damaged += 1
        return packet if out is None else bytes(out)

    def _lost_on_arrival(self, item):
        end, seq, dst, _, _, start, _ = item
        hit = self._collided.pop(seq, False)
        if self.collisions:
            for other in self._bound.get(dst, {}).values():
                # every other arrival at this receiver that overlaps this one
                if ticks_diff(other[5], end) < 0 and ticks_diff(other[0], start) > 0:
                    self._collided[other[1]] = True
                    hit = True
        if hit:
            self.collided += 1
            return True
        if self._in_burst(dst, start, end):
            self.noise_lost += 1
            return True
        return False
