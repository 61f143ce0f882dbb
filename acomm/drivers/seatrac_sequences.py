# The two sequences the SeaTrac driver (acomm.drivers.seatrac) runs on the
# beacon's command slot: its configuration (SeatracConfig) and the one
# acoustic transaction under way (AcousticSlot).
#
# The configuration, before the driver lets the link send, and again after
# the beacon restarted or fell silent:
#
#   SYS_INFO        model (X110/X150), serial number, firmware, uptime
#   SETTINGS_GET    own beacon id, response timeout range, VOS
#   and only when the constructor asked for another beacon id:
#   SETTINGS_SET (id changed) -> SETTINGS_SAVE -> SYS_REBOOT -> wait ->
#   SYS_INFO -> SETTINGS_GET to verify  (the order DUNE uses; communication
#   settings take effect only after a restart)
#
# The byte layout of SETTINGS_T is not confirmed against the vendor manual
# (ref/modem-protocols.md section 8), so the record length and the offset of
# the beacon id are parameters, and a record of another length is never
# written back: the driver then trusts the configured id without checking.
#
# The transaction: a DAT_SEND or PING_SEND from the moment the link hands it
# to the driver until the beacon's final word on it.
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
from .base import ConfigSequence, SlotBase

# these modules' codes, as private constants (inlined: no slot in this
# module's dict on a board); tests/cpython/test_const_copies.py checks them
_IDLE = const(0)  # acomm.drivers.base
_QUEUED = const(1)  # acomm.drivers.base

# seatrac_codes' numbers, as private constants (inlined: no RAM on a board)
_CID_DAT_SEND = const(0x60)
_CID_PING_SEND = const(0x40)
_CID_SETTINGS_GET = const(0x15)
_CID_SETTINGS_SAVE = const(0x18)
_CID_SETTINGS_SET = const(0x16)
_CID_SYS_INFO = const(0x02)
_CID_SYS_REBOOT = const(0x03)
_CST_OK = const(0x00)
_CST_XCVR_BUSY = const(0x30)
_MAX_MSG = const(128)
_MSG_REQ = const(2)
_MSG_REQU = const(4)
_MSG_REQX = const(6)
_PART_X110 = const(843)
_PART_X150 = const(795)
_REBOOT_CHECK = const(0x6A95)

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_DELIVERED = const(3)
_EV_RANGE = const(5)
_EV_TX_DONE = const(2)
_EV_TX_FAILED = const(4)


class SeatracConfig(ConfigSequence):
    """The beacon's configuration: info, settings, and the beacon id written when it differs."""

    # never reboot-loop a beacon that ignores us; a class default, so the
    # instance keeps 17 attributes, one step (48 bytes) below 18 on MicroPython
    max_id_writes = 1

    def __init__(self, driver, beacon_id, set_beacon_id, settings_len, id_offset, retry_ms, reboot_wait_ms):
        if settings_len + 1 > _MAX_MSG or not 0 <= id_offset < settings_len:
            raise ValueError("settings_len / id_offset do not fit a SeaTrac message")
        ConfigSequence.__init__(self, driver, retry_ms)
        self.want_id = beacon_id
        self.own_id = beacon_id  # until the beacon says otherwise
        self.set_beacon_id = set_beacon_id
        self.settings_len = settings_len
        self.id_offset = id_offset
        self.reboot_wait_ms = reboot_wait_ms
        self.id_writes = 0
        self.settings = bytearray(settings_len)
        self.info = {}
        self._next = _CID_SYS_INFO
        self._rebooting = False

    def first(self):
        self._next = _CID_SYS_INFO

    def step(self, now):
        cid = self._next
        m = self.d._msg
        n = 1
        if cid == _CID_SETTINGS_SET:
            m[1 : 1 + self.settings_len] = self.settings
            n += self.settings_len
        elif cid == _CID_SYS_REBOOT:
            m[1] = _REBOOT_CHECK & 0xFF
            m[2] = _REBOOT_CHECK >> 8
            n = 3
        self.d.command(now, cid, n)

    def response(self, now, b, n):
        cid = b[0]
        if cid == _CID_SYS_INFO:
            if n < 39:
                self.failed(now, "short SYS_INFO")
                return
            self._info(b)
            self.d.uptime(now, w.u32(b, 1), self._rebooting)
            self._rebooting = False
            self._next = _CID_SETTINGS_GET
        elif cid == _CID_SETTINGS_GET:
            self._settings(now, b, n)
        elif cid == _CID_SETTINGS_SET or cid == _CID_SETTINGS_SAVE or cid == _CID_SYS_REBOOT:
            if n < 2 or b[1] != _CST_OK:
                name = "SYS_REBOOT"
                if cid != _CID_SYS_REBOOT:
                    name = "SETTINGS_SET" if cid == _CID_SETTINGS_SET else "SETTINGS_SAVE"
                self.failed(now, "%s refused: %s" % (name, w.status_name(b[1]) if n >= 2 else "no status"))
                return
            if cid == _CID_SETTINGS_SET:
                self._next = _CID_SETTINGS_SAVE
            elif cid == _CID_SETTINGS_SAVE:
                self._next = _CID_SYS_REBOOT
            else:
                # the beacon closes its port, restarts and prints its
                # power-up text: ask again only after a while
                self._rebooting = True
                self.d.forget_uptime()
                self._next = _CID_SYS_INFO
                self._wait = ticks_add(now, self.reboot_wait_ms)
        else:
            self.failed(now, "unexpected answer 0x%02X" % cid)

    def _info(self, b):
        part = w.u16(b, 6)
        serial = w.u32(b, 9)
        self.info = {
            "part": part,
            "hw_rev": b[8],
            "serial": serial,
            "section": b[5],
            "firmware": "%d.%d.%d" % (b[31], b[32], w.u16(b, 33)),
        }
        caps = self.d.caps
        if part == _PART_X150:
            caps.model = "X150"
        elif part == _PART_X110:
            caps.model = "X110"
        else:
            caps.model = "SeaTrac part %d" % part
        caps.serial = str(serial)

    def _settings(self, now, b, n):
        ln = self.settings_len
        off = self.id_offset
        if n - 1 != ln or not 1 <= b[1 + off] <= 15:
            # not the layout we know: use the configured id unchecked
            self.done(now)
            self.problem = "SETTINGS_T of %d bytes: beacon id not checked" % (n - 1)
            return
        s = self.settings
        for i in range(ln):
            s[i] = b[1 + i]
        self._timing(s, off)
        have = s[off]
        want = self.want_id
        if want is None or have == want:
            self.own_id = have
            self.done(now)
            return
        if self.set_beacon_id and self.id_writes < self.max_id_writes:
            self.id_writes += 1
            s[off] = want
            self._next = _CID_SETTINGS_SET
            return
        self.failed(now, "beacon id is %d, not %d" % (have, want))

    def _timing(self, s, off):
        # The reply timeout the beacon works with, for the driver's own
        # watchdog: xcvr_range_tmo (m) and xcvr_resp_time (ms) follow the
        # beacon id in the record; VOS (0.1 m/s) sits at offset 35 in DUNE's
        # layout. Out-of-range values are ignored.
        d = self.d
        if off + 5 <= len(s):
            r = w.u16(s, off + 1)
            if 100 <= r <= 3000:
                d.range_tmo_m = r
            t = w.u16(s, off + 3)
            if 10 <= t <= 1000:
                d.resp_time_ms = t
        if len(s) >= 37:
            v = w.u16(s, 35)
            if 13000 <= v <= 17000:
                d.vos = v // 10


CMD = const(2)
AIR = const(3)

K_DAT = const(0)
K_PING = const(1)

REQ_TYPES = (_MSG_REQ, _MSG_REQU, _MSG_REQX)


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
            return _CID_PING_SEND, 3
        n = self.n
        msg[3] = n
        msg[4 : 4 + n] = memoryview(self.buf)[:n]
        return _CID_DAT_SEND, 4 + n

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
        if status != _CST_OK:
            self.fail(w.status_name(status))
            if status == _CST_XCVR_BUSY:
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
                self.state = _IDLE  # one-way: nothing more will come
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
        self.state = _IDLE
        self.done_at = None
        self.d._events.append((_EV_TX_FAILED, self.handle, reason))

    def delivered(self):
        self.tx_done()
        self.state = _IDLE
        self.d._events.append((_EV_DELIVERED, self.handle))

    def dat_error(self, status):
        self.tx_done()  # the packet did go out; nobody answered it
        self.fail(w.status_name(status))

    def ranged(self, src, metres, fix):
        self.state = _IDLE
        self.d._events.append((_EV_RANGE, self.handle, src if metres is not None else None, metres, fix))
