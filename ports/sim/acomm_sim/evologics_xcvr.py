# The acoustic side of an emulated EvoLogics S2C modem: instant messages and
# burst data on the shared medium, the acknowledgement a modem sends by
# itself when an IM asks for one (and always for burst data), the sender's
# wait for it, the propagation time that AT?T reports, and the notifications
# that tell the host (SENDSTART/SENDEND with extended notifications on,
# DELIVEREDIM/FAILEDIM, DELIVERED/FAILED, RECVIM/RECV/RECVIMS/RECVPBM).
#
# Timing model (shared with the driver's options of the same names): a
# packet lasts packet_ms plus its payload at im_bitrate (976 bit/s, the
# figure of the oceansystemslab driver) or burst_bitrate; an ack is an empty
# packet sent turnaround_ms after the IM ended. The sender gives up after
# 2 * max_range_m / c + turnaround + one empty packet past its own end.

from math import log10

from acomm.compat import ticks_add, ticks_diff

P_IM = 0
P_IMS = 1
P_PBM = 2
P_BURST = 3
P_ACK = 4  # IM acknowledgement
P_BACK = 5  # burst acknowledgement

_RX_WORD = {P_IM: b"RECVIM", P_IMS: b"RECVIMS", P_PBM: b"RECVPBM", P_BURST: b"RECV"}


class Packet:
    __slots__ = ("kind", "src", "dst", "ack", "data", "pid")

    def __init__(self, kind, src, dst, ack=False, data=b"", pid=None):
        self.kind = kind
        self.src = src
        self.dst = dst
        self.ack = ack
        self.data = data
        self.pid = pid


class Transceiver:
    def __init__(self, modem, medium, addr, packet_ms, im_bitrate, burst_bitrate, turnaround_ms, max_range_m):
        self.modem = modem
        self.medium = medium
        self.addr = addr
        self.packet_ms = packet_ms
        self.im_bitrate = im_bitrate
        self.burst_bitrate = burst_bitrate
        self.turnaround_ms = turnaround_ms
        self.max_range_m = max_range_m
        self.sent = 0
        self.heard = 0
        self.reset()

    def reset(self):
        self._tx_until = None
        self._pending = None  # [ack kind, dst, deadline, nbytes]
        self._reply = None  # [due, Packet]: our automatic acknowledgement
        self._ends = []  # [due, line]: SENDEND of our packets

    # -- timing ------------------------------------------------------------------
    def airtime(self, n, burst=False):
        rate = self.burst_bitrate if burst else self.im_bitrate
        return self.packet_ms + (n * 8000 + rate - 1) // rate

    def window(self):
        c = self.medium.sound_speed
        return int(2 * self.max_range_m * 1000 / c) + self.turnaround_ms + self.airtime(0)

    def transmitting(self, now):
        return self._tx_until is not None and ticks_diff(self._tx_until, now) > 0

    def busy(self, now):
        # None when free, else the modem's reason
        if self.transmitting(now) or self._reply is not None:
            return b"BUSY BACKOFF STATE"
        if self._pending is not None:
            return b"BUSY DELIVERING"
        return None

    # -- commands ------------------------------------------------------------------
    def send(self, now, kind, dst, ack, data, pid=None):
        # After the command's OK: the packet goes on the air now.
        m = self.modem
        p = Packet(kind, self.addr, dst, ack, bytes(data), pid)
        burst = kind == P_BURST
        air = self.airtime(len(data), burst)
        self._transmit(now, p, air)
        typ = b"burst" if burst else b"im"
        if m.zx:
            m.notify(b"SENDSTART,%d,%s,%d,0" % (dst, typ, air * 1000))
            self._ends.append([ticks_add(now, air), b"SENDEND,%d,%s,%d,%d" % (dst, typ, 0, air * 1000)])
        if burst or ack:
            self._pending = [P_BACK if burst else P_ACK, dst, ticks_add(now, air + self.window()), len(data)]

    def _transmit(self, t, p, air):
        self.sent += 1
        self._tx_until = self.medium.transmit(t, self.addr, p, air)

    def poll(self, now):
        m = self.modem
        ends = self._ends
        while ends and ticks_diff(now, ends[0][0]) >= 0:
            due, line = ends.pop(0)
            m.notify(_stamp(line, m.clock_us(due)))
        r = self._reply
        if r is not None and ticks_diff(now, r[0]) >= 0:
            self._reply = None
            self._transmit(r[0], r[1], self.airtime(0))
        pd = self._pending
        if pd is not None and ticks_diff(now, pd[2]) >= 0:
            self._pending = None
            if pd[0] == P_ACK:
                m.notify(b"FAILEDIM,%d" % pd[1])
            else:
                m.notify(b"FAILED,%d,%d" % (pd[3], pd[1]))

    def cancel(self):
        # ATZ: forget what is waiting (the packet on the air goes on)
        pd = self._pending
        self._pending = None
        if pd is not None and pd[0] == P_ACK:
            self.modem.notify(b"CANCELEDIM,%d" % pd[1])

    # -- the medium --------------------------------------------------------------
    def receive(self, t, src, p, dist):
        m = self.modem
        if m.booting():
            return
        self.heard += 1
        mine = p.dst == self.addr
        if p.kind == P_ACK or p.kind == P_BACK:
            pd = self._pending
            if mine and pd is not None and pd[0] == p.kind and pd[1] == src:
                self._pending = None
                m.ptime_us = int(dist * 1e6 / self.medium.sound_speed + 0.5)
                if p.kind == P_ACK:
                    m.notify(b"DELIVEREDIM,%d" % src)
                else:
                    m.notify(b"DELIVERED,%d,%d" % (pd[3], src))
            return
        if not (mine or p.dst == m.broadcast_addr or (m.promiscuous and p.kind != P_BURST)):
            return
        self._report(t, p, dist)
        if mine and (p.ack or p.kind == P_BURST) and self._reply is None:
            # the firmware acknowledges by itself
            kind = P_BACK if p.kind == P_BURST else P_ACK
            self._reply = [ticks_add(t, self.turnaround_ms), Packet(kind, self.addr, src)]

    def _report(self, t, p, dist):
        m = self.modem
        burst = p.kind == P_BURST
        n = len(p.data)
        dur = self.airtime(n, burst) * 1000
        rssi = -45 - int(20 * log10(dist / 100.0)) if dist > 1 else -5
        integ = 200 - int(dist / 50)
        if integ < 60:
            integ = 60
        ptime = int(dist * 1e6 / self.medium.sound_speed + 0.5)
        pid = b"" if p.pid is None else b"p%d," % p.pid
        head = b"%s,%s%d,%d,%d," % (_RX_WORD[p.kind], pid, n, p.src, p.dst)
        if p.kind == P_IM:
            flag = b"ack" if p.ack else b"noack"
            if m.firmware16:
                tail = b"%s,%d,%d,%d,%d,0.00," % (flag, self.im_bitrate, rssi, integ, ptime)
            else:
                tail = b"%s,%d,%d,%d,0.00," % (flag, dur, rssi, integ)
        elif p.kind == P_IMS:
            tail = b"%d,%d,%d,%d,0.00," % (m.clock_us(t), dur, rssi, integ)
        elif p.kind == P_PBM:
            tail = b"%d,%d,%d,0.00," % (dur, rssi, integ)
        else:
            tail = b"%d,%d,%d,%d,0.00," % (self.burst_bitrate, rssi, integ, ptime)
        if m.zx:
            # the firmware says when reception began, then when it ended
            m.notify(b"RECVSTART")
            m.notify(b"RECVEND,%d,%d,%d,%d" % (m.clock_us(t), dur, rssi, integ))
        m.received(head + tail, p.data, burst)


def _stamp(line, usec):
    # SENDEND,<addr>,<type>,<usec>,<dur>: fill in the modem clock at the end
    f = line.split(b",")
    f[3] = b"%d" % usec
    return b",".join(f)
