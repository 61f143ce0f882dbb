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
#
# Burst data is buffered (EvoLogics' evins sends the next AT*SEND while
# earlier bursts still wait for their DELIVERED / FAILED, docs/transport.md):
# the modem takes a further burst while one is on the air (burst_queue of
# them wait at most), and sends it right after, in the same train, when it
# goes to the same address and comes within turnaround_ms of the last one's
# end (at most train_max bursts). The remote modem acknowledges a train once,
# turnaround_ms after its last burst (when no further one has begun to
# arrive), naming the bursts it heard; the sender then says DELIVERED or
# FAILED for each, in order. How the S2C acknowledges bursts on the air is
# not documented: the train is this emulator's choice.

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
    __slots__ = ("kind", "src", "dst", "ack", "data", "pid", "counter")

    def __init__(self, kind, src, dst, ack=False, data=b"", pid=None):
        self.kind = kind
        self.src = src
        self.dst = dst
        self.ack = ack
        self.data = data
        self.pid = pid
        self.counter = 0  # burst data: the sender's burst counter


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
        self._pending = None  # [ack kind, dst, deadline, nbytes]: an IM awaiting its ack
        self._reply = None  # [due, Packet]: our automatic acknowledgement
        self._ends = []  # [due, line]: SENDEND of our packets
        self._bq = []  # [dst, data, pid]: bursts taken, not on the air yet
        self._train = []  # [counter, dst, nbytes]: bursts of the train, awaiting its ack
        self._train_end = None  # when the train's last burst left
        self._train_wait = None  # the train is closed: its ack is due before this
        self._heard_bursts = {}  # src -> counters of the last train_max bursts heard from it
        self._ack_due = None  # [due, src]: acknowledge src's train then, unless more arrives
        self._count = 0  # burst counter

    burst_queue = 1  # bursts waiting behind the one on the air
    train_max = 8  # bursts per acknowledgement

    # -- timing ------------------------------------------------------------------
    def airtime(self, n, burst=False):
        rate = self.burst_bitrate if burst else self.im_bitrate
        return self.packet_ms + (n * 8000 + rate - 1) // rate

    def window(self):
        c = self.medium.sound_speed
        return int(2 * self.max_range_m * 1000 / c) + self.turnaround_ms + self.airtime(0)

    def transmitting(self, now):
        return self._tx_until is not None and ticks_diff(self._tx_until, now) > 0

    def busy(self, now, burst=False):
        # None when free (for burst data: when its buffer takes one more),
        # else the modem's reason
        if self._reply is not None or self._ack_due is not None:
            return b"BUSY BACKOFF STATE"
        if burst and self._pending is None and len(self._bq) < self.burst_queue:
            if not self.transmitting(now) or self._train:
                return None
        if self.transmitting(now):
            return b"BUSY BACKOFF STATE"
        if self._pending is not None or self._train or self._bq:
            return b"BUSY DELIVERING"
        return None

    # -- commands ------------------------------------------------------------------
    def send(self, now, kind, dst, ack, data, pid=None):
        # After the command's OK: an IM goes on the air now, burst data
        # when the modem gets to it (_next_burst).
        if kind == P_BURST:
            self._bq.append([dst, bytes(data), pid])
            self._next_burst(now)
            return
        p = Packet(kind, self.addr, dst, ack, bytes(data), pid)
        air = self._start(now, p, b"im")
        if ack:
            self._pending = [P_ACK, dst, ticks_add(now, air + self.window()), len(data)]

    def _start(self, now, p, typ):
        # p on the air now, with its SENDSTART and SENDEND; -> its airtime
        m = self.modem
        air = self.airtime(len(p.data), p.kind == P_BURST)
        self._transmit(now, p, air)
        if m.zx:
            m.notify(b"SENDSTART,%d,%s,%d,0" % (p.dst, typ, air * 1000))
            self._ends.append([ticks_add(now, air), b"SENDEND,%d,%s,%d,%d" % (p.dst, typ, 0, air * 1000)])
        return air

    def _next_burst(self, now):
        # The next buffered burst goes on the air if the train goes on (same
        # address, close enough behind, not too long) or none is under way.
        if not self._bq or self.transmitting(now) or self._train_wait is not None or self._reply is not None:
            return
        dst, data, pid = self._bq[0]
        t = self._train
        if t and (t[0][1] != dst or len(t) >= self.train_max or ticks_diff(now, self._train_end) > self.turnaround_ms):
            self._close_train()
            return
        self._bq.pop(0)
        self._count = (self._count + 1) & 0xFFFF
        p = Packet(P_BURST, self.addr, dst, True, data, pid)
        p.counter = self._count
        self._train_end = ticks_add(now, self._start(now, p, b"burst"))
        t.append([self._count, dst, len(data)])

    def _close_train(self):
        # nothing more behind the last burst: wait for the remote's ack
        self._train_wait = ticks_add(self._train_end, self.window())

    def _train_done(self, heard):
        # the train's outcome, burst by burst (heard: the counters the
        # remote acknowledged, or () when its ack never came)
        m = self.modem
        for c, dst, n in self._train:
            m.notify((b"DELIVERED,%d,%d" if c in heard else b"FAILED,%d,%d") % (n, dst))
        self._train = []
        self._train_wait = None

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
        a = self._ack_due
        if a is not None and ticks_diff(now, a[0]) >= 0 and self.medium.arriving(self.addr, a[1]) is None:
            # the train from a[1] is over: one ack names every burst heard
            self._ack_due = None
            heard = self._heard_bursts.get(a[1], ())
            self._transmit(now, Packet(P_BACK, self.addr, a[1], False, _counters(heard)), self.airtime(0))
        pd = self._pending
        if pd is not None and ticks_diff(now, pd[2]) >= 0:
            self._pending = None
            m.notify(b"FAILEDIM,%d" % pd[1])
        if self._train_wait is not None and ticks_diff(now, self._train_wait) >= 0:
            self._train_done(())
        if self._train and self._train_wait is None and not self.transmitting(now):
            if not self._bq and ticks_diff(now, self._train_end) > self.turnaround_ms:
                self._close_train()
        self._next_burst(now)

    def cancel(self):
        # ATZ: forget what is waiting (the packet on the air goes on)
        pd = self._pending
        self._pending = None
        self._bq = []
        self._train = []
        self._train_wait = None
        if pd is not None and pd[0] == P_ACK:
            self.modem.notify(b"CANCELEDIM,%d" % pd[1])

    # -- the medium --------------------------------------------------------------
    def receive(self, t, src, p, dist):
        m = self.modem
        if m.booting():
            return
        self.heard += 1
        mine = p.dst == self.addr
        if p.kind == P_ACK:
            pd = self._pending
            if mine and pd is not None and pd[1] == src:
                self._pending = None
                m.ptime_us = int(dist * 1e6 / self.medium.sound_speed + 0.5)
                m.notify(b"DELIVEREDIM,%d" % src)
            return
        if p.kind == P_BACK:
            if mine and self._train and self._train[0][1] == src:
                m.ptime_us = int(dist * 1e6 / self.medium.sound_speed + 0.5)
                self._train_done(_uncounters(p.data))
            return
        if not (mine or p.dst == m.broadcast_addr or (m.promiscuous and p.kind != P_BURST)):
            return
        self._report(t, p, dist)
        if mine and p.kind == P_BURST:
            # the firmware acknowledges the train by itself once it is over;
            # the ack names the last train_max bursts heard from src, not only
            # those since the last ack: an ack sent early (a lost burst left
            # a gap) meets the sender on the air, and the next one covers it
            h = self._heard_bursts.setdefault(src, [])
            h.append(p.counter)
            if len(h) > self.train_max:
                h.pop(0)
            self._ack_due = [ticks_add(t, self.turnaround_ms), src]
        elif mine and p.ack and self._reply is None:
            # the firmware acknowledges by itself
            self._reply = [ticks_add(t, self.turnaround_ms), Packet(P_ACK, self.addr, src)]

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


def _counters(cs):
    # the burst counters an acknowledgement names, two bytes each
    out = bytearray()
    for c in cs:
        out.extend(bytes(((c >> 8) & 0xFF, c & 0xFF)))
    return bytes(out)


def _uncounters(b):
    return [(b[i] << 8) | b[i + 1] for i in range(0, len(b) - 1, 2)]


def _stamp(line, usec):
    # SENDEND,<addr>,<type>,<usec>,<dur>: fill in the modem clock at the end
    f = line.split(b",")
    f[3] = b"%d" % usec
    return b",".join(f)
