# The one acoustic transaction a Benthos modem runs at a time, from the
# moment the link hands it over until its end, and the events that report it.
#
# A frame:
#   QUEUED   accepted; waits for command mode and a free serial line
#   ADDR     @RemoteAddr=<dst> written (only when it differs from the last
#            one the modem confirmed), waiting for its echo
#   CONNECT  ATO written, waiting for "CONNECT ..."
#   FORWARD  the payload written raw in online mode, waiting for
#            "Forwarding Delay Up" (the modem starts to transmit)
#   AIR      transmitting: EV_TX_DONE at the end of the estimated airtime
#            (the modem does not say); the slot is free once the modem is
#            back at its prompt, or a while later without it (the driver
#            then escapes before the next command)
# A range:
#   QUEUED -> RANGE  ATR<addr> written, waiting for the Range line or
#            "Response Not Received" (EV_RANGE either way)
#
# There is no delivery report on this modem (ref/modem-protocols.md 4.3), so
# a frame ends with EV_TX_DONE alone, or EV_TX_FAILED with a reason.

from ..compat import const, ticks_add, ticks_diff
from ..events import EV_RANGE, EV_TX_DONE, EV_TX_FAILED
from . import benthos_wire as w
from .slotbase import IDLE, QUEUED, SlotBase  # noqa: F401 (QUEUED: for the driver)

ADDR = const(2)
CONNECT = const(3)
FORWARD = const(4)
AIR = const(5)
RANGE = const(6)

K_DATA = const(0)
K_PING = const(1)


class Slot(SlotBase):
    def __init__(self, driver, cap):
        SlotBase.__init__(self, driver, cap)
        self.free_at = None  # give up waiting for the prompt

    def accept(self, handle, kind, addr, data):
        self._take(handle, kind, addr, data)
        self.free_at = None

    def start(self, now):
        # the modem is in command mode and the serial line is free
        d = self.d
        if self.kind == K_PING:
            self.state = RANGE
            d.command_range(now, self.addr)
        elif d.remote != self.addr:
            self.state = ADDR
            d.command_set(now, "RemoteAddr", str(self.addr))
        else:
            self.state = CONNECT
            d.command_ato(now)

    def reply(self, now, ok, detail):
        # the outcome of the command this slot wrote
        d = self.d
        st = self.state
        if st == ADDR:
            if not ok:
                d.remote = None
                self.fail("@RemoteAddr=%d: %s" % (self.addr, detail))
                return
            d.remote = self.addr
            self.state = CONNECT
            d.command_ato(now)
        elif st == CONNECT:
            if not ok:
                self.fail("ATO: %s" % detail)
                return
            self.state = FORWARD
            d.command_payload(now, memoryview(self.buf)[: self.n])
        elif st == FORWARD:
            if not ok:
                # it may be on the air all the same: the next transaction
                # waits until it would be over
                d.hold(ticks_add(now, self.airtime()))
                self.fail(detail)
                return
            self.state = AIR
            self.done_at = ticks_add(now, self.airtime())
            self.free_at = ticks_add(self.done_at, d.prompt_timeout_ms)
        elif st == RANGE:
            if ok:
                src, dst, metres, rt, speed = detail
                extra = {"round_trip_ms": rt, "speed": speed, "from": src}
                self.state = IDLE
                d._events.append((EV_RANGE, self.handle, dst, metres, extra))
            elif detail == w.NO_RESPONSE:
                self.state = IDLE
                d._events.append((EV_RANGE, self.handle, None, None, {"reply": detail}))
            else:
                self.fail("ATR%d: %s" % (self.addr, detail))

    def airtime(self):
        return self.d.airtime_ms(self.n)

    def poll(self, now, in_command_mode):
        if self.state != AIR:
            return
        if self.done_at is not None and ticks_diff(now, self.done_at) >= 0:
            self.done_at = None
            self.d._events.append((EV_TX_DONE, self.handle))
        if self.done_at is None and (in_command_mode or ticks_diff(now, self.free_at) >= 0):
            self.state = IDLE

    def fail(self, reason):
        self.state = IDLE
        self.d._events.append((EV_TX_FAILED, self.handle, reason))

    def lost(self, reason):
        # the modem restarted or stopped answering
        if self.state == AIR and self.done_at is None:
            self.state = IDLE  # already reported as sent
        elif self.state != IDLE:
            self.fail(reason)
