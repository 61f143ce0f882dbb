# Driver for Iridium 9602/9603 SBD transceivers (RockBLOCK) over their AT
# command interface, ref/modem-protocols.md section 5. Sans-IO (interface in
# acomm.drivers); runs on a buoy's microcontroller. docs/drivers-iridium.md
# says what goes on the wire and how the answers map to acomm statuses.
#
# Iridium has no node addressing of its own: every MO message goes to the
# gateway, which hands it on by its own rules (a fleet's vendor application,
# or RockBLOCK's "RB<serial>" prefix, `mo_prefix`). So the caps lack
# CAP_ADDRESSING, the link above sends raw acomm frames (node ids and CRC in
# the frame), and send() ignores `addr`. EV_TX_DONE means "handed to the
# gateway" (a successful SBDIX), never "delivered".
#
# One MO message at a time (ready() is false from send() until its final
# event and during any session). Its life:
#   QUEUED   AT+SBDWB=<n> -> READY -> bytes + sum16 -> "0" OK   (LOADED)
#   LOADED   AT+SBDIX (AT+SBDIXA after a ring alert) when the back-off time
#            has come and there is signal                       (SESSION)
#   SESSION  +SBDIX: <mo>,<momsn>,<mt>,<mtmsn>,<mtlen>,<queued>  OK
#            mo <= 4: EV_TX_DONE; otherwise another session after a
#            back-off that doubles from retry_first_ms up to retry_max_ms,
#            and EV_TX_FAILED (the MO status's name) once give_up_ms have
#            passed since send()
# After a session: AT+SBDRB when an MT message came (checksum and length
# checked, read again when damaged), AT+SBDD0 to clear the MO buffer (a
# later mailbox check must not send it again), and another session while
# the gateway says more MT messages are queued. A ring alert (SBDRING, with
# AT+SBDMTA=1 at start-up) starts a session at once; with nothing to send
# and no ring alert for mailbox_check_ms, an empty session checks the
# mailbox (seed 000 section IV.F).
#
# Time: AT-MSSTM (Iridium system time, iridium_wire.parse_msstm) once the
# modem is up, after each successful session (the unit has just been in
# touch with the network) and every time_period_ms; "no network service"
# asks again a minute later. Each answer is a time for the node's wall
# clock (AtDriver.take_times), uncertain by 0.5 s.

from .caps import Capabilities
from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError, DecodeError, EncodeError
from . import iridium_wire as w
from .atdriver import AtDriver

# these modules' codes, as private constants (inlined: no slot in this
# module's dict on a board); tests/cpython/test_const_copies.py checks them
_R_END = const(2)  # acomm.drivers.atcommand
_R_OK = const(0)  # acomm.drivers.atcommand
_R_TIMEOUT = const(3)  # acomm.drivers.atcommand
_IDLE = const(0)  # acomm.drivers.base
_QUEUED = const(1)  # acomm.drivers.base

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_RX = const(1)
_EV_TX_DONE = const(2)
_EV_TX_FAILED = const(4)

_MSSTM_UNC_MS = const(500)  # acomm.drivers.iridium_wire: the uncertainty of an AT-MSSTM time

# slot states after base's IDLE and QUEUED
_WRITING = const(2)
_LOADED = const(3)
_SESSION = const(4)

_K_MO = const(0)

_T_WB = const(10)
_T_IX = const(11)
_T_RB = const(12)
_T_DD = const(13)

_CLEAR_TRIES = const(3)


class IridiumDriver(AtDriver):
    """An Iridium 9602/9603 SBD transceiver: one MO message per session to the gateway (addr is ignored).

    EV_TX_DONE means handed to the gateway, never delivered. Raises
    AcommError when not ready, EncodeError for a bad size.
    """

    # Defaults that most buoys keep, set on an instance only when given: on
    # MicroPython its attribute table grows in steps (47, 59, 73 slots of 8
    # bytes), and these three take this driver from 73 slots to 59
    address = None
    broadcast_addr = None  # Iridium has no addresses, so no broadcast
    mo_prefix = b""
    time_spec = (b"AT-MSSTM", "iridium", _MSSTM_UNC_MS)
    time_period_ms = 3600000
    time_epoch_s = None  # the era's epoch from 2020-01-01 UTC; None: era 3 (iridium_wire)

    def __init__(
        self,
        address=None,
        mo_mtu=w.MO_MAX,
        mt_mtu=w.MT_MAX,
        mo_prefix=b"",
        cost_tx=0.02,
        cost_rx=0.02,
        latency_ms=20000,
        bitrate=100,
        ring_alerts=True,
        mailbox_check_ms=600000,
        retry_first_ms=20000,
        retry_max_ms=160000,
        give_up_ms=600000,
        min_bars=1,
        cmd_timeout_ms=5000,
        sbdix_timeout_ms=60000,
        wb_timeout_ms=65000,
        csq_timeout_ms=12000,
        csq_period_ms=60000,
        csq_retry_ms=20000,
        retry_ms=5000,
        down_after=3,
        wb_tries=3,
        rb_tries=3,
        banner_marks=(),
        time_period_ms=3600000,
        time_epoch_s=None,
    ):
        if not 1 <= mo_mtu <= 1960 or not 1 <= mt_mtu <= 1890:
            raise AcommError("SBD messages are at most 1960 bytes MO and 1890 MT")
        if len(mo_prefix) >= mo_mtu:
            raise AcommError("the MO prefix leaves no room for data")
        steps = [(b"ATE0Q0V1", None, None), (b"AT&K0", None, None)]
        if ring_alerts:
            steps.append((b"AT+SBDMTA=1", None, None))
        steps.append((b"AT+SBDD0", None, None))
        steps.append((b"AT+CSQ", b"+CSQ", csq_timeout_ms))
        AtDriver.__init__(self, steps, (b"SBDRING", b"+CIEV:", b"+AREG:"), mo_mtu, 64, mt_mtu, cmd_timeout_ms,
                          retry_ms, down_after, csq_period_ms, csq_retry_ms, csq_timeout_ms, banner_marks)
        if address is not None:
            self.address = address  # not used: Iridium does not address nodes
        if mo_prefix:
            self.mo_prefix = bytes(mo_prefix)
        if time_period_ms != 3600000:
            self.time_period_ms = time_period_ms  # 0: never ask
        if time_epoch_s is not None:
            self.time_epoch_s = time_epoch_s
        self.min_bars = min_bars
        self.mailbox_check_ms = mailbox_check_ms
        self.retry_first_ms = retry_first_ms
        self.retry_max_ms = retry_max_ms
        self.give_up_ms = give_up_ms
        self.sbdix_timeout_ms = sbdix_timeout_ms
        self.wb_timeout_ms = wb_timeout_ms
        self.wb_tries = wb_tries
        self.rb_tries = rb_tries
        self._bitrate = bitrate
        self.caps = Capabilities(
            manufacturer="Iridium",
            model="9602/9603 SBD",
            cost_tx=cost_tx,
            cost_rx=cost_rx,
            mtu_tx=mo_mtu - len(mo_prefix),
            mtu_rx=mt_mtu,
            bitrate=0,  # until the modem reports signal
            latency_ms=latency_ms,
            flags=0,
        )
        self.last_session = None  # the last +SBDIX fields
        self.last_failure = None  # why the last session failed
        self.stats.update({
            "sessions": 0, "sessions_failed": 0, "mailbox_checks": 0, "rings": 0, "mo_sent": 0, "mo_failed": 0,
            "mt_received": 0, "mt_bad": 0, "mt_lost": 0, "malformed": 0, "clear_failed": 0, "urcs_other": 0,
        })
        # the MO message in the slot
        self._first_at = 0
        self._sessions = 0
        self._wait = 0
        self._next_at = 0
        self._wb_fails = 0
        # the modem and the gateway
        self._mo_loaded = False  # the MO buffer may hold a message: SBDD0 before an empty session
        self._mt_unread = False  # the last session left an MT message in the MT buffer
        self._mt_waiting = 0  # MT messages queued at the gateway (last session)
        self._ring = False
        self._in_session = False  # an empty session (mailbox, ring alert, MT queued) under way
        self._mailbox_at = None
        self._idle_wait = 0  # back-off of failed empty sessions
        self._idle_at = None
        self._status = None  # the digit that answers SBDWB / SBDD
        self._ix = None
        self._rb_good = False
        self._rb_fails = 0
        self._dd_fails = 0

    # -- the driver interface ------------------------------------------------------
    def ready(self, now):
        return AtDriver.ready(self, now) and not self._in_session

    def send(self, now, addr, data, ack=False):
        # addr and ack are ignored (see the header)
        if not self.ready(now):
            raise AcommError("Iridium modem not ready")
        n = len(data)
        if not 1 <= n <= self.caps.mtu_tx:
            raise EncodeError("an SBD message is 1..%d bytes, not %d" % (self.caps.mtu_tx, n))
        self._first_at = now
        self._sessions = 0
        self._wait = 0
        self._wb_fails = 0
        return self._accept(now, _K_MO, addr, data)

    parse_signal = staticmethod(w.parse_csq)

    def parse_time(self, line):
        return w.parse_msstm(line, self.time_epoch_s)

    def _signal_ok(self, bars):
        return bars >= self.min_bars


    # -- what to do next -------------------------------------------------------------
    def _tick(self, now):
        s = self.slot
        if (s.state == _QUEUED or s.state == _LOADED) and ticks_diff(now, self._first_at) >= self.give_up_ms:
            why = self.stuck_reason() or self.last_failure or "no session"
            self._fail("%s (gave up after %d sessions)" % (why, self._sessions))

    def _work(self, now):
        # the next command when the modem is up and the line free; True
        # when one was written
        at = self.at
        s = self.slot
        if self._mailbox_at is None:
            self._mailbox_at = ticks_add(now, self.mailbox_check_ms)
        if self._mt_unread:
            self._rb_good = False
            at.command(now, b"AT+SBDRB", _T_RB, self.cmd_timeout_ms, block=True)
            return True
        if self._mo_loaded and s.state == _IDLE:
            self._status = None
            at.command(now, b"AT+SBDD0", _T_DD, self.cmd_timeout_ms)
            return True
        if s.state == _QUEUED:
            s.state = _WRITING
            self._status = None
            at.command(now, b"AT+SBDWB=%d" % (len(self.mo_prefix) + s.n), _T_WB, self.cmd_timeout_ms,
                       prompt=b"READY", ends=(b"1",))
            return True
        if not self.signal_ok:
            return False
        if s.state == _LOADED:
            if self._ring or ticks_diff(now, self._next_at) >= 0:
                s.state = _SESSION
                self._session(now)
                return True
            return False
        if s.state != _IDLE or (self._idle_at is not None and ticks_diff(now, self._idle_at) < 0):
            return False
        mailbox = self.mailbox_check_ms and ticks_diff(now, self._mailbox_at) >= 0
        if self._ring or self._mt_waiting > 0 or mailbox:
            if not self._ring and not self._mt_waiting:
                self.stats["mailbox_checks"] += 1
            self._in_session = True
            self._session(now)
            return True
        return False

    def _session(self, now):
        self._ix = None
        self.stats["sessions"] += 1
        self.at.command(now, b"AT+SBDIXA" if self._ring else b"AT+SBDIX", _T_IX, self.sbdix_timeout_ms)

    # -- answers ---------------------------------------------------------------------
    def _info(self, tag, line):
        if tag == _T_WB or tag == _T_DD:
            self._status = w.parse_status(line)
            return self._status is not None
        if tag == _T_IX:
            try:
                self._ix = w.parse_sbdix(line)
            except DecodeError:
                self.stats["malformed"] += 1
            return True
        return False

    def _prompt(self, now, tag):
        if tag != _T_WB:
            self.stats["unexpected"] += 1
            return
        s = self.slot
        self.at.write(w.sbdwb_data(self.mo_prefix + s.buf[: s.n]), now, self.wb_timeout_ms)

    def _block(self, now, tag, buf, n):
        if tag != _T_RB:
            self.stats["unexpected"] += 1
        elif n and not w.block_ok(buf, n):
            self.stats["mt_bad"] += 1
        else:
            self._rb_good = True
            if n:
                self.stats["mt_received"] += 1
                self._events.append((_EV_RX, None, None, bytes(buf[:n])))

    def _result(self, now, tag, code, line):
        if tag == _T_WB:
            self._written(now, code, line)
        elif tag == _T_IX:
            self._in_session = False
            if code == _R_OK and self._ix is not None:
                self._session_done(now, self._ix, None)
            else:
                why = "no reply" if code == _R_TIMEOUT else (line.decode() if code != _R_OK else "no +SBDIX report")
                self._session_done(now, None, "SBDIX: " + why)
        elif tag == _T_RB:
            if code == _R_OK and self._rb_good:
                self._mt_unread = False
            else:
                self._rb_fails += 1
                if self._rb_fails >= self.rb_tries:
                    self.stats["mt_lost"] += 1
                    self._mt_unread = False
        elif tag == _T_DD:
            if code == _R_OK and self._status == 0:
                self._mo_loaded = False
                self._dd_fails = 0
            else:
                self._dd_fails += 1
                if self._dd_fails >= _CLEAR_TRIES:
                    # go on: the next session may send the old MO again,
                    # and the receiving link drops the copy
                    self.stats["clear_failed"] += 1
                    self._mo_loaded = False
                    self._dd_fails = 0

    def _written(self, now, code, line):
        s = self.slot
        if s.state != _WRITING:
            return
        st = self._status
        if code == _R_OK and st == 0:
            s.state = _LOADED
            self._mo_loaded = True
            self._next_at = now
            return
        self._mo_loaded = True  # part of it may be there
        if code == _R_END:
            why = "SBDWB status 1: the modem timed out waiting for the data"
        elif code == _R_OK and st == 2:
            why = "SBDWB status 2: checksum mismatch"
        elif code == _R_OK and st == 3:
            self._fail("SBDWB status 3: bad message size")
            return
        elif code == _R_TIMEOUT:
            # a silent modem: written again when it answers (down_after
            # silences restart it); give_up_ms bounds the wait
            self.last_failure = "SBDWB: no reply"
            s.state = _QUEUED
            return
        else:
            why = "SBDWB: %s" % (line.decode() if code != _R_OK else "no status")
        self.last_failure = why
        self._wb_fails += 1
        if self._wb_fails >= self.wb_tries:
            self._fail(why)
        else:
            s.state = _QUEUED

    def _session_done(self, now, r, why):
        s = self.slot
        mo_session = s.state == _SESSION
        if r is not None:
            self.last_session = r
            if r[2] == 1:
                self._mt_unread = True
                self._rb_fails = 0
            if r[0] <= w.MO_SUCCESS_MAX:
                self._mt_waiting = r[5]
                self._ring = False
                self._mailbox_at = ticks_add(now, self.mailbox_check_ms)
                self._idle_wait = 0
                self._idle_at = None
                if self.time_period_ms:
                    self._time_at = now  # the time from the unit that has just heard the network
                if mo_session:
                    s.state = _IDLE
                    self.stats["mo_sent"] += 1
                    self._events.append((_EV_TX_DONE, s.handle))
                return
            why = "MO status %d: %s" % (r[0], w.mo_status_name(r[0]))
        self.stats["sessions_failed"] += 1
        self.last_failure = why
        self.signal_soon(now)
        if not mo_session:
            # an empty session: again after its own back-off
            self._idle_wait = self._backoff(self._idle_wait)
            self._idle_at = ticks_add(now, self._idle_wait)
            return
        self._sessions += 1
        if ticks_diff(now, self._first_at) >= self.give_up_ms:
            self._fail("%s (gave up after %d sessions)" % (why, self._sessions))
            return
        s.state = _LOADED
        self._wait = self._backoff(self._wait)
        self._next_at = ticks_add(now, self._wait)

    def _backoff(self, wait):
        return self.retry_first_ms if not wait else min(2 * wait, self.retry_max_ms)

    def _fail(self, why):
        s = self.slot
        s.state = _IDLE
        self.stats["mo_failed"] += 1
        self._events.append((_EV_TX_FAILED, s.handle, why))

    def _urc(self, now, line):
        if line == b"SBDRING":
            self.stats["rings"] += 1
            self._ring = True
            self._idle_at = None
            self._mailbox_at = ticks_add(now, self.mailbox_check_ms)
        else:
            self.stats["urcs_other"] += 1

    def _lost(self, now, reason):
        # The modem restarted or went silent: what it held may be gone, so
        # the MO message is written again once it is back (its give-up
        # time still runs).
        s = self.slot
        if s.state == _WRITING or s.state == _LOADED or s.state == _SESSION:
            s.state = _QUEUED
            self._mo_loaded = True
        self._in_session = False
        self._mailbox_at = None
