# The AT command machinery the Iridium SBD and GSM SMS drivers share: one
# command at a time with a deadline, lines cut at CR or LF, the final result
# codes (OK, ERROR, +CME ERROR: <e>, +CMS ERROR: <e>), the echo of our own
# command, unsolicited lines (URCs) told apart by their prefix, a prompt that
# opens a data phase (Iridium's "READY" line, the SMS "> " that has no line
# end), and one binary block read (Iridium's SBDRB: a 2-byte big-endian
# length, the data, a 2-byte checksum, then OK).
#
# The channel only finds the pieces; the driver (the sink) decides what they
# mean:
#   sink.on_info(tag, line)        a line answering the command
#   sink.on_result(tag, code, line)  the command ended: R_OK, R_ERROR (line
#                                  holds the error), R_END (one of the
#                                  command's `ends` lines) or R_TIMEOUT
#   sink.on_prompt(tag)            the prompt arrived: write the data now
#   sink.on_block(tag, buf, n)     a binary block: n data bytes then the two
#                                  checksum bytes in buf
#   sink.on_urc(line)              an unsolicited line, at any time
#   sink.on_echo()                 our own command line came back
#   sink.on_stray(line)            any other line outside a command
#   sink._out                      the bytearray commands are written to
# Lines are bytes without their line end and outer spaces. A control or
# non-ASCII character is noise: the line so far is dropped and counted
# (junk), and the line goes on after it, which is how the channel
# resynchronises after garbage (even "\x00\x00OK" is still an OK). After a timeout the
# channel stays quiet for settle_ms and drops what arrives then, so that a
# late answer is not taken for the answer to the next command.
# Buffers are preallocated; nothing is allocated per byte.
# Framing: lines are cut at CR or at LF and empty ones skipped, so the
# verbose form (CR LF text CR LF), the numeric form (text CR LF, result
# "0" CR), a leading CR LF or none all read the same. A command written with
# numeric=True also takes the numeric result codes "0" (OK) and "4"
# (ERROR): the driver's first commands, before ATV1 has been answered.

from ..compat import const, ticks_add, ticks_diff

R_OK = const(0)
R_ERROR = const(1)
R_END = const(2)
R_TIMEOUT = const(3)

# reading modes
_LINES = const(0)
_B_WAIT = const(1)  # before the block: its length, or a text line first
_B_TEXT = const(2)  # a text line where the length was expected (DUNE)
_B_LEN = const(3)
_B_DATA = const(4)


class AtChannel:
    def __init__(self, sink, urcs=(), line_cap=400, block_cap=0, eol=b"\r", settle_ms=500):
        self.sink = sink
        self.urcs = urcs  # prefixes of unsolicited lines
        self.eol = eol
        self.settle_ms = settle_ms
        self._line = bytearray(line_cap)
        self._block = bytearray(block_cap + 2)
        # a block's first byte is its length's high byte: above this it is
        # the start of a text line instead (0x01 for the 270 bytes of a 9602)
        self._block_hi = block_cap >> 8
        self.junk = {}
        self.stats = {"commands": 0, "timeouts": 0, "echo": 0, "stale": 0, "urcs": 0}
        self.reset()

    def reset(self):
        # forget the command and any partial line (the modem restarted)
        self.tag = 0
        self._text = b""
        self._deadline = 0
        self._prompt = None
        self._ends = ()
        self._numeric = False
        self._mode = _LINES
        self._n = 0
        self._over = False
        self._noisy = False
        self._need = 0
        self._got = 0
        self._quiet_until = None

    def _junk(self, kind):
        self.junk[kind] = self.junk.get(kind, 0) + 1

    # -- writing -------------------------------------------------------------------
    def busy(self, now):
        if self.tag:
            return True
        q = self._quiet_until
        if q is not None:
            if ticks_diff(now, q) < 0:
                return True
            self._quiet_until = None
        return False

    def command(self, now, text, tag, timeout_ms, prompt=None, ends=(), block=False, numeric=False):
        # Write one command (text without its line end). prompt: what opens
        # the data phase; ends: lines that end the command without OK;
        # block: the answer is a binary block (SBDRB); numeric: "0" / "4"
        # are OK / ERROR too (a modem that may be in ATV0).
        self.tag = tag
        self._numeric = numeric
        self._text = text
        self._deadline = ticks_add(now, timeout_ms)
        self._prompt = prompt
        self._ends = ends
        self._mode = _B_WAIT if block else _LINES
        self._n = 0
        self._over = False
        self.stats["commands"] += 1
        out = self.sink._out
        out.extend(text)
        out.extend(self.eol)

    def write(self, data, now=None, timeout_ms=None):
        # the data phase after the prompt; a new deadline when given
        self.sink._out.extend(data)
        if timeout_ms is not None:
            self._deadline = ticks_add(now, timeout_ms)

    def poll(self, now):
        if self.tag and ticks_diff(now, self._deadline) >= 0:
            self.stats["timeouts"] += 1
            self._quiet_until = ticks_add(now, self.settle_ms)
            self._finish(R_TIMEOUT, b"")

    def _finish(self, code, line):
        tag = self.tag
        self.tag = 0
        self._prompt = None
        self._mode = _LINES
        self.sink.on_result(tag, code, line)

    # -- reading -------------------------------------------------------------------
    def feed(self, data):
        buf = self._line
        cap = len(buf)
        for b in data:
            mode = self._mode
            if mode == _B_DATA:
                self._block[self._got] = b
                self._got += 1
                if self._got == self._need:
                    self._mode = _LINES
                    self.sink.on_block(self.tag, self._block, self._need - 2)
                continue
            if mode == _B_LEN:
                n = (self._need << 8) | b
                if n + 2 > len(self._block):
                    # a length we cannot hold: what follows is read as
                    # (junk) lines until the command ends
                    self._junk("block too long")
                    self._mode = _LINES
                else:
                    self._need = n + 2
                    self._got = 0
                    self._mode = _B_DATA
                continue
            if mode == _B_WAIT:
                if b == 13 or b == 10:
                    continue
                if b <= self._block_hi:
                    self._need = b
                    self._mode = _B_LEN
                    continue
                self._mode = _B_TEXT  # and b starts that line
            if b == 13 or b == 10:
                n = self._n
                self._n = 0
                if self._noisy:
                    self._noisy = False
                    self._junk("noise")
                if self._over:
                    self._over = False
                    self._junk("overlong")
                elif n:
                    self._line_done(n)
                if self._mode == _B_TEXT and self.tag:
                    self._mode = _B_WAIT
                continue
            if b < 32 or b > 126:
                # noise: what came before it on this line is dropped, so an
                # answer after garbage on the same line is still read
                self._noisy = True
                self._n = 0
                continue
            n = self._n
            if n < cap:
                buf[n] = b
                n += 1
                self._n = n
                p = self._prompt
                if p is not None and n == len(p) and buf[:n] == p:
                    # the prompt needs no line end (SMS "> ")
                    self._prompt = None
                    self._n = 0
                    self.sink.on_prompt(self.tag)
            else:
                self._over = True

    def _line_done(self, n):
        buf = self._line
        while n and buf[n - 1] == 32:
            n -= 1
        i = 0
        while i < n and buf[i] == 32:
            i += 1  # the space after an SMS prompt, for one
        if i == n:
            return
        s = bytes(buf[i:n])
        sink = self.sink
        tag = self.tag
        if tag and s == self._text:
            self.stats["echo"] += 1
            sink.on_echo()
            return
        for u in self.urcs:
            if s.startswith(u):
                self.stats["urcs"] += 1
                sink.on_urc(s)
                return
        if not tag:
            if self._quiet_until is not None or is_final(s):
                # the late answer to a command that timed out
                self.stats["stale"] += 1
            else:
                sink.on_stray(s)
            return
        if s == b"OK" or (self._numeric and s == b"0"):
            self._finish(R_OK, s)
        elif is_final(s) or (self._numeric and s == b"4"):
            self._finish(R_ERROR, s)
        elif s in self._ends:
            self._finish(R_END, s)
        else:
            sink.on_info(tag, s)


def is_final(s):
    # OK or an error result code
    return s == b"OK" or s == b"ERROR" or s.startswith(b"+CME ERROR") or s.startswith(b"+CMS ERROR")


def after(line, prefix):
    # the text after "prefix" ("+CSQ:"), spaces stripped; None when the
    # line does not start with it
    if not line.startswith(prefix):
        return None
    return line[len(prefix) :].strip()


def ints(text, count):
    # "0, 23, 1, 5, 6, 0" -> [0, 23, 1, 5, 6, 0]; None unless exactly
    # `count` decimal fields (a minus sign allowed: SBDS's MTMSN -1)
    parts = text.split(b",")
    if len(parts) != count:
        return None
    out = []
    for p in parts:
        p = p.strip()
        neg = p[:1] == b"-"
        if neg:
            p = p[1:]
        if not p or len(p) > 9:
            return None
        v = 0
        for c in p:
            if not 48 <= c <= 57:
                return None
            v = v * 10 + c - 48
        out.append(-v if neg else v)
    return out
