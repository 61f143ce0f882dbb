# What the Micro-Modem driver says before it lets the link send, and again
# after the modem rebooted ($CAREV,...,INIT) or stopped answering:
#
#   $CCCFG,SRC,<address>      when the constructor was given an address
#                             (NVRAM SRC; the modem echoes $CACFG,SRC,<address>)
#   $CCCFQ,SRC                when asked to (by default: only when no address
#                             was given): $CACFG,SRC,<n> tells the driver the
#                             modem's own address
#   $CCCLK,YYYY,MM,DD,HH,MM,SS  when a clock function was given (MM1 sentence;
#                             the modem echoes $CACLK)
#
# Each sentence goes through the driver's command slot, which resends it
# after modem_wait_ms up to `retries` times (goby3: 5 s, 3 times). When one
# stays unanswered the sequence starts over after retry_ms, and the link is
# told once (EV_DRIVER_DOWN) per outage.

from ..compat import ticks_add, ticks_diff
from ..events import EV_DRIVER_DOWN
from . import micromodem_nmea as nm


class MicroModemConfig:
    def __init__(self, driver, address, query_src, clock, retry_ms):
        self.d = driver
        self.want = address
        self.query_src = (address is None) if query_src is None else query_src
        self.clock = clock
        self.retry_ms = retry_ms
        self.down_reported = False
        self.fails = 0
        self._steps = []
        self._i = 0
        self._wait = None

    def start(self, now, wait_ms=0):
        steps = []
        if self.want is not None:
            steps.append(("CCCFG", ("SRC", self.want), b"CACFG"))
        if self.query_src:
            steps.append(("CCCFQ", ("SRC",), b"CACFG"))
        if self.clock is not None:
            steps.append(("CCCLK", None, b"CACLK"))
        self._steps = steps
        self._i = 0
        self._wait = ticks_add(now, wait_ms) if wait_ms else None

    def pump(self, now):
        if self._wait is not None:
            if ticks_diff(now, self._wait) < 0:
                return
            self._wait = None
        if self._i >= len(self._steps):
            self.fails = 0
            self.down_reported = False
            self.d.configured(now)
            return
        name, args, expect = self._steps[self._i]
        if args is None:  # the clock, read at the moment it is sent
            args = tuple(self.clock())
        self.d.command(now, nm.sentence(name, *args), expect)

    def answer(self, now, f):
        # The reply to the step in progress (f: the sentence's fields).
        # Returns False when it is not (someone else's $CACFG, say).
        name, args, expect = self._steps[self._i]
        if f[0] != expect:
            return False
        if expect == b"CACFG":
            if len(f) < 3 or f[1] != b"SRC":
                return False
            addr = nm.num(f[2], 0, 254)
            if addr is None:
                self.failed(now, "modem reports SRC %r" % (bytes(f[2]),))
                return True
            if name == "CCCFG" and addr != self.want:
                return False  # not the echo of our setting
            self.d.own_addr = addr
        self._i += 1
        return True

    def failed(self, now, reason):
        # Start over after a pause; say the modem is down once it has
        # failed (once per outage).
        self.fails += 1
        if not self.down_reported:
            self.down_reported = True
            self.d._events.append((EV_DRIVER_DOWN, reason))
        self.start(now, self.retry_ms)
