# acomm_sim.prngskip.skip(rng, n) leaves a generator where n draws leave it:
# the Channel skips the draws owed by stations out of reach with it, and the
# simulator's figures stay identical only if this holds.
from acomm.prng import Prng
from acomm_sim.prngskip import skip


def _drawn(seed, n):
    r = Prng(seed)
    for _ in range(n):
        r.next32()
    return r


def test_skip_lands_where_the_draws_land():
    for seed in (1, 7, 123456):
        for n in (0, 1, 2, 15, 16, 17, 31, 64, 100, 255, 256, 257, 511, 1000, 4097):
            r = Prng(seed)
            skip(r, n)
            ref = _drawn(seed, n)
            # the same state, and so the same draws after it
            assert [r.next32() for _ in range(3)] == [ref.next32() for _ in range(3)], (seed, n)


def test_skips_add_up():
    r = Prng(5)
    for n in (300, 17, 0, 5, 1024):
        skip(r, n)
    assert r.next32() == _drawn(5, 300 + 17 + 5 + 1024).next32()


def test_a_draw_between_skips_is_the_same_draw():
    # as the Channel uses it: skip the stations out of reach, draw for one in reach
    r = Prng(9)
    ref = Prng(9)
    for n in (40, 3, 200, 13):
        skip(r, n)
        for _ in range(n):
            ref.next32()
        assert r.chance(0.3) == ref.chance(0.3)
        assert r.next32() == ref.next32()  # and still the same state: the same next draw
