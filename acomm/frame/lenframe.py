# Length-prefixed framing of a byte stream: how acomm frames travel over a
# TCP connection. Each frame goes as a 2-byte big-endian length (1..max)
# followed by that many bytes. TCP already delivers bytes in order and
# intact, so no escaping or checksum is needed here (the acomm frame
# carries its own CRC anyway).
#
# A length of 0 or above `max_frame` cannot be ours: the peer speaks
# something else or its stream is corrupt. There is no marker to resync on
# (any byte may begin a length), so the decoder refuses, counts it, and
# stays failed until reset(); the port closes the connection and a client
# reconnects to a fresh stream. Memory: one buffer of max_frame bytes per
# connection, filled with slice copies (no per-byte allocation).

from ..compat import const
from ..errors import DecodeError, EncodeError

HEADER_LEN = const(2)
MAX_FRAME = const(65535)  # what two length bytes can say


def append_frame(out, frame, max_frame=MAX_FRAME):
    # Appends the length-prefixed frame to the bytearray out.
    n = len(frame)
    if n == 0 or n > max_frame:
        raise EncodeError("frame of %d bytes outside 1..%d" % (n, max_frame))
    out.append(n >> 8)
    out.append(n & 0xFF)
    out.extend(frame)


class LenDecoder:
    def __init__(self, max_frame=1024):
        if not 1 <= max_frame <= MAX_FRAME:
            raise EncodeError("max_frame %d outside 1..%d" % (max_frame, MAX_FRAME))
        self.max_frame = max_frame
        self._buf = bytearray(max_frame)
        self.frames = 0
        self.bad_lengths = 0
        self.reset()

    def reset(self):
        # A fresh stream (a new connection): forget any partial frame and a
        # past failure. Counters stay.
        self._hdr = 0
        self._hdr_n = 0
        self._need = 0  # length of the frame being read; 0 while in the header
        self._got = 0
        self.error = None

    @property
    def pending(self):
        # bytes held of a frame (or length) not yet complete
        return self._got + self._hdr_n

    def feed(self, data, out):
        # Appends every frame completed by data to the list out. On a bad
        # length raises DecodeError, after the frames before it were
        # appended; further calls raise again until reset().
        if self.error is not None:
            raise DecodeError(self.error)
        mv = memoryview(data)
        n = len(data)
        i = 0
        buf = self._buf
        while i < n:
            if self._need == 0:
                self._hdr = (self._hdr << 8) | data[i]
                self._hdr_n += 1
                i += 1
                if self._hdr_n < HEADER_LEN:
                    continue
                length = self._hdr
                self._hdr = 0
                self._hdr_n = 0
                if length == 0 or length > self.max_frame:
                    self.bad_lengths += 1
                    self.error = "frame length %d outside 1..%d" % (length, self.max_frame)
                    raise DecodeError(self.error)
                self._need = length
                self._got = 0
                continue
            k = self._need - self._got
            if k > n - i:
                k = n - i
            buf[self._got : self._got + k] = mv[i : i + k]
            self._got += k
            i += k
            if self._got == self._need:
                out.append(bytes(memoryview(buf)[: self._need]))
                self.frames += 1
                self._need = 0
                self._got = 0
