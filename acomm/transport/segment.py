# The transport's bytes on a link: fragments of a packet and selective
# acknowledgements (SACKs). Both travel as link frames of type SEGMENT
# (acomm.frame), never acknowledged by the link: the SACK is the transport's
# own acknowledgement of a whole window of fragments.
#
# A segment's first four bits ride in the link frame header's sequence
# field, which SEGMENT frames have no other use for (the link neither
# acknowledges nor filters them; the transport numbers its own fragments):
#   head  K P T G      K: a SACK; P: poll (answer with a SACK), or for a
#                      SACK C: complete; T: lane (two transfers at a time to
#                      one neighbour); G: generation of the lane
# then in the frame's payload:
#   fragment  1 byte   fragment index mod 256, then the fragment's bytes
#                      (none: a bare poll, sent again when a SACK is late)
#   SACK      1 byte   base mod 256: every fragment below base has arrived;
#                      then a bitmap of 0..MAX_BITMAP bytes: bit j of byte k
#                      set when fragment base + 1 + 8k + j arrived
#   complete  3 bytes  (C) fragment count mod 256, packet id (2): the sender
#                      checks that the receiver completed *its* packet (after
#                      a restart of either side a lane's generation is stale)
#   refused   2 bytes  (C) 0, then a reason: the receiver cannot take it
# Indexes are sent mod 256 because neither side is ever more than a window
# (WINDOW = 65 fragments, acomm.transport.arq) from what the other knows: the
# receiver reads an index as the one nearest its own base, the sender reads
# a base as the one nearest its own (unwrap()). So one byte per fragment
# carries the transfer state, and a packet may have up to 4096 fragments.
#
# Packet header, at the start of fragment 0's payload (the end-to-end part):
#   flags    R Z 000000        R relay fields follow, Z body compressed
#   pid      2 bytes           the origin's packet id (duplicate suppression)
#   length   1..3 bytes        body length, 7 bits per byte, high bit = more
#   R only:  origin, final destination (node ids: one byte each, three
#            for an id of 256 or more, acomm.frame.addr_bytes), priority
#            (1..16, one byte), lifespan left in seconds (2 bytes, saturating)
# A packet sent straight to its neighbour costs 4 bytes (length < 128) plus
# 1 per fragment; docs/wire-format.md has the examples.

from ..compat import const
from ..errors import DecodeError, EncodeError
from ..frame import get_addr

FRAG_HEADER = const(1)
MAX_INDEX = const(4095)
MAX_BITMAP = const(8)  # 64 fragments after the base per SACK
MAX_LENGTH = const((1 << 21) - 1)
_MAX_LIFE_S = const(65535)

_K_SACK = const(8)
_P = const(4)
_C = const(4)
_T = const(2)
_G = const(1)

_F_RELAY = const(0x80)
F_COMPRESSED = const(0x40)

# refusal reasons
REFUSE_TOO_BIG = const(1)
REFUSE_FULL = const(2)
REFUSE_NO_ROUTE = const(3)
# indexed by the reason (a tuple stays in flash when frozen; a dict would not)
REFUSE_NAMES = ("?", "too big for the receiver", "receiver full", "no route at the relay")


def refuse_name(reason):
    """What a refusal reason means, or the number itself when it is not one we know."""
    return REFUSE_NAMES[reason] if 0 < reason < len(REFUSE_NAMES) else reason


def _head(k, pc, lane, gen):
    return k | (_P if pc else 0) | (_T if lane else 0) | (_G if gen else 0)


def is_poll(head):
    return not head & _K_SACK and bool(head & _P)


def unwrap(low, ref):
    # the value that is low mod 256 nearest to ref
    return ref + ((low - ref + 128) & 0xFF) - 128


def frag_header(poll, lane, gen, index):
    # -> (head, the payload's first byte)
    if not 0 <= index <= MAX_INDEX:
        raise EncodeError("fragment index %d outside 0..%d" % (index, MAX_INDEX))
    return _head(0, poll, lane, gen), bytes((index & 0xFF,))


def sack(lane, gen, base, bitmap=b""):
    if len(bitmap) > MAX_BITMAP:
        raise EncodeError("SACK bitmap of %d bytes, at most %d" % (len(bitmap), MAX_BITMAP))
    return _head(_K_SACK, 0, lane, gen), bytes((base & 0xFF,)) + bytes(bitmap)


def sack_complete(lane, gen, count, pid):
    return _head(_K_SACK, 1, lane, gen), bytes((count & 0xFF, pid >> 8, pid & 0xFF))


def sack_refused(lane, gen, reason):
    return _head(_K_SACK, 1, lane, gen), bytes((0, reason & 0xFF))


class Segment:
    # A decoded segment: is_sack; lane, gen; for fragments poll, index (mod
    # 256) and payload; for SACKs complete, base (mod 256), bitmap, pid
    # (complete) or reason (refused).
    # fields: is_sack, lane, gen, poll, index, payload, complete, base, bitmap, pid, reason
    pass


def decode(head, data):
    # head: the frame header's sequence field; data: the frame's payload
    n = len(data)
    if n < 1 or not 0 <= head <= 15:
        raise DecodeError("segment of %d bytes, head %d" % (n, head))
    s = Segment()
    s.is_sack = bool(head & _K_SACK)
    s.lane = 1 if head & _T else 0
    s.gen = 1 if head & _G else 0
    if not s.is_sack:
        s.poll = bool(head & _P)
        s.index = data[0]
        s.payload = data[1:]
        if not s.payload and not s.poll:
            raise DecodeError("fragment without bytes")  # only a bare poll has none
        return s
    s.complete = bool(head & _C)
    s.base = data[0]
    s.bitmap = b""
    s.pid = None
    s.reason = None
    if s.complete:
        if n == 2 and data[0] == 0:
            s.reason = data[1]
        elif n == 3:
            s.pid = (data[1] << 8) | data[2]
        else:
            raise DecodeError("completion or refusal of %d bytes" % n)
    else:
        if n - 1 > MAX_BITMAP:
            raise DecodeError("SACK bitmap of %d bytes" % (n - 1))
        s.bitmap = bytes(data[1:])
    return s


# -- the packet header ---------------------------------------------------------


def packet_header(pid, length, compressed=False, relay=None):
    # relay: None, or (origin, final, priority, life_s)
    if not 0 <= pid <= 0xFFFF:
        raise EncodeError("packet id %r outside 0..65535" % (pid,))
    if not 0 <= length <= MAX_LENGTH:
        raise EncodeError("packet of %d bytes, at most %d" % (length, MAX_LENGTH))
    out = bytearray(((_F_RELAY if relay is not None else 0) | (F_COMPRESSED if compressed else 0), pid >> 8, pid & 0xFF))
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
        if not (0 <= origin <= 65534 and 0 <= final <= 65534 and 255 not in (origin, final) and 1 <= prio <= 16):
            raise EncodeError("relay fields out of range: %r" % (relay,))
        life = 0 if life < 0 else (_MAX_LIFE_S if life > _MAX_LIFE_S else int(life))
        if origin < 255 and final < 255:
            out.extend((origin, final))
        else:
            for a in (origin, final):
                out.extend((a,) if a < 255 else (255, a >> 8, a & 0xFF))  # acomm.frame.addr_bytes
        out.extend((prio, life >> 8, life & 0xFF))
    return bytes(out)


class PacketHeader:
    # fields: pid, length, compressed, relay, size
    pass


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
    if f & _F_RELAY:
        if i + 2 <= n and data[i] != 255 and data[i + 1] != 255:
            origin, final = data[i], data[i + 1]  # one-byte ids: no get_addr tuples
            i += 2
        else:
            origin, i = get_addr(data, i)
            final, i = get_addr(data, i)
        if i + 3 > n:
            raise DecodeError("relay fields cut short")
        prio = data[i]
        if not 1 <= prio <= 16:
            raise DecodeError("relay fields out of range")
        h.relay = (origin, final, prio, (data[i + 1] << 8) | data[i + 2])
        i += 3
    h.size = i
    return h
