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
