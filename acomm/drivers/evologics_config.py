# What the EvoLogics driver sends before it lets the link transmit, and again
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
# starts over after retry_ms, and the modem is reported down once per outage
# after down_after failures in a row.

from ..compat import ticks_add, ticks_diff
from ..events import EV_DRIVER_DOWN

S_CTRL = 1
S_MODE = 2
S_AL = 3
S_SET_AL = 4
S_CA = 5
S_ZX = 6
S_EXTRA = 7


class EvologicsConfig:
    def __init__(self, driver, address, take_control, check_mode, notifications, extra, retry_ms):
        self.d = driver
        self.want_addr = address
        self.own_addr = address  # until the modem says otherwise
        self.take_control = take_control
        self.check_mode = check_mode
        self.notifications = notifications
        self.extra = tuple(extra)
        self.retry_ms = retry_ms
        self.zx = False  # extended notifications are on
        self.control = None  # None: not asked; True/False: AT@CTRL answer
        self.problem = None
        self.down_reported = False
        self.fails = 0
        self.al_writes = 0
        self._step = S_CTRL
        self._extra_i = 0
        self._wait = None

    def start(self, now):
        self._step = S_CTRL if self.take_control else S_MODE
        if self._step == S_MODE and not self.check_mode:
            self._step = S_AL
        self._extra_i = 0
        self._wait = None
        self.al_writes = 0
        self.zx = False

    def pump(self, now):
        if self._wait is not None and ticks_diff(now, self._wait) < 0:
            return
        self._wait = None
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

    def failed(self, now, reason):
        # Start over after a pause; say the modem is down once it has
        # failed often enough (once per outage).
        self.fails += 1
        self.problem = reason
        if self.fails >= self.d.down_after and not self.down_reported:
            self.down_reported = True
            self.d._events.append((EV_DRIVER_DOWN, reason))
        self.start(now)
        self._wait = ticks_add(now, self.retry_ms)

    def _after_ca(self, now):
        if self.notifications:
            self._step = S_ZX
        else:
            self._extras(now)

    def _extras(self, now):
        if self._extra_i < len(self.extra):
            self._step = S_EXTRA
            return
        self.fails = 0
        self.down_reported = False
        self.problem = None
        self.d.configured(now)

    def reply(self, now, step, r, kind):
        # The answer to a step: r is the line reader, kind the driver's
        # classification (R_OK, R_ERROR, R_BUSY or R_VALUE).
        d = self.d
        ok = kind == d.R_OK
        if step == S_CTRL:
            # old firmware has no @CTRL: an ERROR is not fatal
            self.control = ok
            self._step = S_MODE if self.check_mode else S_AL
        elif step == S_MODE:
            if kind != d.R_VALUE or not r.is_word(b"NET"):
                self.failed(now, "modem not in NET mode: %s" % _show(r))
                return
            self._step = S_AL
        elif step == S_AL or step == S_SET_AL and ok:
            if step == S_SET_AL:
                self._step = S_AL  # read it back
                return
            a = r.int_field(0) if kind == d.R_VALUE and r.nc == 0 else None
            if a is None or not 0 <= a <= 254:
                self.failed(now, "bad answer to AT?AL: %s" % _show(r))
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
            self.failed(now, "AT!AL%d refused: %s" % (self.want_addr, _show(r)))
        elif step == S_CA:
            v = r.int_field(0) if kind == d.R_VALUE and r.nc == 0 else None
            if v is not None and 1300 <= v <= 1700:
                d.sound_speed = v
            self._after_ca(now)
        elif step == S_ZX:
            self.zx = ok  # without them, the airtime model ends transmissions
            self._extras(now)
        else:
            if not ok:
                self.failed(now, "%s refused: %s" % (self.extra[self._extra_i].decode(), _show(r)))
                return
            self._extra_i += 1
            self._extras(now)


def _show(r):
    t = r.text()
    try:
        return t.decode()
    except Exception:  # noqa: BLE001 - binary junk in a reply
        return repr(t)
