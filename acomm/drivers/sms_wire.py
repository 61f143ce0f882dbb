# The lines a GSM modem prints about short messages (3GPP TS 27.005, ref
# 6.1-6.3) and how acomm's binary frames travel in text mode.
#
# Text mode sends GSM 7-bit characters, so a frame goes as base64: 4
# characters per 3 bytes, all of them in the GSM default alphabet with the
# same codes as ASCII (A-Z a-z 0-9 + / =). 160 characters carry 120 bytes
# (PDU mode carries 140 as 8-bit data). The network does not add a checksum
# a text-mode receiver could check; a character changed on the way changes
# bytes of the frame (PDU mode: the length fields are checked).

from binascii import a2b_base64, b2a_base64

from ..compat import const
from ..errors import DecodeError
from .atcommand import after, ints

TEXT_MTU = const(120)  # bytes whose base64 fits 160 characters


def encode_text(data):
    return b2a_base64(data).strip()


def decode_text(line):
    if not line or len(line) % 4:
        raise DecodeError("not base64 (%d characters)" % len(line))
    for c in line:
        if not (65 <= c <= 90 or 97 <= c <= 122 or 48 <= c <= 57 or c == 43 or c == 47 or c == 61):
            raise DecodeError("not base64: %r" % (line[:20],))
    try:
        return a2b_base64(line)
    except ValueError:
        raise DecodeError("not base64: %r" % (line[:20],))


def parse_csq(line):
    # b"+CSQ: 17,99" -> rssi (0..31, 99 unknown); raises DecodeError
    t = after(line, b"+CSQ:")
    v = ints(t, 2) if t is not None else None
    if v is None or not (0 <= v[0] <= 31 or v[0] == 99):
        raise DecodeError("not a +CSQ answer: %r" % (line,))
    return v[0]


def parse_index(line, prefix):
    # b'+CMTI: "SM",3' (prefix b"+CMTI:", the last field) or
    # b"+CMGL: 3,1,,24" (prefix b"+CMGL:", the first field) -> 3, or None
    t = after(line, prefix)
    if t is None:
        return None
    fields = t.split(b",")
    f = fields[-1] if prefix == b"+CMTI:" else fields[0]
    v = ints(f, 1)
    return v[0] if v is not None and 0 <= v[0] <= 65535 else None


def parse_mr(line):
    # b"+CMGS: 12" -> 12, or None
    t = after(line, b"+CMGS:")
    v = ints(t, 1) if t is not None else None
    return v[0] if v is not None else None


def quoted(text, k):
    # the k-th double-quoted string of text (bytes), or None
    parts = text.split(b'"')
    i = 2 * k + 1
    return parts[i] if i < len(parts) - 1 else None


def cmgr_pdu_length(line):
    # b"+CMGR: 0,,24" -> 24 (the TPDU length), or None
    t = after(line, b"+CMGR:")
    if t is None:
        return None
    v = ints(t.split(b",")[-1], 1)
    return v[0] if v is not None else None


def cmgr_sender(line):
    # text mode: b'+CMGR: "REC UNREAD","+447700900123",,"24/05/01,..."'
    # -> "+447700900123", or None
    t = after(line, b"+CMGR:")
    q = quoted(t, 1) if t is not None else None
    return q.decode() if q else None


# The modem's clock, AT+CCLK? (3GPP TS 27.007 8.15): +CCLK: "yy/MM/dd,hh:mm:ss±zz",
# local time, zz its offset from UTC in quarter hours (the sign and zone
# may be missing: UTC). A modem whose clock the network never set (NITZ)
# answers its power-up date: 2000/01/01, 2002/01/01, 2004/01/01 or
# 1980/01/06 by make, counting from power-up. There is no standard way to
# ask whether the network set it, so a date before 2024 (acomm.wallclock
# MIN_S) is taken as "never set": parse_cclk gives None.
_CCLK_UNC_MS = const(2000)  # whole seconds, and the network's time itself is only as good as a second or so


def parse_cclk(line):
    """'+CCLK: "yy/MM/dd,hh:mm:ss+zz"' -> (secs from 2020-01-01 UTC, 0), None when the modem's clock
    was never set by the network; DecodeError for anything else."""
    from ..civil import days2020
    from ..wallclock import MIN_S

    if not line.startswith(b"+CCLK:"):
        raise DecodeError("not a +CCLK line")
    v = line[6:].strip().strip(b'"')
    try:
        date, hms = v.split(b",")
        y, mo, d = [int(x) for x in date.strip().split(b"/")]
        hms = hms.strip()
        tz = 0
        for i in range(len(hms)):
            c = hms[i]
            if c == 43 or c == 45:  # "+", "-"
                tz = int(hms[i + 1:]) * (-1 if c == 45 else 1)
                hms = hms[:i]
                break
        h, m, s = [int(x) for x in hms.split(b":")]
    except ValueError:
        raise DecodeError("bad +CCLK time: %r" % (line[:40],))
    if not (1 <= mo <= 12 and 1 <= d <= 31 and h < 24 and m < 60 and s < 61 and -96 <= tz <= 96):
        raise DecodeError("bad +CCLK time: %r" % (line[:40],))
    y += 2000 if y < 70 else 1900 if y < 100 else 0
    secs = days2020(y, mo, d) * 86400 + h * 3600 + m * 60 + s - tz * 900
    return (secs, 0) if secs >= MIN_S else None

