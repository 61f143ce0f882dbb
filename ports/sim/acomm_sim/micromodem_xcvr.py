# The acoustic side of an emulated WHOI Micro-Modem: cycles, mini-packets,
# pings and acknowledgements as packets on the shared medium, what the modem
# reports about them on its serial port, and what it answers by itself:
#
#   sender        $CATXP,n now, $CATXF,n when the packet's last bit leaves;
#                 at rate 0 first the cycle init: $CATXP,0 and $CATXF,0
#   receiver      $CARXP,<0 FSK / 1 PSK>, $CACYC (the cycle header), then
#                 $CARXD per frame for this modem or the broadcast address;
#                 for acknowledged frames to this modem an automatic ack
#                 packet, which makes the sender's modem print $CAACK
#   mini-packet   $CAMUA at the receiver (this modem or broadcast)
#   ping          $CAMPA at the pinged modem, which replies by itself; the
#                 pinger prints $CAMPR,<remote>,<us>,<one-way seconds>
#                 (from the medium's distance); nothing when no reply comes
#
# Airtimes come from acomm.drivers.micromodem_wire (an estimate). The ack and
# the ping reply leave turnaround_ms after the packet that asked for them.

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers import micromodem_wire as nm
from acomm.drivers.micromodem_wire import Airtime

P_DATA = "data"
P_MINI = "mini"
P_PING = "ping"
P_PING_REPLY = "ping-reply"
P_ACK = "ack"


class Packet:
    __slots__ = ("kind", "src", "dst", "rate", "ack", "frames", "value")

    def __init__(self, kind, src, dst, rate=0, ack=0, frames=(), value=0):
        self.kind = kind
        self.src = src
        self.dst = dst
        self.rate = rate
        self.ack = ack
        self.frames = frames  # data: list of bytes; ack: list of frame numbers
        self.value = value  # mini-packet: 13 bits


class Transceiver:
    def __init__(self, modem, medium, air, turnaround_ms, ping_window_ms, hear_all):
        self.modem = modem
        self.medium = medium
        self.air = air if air is not None else Airtime()
        self.turnaround_ms = turnaround_ms
        self.ping_window_ms = ping_window_ms
        self.hear_all = hear_all
        self.addr = modem.address
        self.sent = 0
        self.heard = 0
        self.reset()

    def reset(self):
        self._timers = []  # [due, function, argument] by due time
        self._tx_until = None
        self._acks = []  # [dst, frame#, deadline] awaiting the remote's ack
        self._ping = None  # [dst, deadline]

    # -- timers ------------------------------------------------------------------
    def at(self, due, fn, arg=None):
        t = self._timers
        i = len(t)
        while i > 0 and ticks_diff(t[i - 1][0], due) > 0:
            i -= 1
        t.insert(i, [due, fn, arg])

    def poll(self, now):
        t = self._timers
        while t and ticks_diff(t[0][0], now) <= 0:
            due, fn, arg = t.pop(0)
            fn(due, arg)
        if self._ping is not None and ticks_diff(now, self._ping[1]) >= 0:
            self._ping = None  # no reply: the real modem says nothing either
        keep = []
        for a in self._acks:
            if ticks_diff(now, a[2]) < 0:
                keep.append(a)
        self._acks = keep

    def busy(self, now):
        if self._tx_until is not None and ticks_diff(self._tx_until, now) > 0:
            return True
        return self._ping is not None

    # -- sending -----------------------------------------------------------------
    def _transmit(self, t, p, air_ms):
        self.sent += 1
        self._tx_until = self.medium.transmit(t, self.addr, p, air_ms)
        return self._tx_until

    def send_cycle(self, now, dst, rate, ack, frames):
        # the host delivered the cycle's frames: on the air now
        n = 0
        for f in frames:
            n += len(f)
        self.modem.emit("CATXP", n)
        air = self.air.packet_ms(rate, n)
        if rate == 0:
            air -= self.air.mini_ms()  # the cycle init has gone already
        end = self._transmit(now, Packet(P_DATA, self.addr, dst, rate, ack, frames), air)
        self.at(end, self._txf, n)
        if ack and dst != self.modem.broadcast:
            window = 2 * self.turnaround_ms + self.air.mini_ms() + 2 * self.modem.max_travel_ms()
            for k in range(len(frames)):
                self._acks.append([dst, k + 1, ticks_add(end, window)])

    def send_cycle_init(self, now, then):
        # Rate 0: the cycle header as a mini-packet of its own before the
        # data is asked for; then(t) runs when its $CATXF is out. Not put on
        # the medium: the receivers learn of the cycle with its data packet.
        self.modem.emit("CATXP", 0)
        self._tx_until = ticks_add(now, self.air.mini_ms())
        self.at(self._tx_until, self._ci_done, then)

    def _ci_done(self, t, then):
        self.modem.emit("CATXF", 0)
        then(t)

    def send_mini(self, now, dst, value):
        self.modem.emit("CATXP", 0)
        end = self._transmit(now, Packet(P_MINI, self.addr, dst, value=value), self.air.mini_ms())
        self.at(end, self._txf, 0)

    def send_ping(self, now, dst):
        end = self._transmit(now, Packet(P_PING, self.addr, dst), self.air.mini_ms())
        self._ping = [dst, ticks_add(end, self.ping_window_ms)]

    def _txf(self, t, n):
        self.modem.emit("CATXF", n)

    def _reply(self, t, p):
        # an automatic answer (ack, ping reply): the host is not told
        self._transmit(t, p, self.air.mini_ms())

    # -- the medium ----------------------------------------------------------------
    def receive(self, t, src, p, dist):
        m = self.modem
        if m.booting():
            return
        self.heard += 1
        me = self.addr
        mine = p.dst == me
        for_us = mine or p.dst == m.broadcast or self.hear_all
        if p.kind == P_DATA:
            m.emit("CARXP", 0 if p.rate == 0 else 1)
            m.emit("CACYC", 0, p.src, p.dst, p.rate, p.ack, len(p.frames))
            if not for_us:
                return
            good = []
            for k in range(len(p.frames)):
                m.emit("CARXD", p.src, p.dst, p.ack, k + 1, nm.hexlify(p.frames[k]))
                good.append(k + 1)
            if p.ack and mine:
                self.at(ticks_add(t, self.turnaround_ms), self._reply, Packet(P_ACK, me, src, frames=good))
        elif p.kind == P_MINI:
            if for_us:
                m.emit("CAMUA", p.src, p.dst, "%04X" % p.value)
        elif p.kind == P_PING:
            if mine:
                m.emit("CAMPA", p.src, p.dst)
                self.at(ticks_add(t, self.turnaround_ms), self._reply, Packet(P_PING_REPLY, me, src))
        elif p.kind == P_PING_REPLY:
            pg = self._ping
            if mine and pg is not None and pg[0] == src:
                self._ping = None
                m.emit("CAMPR", src, me, "%.4f" % (dist / self.medium.sound_speed))
        elif p.kind == P_ACK and mine:
            keep = []
            for a in self._acks:
                if a[0] == src and a[1] in p.frames:
                    m.emit("CAACK", me, src, a[1], 1)
                else:
                    keep.append(a)
            self._acks = keep
