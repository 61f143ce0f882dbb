# A channel whose losses follow from physics instead of a loss curve: each
# copy of a packet arrives with the power its sender's source level leaves
# after spreading and absorption (acomm_sim.acoustics), at a receiver whose
# band holds the site's ambient noise, plus the late echoes of the site's
# multipath (acomm_sim.multipath) and whatever other packets overlap it at
# that receiver (interference: a strong near packet survives a weak far one,
# the capture effect). From that signal to noise plus interference ratio,
# acomm_sim.detection gives the chance the preamble is detected and the bit
# error rate; a modem that checks a CRC drops a frame with errors, one that
# hands up bytes gets them damaged (the link's FEC repairs what it can).
# Each copy fades (acomm_sim.fading): one Rician draw per copy, with the K
# factor of its pair's geometry, scales its power, as signal at its
# receiver and as interference at the others it overlaps.
#
# Everything else (motion, half-duplex, noise bursts, counters, the Medium
# interface) is Channel's. Nothing here changes Channel: the curve model
# stays as it is, and this class only replaces its range and collision
# decisions. Per pair of stations, what depends on geometry (received
# power, late echoes) is kept until either end has moved move_m metres.
# Portable Python.

from acomm.compat import ticks_add, ticks_diff

from . import acoustics as ac
from . import detection as det
from . import fading
from . import linkbudget as lb
from .channel import Channel
from .modems_db import model, model_of_station
from .site import Site

_WEAK_DB = -40.0  # a copy this far below the receiver's noise neither decodes nor matters as interference


class PhysicsChannel(Channel):
    """Channel(...) with a physics link budget. site: a Site (defaults if
    None); modems: {address: model name} for stations whose model is not
    their emulator's (modems_db.model_of_station); move_m: how far a node
    moves before its pairs' geometry is worked out again; tl: a transmission
    loss model tl(metres, zs, zr, f_khz) -> dB instead of spreading and
    absorption (acomm_cpython.bellhop's, where arlpy and Bellhop are)."""

    def __init__(self, site=None, modems=None, default_distance=100.0, loss=0.0, seed=1, now=0, move_m=5.0,
                 tl=None):
        site = site if site is not None else Site()
        Channel.__init__(self, default_distance, loss, seed, site.sound_speed, loss_curve=None,
                         collisions=False, now=now)
        self.site = site
        self.move_m = move_m
        self.tl = tl
        self._model = dict(modems or {})  # addr -> model name
        self._pair = {}  # (src, dst) -> (src place, dst place, power, late echo ratio, {nbits: chances}, K, scale)
        self._noise = {}  # model name -> noise power in its band (uPa^2)
        self._alpha = {}  # centre frequency -> absorption dB/km
        self._rx = {}  # flight seq -> (signal power, its late echoes' power, {nbits: chances} or None when it fades)
        self._done = {}  # dst -> [(start, end, power)] arrivals that ended, as interferers
        self._longest = 1  # the longest airtime seen (ms)
        self._byte_p = 0.0  # chance of a damaged byte for the copy being delivered
        self.interfered = 0  # copies lost with other packets overlapping them
        self.undetected = 0  # copies whose preamble was missed

    # -- the modems and the water ------------------------------------------------------
    def set_modem(self, addr, name):
        """Station addr uses modem model `name` (modems_db.MODELS)."""
        model(name)
        self._model[addr] = name
        self._pair = {}

    def model_name(self, addr):
        """The modem model of station addr (set, or its emulator's)."""
        name = self._model.get(addr)
        if name is None:
            st = self._stations.get(addr)
            name = self._model[addr] = model_of_station(st)
        return name

    def absorption(self, f_khz):
        """Absorption in the site's water at f_khz -> dB/km (linkbudget.absorption), kept."""
        a = self._alpha.get(f_khz)
        if a is None:
            a = self._alpha[f_khz] = lb.absorption(self.site, f_khz)
        return a

    def noise_power(self, name):
        """Ambient noise in modem model name's band at this site (uPa^2), kept."""
        n = self._noise.get(name)
        if n is None:
            n = self._noise[name] = lb.noise_power(self.site, model(name))
        return n

    def budget(self, src, dst, metres=None):
        """(received power uPa^2 of the direct path, late echo ratio,
        {nbits: chances without interference or fading}, Rician K or None
        for no fading, mean power of the faded sum over the direct path's)
        of src's packets at dst (linkbudget.arrival, fading.params), kept
        per pair until either end moves move_m (metres: the distance, when
        known; else worked out)."""
        ps = self.position(src)
        pd = self.position(dst)
        key = (src, dst)
        kept = self._pair.get(key)
        if kept is not None and _near(kept[0], ps, self.move_m) and _near(kept[1], pd, self.move_m):
            return kept[2], kept[3], kept[4], kept[5], kept[6]
        d = self.distance(src, dst) if metres is None else metres
        ms = model(self.model_name(src))
        zs = ps[2] if ps is not None else self.site.node_depth_m
        zr = pd[2] if pd is not None else self.site.node_depth_m
        power, late, near = lb.arrival(self.site, ms, model(self.model_name(dst)), d, zs, zr,
                                       self.absorption(lb.centre_khz(ms)), self.tl)
        # nbits -> the chances of a copy no other overlaps and that does not
        # fade (they depend on the geometry only); K of the pair's fading
        k, scale = fading.params(self.site.fading, near)
        kept = self._pair[key] = (ps, pd, power, late, {}, k, scale)
        return power, late, kept[4], k, scale

    def snr_db(self, src, dst):
        """The SNR (dB, in dst's band, no interference, no echoes) of src's packets at dst."""
        return ac.db(self.budget(src, dst)[0] / self.noise_power(self.model_name(dst)))

    # -- geometry changes: what was kept for the pairs no longer holds -------------------
    def set_position(self, addr, east, north, depth):
        self._pair = {}
        Channel.set_position(self, addr, east, north, depth)

    def set_distance(self, a, b, metres):
        self._pair = {}
        Channel.set_distance(self, a, b, metres)

    def detach(self, addr):
        # what is on its way to a station that leaves is never decided:
        # forget its powers (poll drops those copies unheard)
        for seq in self._bound.get(addr, {}):
            self._rx.pop(seq, None)
        self._done.pop(addr, None)
        Channel.detach(self, addr)

    # -- the Medium hooks ------------------------------------------------------------------
    def _fly(self, now, end, src, dst, packet, d):
        power, late, clean, k, scale = self.budget(src, dst, d)
        if power <= 0 or ac.db(power / self.noise_power(self.model_name(dst))) < _WEAK_DB:
            self.range_lost += 1  # lost in the noise, and too weak to disturb anything
            return
        Channel._fly(self, now, end, src, dst, packet, d)
        if k is None:
            self._rx[self._seq] = (power, power * late, clean)
        else:
            # this copy's fade: its power as signal here and as interference
            # to the others it overlaps; its late echoes keep their mean
            self._rx[self._seq] = (power * scale * fading.gain(self.rng, k), power * late, None)

    def cancel(self, src, now):
        Channel.cancel(self, src, now)
        alive = {}
        for item in self._flight:
            v = self._rx.get(item[1])
            if v is not None:
                alive[item[1]] = v
        self._rx = alive

    def _lost_on_arrival(self, item):
        end, seq, dst, src, packet, start, _ = item
        power, isi, clean = self._rx.pop(seq, (0.0, 0.0, None))
        done = self._done.get(dst)
        if done is None:
            done = self._done[dst] = []
        dur = ticks_diff(end, start)
        dur = dur if dur > 0 else 1
        if dur > self._longest:
            self._longest = dur
        # arrivals end in order here, so a finished one that ended before
        # this one's end less the longest airtime yet overlaps nothing to come
        while done and ticks_diff(end, done[0][1]) > self._longest:
            done.pop(0)
        # the others: the arrivals that ended (done, as it was before this
        # one), then those still on their way to dst
        others = list(done)
        for o in self._bound.get(dst, {}).values():
            if o[1] != seq:
                p = self._rx.get(o[1])
                if p is not None:
                    others.append((o[5], o[0], p[0]))
        done.append((start, end, power))
        if self._in_burst(dst, start, end):
            self.noise_lost += 1
            return True
        name = self.model_name(dst)
        m = model(name)
        pre_end = ticks_add(start, int(m["preamble_s"] * 1000))
        frac = 0.0  # the largest share of this copy that another overlaps
        inter = 0.0  # interference power, weighted by overlap
        inter_pre = 0.0  # interference during the preamble
        for s, e, p in others:
            ov = _overlap(start, end, s, e)
            if ov <= 0:
                continue
            f = ov / dur
            if f > frac:
                frac = f
            inter += p * f
            if _overlap(start, pre_end, s, e) > 0:
                inter_pre += p
        noise = self.noise_power(name) + isi
        thr = lb.threshold(m["pfa"])
        if isinstance(packet, (bytes, bytearray)):
            nbits = (len(packet) + m["overhead_bytes"]) * 8
        else:
            nbits = (m["default_bytes"] + m["overhead_bytes"]) * 8
        if inter_pre or frac or clean is None:
            pd, ok, ber = lb.chances(m, power, noise, inter_pre, inter, frac, nbits, thr)
        else:
            c = clean.get(nbits)
            if c is None:
                c = clean[nbits] = lb.chances(m, power, noise, 0.0, 0.0, 0.0, nbits, thr)
            pd, ok, ber = c
        rng = self.rng
        if rng.chance(1 - pd):
            self.undetected += 1
            return self._lost(inter_pre > 0)
        if m["crc"]:
            if rng.chance(1 - ok):
                return self._lost(frac > 0)
            self._byte_p = 0.0
        else:
            # the bytes go up as demodulated: each byte is damaged with the
            # chance that one of its 8 bits is wrong
            self._byte_p = 1 - det.frame_ok(ber, 8)
        return False

    def _lost(self, overlapped):
        # count a lost copy: to interference when another arrival overlapped
        # it (also as a collision, the curve model's name), else to the noise
        if overlapped:
            self.interfered += 1
            self.collided += 1
        else:
            self.range_lost += 1
        return True

    def _damaged(self, packet):
        # one draw for "any byte damaged" (most packets), then Channel's
        # byte by byte; if that damages none, one byte at random (so the
        # packet's chance of damage is exactly 1 - (1 - p)^n)
        p = self._byte_p
        if p < 1e-12 or not isinstance(packet, (bytes, bytearray)):
            return packet
        rng = self.rng
        if not rng.chance(1 - det.frame_ok(p, len(packet))):
            return packet
        keep = self.byte_errors
        self.byte_errors = p
        try:
            out = Channel._damaged(self, packet)
        finally:
            self.byte_errors = keep
        if out is packet and packet:
            out = bytearray(packet)
            out[rng.below(len(out))] ^= 1 << rng.below(8)
            self.damaged += 1
            out = bytes(out)
        return out


def _near(a, b, m):
    # two places (or None) within m metres of each other
    if a is None or b is None:
        return a is b
    return (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2 <= m * m


def _overlap(s1, e1, s2, e2):
    # ms that [s1, e1) and [s2, e2) share (ticks arithmetic)
    a = s1 if ticks_diff(s2, s1) <= 0 else s2
    b = e1 if ticks_diff(e2, e1) >= 0 else e2
    d = ticks_diff(b, a)
    return d if d > 0 else 0
