# The Blueprint Subsea SeaTrac serial protocol on the wire: message framing,
# the identifiers both ends use, and the acoustic position fix (ACO_FIX)
# that several messages carry. Shared by the driver (acomm.drivers.seatrac)
# and the emulator (ports/sim), so both ends agree on the bytes; the
# byte-exact tests against the reference examples keep both honest.
#
# A message is SYNC + uppercase hex of (CID byte + payload) + 4 hex digits of
# CRC-16/ARC over the binary bytes, low byte first, + CR LF. SYNC is '#' from
# host to beacon and '$' from beacon to host. Multi-byte fields are little-
# endian.

from ..compat import const
from ..codec.crc import crc16
from ..errors import EncodeError
from .base import SyncLines

# seatrac_codes' numbers this module uses, as private constants (inlined:
# no RAM on a board)
_FIX_BASE = const(16)
_FIX_POSITION = const(0x04)
_FIX_RANGE = const(0x01)
_FIX_USBL = const(0x02)
_JUNK_CRC = const(5)
_JUNK_HEX = const(4)
_JUNK_OVERLONG = const(3)
_JUNK_SHORT = const(6)
_JUNK_TEXT = const(1)
_JUNK_TRUNCATED = const(2)
_MAX_MSG = const(128)

# "CODE NAME" pairs in one constant string: one object on a board's heap when
# the modules run from a ROMFS image, where a tuple of pairs took 19 tuples
# and their strings (frozen, either stays in flash). Read only to name an
# error.
_CST_NAMES = (
    "00 OK 01 FAIL 03 EEPROM_ERROR 04 CMD_PARAM_MISSING 05 CMD_PARAM_INVALID 30 XCVR_BUSY 31 XCVR_ID_REJECTED "
    "32 XCVR_CSUM_ERROR 33 XCVR_LENGTH_ERROR 34 XCVR_RESP_TIMEOUT 35 XCVR_RESP_ERROR 36 XCVR_RESP_WRONG "
    "37 XCVR_PLOAD_ERROR 3A XCVR_STATE_STOPPED 3B XCVR_STATE_IDLE 3C XCVR_STATE_TX 3D XCVR_STATE_REQ "
    "3E XCVR_STATE_RX 3F XCVR_STATE_RESP"
)


def status_name(code):
    """The CST_E name of a status code, or CST_0xNN for one the table lacks."""
    # found in place, not split: a split made a 38-item list and its strings each time a frame
    # went unanswered, and that peak set the routing buoy's smallest heap
    t = _CST_NAMES
    key = "%02X " % code
    i = t.find(key)
    while i > 0 and t[i - 1] != " ":  # inside a word: not a code
        i = t.find(key, i + 1)
    if i < 0:
        return "CST_0x%02X" % code
    j = t.find(" ", i + 3)
    return t[i + 3:] if j < 0 else t[i + 3:j]

_HEX = b"0123456789ABCDEF"


def encode_into(out, sync, msg, n):
    # Writes the line for the binary message msg[:n] (CID + payload) into the
    # bytearray `out`; returns its length. No allocation but the memoryview.
    need = 1 + 2 * n + 6
    if n < 1 or len(out) < need:
        raise EncodeError("SeaTrac message of %d bytes does not fit %d" % (n, len(out)))
    crc = crc16(memoryview(msg)[:n])
    out[0] = sync
    j = 1
    for i in range(n):
        b = msg[i]
        out[j] = _HEX[b >> 4]
        out[j + 1] = _HEX[b & 15]
        j += 2
    for b in (crc & 0xFF, crc >> 8):
        out[j] = _HEX[b >> 4]
        out[j + 1] = _HEX[b & 15]
        j += 2
    out[j] = 13
    out[j + 1] = 10
    return j + 2


class LineReader(SyncLines):
    # Cuts the byte stream into messages that start with `sync` (the
    # framing is base.SyncLines). Accepts CR, LF or both as the end of a line.
    # Good messages go to sink.on_message(buf, n) with buf[0] the CID and n
    # counting CID + payload; everything else is dropped, counted and
    # reported to sink.on_junk(kind). Two preallocated buffers; no allocation per byte.
    _k_text = _JUNK_TEXT
    _k_cut = _JUNK_TRUNCATED
    _k_long = _JUNK_OVERLONG

    def __init__(self, sync, sink, max_msg=_MAX_MSG):
        SyncLines.__init__(self, sync, sink, 2 * max_msg)
        self._msg = bytearray(max_msg)
        self.messages = 0

    def _end_line(self, n):
        self._n = 0
        if n & 1:
            self._junk(_JUNK_HEX)
            return
        if n < 6:
            self._junk(_JUNK_SHORT)
            return
        line = self._line
        msg = self._msg
        m = n >> 1
        for i in range(m):
            # '0'-'9' -> 0..9, 'A'-'F' -> 10..15; anything else, lowercase
            # included (the protocol is uppercase only), marks a damaged
            # line. Worked out, not looked up: a 256-byte table was 288 B
            # of a board's heap when its modules load from flash
            hi = line[2 * i] - 48
            if hi > 9:
                hi = hi - 7 if hi > 16 else 16
            lo = line[2 * i + 1] - 48
            if lo > 9:
                lo = lo - 7 if lo > 16 else 16
            if hi < 0 or lo < 0 or hi > 15 or lo > 15:
                self._junk(_JUNK_HEX)
                return
            msg[i] = (hi << 4) | lo
        m -= 2
        if crc16(memoryview(msg)[:m]) != msg[m] | (msg[m + 1] << 8):
            self._junk(_JUNK_CRC)
            return
        self.messages += 1
        self._sink.on_message(msg, m)


# Little-endian field readers (no slicing, so no allocation).
def u16(b, o):
    return b[o] | (b[o + 1] << 8)


def i16(b, o):
    v = b[o] | (b[o + 1] << 8)
    return v - 0x10000 if v & 0x8000 else v


def u32(b, o):
    return b[o] | (b[o + 1] << 8) | (b[o + 2] << 16) | (b[o + 3] << 24)


def i32(b, o):
    v = u32(b, o)
    return v - 0x100000000 if v & 0x80000000 else v


def fix_len(b, o, end):
    # Length of the ACO_FIX starting at b[o], or -1 when it does not fit in
    # b[o:end] (a damaged or foreign message).
    if end - o < _FIX_BASE:
        return -1
    flags = b[o + 2]
    k = _FIX_BASE
    if flags & _FIX_RANGE:
        k += 10
    if flags & _FIX_USBL:
        if o + k >= end:
            return -1
        k += 1 + 2 * b[o + k] + 6
    if flags & _FIX_POSITION:
        k += 6
    return k if o + k <= end else -1


def fix_dict(b, o):
    # The ACO_FIX at b[o] (already checked with fix_len) in SI units: metres,
    # degrees, seconds, dB. Only the groups the flags mark valid appear.
    flags = b[o + 2]
    d = {
        "dest": b[o],
        "src": b[o + 1],
        "msg_type": b[o + 3],
        "yaw": i16(b, o + 4) / 10,
        "pitch": i16(b, o + 6) / 10,
        "roll": i16(b, o + 8) / 10,
        "depth_local": u16(b, o + 10) / 10,
        "vos": u16(b, o + 12) / 10,
        "rssi": i16(b, o + 14) / 10,
    }
    k = o + _FIX_BASE
    if flags & _FIX_RANGE:
        d["range_count"] = u32(b, k)
        d["range_time"] = i32(b, k + 4) / 1e7
        d["range"] = u16(b, k + 8) / 10
        k += 10
    if flags & _FIX_USBL:
        ch = b[k]
        k += 1 + 2 * ch
        d["azimuth"] = i16(b, k) / 10
        d["elevation"] = i16(b, k + 2) / 10
        d["fit_error"] = i16(b, k + 4)  # units not documented: raw
        k += 6
    if flags & _FIX_POSITION:
        d["easting"] = i16(b, k) / 10
        d["northing"] = i16(b, k + 2) / 10
        d["depth"] = i16(b, k + 4) / 10
    return d
