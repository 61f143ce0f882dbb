# Route discovery's three control messages, and flooding's one, on the water (issue 36): the
# payload of a CONTROL frame (acomm.frame.CONTROL, a type nothing else uses),
# whose header already names the hop that sent it. Decoders raise only
# DecodeError; encoders check every range themselves (struct does not on
# MicroPython). docs/wire-format.md, "Route control", has the layout.
#
#   byte 0: kind (top 2 bits: 0 flood, 1 request, 2 reply, 3 error) and a 6-bit
#           count: the hops so far for a flood, a request or a reply, the
#           destinations for an error
#
#   request (flooded), 10 bytes:
#     kind|hops  id  origin  origin_seq(2)  dest  dest_seq(2)  cost(2)
#     id: the origin's request counter (a relay drops an (origin, id) it has
#     seen); dest_seq UNKNOWN_SEQ when the origin knows none
#   reply (unicast back along the reverse path), 8 bytes:
#     kind|hops  dest  dest_seq(2)  origin  cost(2)  lifetime (4 s units, 1..255)
#   error (to the sources that used the hop), 1 + 3 per destination (1..16):
#     kind|n  (dest  dest_seq(2)) x n
#   flood (acomm.transport.flood, rebroadcast by every node), 3 + 1..MAX_FLOOD_DATA bytes:
#     kind|hops  origin  id  data
#     id: the origin's flood counter mod 256; data is the application's
#
# Sequence numbers and costs are big-endian 16-bit. A request for a
# destination whose sequence number the origin does not know carries
# UNKNOWN_SEQ (0xFFFF, which acomm.transport.routetable therefore never
# hands out: its numbers stay below it). Costs saturate at MAX_COST; 0xFFFF
# is never written, and a decoder refuses it.

from ..compat import const
from ..errors import DecodeError, EncodeError

FLOOD = const(0)
REQUEST = const(1)
REPLY = const(2)
ERROR = const(3)
UNKNOWN_SEQ = const(0xFFFF)
MAX_COST = const(0xFFFE)
MAX_HOPS = const(63)
MAX_ERRORS = const(16)
LIFETIME_UNIT_MS = const(4000)
_REQ_LEN = const(10)
_REP_LEN = const(8)
# A flood's data fits a sealed elided frame on a 30-byte SeaTrac packet, the
# smallest acoustic MTU acomm drives: 30 - 2 (link byte, flags byte) - 7
# (counter and 4-byte tag) - 3 (this header) = 18 bytes.
MAX_FLOOD_DATA = const(18)


def _id(v, what):
    if not isinstance(v, int) or not 0 <= v <= 254:
        raise EncodeError("%s %r outside 0..254" % (what, v))
    return v


def _u16(v, what, top=0xFFFF):
    if not isinstance(v, int) or not 0 <= v <= top:
        raise EncodeError("%s %r outside 0..%d" % (what, v, top))
    return bytes((v >> 8, v & 0xFF))


def _head(kind, n):
    if not isinstance(n, int) or not 0 <= n <= MAX_HOPS:
        raise EncodeError("count %r outside 0..%d" % (n, MAX_HOPS))
    return bytes(((kind << 6) | n,))


def _cost(c):
    if not isinstance(c, int) or c < 0:
        raise EncodeError("cost %r is not a non-negative int" % (c,))
    return MAX_COST if c > MAX_COST else c


def encode_request(rid, origin, origin_seq, dest, dest_seq, hops, cost):
    """A route request: 10 bytes. dest_seq UNKNOWN_SEQ when the origin knows none; cost saturates."""
    if not isinstance(rid, int) or not 0 <= rid <= 255:
        raise EncodeError("request id %r outside 0..255" % (rid,))
    return (_head(REQUEST, hops) + bytes((rid, _id(origin, "origin"))) + _u16(origin_seq, "origin seq", 0xFFFE)
            + bytes((_id(dest, "destination"),)) + _u16(dest_seq, "destination seq") + _u16(_cost(cost), "cost"))


def encode_reply(dest, dest_seq, origin, hops, cost, lifetime_ms):
    """A route reply: 8 bytes. lifetime rounds up to 4 s units, 4 s to 17 min."""
    units = (lifetime_ms + LIFETIME_UNIT_MS - 1) // LIFETIME_UNIT_MS
    units = 1 if units < 1 else (255 if units > 255 else units)
    return (_head(REPLY, hops) + bytes((_id(dest, "destination"),)) + _u16(dest_seq, "destination seq", 0xFFFE)
            + bytes((_id(origin, "origin"),)) + _u16(_cost(cost), "cost") + bytes((units,)))


def encode_error(lost):
    """A route error for [(dest, seq)], 1..16 of them: 1 + 3 bytes each."""
    if not 1 <= len(lost) <= MAX_ERRORS:
        raise EncodeError("a route error names 1..%d destinations, not %d" % (MAX_ERRORS, len(lost)))
    out = bytearray(_head(ERROR, len(lost)))
    for d, s in lost:
        out += bytes((_id(d, "destination"),)) + _u16(s, "destination seq", 0xFFFE)
    return bytes(out)


def encode_flood(origin, mid, hops, data):
    """A flood: origin, its id 0..255, hops 0..63, then 1..MAX_FLOOD_DATA bytes of data."""
    if not isinstance(mid, int) or not 0 <= mid <= 255:
        raise EncodeError("flood id %r outside 0..255" % (mid,))
    if not isinstance(data, (bytes, bytearray, memoryview)) or not 1 <= len(data) <= MAX_FLOOD_DATA:
        raise EncodeError("flood data must be 1..%d bytes" % MAX_FLOOD_DATA)
    return _head(FLOOD, hops) + bytes((_id(origin, "origin"), mid)) + bytes(data)


def decode(data):
    """-> ("request", rid, origin, origin_seq, dest, dest_seq, hops, cost)
       | ("reply", dest, dest_seq, origin, hops, cost, lifetime_ms)
       | ("error", [(dest, seq), ...]) | ("flood", origin, id, hops, data);
       DecodeError for anything else."""
    if not data:
        raise DecodeError("empty route control")
    kind = data[0] >> 6
    n = data[0] & 0x3F
    if kind == REQUEST:
        if len(data) != _REQ_LEN:
            raise DecodeError("route request of %d bytes, expected %d" % (len(data), _REQ_LEN))
        origin, dest = data[2], data[5]
        oseq = (data[3] << 8) | data[4]
        cost = (data[8] << 8) | data[9]
        if origin > 254 or dest > 254 or oseq == UNKNOWN_SEQ or cost > MAX_COST:
            raise DecodeError("route request with a reserved id, origin sequence number or cost")
        return ("request", data[1], origin, oseq, dest, (data[6] << 8) | data[7], n, cost)
    if kind == REPLY:
        if len(data) != _REP_LEN:
            raise DecodeError("route reply of %d bytes, expected %d" % (len(data), _REP_LEN))
        dest, origin = data[1], data[4]
        dseq = (data[2] << 8) | data[3]
        cost = (data[5] << 8) | data[6]
        if dest > 254 or origin > 254 or dseq == UNKNOWN_SEQ or cost > MAX_COST or data[7] == 0:
            raise DecodeError("route reply with a reserved id, sequence number or cost, or no lifetime")
        return ("reply", dest, dseq, origin, n, cost, data[7] * LIFETIME_UNIT_MS)
    if kind == ERROR:
        if not 1 <= n <= MAX_ERRORS or len(data) != 1 + 3 * n:
            raise DecodeError("route error for %d destinations in %d bytes" % (n, len(data)))
        lost = []
        for i in range(1, len(data), 3):
            s = (data[i + 1] << 8) | data[i + 2]
            if data[i] > 254 or s == UNKNOWN_SEQ:
                raise DecodeError("route error with a reserved id or sequence number")
            lost.append((data[i], s))
        return ("error", lost)
    # kind 0, a flood: data of 1..MAX_FLOOD_DATA bytes, never from the broadcast id
    if not 4 <= len(data) <= 3 + MAX_FLOOD_DATA or data[1] > 254:
        raise DecodeError("flood of %d bytes or from a reserved id" % len(data))
    return ("flood", data[1], data[2], n, bytes(data[3:]))
