# The EvoLogics S2C AT interface on the wire, as both ends see it: lines of
# text ended by CR, LF or CR LF, except that a few lines carry a raw binary
# payload whose end is given by a declared length, not by the terminator
# (the payload may itself contain CR LF). Shared by the driver
# (acomm.drivers.evologics) and the emulator (ports/sim), so both cut the
# stream the same way.
#
# Lines with a payload, and the number of commas before the payload (one
# more when the first field is a packet id "p<pid>"):
#   host -> modem  AT*SENDIM,<len>,<dst>,<flag>,<data>          4
#                  AT*SENDIMS,<len>,<dst>,<usec>,<data>         4
#                  AT*SENDPBM,<len>,<dst>,<data>                3
#                  AT*SEND,<len>,<dst>,<data>                   3
#   modem -> host  RECVIM,<len>,<src>,<dst>,<flag>,<dur>,<rssi>,<int>,<vel>,<data>          9
#                  (firmware 1.6: ...,<flag>,<bitrate>,<rssi>,<int>,<ptime>,<vel>,<data>) 10
#                  RECVIMS,<len>,<src>,<dst>,<ts>,<dur>,<rssi>,<int>,<vel>,<data>          9
#                  RECVPBM,<len>,<src>,<dst>,<dur>,<rssi>,<int>,<vel>,<data>               8
#                  RECV,<len>,<src>,<dst>,<bitrate>,<rssi>,<int>,<ptime>,<vel>,<data>      9
# The length is always the first field after the keyword (and pid).

from ..compat import const

CMD_SPECS = {b"AT*SENDIM": 4, b"AT*SENDIMS": 4, b"AT*SENDPBM": 3, b"AT*SEND": 3}
RX_SPECS = {b"RECVIM": 9, b"RECVIMS": 9, b"RECVPBM": 8, b"RECV": 9}
RX_SPECS_16 = {b"RECVIM": 10, b"RECVIMS": 9, b"RECVPBM": 8, b"RECV": 9}

IM_MAX = const(64)  # instant message payload limit (DUNE, oceansystemslab)
BURST_MAX = const(1024)  # burst cap of the oceansystemslab driver (unconfirmed)

MAX_COMMAS = const(24)  # USBLLONG has 16 fields; more commas are not indexed
HEADER_MAX = const(160)  # longest text line / payload header kept

# Kinds of damaged input reported to sink.on_junk(kind).
JUNK_OVERLONG = const(1)  # a text line or header longer than HEADER_MAX
JUNK_LENGTH = const(2)  # no terminator where the declared length ends
JUNK_BAD_LEN = const(3)  # a payload length that is not a number or too big
JUNK_CUT = const(4)  # the line stopped (silence) before it was complete

# notifications: keywords that are never a reply
NOTES = (
    b"RECVSTART",
    b"RECVEND",
    b"RECVFAILED",
    b"RECVSRV",
    b"BITRATE",
    b"SRCLEVEL",
    b"PHYON",
    b"PHYOFF",
    b"STATUS",
    b"RADDR",
    b"DROPCNT",
    b"ECLK",
    b"RTO",
    b"USBLPHYD",
    b"USBLPHYP",
    b"EXPIREDIMS",
    b"CANCELEDIMS",
    b"CANCELEDPBM",
    b"SENDSTART",
)
# receptions (the driver turns them into EV_RX events)
RECV = (b"RECVIM", b"RECV", b"RECVIMS", b"RECVPBM")
# the fields of the USBL fixes (units as the modem gives them, unconfirmed)
USBL_LONG = ("ctime", "mtime", "addr", "x", "y", "z", "east", "north", "up", "roll", "pitch", "yaw", "ptime", "rssi",
             "integrity", "accuracy")
USBL_ANGLES = ("ctime", "mtime", "addr", "lbearing", "lelevation", "bearing", "elevation", "roll", "pitch", "yaw",
               "rssi", "integrity", "accuracy")


class LineReader:
    # Cuts bytes into lines and hands each to sink.on_line(reader); the
    # reader's fields describe the line until the call returns:
    #   buf, n         the line without its terminator (buf[:n])
    #   commas, nc     offsets of the first MAX_COMMAS commas (nc counted in
    #                  full, up to the payload)
    #   data_at, dlen  the payload of a binary line (data_at -1 otherwise)
    # One preallocated buffer; a line that cannot fit is dropped and
    # counted. After damage the reader resynchronises at the next
    # terminator, re-reading payload bytes that turn out to hold one.
    def __init__(self, sink, specs, max_data=BURST_MAX):
        self._sink = sink
        self.specs = specs
        self.max_data = max_data
        self.buf = bytearray(HEADER_MAX + max_data + 2)
        self.commas = [0] * MAX_COMMAS
        self.n = 0
        self.nc = 0
        self.data_at = -1
        self.dlen = 0
        self._want = 0  # commas before the payload; 0 for a text line
        self._need = -1  # payload bytes still to read; -1 in the header
        self._skip = False  # dropping everything up to the next terminator
        self.lines = 0
        self.junk = {}

    def reset(self):
        self.n = 0
        self.nc = 0
        self.data_at = -1
        self._want = 0
        self._need = -1
        self._skip = False

    def partial(self):
        # True in the middle of a line (for the owner's silence timer)
        return self.n > 0 or self._need >= 0 or self._skip

    def _junk(self, kind):
        self.junk[kind] = self.junk.get(kind, 0) + 1
        self._sink.on_junk(kind)

    def flush(self):
        # The sender went quiet in the middle of a line: drop it. Returns
        # nothing; bytes of a cut payload after a terminator are re-read.
        if self._need >= 0:
            self._junk(JUNK_CUT)
            rest = self._resync(b"", False)
            if rest:
                self.feed(rest)
        elif self.n or self._skip:
            if self.n:
                self._junk(JUNK_CUT)
            self.reset()

    def feed(self, data):
        buf = self.buf
        cap = HEADER_MAX
        i = 0
        end = len(data)
        while i < end:
            need = self._need
            if need > 0:
                # payload bytes in bulk
                k = end - i
                if k > need:
                    k = need
                n = self.n
                buf[n : n + k] = memoryview(data)[i : i + k]
                self.n = n + k
                self._need = need - k
                i += k
                continue
            b = data[i]
            i += 1
            if need == 0:
                # the declared length is used up: a terminator must follow
                if b == 13 or b == 10:
                    self._deliver()
                    continue
                self._junk(JUNK_LENGTH)
                rest = self._resync(bytes((b,)), True)
                if rest:
                    data = rest + bytes(memoryview(data)[i:])
                    i = 0
                    end = len(data)
                continue
            if b == 13 or b == 10:
                if self._skip:
                    self._skip = False
                    self.n = 0
                    self.nc = 0
                elif self.n:
                    self._deliver()
                continue
            if self._skip:
                continue
            n = self.n
            if n >= cap:
                self._junk(JUNK_OVERLONG)
                self._drop()
                continue
            buf[n] = b
            self.n = n + 1
            if b == 44:  # ','
                self._comma(n)

    def _comma(self, at):
        nc = self.nc
        if nc < MAX_COMMAS:
            self.commas[nc] = at
        nc += 1
        self.nc = nc
        if nc == 1:
            want = self.specs.get(bytes(memoryview(self.buf)[:at]))
            self._want = want if want is not None else 0
        elif nc == 2 and self._want and self.buf[self.commas[0] + 1] == 112:  # 'p': a packet id
            self._want += 1
        if self._want and nc == self._want:
            li = 1 if self.buf[self.commas[0] + 1] == 112 else 0
            ln = self.int_field(1 + li)
            if ln is None or not 0 <= ln <= self.max_data:
                self._junk(JUNK_BAD_LEN)
                self._drop()
                return
            self.data_at = at + 1
            self.dlen = ln
            self._need = ln

    def _drop(self):
        self.reset()
        self._skip = True

    def _deliver(self):
        self.lines += 1
        if self._want and self._need != 0:
            self.data_at = -1  # a binary keyword cut short: a text line
        try:
            self._sink.on_line(self)
        finally:
            self.reset()

    def _resync(self, extra, skip):
        # A payload that did not end where it said: everything after the
        # first terminator inside it (and `extra`) may be the next lines.
        # Without one, drop up to the next terminator (skip) or not at all
        # (after a silence the next byte starts a line).
        buf = self.buf
        start = self.data_at
        stop = self.n
        self.reset()
        for j in range(start, stop):
            c = buf[j]
            if c == 13 or c == 10:
                return bytes(memoryview(buf)[j + 1 : stop]) + extra
        self._skip = skip
        return b""

    # -- field access (for the sink, during on_line) ----------------------------
    def span(self, k):
        # (start, end) of text field k (0 is the keyword), or None; the
        # payload of a binary line is not a field (see data())
        nc = self.nc
        if k > nc or k > MAX_COMMAS or (self.data_at >= 0 and k >= nc):
            return None
        s = 0 if k == 0 else self.commas[k - 1] + 1
        if k < nc:
            if k >= MAX_COMMAS:
                return None
            e = self.commas[k]
        else:
            e = self.n
        return s, e

    def field(self, k):
        sp = self.span(k)
        if sp is None:
            return None
        return bytes(memoryview(self.buf)[sp[0] : sp[1]])

    def int_field(self, k):
        sp = self.span(k)
        if sp is None:
            return None
        return parse_int(self.buf, sp[0], sp[1])

    def float_field(self, k):
        f = self.field(k)
        if not f:
            return None
        for c in f:
            if not (48 <= c <= 57 or c in (43, 45, 46, 101, 69)):  # digits + - . e E
                return None
        try:
            return float(f)
        except ValueError:
            return None

    def is_word(self, word):
        # the line's keyword (field 0) is exactly `word`
        k = len(word)
        e = self.commas[0] if self.nc else self.n
        if e != k:
            return False
        buf = self.buf
        for j in range(k):
            if buf[j] != word[j]:
                return False
        return True

    def starts(self, prefix):
        k = len(prefix)
        if self.n < k:
            return False
        buf = self.buf
        for j in range(k):
            if buf[j] != prefix[j]:
                return False
        return True

    def data(self):
        if self.data_at < 0:
            return None
        return bytes(memoryview(self.buf)[self.data_at : self.data_at + self.dlen])

    def text(self):
        return bytes(memoryview(self.buf)[: self.n])

    def shown(self):
        # the line as a str for messages (repr when it is not text)
        t = self.text()
        try:
            return t.decode()
        except Exception:  # noqa: BLE001 - binary junk in a reply
            return repr(t)


def parse_int(b, s, e):
    # decimal integer in b[s:e] with an optional sign; None if anything else
    if s >= e:
        return None
    neg = False
    c = b[s]
    if c == 45 or c == 43:
        neg = c == 45
        s += 1
        if s >= e:
            return None
    v = 0
    for j in range(s, e):
        c = b[j]
        if c < 48 or c > 57:
            return None
        v = v * 10 + c - 48
        if v > 0x7FFFFFFF:
            return None
    return -v if neg else v
