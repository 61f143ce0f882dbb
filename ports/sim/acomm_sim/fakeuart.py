# An in-memory UART pair with machine.UART semantics, for tests on both
# runtimes and for demos without hardware.
#
# write(buf) -> n; read(n) -> bytes or None when nothing is waiting;
# readinto(buf[, n]) -> count or None; any() -> bytes waiting.
#
# Faults are applied to what an end writes, per write call (a write is one
# "frame" as the sender sees it): drop it, flip one random bit of it, split it
# into chunks that arrive one millisecond apart, delay it. Noise can be
# injected into an end's receive side. uart_bus() joins several ends on one
# shared line. The receive buffer is bounded like a
# real UART's: bytes arriving when it is full are lost and counted as overruns.

from .clock import ManualClock
from acomm.compat import ticks_add, ticks_diff
from acomm.prng import Prng


class FakeUART:
    def __init__(self, rxbuf=1024, clock=None):
        self.clock = clock if clock is not None else ManualClock()
        self.peer = None  # the other end of a pair
        self.peers = []  # every end that hears this one (a pair, or a bus)
        self._rx = bytearray()
        self._rxcap = rxbuf
        self._pending = []  # (ready_ms, bytes) in arrival order
        self.set_faults()
        self.written = 0
        self.dropped = 0
        self.flipped = 0
        self.overruns = 0

    def set_faults(self, drop=0.0, flip=0.0, split=0, delay_ms=0, seed=1):
        # drop, flip: probability per write; split: max chunk size (0 = whole);
        # delay_ms: latency added to every write.
        self._drop = drop
        self._flip = flip
        self._split = split
        self._delay = delay_ms
        self._rng = Prng(seed)

    # -- sending side -------------------------------------------------------
    def write(self, buf):
        data = bytes(buf)
        n = len(data)
        self.written += n
        if n == 0:
            return 0
        rng = self._rng
        if self._drop and rng.chance(self._drop):
            self.dropped += 1
            return n
        if self._flip and rng.chance(self._flip):
            pos = rng.below(n * 8)
            b = bytearray(data)
            b[pos >> 3] ^= 0x80 >> (pos & 7)
            data = bytes(b)
            self.flipped += 1
        now = self.clock()
        if self._split:
            i = 0
            k = 0
            while i < n:
                step = rng.range(1, self._split)
                for p in self.peers:
                    p._arrive(ticks_add(now, self._delay + k), data[i : i + step])
                i += step
                k += 1
        else:
            for p in self.peers:
                p._arrive(ticks_add(now, self._delay), data)
        return n

    # -- receiving side -----------------------------------------------------
    def _arrive(self, ready, data):
        self._pending.append((ready, data))
        self._deliver()

    def inject(self, data):
        # Bytes appear on this end's receive side at once, as line noise
        # would, even ahead of delayed data still on its way.
        self._deliver()
        self._put(bytes(data))

    def _put(self, data):
        room = self._rxcap - len(self._rx)
        if len(data) > room:
            self.overruns += len(data) - room
            data = data[:room]
        self._rx.extend(data)

    def _deliver(self):
        p = self._pending
        if not p:
            return
        now = self.clock()
        # in order: a later chunk never overtakes an earlier one on a wire
        while p and ticks_diff(p[0][0], now) <= 0:
            self._put(p.pop(0)[1])

    def any(self):
        self._deliver()
        return len(self._rx)

    def read(self, n=-1):
        self._deliver()
        rx = self._rx
        if not rx:
            return None
        if n is None or n < 0 or n >= len(rx):
            out = bytes(rx)
            rx[:] = b""
        else:
            out = bytes(rx[:n])
            rx[:] = rx[n:]
        return out

    def readinto(self, buf, nbytes=None):
        self._deliver()
        rx = self._rx
        if not rx:
            return None
        n = len(buf) if nbytes is None else min(nbytes, len(buf))
        if n > len(rx):
            n = len(rx)
        buf[:n] = rx[:n]
        rx[:] = rx[n:]
        return n

    def in_flight(self):
        # bytes written by the peer that have not arrived yet (delayed)
        t = 0
        for _, d in self._pending:
            t += len(d)
        return t


def uart_pair(rxbuf=1024, clock=None):
    clk = clock if clock is not None else ManualClock()
    a = FakeUART(rxbuf, clk)
    b = FakeUART(rxbuf, clk)
    a.peer = b
    b.peer = a
    a.peers.append(b)
    b.peers.append(a)
    return a, b


def uart_bus(n, rxbuf=1024, clock=None):
    # n ends on one shared line (a transparent radio channel, an RS-485 bus):
    # what one end writes, every other end receives.
    clk = clock if clock is not None else ManualClock()
    ends = [FakeUART(rxbuf, clk) for _ in range(n)]
    for e in ends:
        for o in ends:
            if o is not e:
                e.peers.append(o)
    return ends
