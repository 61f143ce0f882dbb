# The acoustic side of an emulated SeaTrac beacon: DAT and PING packets on the
# shared medium, the automatic reply of a beacon that is asked (REQ/REQU/
# REQX), the requester's reply timeout, and the ACO_FIX records that report
# what was heard (range from the medium distance plus optional noise; bearing,
# elevation and position when the beacon is an X150 and the medium knows
# positions).
#
# Timing (seed 003 section 6.1, ref/modem-protocols.md 1.7): a packet lasts
# packet_ms + byte_ms per data byte (500 + 80 n by default, so a request and
# its empty reply take the 1.3 s minimum turn-around with 300 ms between).
# The reply leaves turnaround_ms + xcvr_resp_time after the request's end.
# The requester gives up after 2 * xcvr_range_tmo / VOS + xcvr_resp_time +
# turnaround + one empty packet, and reports XCVR_RESP_TIMEOUT; a reply whose
# first bit arrived by then is still received to its end (the range timeout
# is about the signal's return, so a reply carrying data is not cut off; our
# assumption, the manual does not say).
#
# DAT_QUEUE_SET (one packet of 0-31 bytes, for one beacon or any): the
# packet rides in the automatic reply to the next DAT request of a REQ type
# from a matching beacon, making that reply byte_ms per byte longer, and is
# then gone. The reply is made up when the request is heard, so a packet
# queued while the reply waits its turnaround goes with the next one. PING
# requests never take it. A beacon with hear_all also reports replies that
# carry data between two other beacons (DAT_RECEIVE, ACK_FLAG 0): passive
# listening, as seed 003 section 6 has the third agent do.

from math import atan2, cos, degrees, radians, sin, sqrt

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers import seatrac_codes as sc
from acomm.prng import Prng

PROTO_PING = 0  # APAYLOAD_E
PROTO_DAT = 3

_REQ = (sc.MSG_REQ, sc.MSG_REQU, sc.MSG_REQX)
_SEND_TYPES = (sc.MSG_OWAY, sc.MSG_OWAYU, sc.MSG_REQ, sc.MSG_REQU, sc.MSG_REQX)


class Packet:
    __slots__ = ("proto", "src", "dst", "mtype", "data")

    def __init__(self, proto, src, dst, mtype, data=b""):
        self.proto = proto
        self.src = src
        self.dst = dst
        self.mtype = mtype
        self.data = data


def _le(v, n):
    return (int(v) & ((1 << (8 * n)) - 1)).to_bytes(n, "little")


def _clamp16(v):
    return -32768 if v < -32768 else (32767 if v > 32767 else int(v))


class Transceiver:
    def __init__(self, beacon, medium, packet_ms, byte_ms, turnaround_ms, range_noise_m, seed, local_flag, hear_all,
                 bearing_noise_deg=0.0):
        self.beacon = beacon
        self.medium = medium
        self.addr = beacon.beacon_id
        self.packet_ms = packet_ms
        self.byte_ms = byte_ms
        self.turnaround_ms = turnaround_ms
        self.range_noise_m = range_noise_m
        self.bearing_noise_deg = bearing_noise_deg
        self.rng = Prng(seed)
        self.local_flag = local_flag
        self.hear_all = hear_all
        self.sent = 0
        self.heard = 0
        self.reset()

    def reset(self):
        self._tx_until = None
        self._pending = None  # [proto, dest, mtype, deadline] awaiting a reply
        self._reply = None  # [due, Packet] our automatic reply
        self._next = None  # the packet a command just accepted
        self.queued = None  # (dest, data) set with DAT_QUEUE_SET; lost in a restart

    # -- timing ------------------------------------------------------------------
    def airtime(self, n):
        return self.packet_ms + self.byte_ms * n

    def _setting16(self, off):
        s = self.beacon.settings
        return s[off] | (s[off + 1] << 8)

    def resp_delay(self):
        return self.turnaround_ms + self._setting16(99)

    def window(self):
        vos = self._setting16(35) or 15000
        return 2 * self._setting16(97) * 10000 // vos + self.resp_delay() + self.airtime(0)

    def busy(self, now):
        if self._tx_until is not None and ticks_diff(self._tx_until, now) > 0:
            return True
        return self._pending is not None or self._reply is not None

    def state(self, now):
        if self._tx_until is not None and ticks_diff(self._tx_until, now) > 0:
            return sc.CST_XCVR_STATE_TX
        if self._reply is not None:
            return sc.CST_XCVR_STATE_RESP
        if self._pending is not None:
            return sc.CST_XCVR_STATE_REQ
        return sc.CST_XCVR_STATE_IDLE

    # -- commands ------------------------------------------------------------------
    def ping_send(self, now, b, n):
        if n < 3:
            return sc.CST_CMD_PARAM_MISSING
        dest, mtype = b[1], b[2]
        if not 1 <= dest <= 15 or dest == self.addr or mtype not in _REQ or n > 3:
            return sc.CST_CMD_PARAM_INVALID
        if self.busy(now):
            return sc.CST_XCVR_BUSY
        self._next = Packet(PROTO_PING, self.addr, dest, mtype)
        return sc.CST_OK

    def dat_send(self, now, b, n):
        if n < 4 or n - 4 < b[3]:
            return sc.CST_CMD_PARAM_MISSING
        dest, mtype, ln = b[1], b[2], b[3]
        if n - 4 > ln or ln > self.beacon.mtu or dest > 15 or dest == self.addr or mtype not in _SEND_TYPES:
            return sc.CST_CMD_PARAM_INVALID
        if dest == sc.BEACON_ALL and mtype not in (sc.MSG_OWAY, sc.MSG_OWAYU):
            return sc.CST_CMD_PARAM_INVALID
        if self.busy(now):
            return sc.CST_XCVR_BUSY
        self._next = Packet(PROTO_DAT, self.addr, dest, mtype, bytes(b[4 : 4 + ln]))
        return sc.CST_OK

    def queue_set(self, b, n):
        # DAT_QUEUE_SET: DEST_ID, PACKET_LEN, PACKET_DATA (the layout
        # UNIZG-FER's driver writes); dest 0 lets any beacon's request take it
        if n < 3 or n - 3 < b[2]:
            return sc.CST_CMD_PARAM_MISSING
        if n - 3 > b[2] or b[2] > 31 or b[1] > 15:
            return sc.CST_CMD_PARAM_INVALID
        self.queued = (b[1], bytes(b[3:n]))
        return sc.CST_OK

    def started(self, now, status):
        # after the command's status line: put the accepted packet on the air
        p = self._next
        self._next = None
        if status != sc.CST_OK or p is None:
            return
        air = self.airtime(len(p.data))
        self._transmit(now, p, air)
        if p.mtype in _REQ:
            self._pending = [p.proto, p.dst, p.mtype, ticks_add(now, air + self.window())]

    def _transmit(self, t, p, air):
        self.sent += 1
        self._tx_until = self.medium.transmit(t, self.addr, p, air)

    def poll(self, now):
        r = self._reply
        if r is not None and ticks_diff(now, r[0]) >= 0:
            self._reply = None
            self._transmit(r[0], r[1], self.airtime(len(r[1].data)))
        pd = self._pending
        if pd is not None and ticks_diff(now, pd[3]) >= 0:
            s = self.medium.arriving(self.addr, pd[1])
            if s is not None and ticks_diff(s, pd[3]) <= 0:
                return  # the reply's signal came back in time: hear it out
            self._pending = None
            cid = sc.CID_PING_ERROR if pd[0] == PROTO_PING else sc.CID_DAT_ERROR
            self.beacon.emit(cid, bytes((sc.CST_XCVR_RESP_TIMEOUT, pd[1])))

    # -- the medium --------------------------------------------------------------
    def receive(self, t, src, p, dist):
        b = self.beacon
        if b._booting_until is not None:
            return
        self.heard += 1
        mine = p.dst == self.addr
        if p.mtype in _REQ or p.mtype in (sc.MSG_OWAY, sc.MSG_OWAYU):
            if p.proto == PROTO_DAT and (mine or p.dst == sc.BEACON_ALL or self.hear_all):
                flags = sc.FIX_USBL if (p.mtype == sc.MSG_OWAYU and b.usbl) else 0
                self._report_dat(p, flags, dist, 0)
            if mine and p.mtype in _REQ:
                if p.proto == PROTO_PING:
                    b.emit(sc.CID_PING_REQ, self.fix(p.dst, src, 0, p.mtype, dist))
                if self._pending is None and self._reply is None:
                    # the firmware answers by itself
                    due = ticks_add(t, self.resp_delay())
                    q = self.queued
                    data = b""
                    if p.proto == PROTO_DAT and q is not None and q[0] in (sc.BEACON_ALL, src):
                        data = q[1]
                        self.queued = None
                    self._reply = [due, Packet(p.proto, self.addr, src, p.mtype + 1, data)]
            return
        if not mine:
            # someone else's reply: heard only when it carries data
            if p.proto == PROTO_DAT and p.data and self.hear_all:
                self._report_dat(p, sc.FIX_USBL if (b.usbl and p.mtype != sc.MSG_RESP) else 0, dist, 0)
            return
        # a reply: only the beacon that asked, for the beacon it asked
        pd = self._pending
        if pd is None or pd[0] != p.proto or pd[1] != src or p.mtype != pd[2] + 1:
            return
        self._pending = None
        flags = sc.FIX_RANGE
        if b.usbl and p.mtype != sc.MSG_RESP:
            flags |= sc.FIX_USBL | sc.FIX_POSITION
        if p.proto == PROTO_PING:
            b.emit(sc.CID_PING_RESP, self.fix(self.addr, src, flags, p.mtype, dist))
        else:
            self._report_dat(p, flags, dist, 1)

    def _report_dat(self, p, flags, dist, ack):
        fix = self.fix(p.dst, p.src, flags, p.mtype, dist)
        fix.append(ack)
        fix.append(len(p.data))
        fix.extend(p.data)
        if self.local_flag:
            fix.append(1 if p.dst in (self.addr, sc.BEACON_ALL) else 0)
        self.beacon.emit(sc.CID_DAT_RECEIVE, fix)

    def fix(self, dest, src, flags, mtype, dist):
        # A well-formed ACO_FIX_T of what this beacon heard from src.
        b = self.beacon
        a = b.attitude
        vos = b.env[4]
        f = bytearray((dest, src, flags, mtype))
        f.extend(_le(a[0], 2) + _le(a[1], 2) + _le(a[2], 2))
        f.extend(_le(b.env[3], 2) + _le(vos, 2) + _le(b.rssi, 2))
        d = dist
        if self.range_noise_m:
            d += (self.rng.below(2001) - 1000) * self.range_noise_m / 1000
            if d < 0:
                d = 0.0
        if flags & sc.FIX_RANGE:
            t = 2 * d * 10 / (vos or 15000)  # round trip, s
            f.extend(_le(round(t * 16000), 4) + _le(round(t * 1e7), 4) + _le(round(d * 10), 2))
        off = self.medium.offset(self.addr, src)
        if off is None:
            off = (0.0, d, 0.0)  # no geometry known: straight ahead, level
        horiz = sqrt(off[0] * off[0] + off[1] * off[1])
        az = degrees(atan2(off[0], off[1]))
        el = degrees(atan2(-off[2], horiz))
        if flags & sc.FIX_USBL and self.bearing_noise_deg:
            az += (self.rng.below(2001) - 1000) * self.bearing_noise_deg / 1000
            el += (self.rng.below(2001) - 1000) * self.bearing_noise_deg / 1000
        if self.range_noise_m or self.bearing_noise_deg:
            # the position is what the noisy range and angles give
            h = d * cos(radians(el))
            off = (h * sin(radians(az)), h * cos(radians(az)), -d * sin(radians(el)))
        if flags & sc.FIX_USBL:
            f.append(4)
            for _ in range(4):
                f.extend(_le(b.rssi, 2))
            f.extend(_le(round(az * 10), 2))
            f.extend(_le(round(el * 10), 2))
            f.extend(_le(0, 2))  # fit error
        if flags & sc.FIX_POSITION:
            f.extend(_le(_clamp16(round(off[0] * 10)), 2))
            f.extend(_le(_clamp16(round(off[1] * 10)), 2))
            f.extend(_le(_clamp16(round((off[2] + b.env[3] / 10) * 10)), 2))
        return f
