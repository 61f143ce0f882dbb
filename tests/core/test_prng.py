# Prng tests (acomm.prng). The fixed values below pin the xorshift32 sequence:
# tests, fault injection and the simulator rely on it being identical on
# MicroPython and CPython, and across versions of acomm.

from acomm.prng import Prng
from checks import raises as _raises

# xorshift32 (13, 17, 5) from seed 1 after the murmur3 finaliser mix
SEED1_FIRST = (2242346331, 730407933, 4045800646, 107306809, 499586808)


def test_fixed_first_outputs_for_seed_1():
    p = Prng(1)
    assert tuple(p.next32() for _ in range(5)) == SEED1_FIRST
    assert tuple(Prng().next32() for _ in range(1)) == SEED1_FIRST[:1]  # default seed is 1


def test_same_seed_same_sequence_and_reseed():
    a = Prng(12345)
    b = Prng(12345)
    sa = [a.next32() for _ in range(100)]
    assert sa == [b.next32() for _ in range(100)]
    a.seed(12345)
    assert [a.next32() for _ in range(100)] == sa
    c = Prng(12346)
    assert [c.next32() for _ in range(100)] != sa
    # seeds are taken modulo 2**32
    assert Prng(1 + (1 << 32)).next32() == SEED1_FIRST[0]


def test_seed_zero_is_not_stuck():
    p = Prng(0)
    outs = [p.next32() for _ in range(10)]
    assert 0 not in outs
    assert len(set(outs)) == 10
    assert outs[:2] == [1359758873, 3761132862]


def test_small_seeds_do_not_start_with_small_numbers():
    # unmixed xorshift from state 1 starts with 270369: chance(0.001) True
    for seed in range(1, 200):
        assert Prng(seed).next32() > 0x400000, seed


def test_next32_range():
    p = Prng(77)
    for _ in range(1000):
        v = p.next32()
        assert 0 < v <= 0xFFFFFFFF


def test_below_range():
    p = Prng(5)
    for n in (1, 2, 3, 7, 10, 255, 256, 1000, 0x7FFFFFFF, 0x80000001, 0xFFFFFFFF, 0x100000000):
        for _ in range(200):
            v = p.below(n)
            assert 0 <= v < n, (n, v)
    assert p.below(1) == 0
    # ranges beyond 32 bits combine words
    for n in (0x100000001, 1 << 40, 1 << 64, (1 << 64) + 3):
        hi = 0
        for _ in range(200):
            v = p.below(n)
            assert 0 <= v < n
            if v > 0xFFFFFFFF:
                hi += 1
        assert hi > 0 or n == 0x100000001
    _raises(ValueError, p.below, 0)
    _raises(ValueError, p.below, -3)


def test_below_hits_every_value_of_small_ranges():
    p = Prng(6)
    for n in (2, 3, 5, 10):
        seen = [0] * n
        for _ in range(50 * n):
            seen[p.below(n)] += 1
        assert min(seen) > 0


def test_range_inclusive_bounds():
    p = Prng(8)
    for lo, hi in ((0, 1), (1, 6), (-3, 3), (-10, -8), (100, 103)):
        seen = {}
        for _ in range(300):
            v = p.range(lo, hi)
            assert lo <= v <= hi, (lo, hi, v)
            seen[v] = 1
        assert len(seen) == hi - lo + 1  # both ends included
    assert p.range(5, 5) == 5
    assert p.range(-7, -7) == -7
    _raises(ValueError, p.range, 3, 2)


def test_bytes_length_and_determinism():
    p = Prng(1)
    for n in range(0, 13):
        b = p.bytes(n)
        assert isinstance(b, bytes)
        assert len(b) == n
    # words are emitted little-endian: 2242346331 = 0x85A77D5B
    assert Prng(1).bytes(6) == b"\x5b\x7d\xa7\x85\xfd\x23"
    assert Prng(1).bytes(8) == b"\x5b\x7d\xa7\x85\xfd\x23\x89\x2b"
    assert Prng(3).bytes(100) == Prng(3).bytes(100)
    assert Prng(1).bytes(0) == b""


def test_chance_extremes():
    p = Prng(4)
    for _ in range(200):
        assert p.chance(1.0)
        assert not p.chance(0.0)
    hits = 0
    for _ in range(1000):
        if p.chance(0.5):
            hits += 1
    assert 0 < hits < 1000
