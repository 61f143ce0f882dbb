# What the drivers that run one acoustic transaction at a time (SeaTrac,
# EvoLogics, Micro-Modem, Benthos) share: their life (configuring, up, and
# down again when the modem restarts or falls silent), the handles the link
# gets for its requests, a request refused through the event list, and the
# slot that holds the one transaction under way. Each modem's slot adds its
# own states (after QUEUED) and how the transaction goes on its wire.

from ..compat import const
from .base import SansIO

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_DRIVER_DOWN = const(7)
_EV_DRIVER_UP = const(6)
_EV_TX_FAILED = const(4)

# the driver's own state
S_START = const(0)  # created: the first poll() starts the configuration
S_CONFIG = const(1)  # (re)configuring; also "down" while the modem is silent
S_UP = const(2)

# the two states every slot has; each *_slot module numbers its own from 2
IDLE = const(0)
QUEUED = const(1)


class SlotDriver(SansIO):
    # needs self.config (start(now), down_reported), self.slot (a SlotBase,
    # or one with start() instead of accept()) and self._pump(now), which
    # writes the next command when it can
    def __init__(self):
        SansIO.__init__(self)
        self._state = S_START
        self._h = 0  # the last handle given out

    def ready(self, now):
        return self._state == S_UP and self.slot.state == IDLE

    def _begin(self, now):
        # for poll(): the first one starts the configuration
        if self._state == S_START:
            self._state = S_CONFIG
            self.config.start(now)

    def _went_up(self):
        # the configuration is done
        self._state = S_UP
        self._events.append((_EV_DRIVER_UP,))

    def _went_down(self, reason):
        # Only a driver that was up says it is down, and the configuration
        # remembers that it did, so that its retries do not say so again.
        if self._state == S_UP:
            self._events.append((_EV_DRIVER_DOWN, reason))
            self.config.down_reported = True

    def _handle(self):
        self._h = (self._h + 1) & 0xFFFF
        return self._h

    def _refuse(self, reason):
        # ping() never raises (the link calls it without a guard): a problem
        # comes back as EV_TX_FAILED for a handle of its own
        h = self._handle()
        self._events.append((_EV_TX_FAILED, h, reason))
        return h

    def _accept(self, now, kind, addr, *rest):
        # the slot takes the request (rest: what that modem's slot needs
        # besides kind and address), and the command goes out as soon as
        # the serial line is free
        h = self._handle()
        self.slot.accept(h, kind, addr, *rest)
        self._pump(now)
        return h


class SlotBase:
    def __init__(self, driver, capacity):
        self.d = driver  # timing model, settings and the event list
        self.state = IDLE
        self.kind = 0
        self.handle = 0
        self.addr = 0
        self.n = 0
        self.buf = bytearray(capacity)
        self.done_at = None  # when our packet has left: EV_TX_DONE

    def _take(self, handle, kind, addr, data):
        # A copy of the bytes (the link may reuse its buffer), queued until
        # the driver can write the command.
        n = len(data)
        self.buf[:n] = data
        self.n = n
        self.kind = kind
        self.handle = handle
        self.addr = addr
        self.done_at = None
        self.state = QUEUED
