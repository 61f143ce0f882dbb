# Driver for EvoLogics S2C acoustic modems over their AT command interface in
# command/NET mode (serial or a TCP socket: the driver only sees bytes).
# Sans-IO: bytes and time in, bytes and events out (interface in
# acomm.drivers). docs/drivers-evologics.md says what goes on the wire and
# how the modem's answers map to acomm statuses.
#
# Two things are tracked apart, as in the SeaTrac driver:
#   the command slot   one AT command awaiting its reply (OK, ERROR, BUSY or
#                      a value), or timed out; the modem answers at once;
#   the acoustic slot  one IM, burst or ping from the moment the link hands
#                      it over until the modem's final notification.
# Notifications (RECV*, DELIVERED*, FAILED*, SEND*, ...) are told from
# replies by their keyword, so they may arrive at any time; what each does
# is in acomm.drivers.evologics_notifications.

from .caps import CAP_ADDRESSING, CAP_BROADCAST, CAP_DELIVERY, CAP_RANGING, CAP_RELIABLE, Capabilities
from ..compat import ticks_add, ticks_diff
from ..errors import AcommError, EncodeError
from ..events import EV_TX_FAILED
from . import evologics_wire as w
from .evologics_notifications import notification
from .evologics_sequences import (C_CTRL, C_PROBE, C_PTIME, C_SEND, CMD, IDLE, K_BURST, K_IM, K_IM_ACK, K_PING,
                                  KIND_NAMES, PTIME, QUEUED, R_BUSY, R_ERROR, R_OK, R_VALUE, AcousticSlot,
                                  EvologicsConfig)
from .base import S_CONFIG, S_UP, AcousticDriver


MAX_AWAITING = 8  # bursts sent whose DELIVERED / FAILED is still to come


class EvologicsDriver(AcousticDriver):
    """An EvoLogics S2C modem: instant messages (acknowledged or not), burst data, pings with a range.

    Addresses are 0..254 (broadcast_addr is everyone); messages are 1..64
    bytes, burst data up to burst_mtu. Raises AcommError for settings out
    of range.
    """

    def __init__(
        self,
        address=None,
        eol=b"\n",
        burst_mtu=w.BURST_MAX,
        broadcast_addr=255,
        im_bitrate=976,
        burst_bitrate=5000,
        packet_ms=150,
        turnaround_ms=100,
        max_range_m=2000,
        sound_speed=1500,
        margin_ms=2000,
        im_tries=1,
        cmd_timeout_ms=5000,
        busy_backoff_ms=1000,
        take_control=True,
        check_mode=True,
        notifications=True,
        extra_commands=(),
        firmware16=False,
        pid=None,
        ping_payload=b"\x30",
        ptime_after_ack=True,
        boot_marks=(b"EvoLogics", b"S2C"),
        alive_period_ms=60000,
        rx_gap_ms=500,
        retry_ms=2000,
        down_after=3,
    ):
        AcousticDriver.__init__(self)
        if address is not None and not 0 <= address <= 254:
            raise AcommError("EvoLogics addresses are 0..254, not %r" % (address,))
        if not 0 <= burst_mtu <= w.BURST_MAX or burst_mtu and burst_mtu <= w.IM_MAX:
            raise AcommError("burst_mtu must be 0 (off) or %d..%d" % (w.IM_MAX + 1, w.BURST_MAX))
        if not 1 <= len(ping_payload) <= w.IM_MAX:
            raise AcommError("ping_payload must be 1..64 bytes")
        self.eol = eol
        self.burst_mtu = burst_mtu
        self.broadcast_addr = broadcast_addr
        self.im_bitrate = im_bitrate
        self.burst_bitrate = burst_bitrate
        self.packet_ms = packet_ms
        self.turnaround_ms = turnaround_ms
        self.max_range_m = max_range_m
        self.sound_speed = sound_speed  # replaced by the modem's AT?CA
        self.margin_ms = margin_ms
        self.im_tries = im_tries
        self.cmd_timeout_ms = cmd_timeout_ms
        self.busy_backoff_ms = busy_backoff_ms
        self.pid = pid
        self.ping_payload = ping_payload
        self.ptime_after_ack = ptime_after_ack
        self.boot_marks = boot_marks
        self.alive_period_ms = alive_period_ms
        self.rx_gap_ms = rx_gap_ms
        self.down_after = down_after
        mtu = burst_mtu if burst_mtu else w.IM_MAX
        flags = CAP_ADDRESSING | CAP_BROADCAST | CAP_RELIABLE | CAP_RANGING
        if mtu > 2 * w.IM_MAX:
            # a frame of more than half the MTU is burst data, which the
            # modem always acknowledges itself and reports DELIVERED / FAILED
            flags |= CAP_DELIVERY
        self.caps = Capabilities(
            manufacturer="EvoLogics",
            model="S2C",
            mtu_tx=mtu,
            mtu_rx=mtu,
            bitrate=burst_bitrate if burst_mtu else im_bitrate,
            latency_ms=self.airtime_ms(mtu, mtu > w.IM_MAX) + self.reply_window_ms(),
            flags=flags,
        )
        self.config = EvologicsConfig(self, address, take_control, check_mode, notifications, extra_commands, retry_ms)
        self.last_ptime_us = None  # propagation time after the latest delivered ack
        self.last_rx = None  # signal figures of the latest reception
        self.last_fix = None  # the latest USBLLONG, as a dict
        self.last_angles = None  # the latest USBLANGLES
        self.info = {}
        self.stats = {
            "cmd_timeouts": 0,
            "reboots": 0,
            "stale": 0,  # replies to nothing, notifications about nothing we sent
            "unknown": 0,  # lines we do not know
            "malformed": 0,  # known keywords with unusable fields
            "notes": 0,  # notifications we only count
            "async_errors": 0,  # ERROR EFAULT / OVERLOAD
        }
        self._reader = w.LineReader(self, w.RX_SPECS_16 if firmware16 else w.RX_SPECS, max(mtu, w.IM_MAX))
        self._rx_at = 0
        self._ctrl = False  # AT@CTRL due (someone took control)
        self._ptime = False  # AT?T due for last_ptime_us
        self.slot = AcousticSlot(self, mtu)
        self.awaiting = []  # [handle, address, deadline]: bursts sent, DELIVERED / FAILED to come, in order

    # -- timing model ------------------------------------------------------
    def airtime_ms(self, nbytes, burst=False):
        rate = self.burst_bitrate if burst else self.im_bitrate
        return self.packet_ms + (nbytes * 8000 + rate - 1) // rate

    def reply_window_ms(self):
        # from the end of our packet to the end of the remote's ack at the
        # range limit
        return 2 * self.max_range_m * 1000 // self.sound_speed + self.turnaround_ms + self.airtime_ms(0)

    # -- the driver interface ----------------------------------------------
    @property
    def address(self):
        return self.config.own_addr

    @property
    def junk(self):
        return self._reader.junk

    def send(self, now, addr, data, ack=False):
        """An instant message (up to 64 bytes; ack asks for DELIVEREDIM) or burst data (longer, always acknowledged).

        Raises AcommError when not ready, EncodeError for a bad size or
        address (burst data cannot be broadcast).
        """
        if not self.ready(now):
            raise AcommError("EvoLogics modem not ready")
        n = len(data)
        mtu = self.caps.mtu_tx
        if n > mtu:
            raise EncodeError("%d bytes exceed the EvoLogics MTU of %d" % (n, mtu))
        if n == 0:
            raise EncodeError("EvoLogics messages carry at least one byte")
        if not isinstance(addr, int) or not 0 <= addr <= 255:
            raise EncodeError("EvoLogics address %r outside 0..255" % (addr,))
        if n > w.IM_MAX:
            kind = K_BURST  # always acknowledged by the modem
            if addr == self.broadcast_addr:
                raise EncodeError("burst data (over %d bytes) cannot be broadcast" % w.IM_MAX)
        elif ack and addr != self.broadcast_addr:
            kind = K_IM_ACK
        else:
            kind = K_IM
        return self._accept(now, kind, addr, data)

    def ping(self, now, addr):
        """An acknowledged IM to addr, then AT?T: EV_RANGE from the propagation time. Never raises."""
        if not isinstance(addr, int) or not 0 <= addr <= 254 or addr == self.broadcast_addr:
            return self._refuse("cannot range to address %r" % (addr,))
        if not self.ready(now):
            return self._refuse("EvoLogics modem not ready")
        return self._accept(now, K_PING, addr, self.ping_payload)

    def feed(self, now, data):
        """Bytes read from the device."""
        self._rx_at = now
        AcousticDriver.feed(self, now, data)

    def poll(self, now):
        """Let timers run: a line cut short by silence, deadlines, probes, retries."""
        r = self._reader
        if r.partial() and ticks_diff(now, self._rx_at) >= self.rx_gap_ms:
            self._now = now
            r.flush()  # a line that never ended
        if self.awaiting and ticks_diff(now, self.awaiting[0][2]) >= 0:
            # the modem said nothing about a burst it sent: as for the slot
            self._fail_awaiting("no final word from the modem")
            self._slot_gave_up(now)
        AcousticDriver.poll(self, now)

    def _fail_awaiting(self, reason):
        for b in self.awaiting:
            self._events.append((EV_TX_FAILED, b[0], reason))
        self.awaiting = []

    def _slot_gave_up(self, now):
        # it accepted a transmission and then said nothing: it may have
        # restarted and lost its settings, so set it up again
        self.refresh(now)

    # -- writing commands --------------------------------------------------
    def command(self, now, what, text):
        self._out.extend(text)
        self._out.extend(self.eol)
        self._await(now, what, self.cmd_timeout_ms)

    def _next_command(self, now):
        # The command slot is free and the modem up: control, the link's
        # frame or ping, the propagation time, then probes.
        slot = self.slot
        if self._ctrl:
            self._ctrl = False
            self.command(now, C_CTRL, b"AT@CTRL")
            return
        if slot.state == PTIME:
            self.command(now, C_PTIME, b"AT?T")
            return
        # while bursts await their report, the modem takes only more bursts
        # (a bounded list: at most MAX_AWAITING)
        n = len(self.awaiting)
        if slot.state == QUEUED and not self._held(now) and (not n or slot.kind == K_BURST and n < MAX_AWAITING):
            slot.write(self._out)
            self._out.extend(self.eol)
            self._await(now, C_SEND, self.cmd_timeout_ms)
            return
        if self._ptime:
            self._ptime = False
            self.command(now, C_PTIME, b"AT?T")
            return
        if self._probe_due(now):
            # the address tells whether the modem forgot its settings
            self.command(now, C_PROBE, b"AT?AL")

    def _unanswered(self, now, what):
        # the command `what` timed out
        if self._state == S_CONFIG:
            self.config.failed(now, "no reply to the modem's set-up")
            return
        slot = self.slot
        if what == C_SEND and slot.state == CMD:
            self._uncertain(now, "no reply to %s" % KIND_NAMES[slot.kind])
        elif what == C_PTIME and slot.state == PTIME:
            slot.ranged(None, self.sound_speed)

    def _uncertain(self, now, reason):
        # The command may have been carried out with only its answer lost:
        # hold the next one until the modem would be idle again.
        self._hold_until = ticks_add(now, self.slot.busy_ms())
        self.slot.fail(reason)

    # -- state changes -----------------------------------------------------
    def address_known(self, now, prev, addr):
        pass  # hook for the configuration; the address lives there

    def lost(self, now, reason):
        """The modem rebooted, fell silent or the connection to it was lost (a transport may call this).

        Whatever it was doing is gone (EV_TX_FAILED); it is configured again.
        """
        self._went_down(reason)
        self._restart(now, reason)

    def refresh(self, now):
        """Set the modem up again without saying it is down."""
        if self._state == S_UP:
            self._restart(now, None)

    def _restart(self, now, reason):
        self._fail_awaiting(reason or "modem set up again")
        if self.slot.state != IDLE and reason is not None:
            self.slot.fail(reason)
        elif self.slot.state not in (IDLE, QUEUED):
            self.slot.fail("modem set up again")
        self._ctrl = False
        self._ptime = False
        self._reader.reset()
        self._set_up_again(now)

    # -- lines from the modem (LineReader sink) ----------------------------
    def on_junk(self, kind):
        pass  # counted by the reader; the request in flight has a watchdog

    def on_line(self, r):
        now = self._now
        if r.n == 0 or notification(self, now, r):
            return
        kind = R_VALUE
        if r.is_word(b"OK") or r.is_word(b"[*]OK"):
            kind = R_OK
        elif r.starts(b"ERROR"):
            kind = R_ERROR
        elif r.starts(b"BUSY"):
            kind = R_BUSY
        if self.cmd:
            self._reply(now, r, kind)
        elif kind == R_VALUE and self._boot_text(r):
            self.stats["reboots"] += 1
            self.lost(now, "modem rebooted")
        elif kind == R_VALUE:
            self.stats["unknown"] += 1
        else:
            self.stats["stale"] += 1

    def _boot_text(self, r):
        t = r.text()
        for m in self.boot_marks:
            if m in t:
                return True
        return False

    def _reply(self, now, r, kind):
        what = self.cmd
        self.cmd = 0
        self._heard_from(now)
        if kind == R_ERROR and r.starts(b"ERROR NO CONTROL") and self.config.take_control:
            self._ctrl = True  # another client took the modem: take it back
        if kind == R_VALUE and self._boot_text(r):
            # power-up text where a reply was due
            self.stats["reboots"] += 1
            self.lost(now, "modem rebooted")
            return
        if self._state == S_CONFIG:
            self.config.reply(now, what, r, kind)
            return
        slot = self.slot
        if what == C_SEND:
            if slot.state != CMD:
                self.stats["stale"] += 1
            elif kind == R_OK:
                slot.accepted(now)
            elif kind == R_ERROR or kind == R_BUSY:
                if kind == R_BUSY:
                    self._hold_until = ticks_add(now, self.busy_backoff_ms)
                slot.refused(r.shown())
            else:
                self.stats["malformed"] += 1
                self._uncertain(now, "garbled reply to %s" % KIND_NAMES[slot.kind])
        elif what == C_PTIME:
            us = r.int_field(0) if kind == R_VALUE and r.nc == 0 else None
            if us is not None and us < 0:
                us = None
            if us is not None:
                self.last_ptime_us = us
            if slot.state == PTIME:
                slot.ranged(us, self.sound_speed)
        elif what == C_PROBE:
            a = r.int_field(0) if kind == R_VALUE and r.nc == 0 else None
            own = self.config.own_addr
            if a is not None and own is not None and a != own:
                # a restart put back the address saved in the modem
                self.stats["reboots"] += 1
                self.lost(now, "modem rebooted")
