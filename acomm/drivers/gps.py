# The time from a GPS receiver's NMEA 0183 output on a board UART (a `gps`
# entry in the board config): sans-IO, bytes in, time fixes out, for the
# node's wall clock (acomm.wallclock). Nothing is ever written to the
# receiver.
#
# Sentences read, any talker (GP, GN, GL, GA, BD ...):
#   $--RMC,hhmmss.ss,A|V,lat,N,lon,E,knots,course,ddmmyy,...*hh
#   $--ZDA,hhmmss.ss,dd,mm,yyyy,zh,zm*hh          (time and date in UTC)
# Each must end in its checksum (*hh: the XOR of the bytes between $ and *,
# in hex). A fix is an event (EV_TIME, "gps", secs, ms, UNC_MS, now): secs
# from 2020-01-01 UTC, taken as the time at which its line ended. No
# source: an RMC with status V (no fix: the receiver's own clock), a ZDA
# while the last RMC said V or with an empty field, a bad or missing
# checksum, a malformed field. Everything else (GGA, GSV, binary
# protocols, noise) is skipped up to the next "$" without being copied.
# A line longer than line_max (NMEA's limit is 82 characters) is dropped.
#
# UNC_MS: the sentences give the second (their hundredths are .00 on most
# receivers) and come out up to several hundred ms after it, behind the
# other sentences of the epoch: 1 s covers both.

from ..compat import const
from ..errors import DecodeError
from ..civil import days2020

_EV_TIME = const(9)  # acomm.events
UNC_MS = const(1000)
_LINE_MAX = const(82)


class GpsReader:
    """NMEA 0183 bytes in (feed), time fixes out (take_times: EV_TIME tuples); bounded line buffer."""

    def __init__(self, line_max=_LINE_MAX):
        self._buf = bytearray(line_max)
        self._n = -1  # -1: outside a sentence (skipping to the next "$")
        self._void = False  # the last RMC said V: its ZDA is the receiver's own clock too
        self._events = []
        self.stats = {"fixes": 0, "void": 0, "bad_checksum": 0, "malformed": 0, "too_long": 0}

    def feed(self, now, data):
        """Takes the receiver's bytes; fixes wait in take_times()."""
        buf = self._buf
        cap = len(buf)
        n = self._n
        i = 0
        end = len(data)
        while i < end:
            if n < 0:
                i = data.find(b"$", i)
                if i < 0:
                    break
                n = 0
                i += 1
                continue
            b = data[i]
            i += 1
            if b == 13 or b == 10:
                self._line(now, n)
                n = -1
            elif b == 36:  # "$": the last sentence was cut; this one starts
                n = 0
            elif n >= cap:
                self.stats["too_long"] += 1
                n = -1
            else:
                buf[n] = b
                n += 1
                if n == 5 and buf[2:5] != b"RMC" and buf[2:5] != b"ZDA":
                    n = -1  # not a time sentence: skip it whole
        self._n = n

    def take_times(self):
        """The fixes since the last call: (EV_TIME, "gps", secs, ms, UNC_MS, at) tuples."""
        ev = self._events
        self._events = []
        return ev

    def _line(self, now, n):
        if n < 6:
            return
        try:
            fix = parse(self._buf, n)
        except DecodeError as e:
            self.stats["bad_checksum" if e.args and e.args[0] == "checksum" else "malformed"] += 1
            return
        if fix is None:
            return
        if fix[0] == 0:  # an RMC: its status says whether a ZDA may be believed
            self._void = fix[1] is None
        elif self._void:
            fix = (1, None)
        if fix[1] is None:
            self.stats["void"] += 1
            return
        self.stats["fixes"] += 1
        self._events.append((_EV_TIME, "gps", fix[1], fix[2], UNC_MS, now))


def parse(buf, n):
    """One sentence without its "$" (buf[:n]) -> (0 for RMC / 1 for ZDA, secs or None, ms), or None
    for another sentence. secs None: no fix (RMC status V, empty ZDA fields). DecodeError: bad."""
    star = n - 3
    if star < 1 or buf[star] != 42:  # "*"
        raise DecodeError("checksum")
    x = 0
    for i in range(star):
        x ^= buf[i]
    try:
        if int(bytes(buf[star + 1:n]), 16) != x:
            raise DecodeError("checksum")
        f = bytes(buf[:star]).split(b",")
        kind = f[0][2:]
        if kind == b"RMC":
            if len(f) < 10:
                raise DecodeError("RMC: %d fields" % len(f))
            if f[2] != b"A" or not f[1] or not f[9]:
                return (0, None, 0)
            d = f[9]
            y = int(d[4:6])
            return _time(0, f[1], 2000 + y if y < 80 else 1900 + y, int(d[2:4]), int(d[0:2]))
        if kind == b"ZDA":
            if len(f) < 5:
                raise DecodeError("ZDA: %d fields" % len(f))
            if not f[1] or not f[2] or not f[3] or not f[4]:
                return (1, None, 0)
            return _time(1, f[1], int(f[4]), int(f[3]), int(f[2]))
    except (ValueError, IndexError):
        raise DecodeError("bad NMEA field")
    return None


def _time(kind, hms, y, mo, d):
    # "hhmmss[.ss]" on y-mo-d -> (kind, secs from 2020-01-01, ms)
    if len(hms) < 6 or not 1 <= mo <= 12 or not 1 <= d <= 31:
        raise DecodeError("bad NMEA date or time")
    h = int(hms[0:2])
    m = int(hms[2:4])
    s = int(hms[4:6])
    if h > 23 or m > 59 or s > 60:
        raise DecodeError("bad NMEA time")
    frac = hms[7:10] if len(hms) > 7 else b""
    ms = int(frac + b"000"[len(frac):]) if frac else 0
    return (kind, days2020(y, mo, d) * 86400 + h * 3600 + m * 60 + s, ms)
