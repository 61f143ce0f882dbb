# The two sequences the EvoLogics driver (acomm.drivers.evologics) runs on
# the modem's command slot: its configuration (EvologicsConfig) and the one
# acoustic transaction under way (AcousticSlot).
#
# The configuration, before the driver lets the link transmit, and again
# after the modem restarted, fell silent or lost its settings:
#
#   AT@CTRL         take control of the modem from other clients (option;
#                   DUNE skips it on firmware 1.6/1.7, where an ERROR to it
#                   is tolerated here)
#   AT?MODE         must answer NET: the driver speaks the command/NET
#                   interface, not the AT data mode (option)
#   AT?AL           the local address; AT!AL<n> then AT?AL again when the
#                   constructor asked for another one
#   AT?CA           sound speed in m/s, for ranging
#   AT@ZX1          extended notifications, so SENDEND marks the end of a
#                   transmission (option; without them the end comes from the
#                   airtime model)
#   extra commands  site settings given to the constructor, each must be OK
#
# Every step is one command on the driver's command slot; a failed step
# starts over after retry_ms (base.ConfigSequence).
#
# The transaction, from the moment the link hands it over until the modem's
# final word:
#
#   QUEUED  accepted, command not written yet (the command slot is busy, or
#           the modem was found busy and we back off)
#   CMD     AT*SENDIM / AT*SEND written, waiting for OK, ERROR or BUSY
#   AIR     the modem took it: SENDEND (or the airtime model when extended
#           notifications are off) gives EV_TX_DONE; an acknowledged IM
#           ends with DELIVEREDIM / FAILEDIM, a noack IM at SENDEND; a
#           watchdog covers silence. Burst data leaves the slot at SENDEND
#           for the driver's list of bursts awaiting their DELIVERED /
#           FAILED (the modem buffers bursts: the next one may follow)
#   PTIME   a ping was delivered: AT?T is due or written, its answer (the
#           propagation time) gives EV_RANGE
#
# Kinds: instant message with or without ack, burst data, ping.

from ..compat import const, ticks_add, ticks_diff
from ..events import EV_DELIVERED, EV_RANGE, EV_TX_DONE, EV_TX_FAILED
from .base import IDLE, QUEUED, ConfigSequence, SlotBase  # noqa: F401 (QUEUED: for the driver)

# What the command slot waits for (the driver's cmd): a configuration step,
# or one of the driver's own commands.
S_CTRL = const(1)
S_MODE = const(2)
S_AL = const(3)
S_SET_AL = const(4)
S_CA = const(5)
S_ZX = const(6)
S_EXTRA = const(7)
C_SEND = const(20)
C_PTIME = const(21)
C_PROBE = const(22)
C_CTRL = const(23)

# how the driver classifies a reply (EvologicsDriver.on_line)
R_OK = const(1)
R_ERROR = const(2)
R_BUSY = const(3)
R_VALUE = const(4)


class EvologicsConfig(ConfigSequence):
    """The modem's configuration: control, mode, address, sound speed, notifications, site settings."""

    def __init__(self, driver, address, take_control, check_mode, notifications, extra, retry_ms):
        ConfigSequence.__init__(self, driver, retry_ms)
        self.want_addr = address
        self.own_addr = address  # until the modem says otherwise
        self.take_control = take_control
        self.check_mode = check_mode
        self.notifications = notifications
        self.extra = tuple(extra)
        self.zx = False  # extended notifications are on
        self.control = None  # None: not asked; True/False: AT@CTRL answer
        self.al_writes = 0
        self._step = S_CTRL
        self._extra_i = 0

    def first(self):
        self._step = S_CTRL if self.take_control else S_MODE
        if self._step == S_MODE and not self.check_mode:
            self._step = S_AL
        self._extra_i = 0
        self.al_writes = 0
        self.zx = False

    def step(self, now):
        st = self._step
        d = self.d
        if st == S_CTRL:
            d.command(now, st, b"AT@CTRL")
        elif st == S_MODE:
            d.command(now, st, b"AT?MODE")
        elif st == S_AL:
            d.command(now, st, b"AT?AL")
        elif st == S_SET_AL:
            d.command(now, st, b"AT!AL%d" % self.want_addr)
        elif st == S_CA:
            d.command(now, st, b"AT?CA")
        elif st == S_ZX:
            d.command(now, st, b"AT@ZX1")
        else:
            d.command(now, st, self.extra[self._extra_i])

    def _after_ca(self, now):
        if self.notifications:
            self._step = S_ZX
        else:
            self._extras(now)

    def _extras(self, now):
        if self._extra_i < len(self.extra):
            self._step = S_EXTRA
            return
        self.done(now)

    def reply(self, now, step, r, kind):
        # The answer to a step: r is the line reader, kind the driver's
        # classification (R_OK, R_ERROR, R_BUSY or R_VALUE).
        d = self.d
        ok = kind == R_OK
        if step == S_CTRL:
            # old firmware has no @CTRL: an ERROR is not fatal
            self.control = ok
            self._step = S_MODE if self.check_mode else S_AL
        elif step == S_MODE:
            if kind != R_VALUE or not r.is_word(b"NET"):
                self.failed(now, "modem not in NET mode: %s" % r.shown())
                return
            self._step = S_AL
        elif step == S_AL or step == S_SET_AL and ok:
            if step == S_SET_AL:
                self._step = S_AL  # read it back
                return
            a = r.int_field(0) if kind == R_VALUE and r.nc == 0 else None
            if a is None or not 0 <= a <= 254:
                self.failed(now, "bad answer to AT?AL: %s" % r.shown())
                return
            want = self.want_addr
            if want is None or a == want:
                prev = self.own_addr
                self.own_addr = a
                d.address_known(now, prev, a)
                self._step = S_CA
            elif self.al_writes < 1:
                self.al_writes += 1
                self._step = S_SET_AL
            else:
                self.failed(now, "local address is %d, not %d" % (a, want))
        elif step == S_SET_AL:
            self.failed(now, "AT!AL%d refused: %s" % (self.want_addr, r.shown()))
        elif step == S_CA:
            v = r.int_field(0) if kind == R_VALUE and r.nc == 0 else None
            if v is not None and 1300 <= v <= 1700:
                d.sound_speed = v
            self._after_ca(now)
        elif step == S_ZX:
            self.zx = ok  # without them, the airtime model ends transmissions
            self._extras(now)
        else:
            if not ok:
                self.failed(now, "%s refused: %s" % (self.extra[self._extra_i].decode(), r.shown()))
                return
            self._extra_i += 1
            self._extras(now)


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
        if self.kind == K_BURST:
            # the modem reports a train of bursts together: the ones before
            # it to the same address wait as long
            for b in d.awaiting:
                if b[1] == self.addr:
                    b[2] = self.deadline

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
            self._left()
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
        self._left()

    def _left(self):
        # burst data has left: its report comes later, and the modem takes
        # the next burst meanwhile
        if self.kind == K_BURST and self.state == AIR:
            self.d.awaiting.append([self.handle, self.addr, self.deadline])
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
