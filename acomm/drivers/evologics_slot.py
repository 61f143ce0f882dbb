# The one acoustic transaction an EvoLogics modem runs for the link at a
# time, from the moment the link hands it over until the modem's final word:
#
#   QUEUED  accepted, command not written yet (the command slot is busy, or
#           the modem was found busy and we back off)
#   CMD     AT*SENDIM / AT*SEND written, waiting for OK, ERROR or BUSY
#   AIR     the modem took it: SENDEND (or the airtime model when extended
#           notifications are off) gives EV_TX_DONE; an acknowledged IM
#           ends with DELIVEREDIM / FAILEDIM, burst data with DELIVERED /
#           FAILED, a noack IM at SENDEND; a watchdog covers silence
#   PTIME   a ping was delivered: AT?T is due or written, its answer (the
#           propagation time) gives EV_RANGE
#
# Kinds: instant message with or without ack, burst data, ping.

from ..compat import const, ticks_add, ticks_diff
from ..events import EV_DELIVERED, EV_RANGE, EV_TX_DONE, EV_TX_FAILED
from .slotbase import IDLE, QUEUED, SlotBase  # noqa: F401 (QUEUED: for the driver)

CMD = const(2)
AIR = const(3)
PTIME = const(4)

K_IM = const(0)
K_IM_ACK = const(1)
K_BURST = const(2)
K_PING = const(3)

KIND_NAMES = ("AT*SENDIM", "AT*SENDIM", "AT*SEND", "AT*SENDIM")


class AcousticSlot(SlotBase):
    # done_at: the airtime estimate of our packet's end
    def __init__(self, driver, capacity):
        SlotBase.__init__(self, driver, capacity)
        self.deadline = None  # watchdog: stop waiting for the modem
        self.sent = False  # EV_TX_DONE given

    def accept(self, handle, kind, addr, data):
        self._take(handle, kind, addr, data)
        self.deadline = None
        self.sent = False

    def write(self, out):
        # Appends the command (without end of line) to the bytearray out.
        d = self.d
        pid = b"" if d.pid is None else b"p%d," % d.pid
        n = self.n
        if self.kind == K_BURST:
            out.extend(b"AT*SEND,%s%d,%d," % (pid, n, self.addr))
        else:
            flag = b"ack" if self.kind in (K_IM_ACK, K_PING) else b"noack"
            out.extend(b"AT*SENDIM,%s%d,%d,%s," % (pid, n, self.addr, flag))
        out.extend(memoryview(self.buf)[:n])
        self.state = CMD

    def acked(self):
        return self.kind != K_IM

    def busy_ms(self):
        # how long the modem may stay busy with this transaction
        d = self.d
        t = d.airtime_ms(self.n, self.kind == K_BURST)
        if self.acked():
            t += d.reply_window_ms()
        return t

    def accepted(self, now):
        # OK to our command: on the air now
        d = self.d
        self.state = AIR
        air = d.airtime_ms(self.n, self.kind == K_BURST)
        if not d.config.zx:
            self.done_at = ticks_add(now, air)
        wait = air + d.margin_ms
        if self.acked():
            wait += d.reply_window_ms() * d.im_tries
        self.deadline = ticks_add(now, wait)

    def poll(self, now):
        # Returns True when the watchdog gave up on the modem.
        if self.state != AIR:
            return False
        if self.done_at is not None and ticks_diff(now, self.done_at) >= 0:
            self.done_at = None
            self.tx_done()
            if not self.acked():
                self.state = IDLE  # noack: nothing more will come
                return False
        if self.deadline is not None and ticks_diff(now, self.deadline) >= 0:
            self.fail("no final word from the modem")
            return True
        return False

    def awaiting(self, kinds, addr):
        return self.state == AIR and self.kind in kinds and addr == self.addr

    def tx_done(self):
        if not self.sent:
            self.sent = True
            self.d._events.append((EV_TX_DONE, self.handle))

    def send_end(self):
        # SENDEND for our packet
        self.done_at = None
        if self.kind == K_PING:
            return  # a ping reports only its range
        self.tx_done()
        if not self.acked():
            self.state = IDLE

    def fail(self, reason):
        self.state = IDLE
        self.done_at = None
        if self.kind == K_PING:
            # pings report problems as a range without an answer
            self.d._events.append((EV_RANGE, self.handle, None, None, {"reason": reason}))
        else:
            self.d._events.append((EV_TX_FAILED, self.handle, reason))

    def refused(self, reason):
        # ERROR / BUSY to our command: nothing went on the air
        self.state = IDLE
        self.d._events.append((EV_TX_FAILED, self.handle, reason))

    def delivered(self):
        if self.kind == K_PING:
            self.state = PTIME  # now ask for the propagation time
            return
        self.tx_done()
        self.state = IDLE
        self.d._events.append((EV_DELIVERED, self.handle))

    def undelivered(self, reason):
        if self.kind != K_PING:
            self.tx_done()  # the packet went out; nobody confirmed it
        self.fail(reason)

    def ranged(self, ptime_us, sound_speed):
        self.state = IDLE
        if ptime_us is None:
            self.d._events.append((EV_RANGE, self.handle, None, None, {"reason": "no propagation time"}))
            return
        metres = metres_of(ptime_us, sound_speed)
        extra = {"ptime_us": ptime_us, "sound_speed": sound_speed}
        self.d._events.append((EV_RANGE, self.handle, self.addr, metres, extra))


def metres_of(ptime_us, sound_speed):
    # one-way propagation time (us) to metres, to the centimetre
    return int(ptime_us * sound_speed / 10000 + 0.5) / 100
