# Advancing an acomm.prng.Prng by n draws without making them, for the
# Channel: a large network's transmission owes one draw to every station,
# in reach or not, so that the figures do not depend on the shortcut for
# stations out of reach (channel.py), and drawing them one by one made the
# cost of a transmission grow with the size of the whole network.
#
# xorshift32's step is linear over GF(2): the state after 2**j steps is a
# fixed 32 x 32 bit matrix times the state. Each such matrix is kept as four
# tables of 256 words (what each byte of the state contributes), so skip(n)
# costs four look-ups per set bit of n. The tables are built on first use
# and shared by every generator: 4 KiB (an array of 32-bit words; a list
# of ints took 66 KiB) per power of two, eight powers for the 256-node
# scale run. tests/core/test_prngskip.py checks that
# skip(rng, n) leaves the generator where n calls of next32 do.
# Portable Python (the core tests run it on MicroPython too).

from array import array

# below this many draws, making them costs less than the tables. On
# CPython 3.11: 2 or 3 draws as fast as the tables, 4 draws 0.92 us against
# 0.37, 13 draws 2.35 us against 1.05 (the 256-node grid's gaps between
# neighbours in the stations' order are 13 or 14 stations)
_DIRECT = 4
_tables = []  # [j] -> flat list of 4 x 256 words: the step taken 2**j times


def _step(s):
    # one xorshift32 step, as acomm.prng.Prng.next32 takes it
    s ^= (s << 13) & 0xFFFFFFFF
    s ^= s >> 17
    s ^= (s << 5) & 0xFFFFFFFF
    return s


def _apply(t, s):
    return t[s & 255] ^ t[256 + ((s >> 8) & 255)] ^ t[512 + ((s >> 16) & 255)] ^ t[768 + (s >> 24)]


def _table(j):
    # the byte tables of the step taken 2**j times (and those of the
    # smaller powers, from which it is built)
    while len(_tables) <= j:
        i = len(_tables)
        if i == 0:
            images = [_step(1 << b) for b in range(32)]
        else:
            prev = _tables[i - 1]
            images = [_apply(prev, _apply(prev, 1 << b)) for b in range(32)]
        t = [0] * 1024
        for byte in range(4):
            base = byte * 256
            for v in range(1, 256):
                low = v & -v  # v's lowest set bit: t[v] = t[v without it] ^ its image
                b = 0
                while (1 << b) != low:
                    b += 1
                t[base + v] = t[base + (v ^ low)] ^ images[byte * 8 + b]
        _tables.append(array("I", t))
    return _tables[j]


def skip(rng, n):
    """Advances rng (an acomm.prng.Prng) as n calls of rng.next32() would, for n >= 0."""
    if n < _DIRECT:
        nxt = rng.next32
        for _ in range(n):
            nxt()
        return
    tables = _tables
    if n >> len(tables):
        j = len(tables)  # the tables up to n's highest bit
        while n >> (j + 1):
            j += 1
        _table(j)
    s = rng._s  # Prng's whole state (xorshift32's word)
    j = 0
    while n:
        if n & 1:
            t = tables[j]  # _apply(t, s), inlined: no call per set bit
            s = t[s & 255] ^ t[256 + ((s >> 8) & 255)] ^ t[512 + ((s >> 16) & 255)] ^ t[768 + (s >> 24)]
        n >>= 1
        j += 1
    rng._s = s
