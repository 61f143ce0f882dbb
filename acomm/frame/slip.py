# SLIP framing (RFC 1055) for raw frames on byte streams: serial cables,
# transparent radio modems, TCP.
#
# A frame goes on the wire as END, the frame with END and ESC bytes escaped,
# END. The leading END flushes whatever noise the receiver collected since the
# last frame, so a receiver resynchronises at the very next frame boundary;
# the frame's own CRC then rejects anything noise made of the bytes between.
# Overhead: 2 bytes plus one per 0xC0/0xDB byte in the frame.
#
# The decoder owns one preallocated buffer of the largest frame it accepts;
# longer runs of bytes are discarded up to the next END and counted.

from ..compat import const
from ..errors import EncodeError

END = const(0xC0)
ESC = const(0xDB)
ESC_END = const(0xDC)
ESC_ESC = const(0xDD)


def encoded_len(data):
    n = 2 + len(data)
    for b in data:
        if b == END or b == ESC:
            n += 1
    return n


def encode_into(buf, data):
    # Writes END + escaped data + END into buf; returns the number of bytes.
    cap = len(buf)
    if cap < 2:
        raise EncodeError("buffer too small for SLIP")
    buf[0] = END
    j = 1
    for b in data:
        if b == END or b == ESC:
            if j + 2 >= cap:
                raise EncodeError("SLIP frame does not fit buffer of %d" % cap)
            buf[j] = ESC
            buf[j + 1] = ESC_END if b == END else ESC_ESC
            j += 2
        else:
            if j + 1 >= cap:
                raise EncodeError("SLIP frame does not fit buffer of %d" % cap)
            buf[j] = b
            j += 1
    buf[j] = END
    return j + 1


def encode(data):
    buf = bytearray(encoded_len(data))
    encode_into(buf, data)
    return bytes(buf)


class SlipDecoder:
    def __init__(self, maxlen=256):
        self._buf = bytearray(maxlen)
        self._max = maxlen
        self._n = 0
        self._esc = False
        self._drop = 0  # 0: collecting, 1: too long, 2: bad escape
        self.frames = 0
        self.oversize = 0  # frames longer than maxlen, discarded
        self.bad_escapes = 0  # ESC followed by something else: frame discarded

    def reset(self):
        self._n = 0
        self._esc = False
        self._drop = 0

    def feed(self, data, out):
        # Decodes bytes; appends each complete frame (as bytes) to the list
        # `out`; returns how many were appended. Empty frames (END END) are
        # not frames.
        got = 0
        buf = self._buf
        n = self._n
        esc = self._esc
        drop = self._drop
        mx = self._max
        for b in data:
            if b == END:
                if drop == 1:
                    self.oversize += 1
                elif n and not drop:
                    out.append(bytes(buf[:n]))
                    got += 1
                n = 0
                esc = False
                drop = 0
                continue
            if drop:
                continue
            if esc:
                esc = False
                if b == ESC_END:
                    b = END
                elif b == ESC_ESC:
                    b = ESC
                else:
                    # a protocol violation: most likely noise; drop this frame
                    self.bad_escapes += 1
                    drop = 2
                    n = 0
                    continue
            elif b == ESC:
                esc = True
                continue
            if n >= mx:
                drop = 1
                n = 0
                continue
            buf[n] = b
            n += 1
        self._n = n
        self._esc = esc
        self._drop = drop
        self.frames += got
        return got
