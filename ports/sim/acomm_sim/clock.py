# Injected time. Core code never reads the wall clock: it is handed `now` in
# integer milliseconds of acomm's ticks domain (see compat). The ports pass
# compat.ticks_ms; tests and the simulator pass a ManualClock.

from acomm.compat import TICKS_MAX, ticks_add


class ManualClock:
    # A clock that moves only when told to. Starting it near the wrap point
    # (e.g. ManualClock(TICKS_MAX - 1000)) makes tests cross the 2**30 wrap.
    def __init__(self, start=0):
        self._now = start & TICKS_MAX

    def __call__(self):
        return self._now

    def now(self):
        return self._now

    def advance(self, ms):
        if ms < 0:
            raise ValueError("time does not go backwards")
        self._now = ticks_add(self._now, ms)
        return self._now
