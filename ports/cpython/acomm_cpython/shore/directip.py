# Iridium SBD DirectIP, the gateway's TCP protocol to a customer's server:
# a sans-IO codec (bytes in, one message or one refusal out; encoders for
# every message a gateway or a shore writes). docs/drivers-iridium.md has
# the conformance table with each field's source.
#
# One message per TCP connection, in both directions:
#   protocol revision (1 byte, = 1) | overall length (2 bytes, big-endian:
#   the bytes that follow) | information elements, each
#   IEI (1 byte) | IE length (2 bytes, big-endian) | IE content
# MO (gateway -> shore): MO header 0x01 (28 bytes: CDR reference u32, IMEI
# 15 ASCII digits, session status u8, MOMSN u16, MTMSN u16, time of session
# u32 epoch seconds), MO location 0x03 (11 bytes), MO payload 0x02; the
# shore may answer with an MO confirmation 0x05 (1 byte: 1 taken, 0 not).
# MT (shore -> gateway): MT header 0x41 (21 bytes: unique client message id
# u32, IMEI, disposition flags u16), MT payload 0x42, MT priority 0x46 (2
# bytes); the gateway answers with an MT confirmation 0x44 (25 bytes: client
# id, IMEI, auto id reference u32, status i16: 1..50 the queue position, 0
# no payload, negative an error, MT_ERRORS).

import struct

PROTOCOL_REVISION = 1
MO_HEADER, MO_PAYLOAD, MO_LOCATION, MO_CONFIRMATION = 0x01, 0x02, 0x03, 0x05
MT_HEADER, MT_PAYLOAD, MT_CONFIRMATION, MT_PRIORITY = 0x41, 0x42, 0x44, 0x46
MO_MAX, MT_MAX = 1960, 1890  # the largest payloads DirectIP carries (9522B and the like)

# the fixed lengths of the IEs that have one
_FIXED = {MO_HEADER: 28, MO_LOCATION: 11, MO_CONFIRMATION: 1, MT_HEADER: 21, MT_CONFIRMATION: 25, MT_PRIORITY: 2}
_PAYLOADS = {MO_PAYLOAD: MO_MAX, MT_PAYLOAD: MT_MAX}
MO_IES = (MO_HEADER, MO_PAYLOAD, MO_LOCATION)
MT_IES = (MT_HEADER, MT_PAYLOAD, MT_PRIORITY)

# MT disposition flags
FLUSH_MT_QUEUE, SEND_RING_ALERT = 0x0001, 0x0002

# MT confirmation statuses below 1 (0 is "no payload": a flush or ring alert only)
MT_ERRORS = {
    -1: "invalid IMEI (too few characters, non-numeric)",
    -2: "unknown IMEI (not provisioned)",
    -3: "payload size exceeded the maximum",
    -4: "payload expected, but none received",
    -5: "MT message queue full (max of 50)",
    -6: "MT resources unavailable",
    -7: "violation of the MT DirectIP protocol",
    -8: "ring alerts to the given IMEI are disabled",
    -9: "the IMEI is not attached (not set up to receive MT)",
    -10: "source IP address rejected by the MT filter",
    -11: "MTMSN value out of range",
}


class DirectIpError(ValueError):
    """A message refused; .reason is the counter's name (e.g. "wrong IE length")."""

    def __init__(self, reason, detail=""):
        ValueError.__init__(self, reason + (": " + detail if detail else ""))
        self.reason = reason


def _ie(iei, content):
    return struct.pack(">BH", iei, len(content)) + content


def _message(ies):
    body = b"".join(ies)
    return struct.pack(">BH", PROTOCOL_REVISION, len(body)) + body


def _imei(imei):
    b = imei.encode("ascii") if isinstance(imei, str) else bytes(imei)
    if len(b) != 15:
        raise ValueError("an IMEI is 15 characters")
    return b


def encode_mo(cdr, imei, status, momsn, mtmsn, time_s, payload, location=None):
    """An MO message as the gateway sends it. location: (lat, lon, cep_km) in degrees, or None."""
    ies = [_ie(MO_HEADER, struct.pack(">I15sBHHI", cdr, _imei(imei), status, momsn, mtmsn, time_s))]
    if location is not None:
        ies.append(_ie(MO_LOCATION, encode_location(*location)))
    ies.append(_ie(MO_PAYLOAD, bytes(payload)))
    return _message(ies)


def encode_location(lat, lon, cep_km):
    """The MO location IE's 11 bytes: format 0, N/S and E/W bits, degrees and thousandths of a minute."""
    flags = (2 if lat < 0 else 0) | (1 if lon < 0 else 0)
    parts = []
    for v in (abs(lat), abs(lon)):
        deg = int(v)
        parts.append((deg, min(59999, int(round((v - deg) * 60000)))))
    return struct.pack(">BBHBHI", flags, parts[0][0], parts[0][1], parts[1][0], parts[1][1], int(cep_km))


def decode_location(b):
    """The 11 bytes of an MO location IE -> (lat, lon, cep_km)."""
    flags, la, lam, lo, lom, cep = struct.unpack(">BBHBHI", b)
    if (flags >> 2) & 3 != 0 or la > 90 or lo > 180 or lam > 59999 or lom > 59999:
        raise DirectIpError("bad location")
    lat = (la + lam / 60000.0) * (-1 if flags & 2 else 1)
    lon = (lo + lom / 60000.0) * (-1 if flags & 1 else 1)
    return lat, lon, cep


def encode_mo_confirmation(taken):
    """The shore's answer to an MO message: 1 taken, 0 not."""
    return _message([_ie(MO_CONFIRMATION, bytes([1 if taken else 0]))])


def encode_mt(client_id, imei, payload, flags=0, priority=None):
    """An MT message as a shore sends it (payload None: none, e.g. a flush or a ring alert alone)."""
    ies = [_ie(MT_HEADER, struct.pack(">I15sH", client_id, _imei(imei), flags))]
    if payload is not None:
        ies.append(_ie(MT_PAYLOAD, bytes(payload)))
    if priority is not None:
        ies.append(_ie(MT_PRIORITY, struct.pack(">H", priority)))
    return _message(ies)


def encode_mt_confirmation(client_id, imei, auto_id, status):
    """The gateway's answer to an MT message (status: queue position 1..50, 0, or an MT_ERRORS code)."""
    imei_b = imei.encode("ascii") if isinstance(imei, str) else bytes(imei)
    imei_b = (imei_b + b" " * 15)[:15]  # the gateway echoes what it got, even a bad IMEI
    return _message([_ie(MT_CONFIRMATION, struct.pack(">I15sIh", client_id, imei_b, auto_id, status))])


class Reader:
    """One DirectIP message from a byte stream, split anywhere.

    feed(data) -> None while the message is incomplete, else a dict IEI ->
    content (bytes); raises DirectIpError(reason) for a message to refuse.
    allowed: the IEIs this side takes (MO_IES, MT_IES, (MO_CONFIRMATION,),
    (MT_CONFIRMATION,)); max_len: the largest overall length taken (memory
    is bounded by it). eof() -> the reason to give when the peer closed
    before the end ("truncated"), or None."""

    def __init__(self, allowed, max_len=MO_MAX + 64):
        self.allowed = allowed
        self.max_len = max_len
        self.buf = bytearray()
        self.done = False

    def feed(self, data):
        if self.done:
            if data:
                raise DirectIpError("trailing bytes")
            return None
        self.buf += data
        if len(self.buf) >= 1 and self.buf[0] != PROTOCOL_REVISION:
            raise DirectIpError("bad protocol revision", str(self.buf[0]))
        if len(self.buf) < 3:
            return None
        n = struct.unpack_from(">H", self.buf, 1)[0]
        if n > self.max_len:
            raise DirectIpError("too long", "%d bytes" % n)
        if len(self.buf) < 3 + n:
            return None
        if len(self.buf) > 3 + n:
            raise DirectIpError("trailing bytes")
        self.done = True
        return parse_ies(bytes(self.buf[3:]), self.allowed)

    def eof(self):
        return None if self.done else "truncated"


def parse_ies(body, allowed):
    """The IEs of a message body -> dict IEI -> content; DirectIpError for a wrong one."""
    ies = {}
    i = 0
    while i < len(body):
        if len(body) - i < 3:
            raise DirectIpError("truncated IE")
        iei, n = struct.unpack_from(">BH", body, i)
        i += 3
        if n > len(body) - i:
            raise DirectIpError("truncated IE", "IE 0x%02x says %d bytes" % (iei, n))
        if iei not in allowed:
            raise DirectIpError("unknown IE", "0x%02x" % iei)
        if iei in ies:
            raise DirectIpError("duplicate IE", "0x%02x" % iei)
        fixed = _FIXED.get(iei)
        if (fixed is not None and n != fixed) or (iei in _PAYLOADS and not 1 <= n <= _PAYLOADS[iei]):
            raise DirectIpError("wrong IE length", "IE 0x%02x of %d bytes" % (iei, n))
        ies[iei] = body[i:i + n]
        i += n
    return ies


def _check_imei(b):
    if not b.isdigit():
        raise DirectIpError("bad IMEI")
    return b.decode("ascii")


def decode_mo(ies):
    """The IEs of an MO message -> dict cdr, imei, status, momsn, mtmsn, time_s, payload, location."""
    if MO_HEADER not in ies:
        raise DirectIpError("no MO header")
    if MO_PAYLOAD not in ies:
        raise DirectIpError("no MO payload")
    cdr, imei, status, momsn, mtmsn, t = struct.unpack(">I15sBHHI", ies[MO_HEADER])
    loc = decode_location(ies[MO_LOCATION]) if MO_LOCATION in ies else None
    return {"cdr": cdr, "imei": _check_imei(imei), "status": status, "momsn": momsn, "mtmsn": mtmsn, "time_s": t,
            "payload": ies[MO_PAYLOAD], "location": loc}


def decode_mt(ies):
    """The IEs of an MT message -> dict client_id, imei (raw bytes), flags, payload or None, priority."""
    if MT_HEADER not in ies:
        raise DirectIpError("no MT header")
    cid, imei, flags = struct.unpack(">I15sH", ies[MT_HEADER])
    prio = struct.unpack(">H", ies[MT_PRIORITY])[0] if MT_PRIORITY in ies else None
    return {"client_id": cid, "imei": imei, "flags": flags, "payload": ies.get(MT_PAYLOAD), "priority": prio}


def decode_mt_confirmation(ies):
    """The IEs of an MT confirmation -> (client_id, imei, auto_id, status)."""
    if MT_CONFIRMATION not in ies:
        raise DirectIpError("no MT confirmation")
    cid, imei, auto_id, status = struct.unpack(">I15sIh", ies[MT_CONFIRMATION])
    return cid, imei.decode("ascii", "replace"), auto_id, status
