# A small LZ77-family compressor that both runtimes can run both ways.
#
# MicroPython's deflate module only decompresses on most boards, and a buoy
# must compress what it forwards, so acomm carries its own format: a bit
# stream of literals and back-references with Elias-gamma lengths and
# offsets, and short tokens that repeat one of the four most recent offsets
# (records and log lines repeat their layout at a fixed distance, so after a
# changed digit the copy goes on from the same offset for 3 bits plus the
# length). 7-bit literals when the data is ASCII. docs/wire-format.md,
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
#       buffer and the bytes copy returned (2 * n at the peak).
#       Compression does not detect damage: a corrupted stream may decode
#       to wrong bytes of a valid length; the transport's CRC guards that.
#
# RAM while compressing: two tables of 16-bit positions (HASH_SIZE +
# WINDOW entries = 2.5 KiB, allocated at the first call and reused) and
# one output buffer of len(data) + 2 bytes.
# Work per input byte is bounded: at most MAX_CHAIN candidates, each
# compared for at most MAX_MATCH bytes, and a candidate's compare length is
# consumed by the match it wins.

from array import array

from ..compat import const
from ..errors import DecodeError

# The compressor's window. The transport compresses one packet at a time
# (typically under 2 KiB) and log lines or records repeat within a few
# hundred bytes: 2048 saved 2 % more on the 2 KiB dive log while the chain
# table grows by 2 bytes per position. The format itself allows any offset
# back to the start of the output, up to 65535.
WINDOW = const(1024)
_WMASK = const(1023)
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
# the four most recent offsets, most recent first, before any match
_REPS0 = (1, 2, 3, 4)

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
    def __init__(self, buf, pos):
        self.buf = buf
        self.pos = pos
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


# The hash and chain tables of the last compress(), kept so that a node that
# compresses every packet does not allocate (and fragment) 2.5 KiB each time.
# Taken out while in use, so a second, concurrent caller (a thread on
# CPython) allocates its own instead of sharing them.
_spare = None


def _take_tables():
    global _spare
    t = _spare
    _spare = None
    if t is None:
        return (array("H", bytes(2 * HASH_SIZE)), array("H", bytes(2 * WINDOW)))
    # cleared so the output never depends on an earlier call
    head, chain = t
    for j in range(HASH_SIZE):
        head[j] = 0
    for j in range(WINDOW):
        chain[j] = 0
    return t


def compress(data):
    global _spare
    n = len(data)
    lit7 = True
    for b in data:
        if b & 0x80:
            lit7 = False
            break
    if n > 2:
        hdr = _header(n, MODE_LZ7 if lit7 else MODE_LZ8)
        # room for the header and a body one byte shorter than the data
        buf = bytearray(len(hdr) + n - 1)
        buf[: len(hdr)] = hdr
        tables = _take_tables()
        try:
            k = _Parser(data, n, 7 if lit7 else 8, buf, len(hdr), tables).run()
            return bytes(memoryview(buf)[:k])
        except _Overflow:
            buf = None
        finally:
            _spare = tables
    return bytes(_header(n, MODE_STORED)) + bytes(data)


class _Parser:
    # Greedy parse with one step of lazy evaluation: at each position the
    # token with the largest saving over plain literals (a repeat of a recent
    # offset, or the best candidate of the hash chain); if the next position
    # offers a larger saving, a literal goes first. find() leaves its answer
    # in attributes rather than a tuple so the loop allocates nothing.

    def __init__(self, data, n, litk, buf, start, tables):
        self.data = data
        self.n = n
        self.litk = litk
        self.out = _BitOut(buf, start)
        self.head, self.chain = tables
        self.reps = array("H", _REPS0)
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
            reps = self.reps
            for j in range(4):
                d = reps[j]
                if d <= i:
                    k = _match_len(data, i, i - d, limit)
                    if k >= 2:
                        g = k * litcost - _REP_COST[j] - _gamma_bits(k - 1)
                        if g > gain:
                            best = k
                            gain = g
                            off = d
                            rep = j
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
                        best = k
                        gain = g
                        off = d
                        rep = -1
                nxt = cand - ((cand - chain[cand & _WMASK]) & 0xFFFF)
                if nxt >= cand:
                    break
                cand = nxt
        # attributes, not a returned tuple: nothing allocated per position
        self.best = best
        self.gain = gain
        self.off = off
        self.rep = rep

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
            best = self.best
            gain = self.gain
            off = self.off
            rep = self.rep
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
        return out.flush()

    def emit(self, length, off, rep):
        out = self.out
        if rep < 0:
            out.put(2, 2)
            v = off - 1
            out.gamma((v >> _OFF_LO) + 1)
            out.put(v & _OFF_LO_MASK, _OFF_LO)
            self.reps[3] = off
            _to_front(self.reps, 3)
        else:
            out.put(_REP_CODE[rep], _REP_COST[rep])
            _to_front(self.reps, rep)
        out.gamma(length - 1)


def _to_front(reps, j):
    # recent offsets: move entry j to the front, shifting the others back
    d = reps[j]
    while j:
        reps[j] = reps[j - 1]
        j -= 1
    reps[0] = d


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
    reps = array("H", _REPS0)
    i = 0
    while i < n:
        if not bits.get(1):
            out[i] = bits.get(litk)
            i += 1
            continue
        if not bits.get(1):
            off = (((bits.gamma() - 1) << _OFF_LO) | bits.get(_OFF_LO)) + 1
            if off > 0xFFFF:  # no valid stream has one (window < 64 KiB)
                raise DecodeError("compressed: offset too large")
            reps[3] = off
            _to_front(reps, 3)
        else:
            j = 0  # 110, 1110, 11110, 11111: repeat 0..3
            while j < 3 and bits.get(1):
                j += 1
            off = reps[j]
            _to_front(reps, j)
        k = bits.gamma() + 1
        if off > i:
            raise DecodeError("compressed: reference before the start")
        if k > n - i:
            raise DecodeError("compressed: match runs past the stated length")
        s = i - off
        if off >= k and k >= 32:
            # one block copy; the two views it allocates only pay off on
            # long copies
            mv[i : i + k] = mv[s : s + k]
            i += k
        else:
            # short or overlapping copy, byte by byte: in an overlapping one
            # each byte may be one this match just wrote
            e = i + k
            while i < e:
                out[i] = out[s]
                i += 1
                s += 1
    if bits.acc or bits.pos != len(data):
        raise DecodeError("compressed: trailing data")
    return bytes(out)
