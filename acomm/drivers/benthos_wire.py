# The Teledyne Benthos ATM-9xx serial dialogue as text: the figures both ends share (rates, addresses, the
# airtime model), the few line formats that carry values (CLAM setting echoes, the range report, hex
# payloads), and the readers of the modem's lines and received blocks. Used by the driver
# (acomm.drivers.benthos) and by the emulator (ports/sim), so both ends agree on every byte; the byte-exact
# tests against ref/modem-protocols.md section 4.6 keep both honest.
#
# Parsing is by hand (MicroPython's re is too small) and never raises: a parser returns None for a line that
# does not have its shape.

from ..compat import const

BROADCAST = const(255)  # @RemoteAddr for everyone
MAX_ADDR = const(249)  # local and remote addresses are 0..249
MAX_FRAME = const(4091)  # goby's absolute ceiling for one frame
DEFAULT_MTU = const(64)  # goby's default max_frame_size

# @TxRate code -> bit/s (AcousticModem.py TxRate): 2..8 MFSK, 9..13 PSK
RATES = {2: 140, 3: 300, 4: 600, 5: 800, 6: 1066, 7: 1200, 8: 2400, 9: 2560, 10: 5120, 11: 7680, 12: 10240, 13: 15360}

PROMPT_HEAD = b"user:"
NOT_FOUND = "Command '+++' not found"  # the answer to +++ in command mode
FWD_UP = "Forwarding Delay Up"  # the modem starts to transmit
NO_RESPONSE = "Response Not Received"  # an acoustic command timed out
EOP = "<EOP>"

ECHO_WIDTH = const(16)  # "P1EchoChar      | Dis": the name is padded to 16

_HEX = "0123456789ABCDEF"


def airtime_ms(rate, nbytes, packet_ms):
    # One acoustic packet: a fixed part (wake-up, training, header; not
    # confirmed, so a parameter) plus the payload at the code's bit rate.
    bps = RATES.get(rate, 140)
    return packet_ms + (nbytes * 8000 + bps - 1) // bps


def secs_text(ms):
    # 50 -> "0.05", 1000 -> "1.0": seconds as CLAM settings take them
    s = "%d.%03d" % (ms // 1000, ms % 1000)
    while s[-1] == "0" and s[-2] != ".":
        s = s[:-1]
    return s


def milli(text):
    # "0.05" -> 50, "10" -> 10000, "+1.5" -> 1500; None when not a number.
    # Thousandths in integers, so values compare exactly on both runtimes.
    t = text.strip()
    if t and t[0] == "+":
        t = t[1:]
    neg = t[:1] == "-"
    if neg:
        t = t[1:]
    i = t.find(".")
    whole, frac = (t, "") if i < 0 else (t[:i], t[i + 1 :])
    if not (whole or frac) or not _digits(whole) or not _digits(frac):
        return None
    v = int(whole or "0") * 1000 + int((frac + "000")[:3] or "0")
    return -v if neg else v


def _digits(s):
    for c in s:
        if not "0" <= c <= "9":
            return False
    return True


def number(text):
    # an integer written in decimal ("002" -> 2), None otherwise
    t = text.strip()
    return int(t) if t and _digits(t) else None


def fmt1(x):
    # one decimal, rounded half away from zero in integers (float
    # formatting differs between the runtimes at the half)
    t = int(abs(x) * 10 + 0.5)
    return "%s%d.%d" % ("-" if x < 0 and t else "", t // 10, t % 10)


# -- CLAM settings ----------------------------------------------------------------
def echo_line(name, value):
    return "%-16s| %s" % (name, value)


def parse_echo(s):
    # "RemoteAddr      | 2" -> ("RemoteAddr", "2")
    i = s.find("|")
    if i <= 0:
        return None
    name = s[:i].strip()
    if not name or " " in name:
        return None
    return name, s[i + 1 :].strip()


_WORDS = {"ena": "1", "enabled": "1", "dis": "0", "disabled": "0"}


def same_value(want, got):
    # The modem may print a value in its own way ("0.05" as "0.050", 0 as
    # Dis): numbers compare as numbers, words without regard to case.
    want = _WORDS.get(want.lower(), want)
    got = _WORDS.get(got.lower(), got)
    a = milli(want)
    b = milli(got)
    if a is not None or b is not None:
        return a == b
    return want.lower() == got.lower()


# -- the prompt -----------------------------------------------------------------------
def prompt_at(buf, n):
    # Where "user:<digits>>" ending at buf[n-1] starts, or -1. The prompt has
    # no line ending, so the line splitter asks at every '>'.
    i = n - 2
    while i >= 0 and 48 <= buf[i] <= 57:
        i -= 1
    if i == n - 2 or i < 4:
        return -1
    p = i - 4
    for k in range(5):
        if buf[p + k] != PROMPT_HEAD[k]:
            return -1
    return p


def prompt_text(n=1):
    return "user:%d>" % n


# -- ranging --------------------------------------------------------------------------
def range_line(src, dst, metres, round_trip_ms, speed):
    # "Range 1 to 2 : 1499.6 m  (Round-trip  1999.5 ms) speed  0.0 m/s"
    return "Range %d to %d : %s m  (Round-trip  %s ms) speed %4s m/s" % (
        src,
        dst,
        fmt1(metres),
        fmt1(round_trip_ms),
        fmt1(speed),
    )


def _float(tok):
    try:
        return float(tok)
    except ValueError:
        return None


def parse_range(s):
    # -> (src, dst, metres, round_trip_ms, speed or None), or None. Spaces
    # are not counted: the widths in the reference are one example.
    if not s.startswith("Range"):
        return None
    col = s.find(":")
    if col < 0:
        return None
    ends = s[5:col].split()
    if len(ends) != 3 or ends[1] != "to":
        return None
    src = number(ends[0])
    dst = number(ends[2])
    rest = s[col + 1 :].split()
    if src is None or dst is None or len(rest) < 2 or rest[1] != "m":
        return None
    metres = _float(rest[0])
    rt = None
    speed = None
    for i in range(2, len(rest) - 1):
        if rest[i] == "(Round-trip":
            rt = _float(rest[i + 1])
        elif rest[i] == "speed":
            speed = _float(rest[i + 1])
    if metres is None or rt is None:
        return None
    return src, dst, metres, rt, speed


# -- hex payloads ---------------------------------------------------------------------------
def hex_text(data):
    # uppercase hex, as in the reference's DATA line
    out = []
    for b in data:
        out.append(_HEX[b >> 4])
        out.append(_HEX[b & 15])
    return "".join(out)


def _nibble(c):
    if 48 <= c <= 57:
        return c - 48
    c |= 0x20  # either case: goby's own log shows lowercase
    if 97 <= c <= 102:
        return c - 87
    return -1


def hex_into(buf, off, s):
    # Decodes the hex digits of str s (spaces allowed) into buf from off.
    # Returns the new offset, or -1 for a bad digit, an odd count or more
    # bytes than buf holds.
    hi = -1
    n = off
    cap = len(buf)
    for ch in s:
        c = ord(ch)
        if c == 32:
            continue
        v = _nibble(c)
        if v < 0:
            return -1
        if hi < 0:
            hi = v
            continue
        if n >= cap:
            return -1
        buf[n] = (hi << 4) | v
        n += 1
        hi = -1
    return n if hi < 0 else -1


def is_hex(s):
    got = False
    for ch in s:
        if ch != " ":
            if _nibble(ord(ch)) < 0:
                return False
            got = True
    return got


# -- reading the modem: lines, the prompt, a received packet's block ---------
# LineReader: the modem ends lines with CR LF; CR, LF and LF CR are taken
# too (empty lines are skipped). The shell prompt `user:N>` has no line
# ending, so it is recognised as soon as its '>' arrives, even after noise
# on the same line (the noise is handed on first, as a line of its own).
# The buffer is preallocated; a line longer than it is dropped up to its
# end and counted.
#
# RxBlock (ref/modem-protocols.md 4.3, with @Verbose=3 and @PrintHex=Ena):
#     DATA(0005):68656C6C6F          count in decimal; more hex lines follow
#     Source:001  Destination:002    while fewer bytes than the count came
#     CRC:Pass MPD:03.2 SNR:31.3 AGC:91 SPD:+00.0 CCERR:013
#     <EOP>
# The payload goes to a preallocated buffer; a block that is larger, damaged
# or never ends (the next DATA line, a prompt, or max_lines other lines
# arrive first) is dropped and counted. Lines that are not part of a block
# are left to the caller, so a reply that comes in the middle is not lost.

_B_IDLE = const(0)
_B_HEX = const(1)  # hex lines until the count is reached
_B_TAIL = const(2)  # Source, CRC, <EOP>
_B_SKIP = const(3)  # a block being dropped: its lines are eaten up to <EOP>


class LineReader:
    def __init__(self, cap, sink):
        self.buf = bytearray(cap)
        self.sink = sink  # on_line(bytes, is_prompt), on_junk(kind)
        self.n = 0
        self.over = False

    def reset(self):
        self.n = 0
        self.over = False

    def feed(self, data):
        buf = self.buf
        cap = len(buf)
        sink = self.sink
        n = self.n
        for c in data:
            if c == 13 or c == 10:
                if self.over:
                    self.over = False
                    sink.on_junk("overlong")
                elif n:
                    self.n = 0
                    sink.on_line(bytes(buf[:n]), False)
                n = 0
                continue
            if self.over:
                continue
            if n >= cap:
                self.over = True
                n = 0
                continue
            buf[n] = c
            n += 1
            if c == 62:  # '>'
                p = prompt_at(buf, n)
                if p >= 0:
                    self.n = 0
                    if p:
                        sink.on_line(bytes(buf[:p]), False)
                    sink.on_line(bytes(buf[p:n]), True)
                    n = 0
        self.n = n


def parse_ends(s):
    # "Source:001  Destination:002" -> (1, 2), or None
    src = dst = None
    for tok in s.split():
        if tok.startswith("Source:"):
            src = number(tok[7:])
        elif tok.startswith("Destination:"):
            dst = number(tok[12:])
    if src is None or dst is None:
        return None
    return src, dst


def parse_stats(s):
    # "CRC:Pass MPD:03.2 ..." -> (crc passed?, {"mpd": 3.2, ...})
    ok = False
    stats = {}
    for tok in s.split():
        i = tok.find(":")
        if i <= 0:
            continue
        key = tok[:i]
        val = tok[i + 1 :]
        if key == "CRC":
            ok = val == "Pass"
        else:
            try:
                stats[key.lower()] = float(val)
            except ValueError:
                pass
    return ok, stats


class RxBlock:
    def __init__(self, cap, sink, max_lines=8):
        self.data = bytearray(cap)
        self.sink = sink  # on_block(src, dst, data, stats), on_junk(kind)
        self.max_lines = max_lines
        self.received = 0
        self.crc_fail = 0
        self.reset()

    def reset(self):
        self.state = _B_IDLE
        self.count = 0
        self.got = 0
        self.ends = None
        self.crc = None
        self.stats = None
        self.other = 0

    def _drop(self, kind, skip):
        self.sink.on_junk(kind)
        self.reset()
        if skip:
            self.state = _B_SKIP

    def prompt(self):
        # the modem is back at its shell: any open block is over
        if self.state == _B_HEX or self.state == _B_TAIL:
            self._drop("unterminated block", False)
        self.reset()

    def line(self, s):
        # True when s belonged to a block (consumed).
        st = self.state
        if s.startswith("DATA("):
            if st == _B_HEX or st == _B_TAIL:
                self._drop("unterminated block", False)
            self._start(s)
            return True
        if st == _B_IDLE:
            return False
        tail = s == EOP or s.startswith("Source:") or s.startswith("CRC:")
        if st == _B_HEX:
            if is_hex(s):
                n = hex_into(self.data, self.got, s)
                if n < 0 or n > self.count:
                    self._drop("bad hex in block", True)
                else:
                    self.got = n
                    if n == self.count:
                        self.state = _B_TAIL
                return True
            self._drop("short block", tail)
            if s == EOP:
                self.reset()
            return tail
        if st == _B_SKIP:
            if s == EOP:
                self.reset()
                return True
            if tail or is_hex(s):
                return True
            return self._other()
        # _B_TAIL
        if s == EOP:
            self._finish()
            return True
        if s.startswith("Source:"):
            self.ends = parse_ends(s)
            if self.ends is None:
                self.sink.on_junk("bad Source line")
            return True
        if s.startswith("CRC:"):
            self.crc, self.stats = parse_stats(s)
            return True
        return self._other()

    def _other(self):
        # a line from elsewhere in the middle of a block: not ours, but a
        # block cannot stay open for ever
        self.other += 1
        if self.other > self.max_lines:
            if self.state == _B_SKIP:
                self.reset()
            else:
                self._drop("unterminated block", False)
        return False

    def _start(self, s):
        self.reset()
        close = s.find(")")
        count = number(s[5:close]) if close > 5 else None
        if count is None or s[close + 1 : close + 2] != ":":
            self._drop("bad DATA line", True)
            return
        if count > len(self.data):
            self._drop("block larger than the buffer", True)
            return
        self.count = count
        n = hex_into(self.data, 0, s[close + 2 :])
        if n < 0 or n > count:
            self._drop("bad hex in block", True)
            return
        self.got = n
        self.state = _B_TAIL if n == count else _B_HEX

    def _finish(self):
        ends = self.ends
        crc = self.crc
        stats = self.stats
        n = self.count
        self.reset()
        if crc is None or ends is None:
            self.sink.on_junk("incomplete block")
            return
        if not crc:
            self.crc_fail += 1
            return
        self.received += 1
        self.sink.on_block(ends[0], ends[1], bytes(self.data[:n]), stats)
