# Faults of a whole node for long runs (the soak, acomm bench soak), on top
# of the emulators' own (acomm_sim.faults) and the channel's noise bursts:
#
#   Cable        the serial cable between a node and its modem, which can
#                be unplugged: while it is out the node's reads raise
#                OSError (as pyserial does when a USB adapter goes away) or
#                return nothing, its writes raise or vanish, and what the
#                modem sends meanwhile is lost. Plugged back, bytes flow.
#   WallClock    a node's wall clock (seconds; the transport keeps its
#                lifespans in them) that can jump forward or backward while
#                the millisecond ticks keep running.
#   FaultPlan    a seeded schedule of (time, kind, node, parameter) events,
#                each kind at its own rate per simulated hour, drawn once so
#                that a run is the same for the same seed; a World task
#                hands each event to a callback when its time comes.
#
# CPython only (heapq); the core never imports this.

import heapq
import math

from acomm.prng import Prng


class Cable:
    def __init__(self, end):
        self.end = end  # the node's end of the serial line (a FakeUART)
        self.out = False  # unplugged
        self.raises = True  # while out: OSError (True) or silence (False)
        self.errors_raised = 0

    def unplug(self, raises):
        self.out = True
        self.raises = raises

    def plug(self):
        self.out = False

    def _dead(self):
        if self.raises:
            self.errors_raised += 1
            raise OSError(5, "serial cable unplugged")

    def read(self, n=-1):
        if self.out:
            # the modem's bytes fall on the floor; the World's end is
            # drained so that it does not keep the node awake
            self.end.read()
            self._dead()
            return None
        return self.end.read(n)

    def write(self, data):
        if self.out:
            self._dead()
            return len(data)
        return self.end.write(data)

    def any(self):
        return 0 if self.out else self.end.any()


class WallClock:
    # wall() -> int seconds: a base epoch plus the simulated ticks plus the
    # sum of the jumps so far
    def __init__(self, clock, base=1700000000):
        self.clock = clock
        self.base = base
        self.offset = 0
        self.jumps = 0

    def __call__(self):
        return self.base + self.clock() // 1000 + self.offset

    def jump(self, seconds):
        self.offset += seconds
        self.jumps += 1


class FaultPlan:
    # kinds: {kind: (events per simulated hour, param(prng) -> value)}.
    # Events are drawn for [start, start + duration) with exponential gaps
    # (a Poisson process per kind), on one of `names` chosen at random.
    def __init__(self, seed, start, duration_ms, kinds, names, on_fault):
        self.on_fault = on_fault
        self.counts = {}
        self._heap = []
        rng = Prng(seed)
        n = 0
        for kind in sorted(kinds):
            rate, param = kinds[kind]
            self.counts[kind] = 0
            if rate <= 0:
                continue
            mean_ms = 3600000.0 / rate
            t = start
            while True:
                # -ln(u) * mean: an exponential gap (u in (0, 1])
                t += int(exp_gap(rng) * mean_ms) + 1
                if t >= start + duration_ms:
                    break
                name = names[rng.below(len(names))]
                heapq.heappush(self._heap, (t, n, kind, name, param(rng)))
                n += 1
        self.planned = n

    def later(self, at, kind, name, param):
        # an event that another one brings with it (a cable plugged back)
        heapq.heappush(self._heap, (at, self.planned, kind, name, param))
        self.planned += 1

    def poll(self, now):
        h = self._heap
        while h and h[0][0] <= now:
            _, _, kind, name, param = heapq.heappop(h)
            self.counts[kind] = self.counts.get(kind, 0) + 1
            self.on_fault(now, kind, name, param)
        return h[0][0] if h else now + 3600000

def exp_gap(rng):
    # -ln(u) for u uniform in (0, 1]: an exponential gap of mean 1
    u = (rng.below(1 << 30) + 1) / float(1 << 30)
    return -math.log(u)
