# The Blueprint Subsea SeaTrac serial protocol's numbers by name (command
# identifiers, status codes, acoustic message types, position-fix flags,
# part numbers) and a one-shot line encoder: for the emulator (ports/sim),
# tools and tests. The driver's modules (seatrac, seatrac_sequences,
# seatrac_wire) keep private copies of the numbers they use: MicroPython
# inlines `_NAME = const(x)`, where each public name took a slot in a
# module's dict and an entry in the string pool of a board's heap (about
# 16 B each, 0.9 KiB for this table). tests/cpython/test_const_copies.py
# checks every copy against this module, the one source.

from ..compat import const
from .seatrac_wire import encode_into

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

# Kinds of damaged input a LineReader reports to its sink's on_junk().
JUNK_TEXT = const(1)  # a line without the sync character (noise, boot text)
JUNK_TRUNCATED = const(2)  # a new sync arrived before the line ended
JUNK_OVERLONG = const(3)
JUNK_HEX = const(4)  # odd length, non-hex or lowercase characters
JUNK_CRC = const(5)
JUNK_SHORT = const(6)  # fewer than CID + CRC


def encode(sync, cid, payload=b""):
    # Convenience for tests and the emulator: one line as bytes.
    msg = bytearray(1 + len(payload))
    msg[0] = cid
    msg[1:] = payload
    out = bytearray(2 * len(msg) + 7)
    return bytes(memoryview(out)[: encode_into(out, sync, msg, len(msg))])
