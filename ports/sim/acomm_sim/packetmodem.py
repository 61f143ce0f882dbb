# An emulated acoustic packet modem with a transparent host interface: the
# host writes SLIP-delimited frames (what acomm.drivers.transparent writes),
# the modem sends each one as one acoustic packet, and every packet it hears
# comes out SLIP-encoded. This is the kind of software-defined modem of seed
# 004, whose profiles are given here by their application bit rate, the
# modem's own framing bytes and a fixed cost per packet:
#
#   BPSK  400 bit/s, 12 bytes of framing (seed 004 section IV-B, VI-A)
#   FHSS  192 bit/s, 10 bytes of framing
#
# Half-duplex: frames written while the modem transmits wait in a bounded
# queue (overflow: the newest is dropped and counted). Sans-IO like the other
# emulators; portable Python.

from acomm.compat import ticks_diff
from acomm.drivers.base import SansIO
from acomm.frame.slip import SlipDecoder, encode

# name -> (bit rate, framing bytes, fixed cost per packet in ms)
PROFILES = {
    "bpsk": (400, 12, 0),
    "fhss": (192, 10, 0),
}


class PacketModemEmulator(SansIO):
    # idle, it does nothing until the host writes or a packet arrives (the
    # World lets its node sleep)
    quiet_until_heard = True

    def __init__(self, medium, address, now=0, bitrate=400, overhead=12, fixed_ms=0, mtu=255, queue=8,
                 profile=None):
        SansIO.__init__(self)
        if profile is not None:
            bitrate, overhead, fixed_ms = PROFILES[profile]
        self.medium = medium
        self.address = address
        self.bitrate = bitrate
        self.overhead = overhead
        self.fixed_ms = fixed_ms
        self.mtu = mtu
        self.queue_cap = queue
        self._dec = SlipDecoder(mtu + 8)
        self._frames = []
        self._queue = []
        self._tx_until = None
        self.tx_packets = 0
        self.rx_packets = 0
        self.queue_overflows = 0
        medium.attach(address, self)

    def airtime_ms(self, nbytes):
        return ((nbytes + self.overhead) * 8000 + self.bitrate - 1) // self.bitrate + self.fixed_ms

    def feed(self, now, data):
        frames = self._frames
        self._dec.feed(data, frames)
        for f in frames:
            if len(self._queue) >= self.queue_cap:
                self.queue_overflows += 1
            else:
                self._queue.append(bytes(f))
        frames.clear()
        self.poll(now)

    def poll(self, now):
        if self._tx_until is not None and ticks_diff(now, self._tx_until) < 0:
            return
        self._tx_until = None
        if self._queue:
            p = self._queue.pop(0)
            self._tx_until = self.medium.transmit(now, self.address, p, self.airtime_ms(len(p)))
            self.tx_packets += 1

    def idle(self, now):
        # nothing queued, nothing on the air: poll() would do nothing
        return not self._queue and not self.transmitting(now)

    def busy_until(self, now):
        # until when poll() has nothing to do while it is not idle: the end
        # of the packet on the air (None: at once)
        return self._tx_until if self.transmitting(now) else None

    def transmitting(self, now):
        return self._tx_until is not None and ticks_diff(now, self._tx_until) < 0

    def receive(self, t, src, packet, distance):
        self.rx_packets += 1
        self._out.extend(encode(packet))

    def reboot(self, now):
        # a power cycle: whatever was queued or on the air is gone
        if self._tx_until is not None:
            self.medium.cancel(self.address, now)
        self._tx_until = None
        self._queue = []
        self._out = bytearray()
