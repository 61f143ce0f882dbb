# Runtime shims so that one source runs on MicroPython and CPython.
#
# const: MicroPython inlines `_NAME = const(x)` at compile time; CPython needs
#   an identity function.
# micropython: the compiler recognises `@micropython.native` / `@micropython.viper`
#   by name, so modules must write those decorators literally. On CPython we
#   provide a class with the same names that returns the function unchanged.
# ticks: acomm keeps its own millisecond clock domain with a period of 2**30 on
#   every runtime (the period of 32-bit MCUs). Times are compared only with
#   ticks_diff, never with < or >, so wrap-around is safe, and the CPython tests
#   exercise it because the period is small. ticks_add takes a delta of
#   less than half the period either way, as MicroPython's does on a 32-bit
#   board, and raises OverflowError otherwise on every runtime: a deadline
#   half a period or more ahead could not be told from one in the past.

try:
    import micropython
    from micropython import const
except ImportError:

    def const(x):
        return x

    class micropython:
        @staticmethod
        def native(f):
            return f

        @staticmethod
        def viper(f):
            return f

        @staticmethod
        def const(x):
            return x

import time

TICKS_PERIOD = const(1 << 30)
TICKS_MAX = const((1 << 30) - 1)
_TICKS_HALF = const(1 << 29)

IS_MICROPYTHON = hasattr(time, "ticks_ms")


if IS_MICROPYTHON and time.ticks_add(0, -1) == TICKS_MAX:
    # The board's own ticks already wrap at 2**30: use the C versions, which
    # do not allocate (and the Python ones below are never made: on a board
    # that loads its modules from flash they would take heap for nothing).
    ticks_add = time.ticks_add
    ticks_diff = time.ticks_diff
    ticks_ms = time.ticks_ms
else:

    def ticks_add(ticks, delta):
        # ticks + delta in the domain; |delta| < 2**29 (OverflowError otherwise)
        if not -_TICKS_HALF < delta < _TICKS_HALF:
            raise OverflowError("ticks interval overflow")
        return (ticks + delta) & TICKS_MAX

    def ticks_diff(a, b):
        # Signed distance a - b in the circular domain, in [-2**29, 2**29).
        return ((a - b + _TICKS_HALF) & TICKS_MAX) - _TICKS_HALF

    if IS_MICROPYTHON:
        # The unix port wraps at 2**62, a multiple of 2**30: masking keeps
        # the arithmetic consistent.
        def ticks_ms():
            return time.ticks_ms() & TICKS_MAX

    else:

        def ticks_ms():
            return int(time.monotonic() * 1000) & TICKS_MAX


def ticks_less(a, b):
    # True when a is earlier than b.
    return ticks_diff(a, b) < 0
