# Reading what a Benthos ATM-9xx prints: lines, the prompt, and the block of
# lines that reports a received packet.
#
# LineSplitter: the modem ends lines with CR LF; CR, LF and LF CR are taken
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

from ..compat import const
from . import benthos_wire as w

_IDLE = const(0)
_HEX = const(1)  # hex lines until the count is reached
_TAIL = const(2)  # Source, CRC, <EOP>
_SKIP = const(3)  # a block being dropped: its lines are eaten up to <EOP>


class LineSplitter:
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
                p = w.prompt_at(buf, n)
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
            src = w.number(tok[7:])
        elif tok.startswith("Destination:"):
            dst = w.number(tok[12:])
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
        self.state = _IDLE
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
            self.state = _SKIP

    def prompt(self):
        # the modem is back at its shell: any open block is over
        if self.state == _HEX or self.state == _TAIL:
            self._drop("unterminated block", False)
        self.reset()

    def line(self, s):
        # True when s belonged to a block (consumed).
        st = self.state
        if s.startswith("DATA("):
            if st == _HEX or st == _TAIL:
                self._drop("unterminated block", False)
            self._start(s)
            return True
        if st == _IDLE:
            return False
        tail = s == w.EOP or s.startswith("Source:") or s.startswith("CRC:")
        if st == _HEX:
            if w.is_hex(s):
                n = w.hex_into(self.data, self.got, s)
                if n < 0 or n > self.count:
                    self._drop("bad hex in block", True)
                else:
                    self.got = n
                    if n == self.count:
                        self.state = _TAIL
                return True
            self._drop("short block", tail)
            if s == w.EOP:
                self.reset()
            return tail
        if st == _SKIP:
            if s == w.EOP:
                self.reset()
                return True
            if tail or w.is_hex(s):
                return True
            return self._other()
        # _TAIL
        if s == w.EOP:
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
            if self.state == _SKIP:
                self.reset()
            else:
                self._drop("unterminated block", False)
        return False

    def _start(self, s):
        self.reset()
        close = s.find(")")
        count = w.number(s[5:close]) if close > 5 else None
        if count is None or s[close + 1 : close + 2] != ":":
            self._drop("bad DATA line", True)
            return
        if count > len(self.data):
            self._drop("block larger than the buffer", True)
            return
        self.count = count
        n = w.hex_into(self.data, 0, s[close + 2 :])
        if n < 0 or n > count:
            self._drop("bad hex in block", True)
            return
        self.got = n
        self.state = _TAIL if n == count else _HEX

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
