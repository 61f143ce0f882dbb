# The link frame: acomm's compact header, payload and CRC.
#
# Two forms (bit layouts and examples in docs/wire-format.md):
#
# raw     for links that carry no addressing or integrity of their own (UDP,
#         transparent serial radios). Header of 3 bytes when both addresses fit
#         in 4 bits (networks of up to 16 nodes), 4 to 8 bytes otherwise (ids
#         up to 65534, below), then the payload, then CRC-16/ARC big-endian over everything
#         before it. Length comes from the container (datagram, serial framing).
#
#           byte 0  VV W TTT FF     V version (1), W wide addresses, T type,
#           byte 1  FF SSSSSS       F flags (4 bits split), S sequence (0..63)
#           short:  byte 2 = DDDD SSSS (destination, source)
#           wide:   destination, then source, each a node id on the water
#
#         A node id on the water (addr_bytes / get_addr, here and in every
#         layer above that names a node) is one byte for 0..254, and for
#         256..65534 the byte 0xFF then the id in 2 bytes: 255 is the API's
#         broadcast, never a node, so that byte was free and every encoding
#         of the one-byte ids stays as it was.
#
#         A node never addresses itself, so destination == source on the wire
#         means broadcast; this keeps all 16 short addresses usable by nodes.
#
# elided  for modems that already carry source, destination and a CRC
#         (Seatrac, EvoLogics, Micro-Modem): the link supplies the addresses.
#         One byte: X TTT SSSS (X: a flags byte follows, T type, S sequence
#         0..15); the flags byte, when present, is 0000 FFFF.

from ..compat import const
from ..codec.crc import crc16
from ..errors import CRCError, DecodeError, EncodeError

VERSION = const(1)

# Frame types (3 bits). 7 is free for later use; decoders pass unknown types
# up and the layers above ignore them.
DATA = const(0)
ACK = const(1)
ADVERT = const(2)
RANGE = const(3)
CONTROL = const(4)
SEGMENT = const(5)  # the transport's fragments and selective acknowledgements
REPLY = const(6)  # DATA that a modem sent by itself when interrogated

# Flags (4 bits).
F_ACK_REQ = const(8)
F_FRAG = const(4)
F_COMPRESSED = const(2)
F_AUTH = const(1)

BROADCAST = const(255)  # API value; see the header comment for the encoding
MAX_ADDR = const(65534)  # node ids are 0..254 (one byte on the water) and 256..65534 (255 is BROADCAST)
_SHORT_MAX_ADDR = const(15)
_ESC = const(0xFF)

SEQ_MOD_RAW = const(64)
SEQ_MOD_ELIDED = const(16)

RAW_OVERHEAD_SHORT = const(5)  # 3 header + 2 CRC
RAW_OVERHEAD_WIDE = const(6)  # with two one-byte ids
RAW_OVERHEAD_MAX = const(10)  # with two ids of 256 or more
ELIDED_OVERHEAD = const(1)  # 2 when flags are set

_X_FLAGS = const(0x80)


class Frame:
    # fields: ftype, src, dst, seq, flags, payload, authed
    ctr = 0  # a sealed frame's counter, set by the link that opened it (acomm.frame.auth)

    def __init__(self, ftype, src, dst, seq, payload=b"", flags=0):
        self.authed = False  # set by the link when its tag verified (acomm.frame.auth)
        self.ftype = ftype
        self.src = src
        self.dst = dst
        self.seq = seq
        self.flags = flags
        self.payload = payload

    def __eq__(self, other):
        return (
            isinstance(other, Frame)
            and self.ftype == other.ftype
            and self.src == other.src
            and self.dst == other.dst
            and self.seq == other.seq
            and self.flags == other.flags
            and bytes(self.payload) == bytes(other.payload)
        )

    def __repr__(self):
        return "Frame(type=%d, %d->%d, seq=%d, flags=%d, %d bytes)" % (
            self.ftype,
            self.src,
            self.dst,
            self.seq,
            self.flags,
            len(self.payload),
        )


def _check_common(ftype, seq, flags, seq_mod):
    if not 0 <= ftype <= 7:
        raise EncodeError("frame type %d outside 0..7" % ftype)
    if not 0 <= flags <= 15:
        raise EncodeError("flags %d outside 0..15" % flags)
    if not 0 <= seq < seq_mod:
        raise EncodeError("sequence %d outside 0..%d" % (seq, seq_mod - 1))


def addr_bytes(a):
    """Node id a as it goes on the water: 0..254 in one byte, 256..65534 as
    0xFF and 2 bytes big-endian. The layers that are on every board write
    this inline: importing it cost their modules 112 bytes of heap (i386
    firmware, acomm frozen), slots in their dicts."""
    return bytes((a,)) if a < BROADCAST else bytes((_ESC, a >> 8, a & 0xFF))


def get_addr(data, i, end=-1):
    """-> (node id, index after it) read from data at i, before end (len(data)
    by default). DecodeError when it is cut short, or an escaped id is one a
    single byte writes (so each id has one encoding) or 65535."""
    if end < 0:
        end = len(data)
    if i >= end:
        raise DecodeError("node id missing")
    a = data[i]
    if a != _ESC:
        return a, i + 1
    if i + 3 > end:
        raise DecodeError("node id cut short")
    a = (data[i + 1] << 8) | data[i + 2]
    if a <= BROADCAST or a > MAX_ADDR:
        raise DecodeError("escaped node id %d" % a)
    return a, i + 3


def _wire_dst(src, dst):
    if not 0 <= src <= MAX_ADDR or src == BROADCAST:
        raise EncodeError("source address %d is not a node id" % src)
    if dst == BROADCAST:
        return src
    if not 0 <= dst <= MAX_ADDR:
        raise EncodeError("destination address %d is not a node id" % dst)
    if dst == src:
        raise EncodeError("node %d cannot address itself" % src)
    return dst


def raw_overhead(src, dst):
    """Bytes a raw frame adds to its payload between these two nodes."""
    if src <= _SHORT_MAX_ADDR and (dst <= _SHORT_MAX_ADDR or dst == BROADCAST):
        return RAW_OVERHEAD_SHORT
    # 1 byte for each id below 255, else 3; a broadcast's destination is its source
    return (6 if src < BROADCAST else 8) + (2 if BROADCAST < dst or (dst == BROADCAST and src > BROADCAST) else 0)


def encode_raw_into(buf, ftype, src, dst, seq, payload, flags=0):
    """Writes the raw frame into buf (a bytearray) and returns its length.
    Does not allocate when payload is a bytes-like object."""
    _check_common(ftype, seq, flags, SEQ_MOD_RAW)
    wdst = _wire_dst(src, dst)
    wide = src > _SHORT_MAX_ADDR or wdst > _SHORT_MAX_ADDR
    hlen = (4 + (2 if wdst > BROADCAST else 0) + (2 if src > BROADCAST else 0)) if wide else 3
    n = hlen + len(payload)
    if n + 2 > len(buf):
        raise EncodeError("frame of %d bytes does not fit buffer of %d" % (n + 2, len(buf)))
    buf[0] = (VERSION << 6) | (0x20 if wide else 0) | (ftype << 2) | (flags >> 2)
    buf[1] = ((flags & 3) << 6) | seq
    if wide:
        i = 2
        for a in (wdst, src):
            if a < BROADCAST:
                buf[i] = a
                i += 1
            else:
                buf[i] = _ESC
                buf[i + 1] = a >> 8
                buf[i + 2] = a & 0xFF
                i += 3
    else:
        buf[2] = (wdst << 4) | src
    buf[hlen:n] = payload
    c = crc16(memoryview(buf)[:n])
    buf[n] = c >> 8
    buf[n + 1] = c & 0xFF
    return n + 2


def encode_raw(frame):
    """The raw frame's bytes (see encode_raw_into)."""
    buf = bytearray(len(frame.payload) + RAW_OVERHEAD_MAX)
    n = encode_raw_into(buf, frame.ftype, frame.src, frame.dst, frame.seq, frame.payload, frame.flags)
    return bytes(buf[:n])


def check_raw(data):
    """Validates version, length, addresses and CRC of a raw frame without
    building a Frame; returns the header length. Raises DecodeError / CRCError.
    Allocates nothing: it runs on every frame a board hears."""
    n = len(data)
    if n < RAW_OVERHEAD_SHORT:
        raise DecodeError("raw frame of %d bytes is shorter than the minimum 5" % n)
    b0 = data[0]
    if b0 >> 6 != VERSION:
        raise DecodeError("unsupported frame version %d" % (b0 >> 6))
    if b0 & 0x20 and n < RAW_OVERHEAD_WIDE:
        raise DecodeError("wide raw frame of %d bytes is shorter than the minimum 6" % n)
    want = (data[n - 2] << 8) | data[n - 1]
    got = crc16(memoryview(data)[: n - 2])
    if want != got:
        raise CRCError("frame CRC 0x%04x does not match computed 0x%04x" % (want, got))
    if not b0 & 0x20:
        return 3
    # two node ids (get_addr's rules), ending before the CRC
    i = 2
    for _ in (0, 1):
        if i >= n - 2:
            raise DecodeError("node id missing")
        if data[i] == _ESC:
            a = (data[i + 1] << 8) | data[i + 2] if i + 3 <= n - 2 else 0
            if a <= BROADCAST or a > MAX_ADDR:
                raise DecodeError("escaped node id cut short or %d" % a)
            i += 3
        else:
            i += 1
    if i == 4 and data[2] <= _SHORT_MAX_ADDR and data[3] <= _SHORT_MAX_ADDR:
        # the encoder always uses the short form for these; a wide one is
        # not ours (and would give two encodings for one frame)
        raise DecodeError("wide header for short addresses")
    return i


def _addresses(data, hlen):
    # (source, wire destination) of a raw frame check_raw passed
    if hlen == 3:
        return data[2] & 0x0F, data[2] >> 4
    if hlen == 4:
        return data[3], data[2]
    wdst, i = get_addr(data, 2)
    return get_addr(data, i)[0], wdst


def raw_addresses(data):
    """(source, destination) node ids of a raw frame, destination BROADCAST
    for a broadcast, after check_raw's checks and without copying the
    payload: the IP links route and learn senders by them."""
    src, wdst = _addresses(data, check_raw(data))
    return src, (BROADCAST if wdst == src else wdst)


def decode_raw(data):
    """The Frame in raw bytes. Raises DecodeError / CRCError."""
    hlen = check_raw(data)
    src, wdst = _addresses(data, hlen)
    b0 = data[0]
    b1 = data[1]
    dst = BROADCAST if wdst == src else wdst
    flags = ((b0 & 3) << 2) | (b1 >> 6)
    return Frame((b0 >> 2) & 7, src, dst, b1 & 0x3F, bytes(data[hlen : len(data) - 2]), flags)


def encode_elided_into(buf, ftype, seq, payload, flags=0):
    _check_common(ftype, seq, flags, SEQ_MOD_ELIDED)
    hlen = 2 if flags else 1
    n = hlen + len(payload)
    if n > len(buf):
        raise EncodeError("frame of %d bytes does not fit buffer of %d" % (n, len(buf)))
    buf[0] = (_X_FLAGS if flags else 0) | (ftype << 4) | seq
    if flags:
        buf[1] = flags
    buf[hlen:n] = payload
    return n


def encode_elided(frame):
    # the header's bytes and then the payload's, in one concatenation: no
    # buffer to fill and copy out again (410 -> 190 ns on CPython)
    _check_common(frame.ftype, frame.seq, frame.flags, SEQ_MOD_ELIDED)
    h = (frame.ftype << 4) | frame.seq
    return (bytes((_X_FLAGS | h, frame.flags)) if frame.flags else bytes((h,))) + frame.payload


def decode_elided(data, src, dst):
    # src, dst: the addresses the modem reported with these bytes.
    n = len(data)
    if n < 1:
        raise DecodeError("empty elided frame")
    b0 = data[0]
    hlen = 1
    flags = 0
    if b0 & _X_FLAGS:
        if n < 2:
            raise DecodeError("elided frame announces a flags byte but ends")
        flags = data[1]
        if flags == 0 or flags > 15:
            raise DecodeError("bad flags byte 0x%02x in elided frame" % flags)
        hlen = 2
    return Frame((b0 >> 4) & 7, src, dst, b0 & 0x0F, bytes(data[hlen:]), flags)
