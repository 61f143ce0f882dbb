# The one acoustic transaction a SeaTrac beacon runs at a time: a DAT_SEND or
# PING_SEND from the moment the link hands it to the driver until the
# beacon's final word on it, and the events that tell the link.
#
#   QUEUED  accepted from the link, command not written yet (the serial line
#           is busy, or the beacon is known to be busy for a while)
#   CMD     command written, waiting for its status (OK or a CST_E error)
#   AIR     the beacon took it: EV_TX_DONE when our packet has left (from
#           the airtime model; the beacon does not say), then for REQ types
#           the remote's automatic reply (EV_DELIVERED / EV_RANGE) or the
#           beacon's DAT_ERROR / PING_ERROR, or our own watchdog.

from ..compat import const, ticks_add, ticks_diff
from . import seatrac_wire as w
from .slotbase import IDLE, QUEUED, SlotBase  # noqa: F401 (QUEUED: for the driver)

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_DELIVERED = const(3)
_EV_RANGE = const(5)
_EV_TX_DONE = const(2)
_EV_TX_FAILED = const(4)

CMD = const(2)
AIR = const(3)

K_DAT = const(0)
K_PING = const(1)

REQ_TYPES = (w.MSG_REQ, w.MSG_REQU, w.MSG_REQX)


class AcousticSlot(SlotBase):
    def __init__(self, driver):
        SlotBase.__init__(self, driver, 31)
        self.mtype = 0
        self.deadline = None  # stop waiting for the beacon's reply

    def accept(self, handle, kind, addr, mtype, data):
        self._take(handle, kind, addr, data)
        self.mtype = mtype
        self.deadline = None

    def build(self, msg):
        # Fills msg (CID at [0]) with the command; returns (cid, length).
        msg[1] = self.addr
        msg[2] = self.mtype
        self.state = CMD
        if self.kind == K_PING:
            return w.CID_PING_SEND, 3
        n = self.n
        msg[3] = n
        msg[4 : 4 + n] = memoryview(self.buf)[:n]
        return w.CID_DAT_SEND, 4 + n

    def busy_ms(self):
        # how long the beacon may stay busy with this transaction
        d = self.d
        t = d.airtime_ms(self.n)
        if self.mtype in REQ_TYPES:
            t += d.reply_window_ms()
        return t

    def command_status(self, now, status):
        # The beacon's answer to our command. Returns the time before which
        # no new acoustic command should be written, or None.
        if status != w.CST_OK:
            self.fail(w.status_name(status))
            if status == w.CST_XCVR_BUSY:
                return ticks_add(now, self.d.busy_backoff_ms)
            return None
        d = self.d
        self.state = AIR
        air = d.airtime_ms(self.n)
        if self.kind == K_DAT:
            self.done_at = ticks_add(now, air)
        if self.mtype in REQ_TYPES:
            self.deadline = ticks_add(now, air + d.reply_window_ms() + d.margin_ms)
        return None

    def poll(self, now):
        # Returns True when the watchdog gave up on the beacon.
        if self.state != AIR:
            return False
        if self.done_at is not None and ticks_diff(now, self.done_at) >= 0:
            self.tx_done()
            if self.deadline is None:
                self.state = IDLE  # one-way: nothing more will come
                return False
        if self.deadline is not None and ticks_diff(now, self.deadline) >= 0:
            self.fail("no reply from the modem")
            return True
        return False

    def awaiting(self, kind, src):
        return self.state == AIR and self.kind == kind and self.deadline is not None and src == self.addr

    def tx_done(self):
        if self.done_at is not None:
            self.done_at = None
            self.d._events.append((_EV_TX_DONE, self.handle))

    def fail(self, reason):
        self.state = IDLE
        self.done_at = None
        self.d._events.append((_EV_TX_FAILED, self.handle, reason))

    def delivered(self):
        self.tx_done()
        self.state = IDLE
        self.d._events.append((_EV_DELIVERED, self.handle))

    def dat_error(self, status):
        self.tx_done()  # the packet did go out; nobody answered it
        self.fail(w.status_name(status))

    def ranged(self, src, metres, fix):
        self.state = IDLE
        self.d._events.append((_EV_RANGE, self.handle, src if metres is not None else None, metres, fix))
