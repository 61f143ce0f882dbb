# What the emulated Hayes-AT surface modems (Iridium SBD in acomm_sim.iridium,
# GSM in acomm_sim.gsm) share: command lines ending in CR (a LF after it is
# ignored), the echo (on after power-up, ATE0 turns it off), the V.250
# framing of answers in the mode the host chose (ISU AT Command Reference
# table 3-1; 3GPP TS 27.007 / V.250 the same):
#     ATV1 (verbose, power-up)   information text  CR LF text CR LF
#                                result code       CR LF OK CR LF
#     ATV0 (numeric)             information text  text CR LF
#                                result code       0 CR  (4 for ERROR)
# ATQ1 silences the result codes. Further lines of one information response
# (the text of +CMGR under its header) are `text CR LF`. Basic commands may
# be chained on one line (ATE0V1Q0). A data phase after a prompt (a byte count, as for
# SBDWB, or up to Ctrl-Z with ESC to abort, as for CMGS), answers that come
# later (an SBDIX session, an SMS being sent) while the modem takes no
# commands, and the fault modes of acomm_sim.faults: corrupt_next /
# truncate_next keyed by how an output line starts (b"+SBDIX", b"+CMTI"),
# swallow_next keyed by how a command starts (b"AT+SBDIX"), noise, and
# reboot(now): deaf for boot_ms, settings back to their power-up values,
# then the banner lines.
#
# The subclass gives _command(now, text, c) (text as typed; c: what follows
# "AT", in capitals; "AT" and chains of E, V, Q are answered here), _reset()
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
    def __init__(self, now, banner, boot_ms, line_cap=600):
        SansIO.__init__(self)
        self.banner = banner
        self.boot_ms = boot_ms
        self.line_cap = line_cap
        self._faults = []
        self._booting_until = None
        self._now = now
        self.commands = {}  # command (up to '=' or '?') -> count, for tests
        self.ignored = 0  # lines that are not commands, input while busy
        self._mute = False
        self._reset_io()

    def _reset_io(self):
        # the factory defaults of both real units: E1 V1 Q0
        self.echo = True
        self.verbose = True
        self.quiet = False
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

    @property
    def pending_reply(self):
        # True while an answer is still to come (an SMS being sent, an SBDIX
        # session): the modem takes no commands until then. For tests.
        return self._later is not None

    def idle(self, now):
        return self._data is None and self._later is None and self._booting_until is None and not self.net.busy()

    def _end_line(self, now):
        text = bytes(self._line)
        self._line = bytearray()
        if self._over:
            self._over = False
            self.ignored += 1
            self.error()
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
        basic = _basic(c)
        if basic is not None:
            for k, v in basic:
                if k == 69:
                    self.echo = v == 1
                elif k == 86:
                    self.verbose = v == 1
                else:
                    self.quiet = v == 1
            self.ok()  # in the mode just set, as the real units do
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
    def reply(self, line, more=False):
        # information text; more: a further line of the same response
        if not self._mute:
            self._emit(line, _MORE if more else _INFO)

    def result(self, line, code):
        # a final result code (numeric form `code`) unless ATQ1
        if not self._mute and not self.quiet:
            self._emit(line, code)

    def ok(self):
        self.result(b"OK", b"0")

    def error(self):
        self.result(b"ERROR", b"4")

    def notify(self, line, code=None, more=False):
        # unsolicited: not while restarting, not muted; a result code
        # (numeric form `code`) or information text (more: a further line
        # of the same, such as the PDU under +CMT)
        if self._booting_until is None:
            self._emit(line, _MORE if more else (code or _INFO))

    def prompt(self, text):
        # a data prompt (the SMS "> "): after CR LF in verbose mode
        if not self._mute:
            if self.verbose:
                self._out.extend(CRLF)
            self._out.extend(text)

    def raw(self, data):
        if not self._mute:
            self._out.extend(data)

    def _emit(self, line, kind):
        # kind: _INFO, _MORE or the numeric form of a result code
        f = self._fault(("corrupt", "truncate"), line)
        if not self.verbose and kind is not _INFO and kind is not _MORE:
            line = kind
            term = b"\r"
        else:
            term = CRLF
            if self.verbose and kind is not _MORE:
                self._out.extend(CRLF)
        if f is not None and f[0] == "corrupt":
            line = hit(line, len(line) // 2)
        elif f is not None:
            line = line[: len(line) // 2]
            term = term if f[3] else b""
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
        for ln in self.banner:
            self._emit(ln, _INFO)


_INFO = "info"
_MORE = "more"


def _basic(c):
    # "E0V1Q0" -> [(69, 0), (86, 1), (81, 0)]: a chain of the basic
    # commands E, V, Q (no digit means 0); "" (plain AT) -> []; None for
    # anything else
    out = []
    i = 0
    while i < len(c):
        k = c[i]
        if k not in (69, 81, 86):
            return None
        v = 0
        if i + 1 < len(c) and c[i + 1] in (48, 49):
            v = c[i + 1] - 48
            i += 1
        elif i + 1 < len(c) and 50 <= c[i + 1] <= 57:
            return None
        out.append((k, v))
        i += 1
    return out


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
