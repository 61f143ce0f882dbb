# A tiny deterministic pseudo-random generator (xorshift32).
#
# Tests, fault injection and the simulator need sequences that are identical
# on MicroPython and CPython for the same seed; the runtimes' own `random`
# modules differ, so acomm carries its own. Not for cryptography.


class Prng:
    def __init__(self, seed=1):
        self.seed(seed)

    def seed(self, seed):
        # xorshift's first outputs from a small state are small (seed 1
        # gives 270369 first: chance(0.001) would be True), so the seed is
        # mixed first (the murmur3 finaliser): nearby seeds give unrelated
        # sequences from the first draw.
        s = (seed * 0x9E3779B1) & 0xFFFFFFFF
        s ^= s >> 16
        s = (s * 0x85EBCA6B) & 0xFFFFFFFF
        s ^= s >> 13
        s = (s * 0xC2B2AE35) & 0xFFFFFFFF
        s ^= s >> 16
        self._s = s if s else 0x9E3779B9

    def next32(self):
        s = self._s
        s ^= (s << 13) & 0xFFFFFFFF
        s ^= s >> 17
        s ^= (s << 5) & 0xFFFFFFFF
        self._s = s
        return s

    def below(self, n):
        # uniform integer in [0, n) for 0 < n <= 2**32, without modulo bias
        if n <= 0:
            raise ValueError("n must be positive")
        if n > 0x100000000:
            # big ranges: combine words
            v = 0
            bits = 0
            while (1 << bits) < n:
                v = (v << 32) | self.next32()
                bits += 32
            return v % n
        lim = 0x100000000 - (0x100000000 % n)
        while True:
            v = self.next32()
            if v < lim:
                return v % n

    def range(self, lo, hi):
        # integer in [lo, hi] inclusive
        return lo + self.below(hi - lo + 1)

    def chance(self, p):
        # True with probability p (0..1)
        return self.next32() < int(p * 0x100000000)

    def bytes(self, n):
        out = bytearray(n)
        i = 0
        while i < n:
            v = self.next32()
            for _ in range(4):
                if i < n:
                    out[i] = v & 0xFF
                    v >>= 8
                    i += 1
        return bytes(out)
