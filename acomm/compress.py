# A small LZ77-family compressor that both runtimes can run both ways.
#
# MicroPython's deflate module only decompresses on most boards, and a buoy
# must compress what it forwards, so acomm carries its own format: a bit
# stream of literals and back-references with Elias-gamma lengths and
# offsets and a "repeat the last offset" token (records and log lines repeat
# their layout at a fixed distance, so after a changed digit the copy goes on
# from the same offset for 2 bits plus the length). docs/wire-format.md,
# "Compression", has the byte and bit layout.
#
# Interface (used by the store-and-forward transport):
#
#   compress(data) -> bytes
#       Never raises for bytes, bytearray or memoryview input. The result is
#       at most len(data) + 3 bytes for inputs below 512 KiB (a stored block:
#       the header, then the bytes as they are) and is never longer than
#       that; the caller may still keep whichever of the two forms is shorter.
#       Deterministic: the same input gives the same bytes on every runtime.
#   decompress(data, max_out) -> bytes
#       Raises acomm.errors.DecodeError for any malformed input and when the
#       output would be longer than max_out. The output length is in the
#       header and is checked before anything is allocated, so a
#       decompression bomb costs nothing; working memory is the output
#       buffer only.
#
# RAM while compressing: two tables of 16-bit positions (HASH_SIZE +
# WINDOW entries = 2.5 KiB) and one output buffer of len(data) bytes.
# Work per input byte is bounded: at most MAX_CHAIN candidates, each
# compared for at most MAX_MATCH bytes, and a candidate's compare length is
# consumed by the match it wins.

from array import array

from .compat import const
from .errors import DecodeError

# The compressor's window. The transport compresses one packet at a time
# (typically under 2 KiB) and log lines or records repeat within a few
# hundred bytes, so a larger window would find little more while the chain
# table grows by 2 bytes per position. The format itself allows any offset
# back to the start of the output.
WINDOW = const(1024)
_WMASK = const(1023)
HASH_BITS = const(8)
HASH_SIZE = const(256)
_HMASK = const(255)
MAX_CHAIN = const(8)
MAX_MATCH = const(1024)
# a match at least this long is taken without looking one position ahead
LAZY_BELOW = const(32)

# Offsets are coded as gamma(((off - 1) >> _OFF_LO) + 1) then the low
# _OFF_LO bits: offsets 1..64 cost 7 bits, up to 192 cost 9, up to 448
# cost 11, up to 960 cost 13 (6 low bits came out best on logs, records
# and chat; 5 and 7 were within 1 %).
_OFF_LO = const(6)
_OFF_LO_MASK = const(63)

# Token prefixes: 0 literal, 10 new offset, 110 / 1110 / 11110 / 11111
# repeat of the 1st..4th most recent offset.
_REP_CODE = (6, 14, 30, 31)
_REP_COST = (3, 4, 5, 5)

MODE_STORED = const(0)
MODE_LZ8 = const(1)  # literals are 8 bits
MODE_LZ7 = const(2)  # every input byte < 0x80: literals are 7 bits
# mode 3 is reserved and rejected

# Decoder limits: the longest gamma prefix any valid stream can have
# (lengths and offset classes below 2**21; the compressor never comes near) and
# the varint header's length.
_MAX_ZEROS = const(20)
_MAX_HEADER = const(5)


def _gamma_bits(v):
    # Bits of the Elias-gamma code of v >= 1: 2 * floor(log2(v)) + 1.
    k = 0
    while v > 1:
        v >>= 1
        k += 1
    return 2 * k + 1


def _offset_bits(off):
    return _gamma_bits(((off - 1) >> _OFF_LO) + 1) + _OFF_LO


def _header(n, mode):
    # LEB128 of n * 4 + mode: 1 byte below 32 bytes of input, 2 below 4 KiB,
    # 3 below 512 KiB.
    v = (n << 2) | mode
    h = bytearray()
    while v >= 0x80:
        h.append((v & 0x7F) | 0x80)
        v >>= 7
    h.append(v)
    return h


class _Overflow(Exception):
    # Internal: the compressed body reached the input's size, so the stored
    # form is at least as short. Never leaves this module.
    pass


class _BitOut:
    # MSB-first bit writer into a preallocated buffer. put() takes at most
    # 22 bits so the accumulator stays a small int on a 32-bit MCU.
    def __init__(self, buf):
        self.buf = buf
        self.pos = 0
        self.acc = 0
        self.nacc = 0

    def put(self, v, k):
        acc = (self.acc << k) | v
        n = self.nacc + k
        buf = self.buf
        while n >= 8:
            n -= 8
            if self.pos >= len(buf):
                raise _Overflow()
            buf[self.pos] = (acc >> n) & 0xFF
            self.pos += 1
        self.acc = acc & ((1 << n) - 1)
        self.nacc = n

    def gamma(self, v):
        # k zero bits, then v in k + 1 bits (its leading 1 ends the zeros).
        k = 0
        t = v
        while t > 1:
            t >>= 1
            k += 1
        if k:
            self.put(0, k)
        self.put(v, k + 1)

    def flush(self):
        # pad the last byte with zero bits
        if self.nacc:
            self.put(0, 8 - self.nacc)
        return self.pos


def _match_len(data, a, b, limit):
    # How many bytes from a equal those from b (b < a; may overlap).
    k = 0
    while k < limit and data[a + k] == data[b + k]:
        k += 1
    return k


def _hash(data, i):
    return ((data[i] << 5) ^ (data[i + 1] << 2) ^ data[i + 2] ^ (data[i] >> 3)) & _HMASK


def compress(data):
    n = len(data)
    lit7 = True
    for b in data:
        if b & 0x80:
            lit7 = False
            break
    mode = MODE_LZ7 if lit7 else MODE_LZ8
    hdr = _header(n, mode)
    if n > 2:
        try:
            body = _lz(data, n, 7 if lit7 else 8)
            return bytes(hdr) + body
        except _Overflow:
            pass
    hdr = _header(n, MODE_STORED)
    return bytes(hdr) + bytes(data)


def _lz(data, n, litk):
    return _Parser(data, n, litk).run()


class _Parser:
    # Greedy parse with one step of lazy evaluation: at each position the
    # token with the largest saving over plain literals (a repeat of a recent
    # offset, or the best candidate of the hash chain); if the next position
    # offers a larger saving, a literal goes first. find() leaves its answer
    # in attributes rather than a tuple so the loop allocates nothing.

    def __init__(self, data, n, litk):
        self.data = data
        self.n = n
        self.litk = litk
        self.out = _BitOut(bytearray(n - 1))
        self.head = array("H", bytes(2 * HASH_SIZE))
        self.chain = array("H", bytes(2 * WINDOW))
        # the four most recent distinct offsets, most recent first
        self.r0, self.r1, self.r2, self.r3 = 1, 2, 3, 4
        self.best = self.gain = self.off = 0
        self.rep = -1

    def insert(self, j):
        # index position j (needs 3 bytes from j)
        h = _hash(self.data, j)
        self.chain[j & _WMASK] = self.head[h]
        self.head[h] = j & 0xFFFF

    def find(self, i):
        data = self.data
        litcost = self.litk + 1
        best = gain = off = 0
        rep = -1
        limit = self.n - i
        if limit > MAX_MATCH:
            limit = MAX_MATCH
        if limit >= 2:
            j = 0
            for d in (self.r0, self.r1, self.r2, self.r3):
                if d <= i:
                    k = _match_len(data, i, i - d, limit)
                    if k >= 2:
                        g = k * litcost - _REP_COST[j] - _gamma_bits(k - 1)
                        if g > gain:
                            best, gain, off, rep = k, g, d, j
                j += 1
        if limit >= 3:
            chain = self.chain
            cand = i - ((i - self.head[_hash(data, i)]) & 0xFFFF)
            depth = MAX_CHAIN
            while depth and 0 <= cand < i and i - cand < WINDOW and best < limit:
                depth -= 1
                k = _match_len(data, i, cand, limit)
                if k >= 3:
                    d = i - cand
                    g = k * litcost - 2 - _offset_bits(d) - _gamma_bits(k - 1)
                    if g > gain:
                        best, gain, off, rep = k, g, d, -1
                nxt = cand - ((cand - chain[cand & _WMASK]) & 0xFFFF)
                if nxt >= cand:
                    break
                cand = nxt
        self.best, self.gain, self.off, self.rep = best, gain, off, rep

    def run(self):
        data = self.data
        n = self.n
        out = self.out
        litk = self.litk
        i = 0
        while i < n:
            self.find(i)
            if i <= n - 3:
                self.insert(i)
            best, gain, off, rep = self.best, self.gain, self.off, self.rep
            if best and best < LAZY_BELOW and i + 1 < n:
                self.find(i + 1)
                if self.gain > gain:
                    best = 0
            if best == 0:
                out.put(data[i], litk + 1)  # flag 0 then the literal
                i += 1
                continue
            self.emit(best, off, rep)
            # index the positions the match covers so later data can refer
            # to them
            j = i + 1
            i += best
            stop = i if i <= n - 3 else n - 2
            while j < stop:
                self.insert(j)
                j += 1
        k = out.flush()
        return bytes(memoryview(out.buf)[:k])

    def emit(self, length, off, rep):
        out = self.out
        if rep < 0:
            out.put(2, 2)
            v = off - 1
            out.gamma((v >> _OFF_LO) + 1)
            out.put(v & _OFF_LO_MASK, _OFF_LO)
            self.r0, self.r1, self.r2, self.r3 = off, self.r0, self.r1, self.r2
        else:
            out.put(_REP_CODE[rep], _REP_COST[rep])
            if rep == 1:
                self.r0, self.r1 = self.r1, self.r0
            elif rep == 2:
                self.r0, self.r1, self.r2 = self.r2, self.r0, self.r1
            elif rep == 3:
                self.r0, self.r1, self.r2, self.r3 = self.r3, self.r0, self.r1, self.r2
        out.gamma(length - 1)


class _BitIn:
    def __init__(self, data, pos):
        self.data = data
        self.pos = pos
        self.acc = 0
        self.nacc = 0

    def get(self, k):
        # k <= 24 bits, MSB first; DecodeError when the stream ends
        acc = self.acc
        n = self.nacc
        data = self.data
        while n < k:
            if self.pos >= len(data):
                raise DecodeError("compressed stream truncated")
            acc = (acc << 8) | data[self.pos]
            self.pos += 1
            n += 8
        n -= k
        self.nacc = n
        self.acc = acc & ((1 << n) - 1)
        return acc >> n

    def gamma(self):
        k = 0
        while not self.get(1):
            k += 1
            if k > _MAX_ZEROS:
                raise DecodeError("compressed stream: bad gamma code")
        return (1 << k) | self.get(k) if k else 1


def _read_header(data, max_out):
    v = 0
    shift = 0
    i = 0
    lim = (max_out << 2) | 3
    while True:
        if i >= len(data) or i >= _MAX_HEADER:
            raise DecodeError("compressed header truncated or too long")
        b = data[i]
        i += 1
        v |= (b & 0x7F) << shift
        if v > lim:
            raise DecodeError("compressed data longer than max_out")
        if not b & 0x80:
            if b == 0 and i > 1:
                raise DecodeError("compressed header not minimal")
            return v >> 2, v & 3, i
        shift += 7


def decompress(data, max_out):
    n, mode, p = _read_header(data, max_out)
    if mode == MODE_STORED:
        if len(data) - p != n:
            raise DecodeError("stored block length mismatch")
        return bytes(data[p:])
    if mode == 3:
        raise DecodeError("compressed: unknown mode")
    litk = 7 if mode == MODE_LZ7 else 8
    out = bytearray(n)
    mv = memoryview(out)
    bits = _BitIn(data, p)
    r0, r1, r2, r3 = 1, 2, 3, 4
    i = 0
    while i < n:
        if not bits.get(1):
            out[i] = bits.get(litk)
            i += 1
            continue
        if not bits.get(1):
            off = (((bits.gamma() - 1) << _OFF_LO) | bits.get(_OFF_LO)) + 1
            r0, r1, r2, r3 = off, r0, r1, r2
        elif not bits.get(1):
            off = r0
        elif not bits.get(1):
            off = r1
            r0, r1 = r1, r0
        elif not bits.get(1):
            off = r2
            r0, r1, r2 = r2, r0, r1
        else:
            off = r3
            r0, r1, r2, r3 = r3, r0, r1, r2
        k = bits.gamma() + 1
        if off > i:
            raise DecodeError("compressed: reference before the start")
        if k > n - i:
            raise DecodeError("compressed: match runs past the stated length")
        s = i - off
        if off >= k:
            mv[i : i + k] = mv[s : s + k]
            i += k
        else:
            # overlapping copy: each byte may be one this match just wrote
            e = i + k
            while i < e:
                out[i] = out[s]
                i += 1
                s += 1
    if bits.acc or bits.pos != len(data):
        raise DecodeError("compressed: trailing data")
    return bytes(out)
