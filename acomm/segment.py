# The transport's bytes on a link: fragments of a packet and selective
# acknowledgements (SACKs). Both travel as link frames of type SEGMENT
# (acomm.frame), never acknowledged by the link: the SACK is the transport's
# own acknowledgement of a whole window of fragments.
#
# Fragment, 2 bytes then payload:
#   byte 0  0 P T G iiii      P poll (answer with a SACK), T lane (two
#   byte 1  iiiiiiii             transfers at a time to one neighbour), G
#                                generation of the lane, i fragment index
#                                (12 bits: 0..4095)
# SACK, 2 bytes then a bitmap (0..MAX_BITMAP bytes):
#   byte 0  1 C T G bbbb      C complete, b base (12 bits): every fragment
#   byte 1  bbbbbbbb             below base has arrived. Bitmap bit j of
#                                byte k: fragment base + 1 + 8k + j arrived.
#   complete: base = the fragment count, and 2 bytes of packet id follow (the
#   sender checks that the receiver completed *its* packet: after a restart
#   of either side a lane's generation can be stale). base = 0 with C means
#   refused (the receiver cannot take the packet), a reason byte follows.
#
# Packet header, at the start of fragment 0's payload (the end-to-end part):
#   flags    R Z 000000        R relay fields follow, Z body compressed
#   pid      2 bytes           the origin's packet id (duplicate suppression)
#   length   1..3 bytes        body length, 7 bits per byte, high bit = more
#   R only:  origin, final destination (node ids), priority (1..16, one
#            byte), lifespan left in seconds (2 bytes, saturating)
# A packet sent straight to its neighbour costs 4 bytes (length < 128) plus
# 2 per fragment; docs/wire-format.md has the examples.

from .compat import const
from .errors import DecodeError, EncodeError

FRAG_HEADER = const(2)
MAX_INDEX = const(4095)
MAX_BITMAP = const(8)  # 64 fragments after the base per SACK
MAX_LENGTH = const((1 << 21) - 1)
MAX_LIFE_S = const(65535)

_K_SACK = const(0x80)
_P = const(0x40)
_C = const(0x40)
_T = const(0x20)
_G = const(0x10)

F_RELAY = const(0x80)
F_COMPRESSED = const(0x40)

# refusal reasons (SACK with C and base 0)
REFUSE_TOO_BIG = const(1)
REFUSE_FULL = const(2)
REFUSE_NO_ROUTE = const(3)
REFUSE_NAMES = {REFUSE_TOO_BIG: "too big for the receiver", REFUSE_FULL: "receiver full",
                REFUSE_NO_ROUTE: "no route at the relay"}


def frag_header(poll, lane, gen, index):
    if not 0 <= index <= MAX_INDEX:
        raise EncodeError("fragment index %d outside 0..%d" % (index, MAX_INDEX))
    return bytes(((_P if poll else 0) | (_T if lane else 0) | (_G if gen else 0) | (index >> 8), index & 0xFF))


def sack(lane, gen, base, bitmap=b""):
    if len(bitmap) > MAX_BITMAP:
        raise EncodeError("SACK bitmap of %d bytes, at most %d" % (len(bitmap), MAX_BITMAP))
    return bytes((_K_SACK | (_T if lane else 0) | (_G if gen else 0) | (base >> 8), base & 0xFF)) + bytes(bitmap)


def sack_complete(lane, gen, count, pid):
    return bytes((_K_SACK | _C | (_T if lane else 0) | (_G if gen else 0) | (count >> 8), count & 0xFF, pid >> 8, pid & 0xFF))


def sack_refused(lane, gen, reason):
    return bytes((_K_SACK | _C | (_T if lane else 0) | (_G if gen else 0), 0, reason & 0xFF))


class Segment:
    # A decoded segment: is_sack; lane, gen; for fragments poll, index,
    # payload; for SACKs complete, base, bitmap, pid (complete) or reason
    # (refused, base 0).
    __slots__ = ("is_sack", "lane", "gen", "poll", "index", "payload", "complete", "base", "bitmap", "pid", "reason")


def decode(data):
    n = len(data)
    if n < 2:
        raise DecodeError("segment of %d bytes" % n)
    b0 = data[0]
    s = Segment()
    s.is_sack = bool(b0 & _K_SACK)
    s.lane = 1 if b0 & _T else 0
    s.gen = 1 if b0 & _G else 0
    v = ((b0 & 0x0F) << 8) | data[1]
    if not s.is_sack:
        s.poll = bool(b0 & _P)
        s.index = v
        s.payload = data[2:]
        return s
    s.complete = bool(b0 & _C)
    s.base = v
    s.bitmap = b""
    s.pid = None
    s.reason = None
    if s.complete:
        if v == 0:
            if n != 3:
                raise DecodeError("refusal of %d bytes" % n)
            s.reason = data[2]
        else:
            if n != 4:
                raise DecodeError("completion of %d bytes" % n)
            s.pid = (data[2] << 8) | data[3]
    else:
        if n - 2 > MAX_BITMAP:
            raise DecodeError("SACK bitmap of %d bytes" % (n - 2))
        s.bitmap = bytes(data[2:])
    return s


# -- the packet header ---------------------------------------------------------


def packet_header(pid, length, compressed=False, relay=None):
    # relay: None, or (origin, final, priority, life_s)
    if not 0 <= pid <= 0xFFFF:
        raise EncodeError("packet id %r outside 0..65535" % (pid,))
    if not 0 <= length <= MAX_LENGTH:
        raise EncodeError("packet of %d bytes, at most %d" % (length, MAX_LENGTH))
    out = bytearray(((F_RELAY if relay is not None else 0) | (F_COMPRESSED if compressed else 0), pid >> 8, pid & 0xFF))
    while True:
        b = length & 0x7F
        length >>= 7
        if length:
            out.append(b | 0x80)
        else:
            out.append(b)
            break
    if relay is not None:
        origin, final, prio, life = relay
        if not (0 <= origin <= 254 and 0 <= final <= 254 and 1 <= prio <= 16):
            raise EncodeError("relay fields out of range: %r" % (relay,))
        life = 0 if life < 0 else (MAX_LIFE_S if life > MAX_LIFE_S else int(life))
        out.extend((origin, final, prio, life >> 8, life & 0xFF))
    return bytes(out)


class PacketHeader:
    __slots__ = ("pid", "length", "compressed", "relay", "size")


def decode_packet_header(data):
    # -> PacketHeader (size: its bytes). Raises DecodeError.
    n = len(data)
    if n < 4:
        raise DecodeError("packet header of %d bytes" % n)
    f = data[0]
    if f & 0x3F:
        raise DecodeError("packet flags 0x%02x: unknown bits" % f)
    h = PacketHeader()
    h.pid = (data[1] << 8) | data[2]
    h.compressed = bool(f & F_COMPRESSED)
    length = 0
    shift = 0
    i = 3
    while True:
        if i >= n or shift > 14:
            raise DecodeError("packet length runs past the header")
        b = data[i]
        i += 1
        length |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            break
    h.length = length
    h.relay = None
    if f & F_RELAY:
        if i + 5 > n:
            raise DecodeError("relay fields cut short")
        prio = data[i + 2]
        if not 1 <= prio <= 16 or data[i] > 254 or data[i + 1] > 254:
            raise DecodeError("relay fields out of range")
        h.relay = (data[i], data[i + 1], prio, (data[i + 3] << 8) | data[i + 4])
        i += 5
    h.size = i
    return h
