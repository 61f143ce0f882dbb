# What the emulated Hayes-AT surface modems (Iridium SBD in acomm_sim.iridium,
# GSM in acomm_sim.gsm) share: command lines ending in CR (a LF after it is
# ignored), the echo (on after power-up, ATE0 turns it off), answers
# `lead + text + CR LF`, a data phase after a prompt (a byte count, as for
# SBDWB, or up to Ctrl-Z with ESC to abort, as for CMGS), answers that come
# later (an SBDIX session, an SMS being sent) while the modem takes no
# commands, and the fault modes of acomm_sim.faults: corrupt_next /
# truncate_next keyed by how an output line starts (b"+SBDIX", b"+CMTI"),
# swallow_next keyed by how a command starts (b"AT+SBDIX"), noise, and
# reboot(now): deaf for boot_ms, settings back to their power-up values,
# then the banner lines.
#
# The subclass gives _command(now, text, c) (text as typed; c: what follows
# "AT", in capitals; "AT" and "ATE0/1" are answered here), _reset()
# (power-up state), self.net (its network, polled with it) and, for the
# data phase it opens, the function to call with the bytes (or None when
# the phase timed out or was aborted). shared_network() gives every modem
# on one medium the same network.

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers.base import SansIO

from .faults import CRLF, FaultModes, hit

_CTRL_Z = 0x1A
_ESC = 0x1B


class AtModem(SansIO, FaultModes):
    def __init__(self, now, banner, boot_ms, lead, line_cap=600):
        SansIO.__init__(self)
        self.banner = banner
        self.boot_ms = boot_ms
        self.lead = lead
        self.line_cap = line_cap
        self._faults = []
        self._booting_until = None
        self._now = now
        self.commands = {}  # command (up to '=' or '?') -> count, for tests
        self.ignored = 0  # lines that are not commands, input while busy
        self._mute = False
        self._reset_io()

    def _reset_io(self):
        self.echo = True
        self._line = bytearray()
        self._over = False
        self._data = None  # the data phase: bytes so far
        self._data_need = None  # its length, or None: up to Ctrl-Z
        self._data_until = None
        self._data_done = None
        self._later = None  # [when, fn, muted]: an answer still to come

    # -- the port ----------------------------------------------------------------------
    def feed(self, now, data):
        self._now = now
        if self._booting_until is not None:
            return
        for b in data:
            if self._data is not None:
                self._data_byte(now, b)
            elif self._later is not None:
                self.ignored += 1  # busy: a real modem takes no command now
            elif b == 13:
                self._end_line(now)
            elif b == 10:
                continue
            elif len(self._line) < self.line_cap:
                self._line.append(b)
            else:
                self._over = True

    def poll(self, now):
        self._now = now
        self.net.poll(now)
        if self._still_booting(now):
            return
        if self._data is not None and ticks_diff(now, self._data_until) >= 0:
            fn = self._data_done
            self._data = None
            fn(now, None)
        later = self._later
        if later is not None and ticks_diff(now, later[0]) >= 0:
            self._later = None
            self._mute = later[2]
            later[1](now)
            self._mute = False

    def idle(self, now):
        return self._data is None and self._later is None and self._booting_until is None and not self.net.busy()

    def _end_line(self, now):
        text = bytes(self._line)
        self._line = bytearray()
        if self._over:
            self._over = False
            self.ignored += 1
            self._emit(b"ERROR")
            return
        if self.echo:
            self._out.extend(text + b"\r")
        if not text:
            return
        if len(text) < 2 or text[0] not in (65, 97) or text[1] not in (84, 116):
            self.ignored += 1
            return
        name = text
        for sep in b"=?":
            i = name.find(bytes((sep,)))
            if i > 0:
                name = name[:i]
        self.commands[name] = self.commands.get(name, 0) + 1
        f = self._fault(("swallow",), text)
        if f is not None:
            if not f[3]:
                return
            self._mute = True
        c = text[2:].upper()
        if c == b"":
            self.ok()
        elif c in (b"E0", b"E1", b"E"):
            self.echo = c == b"E1"
            self.ok()
        else:
            self._command(now, text, c)
        if self._later is not None:
            self._later[2] = self._mute
        self._mute = False

    # -- the data phase and later answers ---------------------------------------------------
    def begin_data(self, now, need, timeout_ms, done):
        self._data = bytearray()
        self._data_need = need
        self._data_until = ticks_add(now, timeout_ms)
        self._data_done = done

    def _data_byte(self, now, b):
        d = self._data
        if self._data_need is None:
            if b == _CTRL_Z or b == _ESC:
                self._data = None
                self._data_done(now, bytes(d) if b == _CTRL_Z else None)
                return
            if len(d) >= self.line_cap:
                self._data = None
                self._data_done(now, b"")  # too long: the subclass refuses it
                return
        d.append(b)
        if self._data_need is not None and len(d) >= self._data_need:
            self._data = None
            self._data_done(now, bytes(d))

    def later(self, now, ms, fn):
        # fn(now) answers after ms; the modem is busy until then
        self._later = [ticks_add(now, ms), fn, False]

    # -- output -------------------------------------------------------------------------
    def reply(self, line):
        if not self._mute:
            self._emit(line)

    def ok(self):
        self.reply(b"OK")

    def error(self):
        self.reply(b"ERROR")

    def notify(self, line):
        # unsolicited: not while restarting, not muted
        if self._booting_until is None:
            self._emit(line)

    def raw(self, data):
        if not self._mute:
            self._out.extend(data)

    def _emit(self, line):
        f = self._fault(("corrupt", "truncate"), line)
        term = CRLF
        if f is not None and f[0] == "corrupt":
            line = hit(line, len(line) // 2)
        elif f is not None:
            line = line[: len(line) // 2]
            term = CRLF if f[3] else b""
        self._out.extend(self.lead)
        self._out.extend(line)
        self._out.extend(term)

    def _fault_matches(self, f, line):
        return f[1] is None or line[: len(f[1])] == f[1]

    # -- restarts ----------------------------------------------------------------------------
    def reboot(self, now):
        # Power cycle: the command in progress and the data phase are
        # gone, settings are back to their power-up values.
        self._start_boot(now)
        self._reset_io()
        self._mute = False
        self._reset()

    def _booted(self, now):
        self._print_banner()


def shared_network(medium, cls, attr):
    # The network of a medium: medium itself when it is one, else one made
    # on first use and kept on the medium (the acoustic medium of a World or
    # of `acomm emulate`) under attr.
    if isinstance(medium, cls):
        return medium
    net = getattr(medium, attr, None)
    if net is None:
        net = cls()
        setattr(medium, attr, net)
    return net
