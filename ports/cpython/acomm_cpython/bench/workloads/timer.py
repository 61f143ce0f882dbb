# What the workloads share, on both runtimes: wall-clock microseconds (for
# benchmark workloads only: the core never reads the clock), rate(),
# emit_json() and quick mode (`acomm bench NAME --quick`, or --quick to a
# workload run as a script: its code path with small sizes, every rate()
# measured for QUICK_US, the figures meaningless; a workload's run(emit,
# quick) calls set_quick). Every portable workload imports this first, so it also puts
# the checkout's root on the path of a workload run as a script from a
# checkout (python3 or micropython ports/cpython/acomm_cpython/bench/
# workloads/NAME.py): five folders above this one.
import sys

try:
    import acomm  # noqa: F401
except ImportError:
    sys.path.insert(0, "/".join(__file__.split("/")[:-6]) or ".")

try:
    from time import ticks_diff, ticks_us

    def now_us():
        return ticks_us()

    def elapsed_us(t0):
        return ticks_diff(ticks_us(), t0)

except ImportError:
    from time import perf_counter

    def now_us():
        return perf_counter() * 1e6

    def elapsed_us(t0):
        return perf_counter() * 1e6 - t0


QUICK_US = 2000
_quick = [False]


def set_quick(on):
    """Quick mode on (rate() measures for QUICK_US) or off."""
    _quick[0] = bool(on)


def quick_argv():
    """Whether a workload run as a script was given --quick."""
    return "--quick" in sys.argv


def rate(fn, min_us=300000):
    # Calls fn() (which does `k` units of work and returns k) until min_us
    # have passed (QUICK_US in quick mode); returns units per second.
    if _quick[0]:
        min_us = QUICK_US
    units = 0
    t0 = now_us()
    while True:
        units += fn()
        dt = elapsed_us(t0)
        if dt >= min_us:
            return units * 1e6 / dt


def emit_json(name, value, unit):
    print('{"name": "%s", "value": %s, "unit": "%s"}' % (name, _num(value), unit))


def _num(v):
    if isinstance(v, float):
        return "%.6g" % v
    return "%d" % v
