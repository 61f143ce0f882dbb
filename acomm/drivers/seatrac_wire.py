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

SYNC_CMD = const(0x23)  # '#'
SYNC_RSP = const(0x24)  # '$'

# Command identifiers (the response to a command carries the same CID).
CID_SYS_ALIVE = const(0x01)
CID_SYS_INFO = const(0x02)
CID_SYS_REBOOT = const(0x03)
CID_STATUS = const(0x10)
CID_SETTINGS_GET = const(0x15)
CID_SETTINGS_SET = const(0x16)
CID_SETTINGS_LOAD = const(0x17)
CID_SETTINGS_SAVE = const(0x18)
CID_SETTINGS_RESET = const(0x19)
CID_XCVR_STATUS = const(0x3A)
CID_PING_SEND = const(0x40)
CID_PING_REQ = const(0x41)
CID_PING_RESP = const(0x42)
CID_PING_ERROR = const(0x43)
CID_DAT_SEND = const(0x60)
CID_DAT_RECEIVE = const(0x61)
CID_DAT_ERROR = const(0x63)
CID_DAT_QUEUE_SET = const(0x64)  # a packet for the automatic reply to the next DAT request
CID_DAT_QUEUE_CLR = const(0x65)
CID_DAT_QUEUE_STATUS = const(0x66)

REBOOT_CHECK = const(0x6A95)  # SYS_REBOOT's guard word

# CST_E status codes.
CST_OK = const(0x00)
CST_FAIL = const(0x01)
CST_CMD_PARAM_MISSING = const(0x04)
CST_CMD_PARAM_INVALID = const(0x05)
CST_XCVR_BUSY = const(0x30)
CST_XCVR_RESP_TIMEOUT = const(0x34)
CST_XCVR_RESP_ERROR = const(0x35)
CST_XCVR_RESP_WRONG = const(0x36)
CST_XCVR_STATE_IDLE = const(0x3B)
CST_XCVR_STATE_TX = const(0x3C)
CST_XCVR_STATE_REQ = const(0x3D)
CST_XCVR_STATE_RX = const(0x3E)
CST_XCVR_STATE_RESP = const(0x3F)

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
    words = _CST_NAMES.split()
    key = "%02X" % code
    for i in range(0, len(words), 2):
        if words[i] == key:
            return words[i + 1]
    return "CST_0x%02X" % code


# AMSGTYPE_E: acoustic message types.
MSG_OWAY = const(0)
MSG_OWAYU = const(1)
MSG_REQ = const(2)
MSG_RESP = const(3)
MSG_REQU = const(4)
MSG_RESPU = const(5)
MSG_REQX = const(6)
MSG_RESPX = const(7)

BEACON_ALL = const(0)  # destination 0: every beacon (one-way types only)

# ACO_FIX flags.
FIX_RANGE = const(0x01)
FIX_USBL = const(0x02)
FIX_POSITION = const(0x04)

FIX_BASE = const(16)  # dest, src, flags, type, yaw, pitch, roll, depth, vos, rssi

# Hardware part numbers reported by SYS_INFO.
PART_X150 = const(795)
PART_X110 = const(843)

# Largest binary message (CID + payload + CRC) either end accepts: a 110-byte
# settings record is the longest message the driver deals with.
MAX_MSG = const(128)

_HEX = b"0123456789ABCDEF"


# The value of each byte as an uppercase hex digit, 0..15; 0xFF for every
# other byte: the protocol is uppercase only, so lowercase hex marks a
# damaged line. A bytes constant, which stays in flash when frozen (a table
# built at import took 272 B of a board's heap); test_name_tables checks it.
HEXVAL = (
    b"\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff"
    b"\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\x00\x01\x02\x03\x04\x05\x06\x07\x08\x09\xff\xff\xff\xff\xff\xff"
    b"\xff\x0a\x0b\x0c\x0d\x0e\x0f\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff"
    b"\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff"
    b"\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff"
    b"\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff"
    b"\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff"
    b"\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff"
)


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


def encode(sync, cid, payload=b""):
    # Convenience for tests and the emulator: one line as bytes.
    msg = bytearray(1 + len(payload))
    msg[0] = cid
    msg[1:] = payload
    out = bytearray(2 * len(msg) + 7)
    return bytes(memoryview(out)[: encode_into(out, sync, msg, len(msg))])


# Kinds of damaged input a LineReader reports to its sink's on_junk().
JUNK_TEXT = const(1)  # a line without the sync character (noise, boot text)
JUNK_TRUNCATED = const(2)  # a new sync arrived before the line ended
JUNK_OVERLONG = const(3)
JUNK_HEX = const(4)  # odd length, non-hex or lowercase characters
JUNK_CRC = const(5)
JUNK_SHORT = const(6)  # fewer than CID + CRC


class LineReader(SyncLines):
    # Cuts the byte stream into messages that start with `sync` (the
    # framing is base.SyncLines). Accepts CR, LF or both as the end of a line.
    # Good messages go to sink.on_message(buf, n) with buf[0] the CID and n
    # counting CID + payload; everything else is dropped, counted and
    # reported to sink.on_junk(kind). Two preallocated buffers; no allocation per byte.
    def __init__(self, sync, sink, max_msg=MAX_MSG):
        SyncLines.__init__(self, sync, sink, 2 * max_msg, JUNK_TEXT, JUNK_TRUNCATED, JUNK_OVERLONG)
        self._msg = bytearray(max_msg)
        self.messages = 0

    def _end_line(self, n):
        self._n = 0
        if n & 1:
            self._junk(JUNK_HEX)
            return
        if n < 6:
            self._junk(JUNK_SHORT)
            return
        line = self._line
        msg = self._msg
        hv = HEXVAL
        m = n >> 1
        for i in range(m):
            hi = hv[line[2 * i]]
            lo = hv[line[2 * i + 1]]
            if hi > 15 or lo > 15:
                self._junk(JUNK_HEX)
                return
            msg[i] = (hi << 4) | lo
        m -= 2
        if crc16(memoryview(msg)[:m]) != msg[m] | (msg[m + 1] << 8):
            self._junk(JUNK_CRC)
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
    if end - o < FIX_BASE:
        return -1
    flags = b[o + 2]
    k = FIX_BASE
    if flags & FIX_RANGE:
        k += 10
    if flags & FIX_USBL:
        if o + k >= end:
            return -1
        k += 1 + 2 * b[o + k] + 6
    if flags & FIX_POSITION:
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
    k = o + FIX_BASE
    if flags & FIX_RANGE:
        d["range_count"] = u32(b, k)
        d["range_time"] = i32(b, k + 4) / 1e7
        d["range"] = u16(b, k + 8) / 10
        k += 10
    if flags & FIX_USBL:
        ch = b[k]
        k += 1 + 2 * ch
        d["azimuth"] = i16(b, k) / 10
        d["elevation"] = i16(b, k + 2) / 10
        d["fit_error"] = i16(b, k + 4)  # units not documented: raw
        k += 6
    if flags & FIX_POSITION:
        d["easting"] = i16(b, k) / 10
        d["northing"] = i16(b, k + 2) / 10
        d["depth"] = i16(b, k + 4) / 10
    return d
