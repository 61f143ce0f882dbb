# MSB-first bit packing into preallocated buffers.
#
# BitWriter writes unsigned and two's-complement signed fields of any width
# into a bytearray it does not grow (bounded memory); BitReader reads them back
# from any buffer through a memoryview, without copies. Fields larger than 32
# bits are fine: values are Python ints.
#
# Errors: a value that does not fit its width, or a write past the buffer's
# capacity, raises EncodeError; a read past the end raises DecodeError.

from ..errors import DecodeError, EncodeError


class BitWriter:
    def __init__(self, buf):
        # buf: a bytearray (or a writable memoryview) owned by the caller.
        self._buf = buf
        self._cap = len(buf) * 8
        self._pos = 0

    def reset(self):
        self._pos = 0

    @property
    def bit_length(self):
        return self._pos

    @property
    def capacity(self):
        # bits the buffer holds
        return self._cap

    def __len__(self):
        # whole bytes used, the last one padded with zero bits
        return (self._pos + 7) >> 3

    def write(self, value, nbits):
        if nbits <= 0:
            if nbits == 0 and value == 0:
                return
            raise EncodeError("bad field width %d" % nbits)
        if value < 0 or value >> nbits:
            raise EncodeError("value %d does not fit in %d bits" % (value, nbits))
        pos = self._pos
        if pos + nbits > self._cap:
            raise EncodeError("buffer full: %d bits free, %d needed" % (self._cap - pos, nbits))
        buf = self._buf
        while nbits:
            i = pos >> 3
            room = 8 - (pos & 7)
            if room == 8:
                buf[i] = 0  # first write into this byte: clear leftovers
            take = room if room < nbits else nbits
            nbits -= take
            buf[i] |= ((value >> nbits) & ((1 << take) - 1)) << (room - take)
            pos += take
        self._pos = pos

    def write_signed(self, value, nbits):
        if nbits == 0 and value == 0:
            return
        lim = 1 << (nbits - 1) if nbits > 0 else 0
        if value < -lim or value >= lim:
            raise EncodeError("value %d does not fit in %d signed bits" % (value, nbits))
        self.write(value & ((1 << nbits) - 1), nbits)

    def write_bytes(self, data):
        # Whole bytes at the current (possibly unaligned) position; all or nothing.
        n = len(data)
        if self._pos + n * 8 > self._cap:
            raise EncodeError("buffer full: %d bits free, %d needed" % (self._cap - self._pos, n * 8))
        if self._pos & 7 == 0:
            i = self._pos >> 3
            self._buf[i : i + n] = data
            self._pos += n * 8
        else:
            for b in data:
                self.write(b, 8)

    def getvalue(self):
        # A copy of the used bytes (allocates; hot paths use len() and the buffer).
        return bytes(self._buf[: len(self)])


class BitReader:
    def __init__(self, data, nbits=None):
        # data: any buffer. nbits limits the readable length (default: all).
        self._mv = memoryview(data)
        total = len(self._mv) * 8
        if nbits is None:
            nbits = total
        elif nbits < 0 or nbits > total:
            raise DecodeError("bit length %d outside buffer of %d bits" % (nbits, total))
        self._end = nbits
        self._pos = 0

    @property
    def position(self):
        return self._pos

    @property
    def remaining(self):
        return self._end - self._pos

    def read(self, nbits):
        if nbits < 0:
            raise DecodeError("bad field width %d" % nbits)
        pos = self._pos
        if pos + nbits > self._end:
            raise DecodeError("read past end: %d bits wanted, %d left" % (nbits, self._end - pos))
        mv = self._mv
        value = 0
        while nbits:
            i = pos >> 3
            room = 8 - (pos & 7)
            take = room if room < nbits else nbits
            nbits -= take
            value = (value << take) | ((mv[i] >> (room - take)) & ((1 << take) - 1))
            pos += take
        self._pos = pos
        return value

    def read_signed(self, nbits):
        v = self.read(nbits)
        if nbits and v >> (nbits - 1):
            v -= 1 << nbits
        return v

    def read_bytes(self, n):
        # Returns a memoryview slice when aligned (no copy), else a new bytes.
        if n < 0:
            raise DecodeError("bad byte count %d" % n)
        if self._pos + n * 8 > self._end:
            raise DecodeError("read past end: %d bytes wanted, %d bits left" % (n, self._end - self._pos))
        if self._pos & 7 == 0:
            i = self._pos >> 3
            self._pos += n * 8
            return self._mv[i : i + n]
        out = bytearray(n)
        for k in range(n):
            out[k] = self.read(8)
        return bytes(out)

    def skip(self, nbits):
        if nbits < 0 or self._pos + nbits > self._end:
            raise DecodeError("skip past end")
        self._pos += nbits
