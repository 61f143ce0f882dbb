# The acoustic side of an emulated Benthos ATM-9xx: data packets on the shared
# medium, the two-way range (ATR) with the automatic reply of the modem that
# is asked, and the requester's reply timeout (@AcRspTmOut).
#
# Timing: a packet lasts packet_ms plus its payload at the @TxRate bit rate
# (acomm.drivers.benthos_wire.airtime_ms, the same model as the driver's). A
# ranging ping is a packet without payload; the modem that hears one for its
# address answers turnaround_ms after its end. The round trip the requester
# reports is the travel time both ways (2 d / c), as in the reference's
# example (1499.6 m for 1999.5 ms): the modem takes its own delays out.

from acomm.compat import const, ticks_add, ticks_diff
from acomm.drivers import benthos_wire as w

P_DATA = const(0)
P_PING = const(1)
P_PONG = const(2)


class Packet:
    __slots__ = ("kind", "src", "dst", "data", "rate")

    def __init__(self, kind, src, dst, data=b"", rate=2):
        self.kind = kind
        self.src = src
        self.dst = dst
        self.data = data
        self.rate = rate

    def __repr__(self):
        return "Packet(%d, %d->%d, %r)" % (self.kind, self.src, self.dst, self.data)


class Transceiver:
    def __init__(self, modem, medium, packet_ms, turnaround_ms):
        self.m = modem
        self.medium = medium
        self.packet_ms = packet_ms
        self.turnaround_ms = turnaround_ms
        self.sent = 0
        self.heard = 0
        self.reset()

    def reset(self):
        self._tx_until = None
        self._tx_data = False  # the packet on the air is the host's data
        self._pending = None  # [dst, deadline] of our ATR
        self._reply = None  # [due, Packet] our automatic answer to a ping

    def busy(self, now):
        if self._tx_until is not None and ticks_diff(self._tx_until, now) > 0:
            return True
        return self._reply is not None

    def _rate(self):
        return int(self.m.settings["TxRate"])

    def _transmit(self, now, p):
        self.sent += 1
        air = w.airtime_ms(p.rate, len(p.data), self.packet_ms)
        self._tx_until = self.medium.transmit(now, self.m.address, p, air)

    def send_data(self, now, data):
        dst = int(self.m.settings["RemoteAddr"])
        self._transmit(now, Packet(P_DATA, self.m.address, dst, data, self._rate()))
        self._tx_data = True

    def ping(self, now, dst):
        # ATR: False when the modem is busy with another acoustic exchange
        if self._pending is not None or self.busy(now):
            return False
        self._transmit(now, Packet(P_PING, self.m.address, dst, b"", self._rate()))
        tmo = w.milli(self.m.settings["AcRspTmOut"])
        self._pending = [dst, ticks_add(now, tmo)]
        return True

    def poll(self, now):
        r = self._reply
        if r is not None and ticks_diff(now, r[0]) >= 0 and not self.medium.transmitting(self.m.address, now):
            self._reply = None
            self._transmit(r[0] if ticks_diff(now, r[0]) < 50 else now, r[1])
        if self._tx_data and ticks_diff(now, self._tx_until) >= 0:
            self._tx_data = False
            self.m.transmitted(now)
        pd = self._pending
        if pd is not None and ticks_diff(now, pd[1]) >= 0:
            self._pending = None
            self.m.range_result(now, pd[0], None)

    def receive(self, t, src, p, dist):
        if not isinstance(p, Packet):
            return  # another kind of modem on the medium
        self.heard += 1
        me = self.m.address
        if p.kind == P_DATA:
            if p.dst == me or p.dst == w.BROADCAST or self.m.settings["RcvAll"] == "Ena":
                self.m.report(p)
        elif p.kind == P_PING:
            if p.dst == me and self._reply is None:
                # the modem answers by itself, whoever drives it
                self._reply = [ticks_add(t, self.turnaround_ms), Packet(P_PONG, me, src, b"", p.rate)]
        elif p.kind == P_PONG:
            pd = self._pending
            if pd is not None and p.dst == me and src == pd[0]:
                self._pending = None
                self.m.range_result(t, src, dist)
