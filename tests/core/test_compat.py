from acomm_sim.clock import ManualClock
from acomm.compat import TICKS_MAX, TICKS_PERIOD, const, micropython, ticks_add, ticks_diff, ticks_less, ticks_ms
from acomm.errors import AcommError, CRCError, DecodeError, EncodeError
from checks import raises

_SEVEN = const(7)


def test_const_inlines_value():
    assert _SEVEN == 7


@micropython.native
def _native_sum(n):
    s = 0
    for i in range(n):
        s += i
    return s


def test_native_decorator_runs_on_both_runtimes():
    assert _native_sum(10) == 45


def test_ticks_period_is_2_pow_30():
    assert TICKS_PERIOD == 1 << 30
    assert ticks_add(TICKS_MAX, 1) == 0
    assert ticks_add(0, -1) == TICKS_MAX


def test_ticks_diff_across_wrap():
    a = TICKS_MAX - 5
    b = ticks_add(a, 10)
    assert b == 4
    assert ticks_diff(b, a) == 10
    assert ticks_diff(a, b) == -10
    assert ticks_less(a, b)
    assert not ticks_less(b, a)


def test_ticks_diff_half_range():
    half = TICKS_PERIOD // 2
    # the largest forward distance that still reads as "later"
    assert ticks_diff(ticks_add(0, half - 1), 0) == half - 1
    assert ticks_diff(ticks_add(0, -(half - 1)), 0) == -(half - 1)
    # half a period or more either way is refused, as by MicroPython's own
    # ticks_add on a 32-bit board: it would read as the other direction
    for delta in (half, -half, half + 7, TICKS_PERIOD):
        raises(OverflowError, ticks_add, 0, delta)
    assert ticks_diff(ticks_add(ticks_add(0, half - 1), 1), 0) == -half


def test_ticks_ms_in_domain():
    t = ticks_ms()
    assert 0 <= t <= TICKS_MAX


def test_manual_clock_wraps():
    c = ManualClock(TICKS_MAX - 1)
    t0 = c()
    c.advance(3)
    assert c() == 1
    assert ticks_diff(c(), t0) == 3
    try:
        c.advance(-1)
        assert False
    except ValueError:
        pass


def test_error_hierarchy():
    assert issubclass(DecodeError, AcommError)
    assert issubclass(CRCError, DecodeError)
    assert issubclass(EncodeError, AcommError)
    assert not issubclass(EncodeError, DecodeError)
