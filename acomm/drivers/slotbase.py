# What the drivers that run one acoustic transaction at a time (SeaTrac,
# EvoLogics, Micro-Modem, Benthos) share: the handles the link gets for its
# requests, a request refused through the event list, and the slot that
# holds the one transaction under way. Each modem's slot adds its own
# states (after QUEUED) and how the transaction goes on its wire.

from ..compat import const
from ..events import EV_TX_FAILED
from .base import SansIO

# the two states every slot has; each *_slot module numbers its own from 2
IDLE = const(0)
QUEUED = const(1)


class SlotDriver(SansIO):
    # needs self.slot (a SlotBase, or one with start() instead of accept())
    # and self._pump(now), which writes the next command when it can
    def __init__(self):
        SansIO.__init__(self)
        self._h = 0  # the last handle given out

    def _handle(self):
        self._h = (self._h + 1) & 0xFFFF
        return self._h

    def _refuse(self, reason):
        # ping() never raises (the link calls it without a guard): a problem
        # comes back as EV_TX_FAILED for a handle of its own
        h = self._handle()
        self._events.append((EV_TX_FAILED, h, reason))
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
