# Driver for a transparent byte pipe: a serial cable, a half-duplex serial
# radio modem of the MaxStream kind (seed 002) that puts on the air whatever
# bytes it is given, or an acoustic packet modem that sends each SLIP frame
# as one packet (the software-defined modems of seed 004: give air_bitrate,
# the modem's own framing bytes air_overhead and its fixed cost
# turnaround_ms, and the airtime model follows the modem instead of the
# serial line). The pipe has no addressing and no integrity, so
# the link above sends raw acomm frames (addresses + CRC) and this driver only
# delimits them with SLIP and models the time the bytes take on the line.

from .caps import CAP_BROADCAST, Capabilities
from ..compat import const, ticks_add, ticks_diff
from ..events import EV_RX, EV_TX_DONE
from ..frame.slip import SlipDecoder, encode_into
from ..errors import EncodeError
from .base import SansIO

_OUT_CAP = const(1024)


class TransparentDriver(SansIO):
    """A transparent byte pipe: SLIP-delimited frames, no addressing of its own.

    EV_TX_DONE when the bytes have left (by the line's or the modem's timing model).
    """

    def __init__(self, baud=9600, mtu=255, turnaround_ms=0, model="transparent serial", air_bitrate=None, air_overhead=0):
        SansIO.__init__(self)
        self.baud = baud
        self.mtu = mtu
        self.turnaround_ms = turnaround_ms
        self.air_bitrate = air_bitrate
        self.air_overhead = air_overhead
        # 8N1: ten bits on the line per byte
        self.caps = Capabilities(
            manufacturer="generic",
            model=model,
            mtu_tx=mtu,
            mtu_rx=mtu,
            bitrate=air_bitrate or baud * 8 // 10,
            latency_ms=self.airtime_ms(mtu // 2),
            flags=CAP_BROADCAST,
        )
        self.broadcast_addr = None
        self._dec = SlipDecoder(mtu + 8)
        self._frames = []
        self._slip = bytearray(2 * mtu + 2)
        self._busy_until = None
        self._handle = 0
        self._tx_handle = None
        self.tx_frames = 0
        self.rx_frames = 0
        self.output_overruns = 0

    def airtime_ms(self, nbytes):
        if self.air_bitrate:
            return ((nbytes + self.air_overhead) * 8000 + self.air_bitrate - 1) // self.air_bitrate + self.turnaround_ms
        return (nbytes * 10 * 1000 + self.baud - 1) // self.baud + self.turnaround_ms

    def ready(self, now):
        return self._tx_handle is None

    def send(self, now, addr, data, ack=False):
        if len(data) > self.mtu:
            raise EncodeError("%d bytes exceed the MTU of %d" % (len(data), self.mtu))
        n = encode_into(self._slip, data)
        if len(self._out) + n > _OUT_CAP:
            # the host is not draining our output: drop rather than grow
            self.output_overruns += 1
            raise EncodeError("output buffer full")
        self._out.extend(memoryview(self._slip)[:n])
        self._handle = (self._handle + 1) & 0xFFFF
        self._tx_handle = self._handle
        self._busy_until = ticks_add(now, self.airtime_ms(len(data) if self.air_bitrate else n))
        self.tx_frames += 1
        return self._handle

    def feed(self, now, data):
        frames = self._frames
        if self._dec.feed(data, frames):
            for f in frames:
                self._events.append((EV_RX, None, None, f))
                self.rx_frames += 1
            frames.clear()

    def poll(self, now):
        if self._tx_handle is not None and ticks_diff(now, self._busy_until) >= 0:
            self._events.append((EV_TX_DONE, self._tx_handle))
            self._tx_handle = None
