# Finds IMC packets in a byte stream (a serial line, a TCP connection) with
# noise, cut packets and garbage between them. Sans-IO: feed() takes bytes
# and returns the packets completed by them.
#
# The buffer has a fixed capacity, which is also the largest packet taken:
# a header announcing more is refused at once. A candidate is only dropped
# one byte at a time (bad CRC, impossible size), and the search restarts
# from the next byte, so a real packet hidden inside a false one (noise that
# happened to read as a sync and a size) is still found. A lying size within
# capacity holds the packets behind it back until enough bytes have come to
# check its CRC; the capacity bounds that delay.
#
# Counters: packets (returned), unknown (of those, with an id acomm does not
# know: msg is None), bad_crc, bad_size (headers announcing more than fits),
# bad_payload (good CRC, fields that do not decode), skipped (bytes dropped:
# noise and the first byte of every refused candidate).

from .packet import check_frame, decode_checked
from .wire import OVERHEAD, SYNC_BE, SYNC_LE, read_crc
from ..codec.crc import crc16
from ..errors import DecodeError


class StreamParser:
    def __init__(self, capacity=4096, exact=False):
        if capacity < OVERHEAD:
            raise ValueError("capacity below one IMC packet")
        self.capacity = capacity
        self.exact = exact
        self._buf = bytearray(capacity)
        self._mv = memoryview(self._buf)
        self._n = 0
        self.packets = 0
        self.unknown = 0
        self.bad_crc = 0
        self.bad_size = 0
        self.bad_payload = 0
        self.skipped = 0

    def counters(self):
        return {
            "packets": self.packets,
            "unknown": self.unknown,
            "bad_crc": self.bad_crc,
            "bad_size": self.bad_size,
            "bad_payload": self.bad_payload,
            "skipped": self.skipped,
        }

    def pending(self):
        # bytes held, waiting for the rest of a candidate packet
        return self._n

    def reset(self):
        self._n = 0

    def feed(self, data):
        # The packets that data completes, in stream order.
        out = []
        src = memoryview(data)
        i = 0
        total = len(src)
        while i < total:
            k = self.capacity - self._n
            if k > total - i:
                k = total - i
            self._mv[self._n : self._n + k] = src[i : i + k]
            self._n += k
            i += k
            self._scan(out)
        return out

    def _scan(self, out):
        buf = self._buf
        mv = self._mv
        n = self._n
        s = 0
        # next sync of each order at or after s; -1: none before n. Kept
        # between candidates so garbage full of one order's syncs does not
        # make every step scan to the end for the other.
        a = b = -2
        while n - s >= 2:
            if a != -1 and a < s:
                a = buf.find(SYNC_LE, s, n)
            if b != -1 and b < s:
                b = buf.find(SYNC_BE, s, n)
            j = b if a < 0 or (0 <= b < a) else a
            if j < 0:
                # keep a last byte that may be the first half of a sync
                j = n - 1 if buf[n - 1] in (0x54, 0xFE) else n
                self.skipped += j - s
                s = j
                break
            self.skipped += j - s
            s = j
            try:
                fr = check_frame(mv, s, n - s)
            except DecodeError:
                fr = False
            if fr is None:
                break  # the header is not all here yet
            if fr is False or fr[1] > self.capacity:
                self.bad_size += 1
                self.skipped += 1
                s += 1
                continue
            big, size = fr
            if n - s < size:
                break  # wait for the rest
            end = s + size
            if read_crc(mv, end - 2, big) != crc16(mv[s : end - 2]):
                self.bad_crc += 1
                self.skipped += 1
                s += 1
                continue
            try:
                p = decode_checked(mv, s, big, self.exact)
            except DecodeError:
                self.bad_payload += 1
                self.skipped += size
                s = end
                continue
            self.packets += 1
            if p.msg is None:
                self.unknown += 1
            out.append(p)
            s = end
        if s:
            # one move per feed, not per byte
            rest = n - s
            if rest:
                buf[0:rest] = mv[s:n]
            self._n = rest
