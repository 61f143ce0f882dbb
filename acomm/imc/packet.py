# IMC messages and packets (docs/imc.md). A message is a dict: "abbrev" (the
# IMC name, as in the XML and in DUNE's JSON) plus one key per field. The
# message table (messages.py) drives one generic encoder and decoder, so a
# new message is one line there. Inline messages are a dict or None (id
# 0xFFFF), message lists a list of dicts.
#
# Packets are the 20-byte header + fields + CRC-16/ARC. A packet with an id
# acomm does not know still decodes: its size is in the header, so it comes
# back with msg None and its payload bytes, and can be forwarded unchanged.
# Only an unknown id *inside* a message is an error: nothing gives its size.

from ..compat import const
from ..codec.crc import crc16
from ..errors import CRCError, DecodeError, EncodeError
from . import fp64
from .messages import by_id, by_name
from .wire import (
    FP32,
    FP64,
    HEADER_SIZE,
    I64,
    MAX_PACKET,
    MAX_PAYLOAD,
    MSG,
    MSGLIST,
    NULL_ID,
    OVERHEAD,
    RAW,
    TEXT,
    Reader,
    Writer,
    read_crc,
    read_header,
    sync_order,
)

# Inline messages nest (AcousticMessage in AcousticMessage ...): 2 bytes a
# level would let a 64 KiB packet recurse 32000 deep, past either runtime's
# stack. DUNE's messages nest two or three levels.
MAX_DEPTH = const(8)

_DEFAULTS = {FP32: 0.0, FP64: 0, TEXT: "", RAW: b"", MSG: None, MSGLIST: ()}


def _encode_value(w, code, v, depth):
    if code <= I64:
        w.int(code, v)
    elif code == FP32:
        w.f32(v)
    elif code == FP64:
        w.f64(v)
    elif code == TEXT:
        if not isinstance(v, str):
            raise EncodeError("%r is not a str" % (type(v).__name__,))
        w.raw(v.encode())
    elif code == RAW:
        if isinstance(v, str):
            raise EncodeError("rawdata takes bytes, not str")
        w.raw(v)
    elif code == MSG:
        _encode_inline(w, v, depth + 1)
    else:
        if not isinstance(v, (list, tuple)):
            raise EncodeError("message-list takes a list, not %s" % (type(v).__name__,))
        w.u16(len(v))
        for m in v:
            if m is None:
                raise EncodeError("a message-list holds no null message")
            _encode_inline(w, m, depth + 1)


def _encode_fields(w, mdef, msg, depth):
    if not isinstance(msg, dict):
        raise EncodeError("a message is a dict, not %s" % (type(msg).__name__,))
    if depth > MAX_DEPTH:
        raise EncodeError("messages nested deeper than %d" % MAX_DEPTH)
    found = 1 if "abbrev" in msg else 0
    for name, code in mdef[2]:
        if name in msg:
            v = msg[name]
            found += 1
        else:
            v = _DEFAULTS.get(code, 0)  # IMC's defaults: zero, empty, null
        try:
            _encode_value(w, code, v, depth)
        except EncodeError as e:
            raise EncodeError("%s.%s: %s" % (mdef[1], name, e)) from None
    if found != len(msg):
        # a misspelt field would otherwise go out as its default, unnoticed
        names = [f[0] for f in mdef[2]]
        for k in msg:
            if k != "abbrev" and k not in names:
                raise EncodeError("%s has no field %r" % (mdef[1], k))


def _encode_inline(w, m, depth):
    if m is None:
        w.u16(NULL_ID)
        return
    if not isinstance(m, dict):
        raise EncodeError("a message is a dict, not %s" % (type(m).__name__,))
    mdef = by_name(m.get("abbrev"))
    w.u16(mdef[0])
    _encode_fields(w, mdef, m, depth)


def _decode_value(r, code, depth, exact):
    if code <= I64:
        return r.int(code)
    if code == FP32:
        return r.f32()
    if code == FP64:
        bits = r.f64_bits()
        return fp64.F64(bits) if exact else fp64.to_float(bits)
    if code == TEXT:
        return r.text()
    if code == RAW:
        return r.raw()
    if code == MSG:
        return _decode_inline(r, depth + 1, exact)
    n = r.u16()
    if 2 * n > r.end - r.pos:
        raise DecodeError("message-list of %d in %d bytes" % (n, r.end - r.pos))
    out = []
    for _ in range(n):
        m = _decode_inline(r, depth + 1, exact)
        if m is None:
            raise DecodeError("null message in a message-list")
        out.append(m)
    return out


def _decode_fields(r, mdef, depth, exact):
    out = {"abbrev": mdef[1]}
    for name, code in mdef[2]:
        try:
            out[name] = _decode_value(r, code, depth, exact)
        except DecodeError as e:
            raise DecodeError("%s.%s: %s" % (mdef[1], name, e)) from None
    return out


def _decode_inline(r, depth, exact):
    if depth > MAX_DEPTH:
        raise DecodeError("messages nested deeper than %d" % MAX_DEPTH)
    mgid = r.u16()
    if mgid == NULL_ID:
        return None
    mdef = by_id(mgid)
    if mdef is None:
        raise DecodeError("inline message id %d unknown, its size with it" % mgid)
    return _decode_fields(r, mdef, depth, exact)


def encode_inline(msg, big=False):
    # u16 id + fields, no header: IMC's inline form (None: just 0xFFFF), as
    # DUNE's compact acoustic RAW frames carry messages.
    w = Writer(big)
    _encode_inline(w, msg, 0)
    return bytes(w.out)


def decode_inline(data, big=False, exact=False):
    # The message (or None) that data holds in inline form, all of data.
    r = Reader(memoryview(data), 0, len(data), big)
    m = _decode_inline(r, 0, exact)
    if r.pos != r.end:
        raise DecodeError("%d bytes after the inline message" % (r.end - r.pos))
    return m


class Packet:
    # One IMC packet. msg is the message dict, or None for an id acomm does
    # not know (then payload holds its field bytes). timestamp is a float,
    # or an F64 when decoded with exact=True; any fp64 value encodes. big
    # records the byte order a decoded packet came in.

    def __init__(self, msg=None, src=0xFFFF, dst=0xFFFF, timestamp=0, src_ent=0xFF, dst_ent=0xFF, mgid=None, payload=None):
        self.msg = msg
        self.src = src
        self.src_ent = src_ent
        self.dst = dst
        self.dst_ent = dst_ent
        self.timestamp = timestamp
        self.mgid = mgid
        self.payload = payload
        self.big = False

    def __repr__(self):
        name = self.msg.get("abbrev") if isinstance(self.msg, dict) else self.mgid
        return "<Packet %s %d.%d->%d.%d>" % (name, self.src, self.src_ent, self.dst, self.dst_ent)

    def encode(self, big=False):
        if self.msg is not None:
            return encode(self.msg, self.src, self.dst, self.timestamp, self.src_ent, self.dst_ent, big)
        # an opaque packet: its fields are in the byte order it came in
        if self.mgid is None or self.payload is None:
            raise EncodeError("a packet needs msg, or mgid and payload")
        if bool(big) != self.big:
            raise EncodeError("payload of id %d cannot change byte order" % self.mgid)
        w = Writer(big, HEADER_SIZE)
        w.out += self.payload
        return _finish(w, self.mgid, self.timestamp, self.src, self.src_ent, self.dst, self.dst_ent)


def _finish(w, mgid, timestamp, src, src_ent, dst, dst_ent):
    size = len(w.out) - HEADER_SIZE
    if size > MAX_PAYLOAD:
        raise EncodeError("payload of %d bytes, at most %d" % (size, MAX_PAYLOAD))
    try:
        w.header(mgid, size, fp64.bits_of(timestamp), src, src_ent, dst, dst_ent)
    except EncodeError as e:
        raise EncodeError("header: %s" % e) from None
    w.crc(crc16(w.out))
    return bytes(w.out)


def encode(msg, src=0xFFFF, dst=0xFFFF, timestamp=0, src_ent=0xFF, dst_ent=0xFF, big=False):
    # The packet bytes of message dict msg; little-endian unless big.
    # timestamp: epoch seconds as int, float or F64 (F64.seconds(s, us)).
    if not isinstance(msg, dict):
        raise EncodeError("a message is a dict, not %s" % (type(msg).__name__,))
    mdef = by_name(msg.get("abbrev"))
    w = Writer(big, HEADER_SIZE)
    _encode_fields(w, mdef, msg, 0)
    return _finish(w, mdef[0], timestamp, src, src_ent, dst, dst_ent)


def check_frame(buf, pos, avail):
    # For a candidate packet at buf[pos:pos+avail]: (big, total length) when
    # its header reads; DecodeError for a bad sync or an impossible size;
    # None when fewer than a header's bytes are there.
    if avail < 2:
        return None
    big = sync_order(buf[pos], buf[pos + 1])
    if big is None:
        raise DecodeError("no IMC sync: %02x%02x" % (buf[pos], buf[pos + 1]))
    if avail < HEADER_SIZE:
        return None
    total = OVERHEAD + read_header(buf, pos, big)[1]
    if total > MAX_PACKET:
        raise DecodeError("size %d past the IMC maximum" % (total - OVERHEAD))
    return big, total


def decode_checked(buf, pos, big, exact=False):
    # The Packet at buf[pos:], whose sync, size and CRC are already checked.
    hdr = read_header(buf, pos, big)
    start = pos + HEADER_SIZE
    end = start + hdr[1]
    p = Packet(None, hdr[3], hdr[5], None, hdr[4], hdr[6], hdr[0])
    p.big = big
    p.timestamp = fp64.F64(hdr[2]) if exact else fp64.to_float(hdr[2])
    mdef = by_id(hdr[0])
    if mdef is None:
        p.payload = bytes(buf[start:end])
    else:
        # Bytes past the fields we know are ignored: a newer IMC revision
        # may have appended fields.
        p.msg = _decode_fields(Reader(buf, start, end, big), mdef, 0, exact)
    return p


def decode(data, exact=False):
    # The Packet that data (one whole packet, e.g. a UDP datagram) holds.
    # DecodeError (CRCError for the checksum) for anything else.
    mv = memoryview(data)
    n = len(mv)
    fr = check_frame(mv, 0, n)
    if fr is None:
        raise DecodeError("%d bytes, shorter than an IMC header" % n)
    big, total = fr
    if total != n:
        raise DecodeError("header says %d bytes, packet has %d" % (total, n))
    want = read_crc(mv, n - 2, big)
    got = crc16(mv[: n - 2])
    if got != want:
        raise CRCError("IMC CRC %04x, computed %04x" % (want, got))
    return decode_checked(mv, 0, big, exact)
