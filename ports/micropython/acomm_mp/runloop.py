# The node's main loop: one Board.poll() per step_ms. Board.tick() steps
# the node, feeds the watchdog and collects garbage at safe points. It
# never lets an error out: a MemoryError in the middle of a transfer, or
# anything a driver raises on garbage, is counted, reported once per kind
# through say(), and the node carries on at the next tick (the store still
# holds every packet).
#
# An idle node is stepped every idle_ms only. Stepped every 10 ms, the
# idle buoy's RP2040 ran 37 % of the time (the emulator's sleep_ms: about
# 3.7 ms a pass); stepped every 100 ms, 7.6 %. Asking its UARTs whether
# bytes wait costs little. So poll() ticks when bytes wait on a UART, when
# the last step moved bytes (a command answered, a frame half written), or
# when idle_ms have passed since it last ran (the timers: retries, adverts,
# lifespans, gc); otherwise it only feeds the watchdog. Acoustic and satellite timers are seconds long: 100 ms
# late is nothing to them, and input is still taken within step_ms.
#
# run_blocking() is what acomm_mp.start runs on a board: a plain loop that
# sleeps what is left of each step. acomm_mp.runasync.run() is the same
# loop as an asyncio task, in its own module: a relay loads neither it nor
# asyncio (on a 64 KiB heap asyncio's module objects cost about 2.3 KiB).

import gc

from acomm.compat import ticks_add, ticks_diff, ticks_ms


class Board:
    def __init__(self, cfg, node, transport, station, say, streams=()):
        self.cfg = cfg
        self.node = node
        self.transport = transport
        self.station = station
        self.say = say
        self.wdt = None
        self._gc_due = None
        self.stats = {"ticks": 0, "errors": 0, "oom": 0, "gc": 0, "rests": 0}
        # the any() of each UART (links, GPS) poll() asks, bound once (a
        # bound method made per pass is an allocation every step_ms); None
        # for a stream without one, which makes every poll a tick
        self._waiting = [getattr(s, "any", None) for s in streams]
        self._last = None  # when the node last stepped
        self._busy = True  # whether that step moved bytes
        self._reported = []  # exception types already reported (at most 8)
        self.mem_peak = 0

    def poll(self, now):
        """One pass of the main loop at `now`: tick() when the node has work or idle_ms have passed, else only feed the watchdog."""
        if self._busy or ticks_diff(now, self._last) >= self.cfg["idle_ms"]:
            self.tick(now)
            return
        for a in self._waiting:
            if a is None or a():
                self.tick(now)
                return
        self.stats["rests"] += 1
        if self.wdt is not None:
            self.wdt.feed()

    def tick(self, now):
        """One step of the node at `now`: errors counted and reported, never raised; the watchdog fed; gc when due."""
        self.stats["ticks"] += 1
        self._last = now
        moved = self.node.moved
        try:
            self.node.step(now)
            if self.station is not None:
                self.station.poll(now)
        except MemoryError:
            self.stats["oom"] += 1
            gc.collect()
            self._report("MemoryError", "out of memory during a step; packets stay in the store, carrying on")
        except Exception as e:  # noqa: BLE001 - the node must keep running at sea
            self.stats["errors"] += 1
            kind = type(e).__name__
            self._report(kind, "error during a step: %s %s" % (kind, e))
        self._busy = self.node.moved != moved
        if self.wdt is not None:
            self.wdt.feed()
        if self._gc_due is None or ticks_diff(now, self._gc_due) >= 0:
            # between steps nothing is half-built: a safe point to collect
            self._gc_due = ticks_add(now, self.cfg["gc_ms"])
            self._measure()
            gc.collect()
            self.stats["gc"] += 1

    def _measure(self):
        alloc = getattr(gc, "mem_alloc", None)
        if alloc is not None:
            a = alloc()
            if a > self.mem_peak:
                self.mem_peak = a

    def _report(self, kind, text):
        # once per exception type, and for at most 8 types: a fault that
        # repeats every tick must not flood the console (stats count all)
        if kind in self._reported or len(self._reported) >= 8:
            return
        self._reported.append(kind)
        self.say("acomm %s: %s" % (self.cfg["name"], text))


def run_blocking(board, clock=ticks_ms, sleep_ms=None, stop=None):
    """Polls the board every step_ms until stop() is true (for ever by default)."""
    if sleep_ms is None:
        import time

        sleep_ms = time.sleep_ms
    step = board.cfg["step_ms"]
    while stop is None or not stop():
        t = clock()
        board.poll(t)
        left = step - ticks_diff(clock(), t)
        if left > 0:
            sleep_ms(left)

