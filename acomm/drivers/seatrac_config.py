# What the SeaTrac driver does before it lets the link send, and again after
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

from ..compat import const, ticks_add, ticks_diff
from . import seatrac_wire as w

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_EV_DRIVER_DOWN = const(7)

_MODELS = {w.PART_X150: "X150", w.PART_X110: "X110"}


class SeatracConfig:
    def __init__(self, driver, beacon_id, set_beacon_id, settings_len, id_offset, retry_ms, reboot_wait_ms):
        if settings_len + 1 > w.MAX_MSG or not 0 <= id_offset < settings_len:
            raise ValueError("settings_len / id_offset do not fit a SeaTrac message")
        self.d = driver
        self.want_id = beacon_id
        self.own_id = beacon_id  # until the beacon says otherwise
        self.set_beacon_id = set_beacon_id
        self.settings_len = settings_len
        self.id_offset = id_offset
        self.retry_ms = retry_ms
        self.reboot_wait_ms = reboot_wait_ms
        self.max_id_writes = 1  # never reboot-loop a beacon that ignores us
        self.id_writes = 0
        self.settings = bytearray(settings_len)
        self.info = {}
        self.problem = None  # why the id could not be checked or set
        self.down_reported = False
        self.fails = 0
        self._next = w.CID_SYS_INFO
        self._wait = None
        self._rebooting = False

    def start(self, now):
        self._next = w.CID_SYS_INFO
        self._wait = None

    def pump(self, now):
        if self._wait is not None and ticks_diff(now, self._wait) < 0:
            return
        self._wait = None
        cid = self._next
        m = self.d._msg
        n = 1
        if cid == w.CID_SETTINGS_SET:
            m[1 : 1 + self.settings_len] = self.settings
            n += self.settings_len
        elif cid == w.CID_SYS_REBOOT:
            m[1] = w.REBOOT_CHECK & 0xFF
            m[2] = w.REBOOT_CHECK >> 8
            n = 3
        self.d.command(now, cid, n)

    def failed(self, now, reason):
        # Start over after a pause; say the modem is down once it has
        # failed often enough (once per outage).
        self.fails += 1
        if self.fails >= self.d.down_after and not self.down_reported:
            self.down_reported = True
            self.d._events.append((_EV_DRIVER_DOWN, reason))
        self._next = w.CID_SYS_INFO
        self._wait = ticks_add(now, self.retry_ms)

    def _done(self, now):
        self.fails = 0
        self.down_reported = False
        self.d.configured(now)

    def response(self, now, b, n):
        cid = b[0]
        if cid == w.CID_SYS_INFO:
            if n < 39:
                self.failed(now, "short SYS_INFO")
                return
            self._info(b)
            self.d.uptime(now, w.u32(b, 1), self._rebooting)
            self._rebooting = False
            self._next = w.CID_SETTINGS_GET
        elif cid == w.CID_SETTINGS_GET:
            self._settings(now, b, n)
        elif cid == w.CID_SETTINGS_SET or cid == w.CID_SETTINGS_SAVE or cid == w.CID_SYS_REBOOT:
            if n < 2 or b[1] != w.CST_OK:
                self.failed(now, "%s refused: %s" % (_NAMES[cid], w.status_name(b[1]) if n >= 2 else "no status"))
                return
            if cid == w.CID_SETTINGS_SET:
                self._next = w.CID_SETTINGS_SAVE
            elif cid == w.CID_SETTINGS_SAVE:
                self._next = w.CID_SYS_REBOOT
            else:
                # the beacon closes its port, restarts and prints its
                # power-up text: ask again only after a while
                self._rebooting = True
                self.d.forget_uptime()
                self._next = w.CID_SYS_INFO
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
        model = _MODELS.get(part)
        caps = self.d.caps
        caps.model = model if model is not None else "SeaTrac part %d" % part
        caps.serial = str(serial)

    def _settings(self, now, b, n):
        ln = self.settings_len
        off = self.id_offset
        if n - 1 != ln or not 1 <= b[1 + off] <= 15:
            # not the layout we know: use the configured id unchecked
            self.problem = "SETTINGS_T of %d bytes: beacon id not checked" % (n - 1)
            self._done(now)
            return
        s = self.settings
        for i in range(ln):
            s[i] = b[1 + i]
        self._timing(s, off)
        have = s[off]
        want = self.want_id
        if want is None or have == want:
            self.own_id = have
            self.problem = None
            self._done(now)
            return
        if self.set_beacon_id and self.id_writes < self.max_id_writes:
            self.id_writes += 1
            s[off] = want
            self._next = w.CID_SETTINGS_SET
            return
        self.problem = "beacon id is %d, not %d" % (have, want)
        self.failed(now, self.problem)

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


_NAMES = {w.CID_SETTINGS_SET: "SETTINGS_SET", w.CID_SETTINGS_SAVE: "SETTINGS_SAVE", w.CID_SYS_REBOOT: "SYS_REBOOT"}
