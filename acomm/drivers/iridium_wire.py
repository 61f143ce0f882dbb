# What goes over the serial line to an Iridium 9602/9603 SBD transceiver
# (RockBLOCK), ref/modem-protocols.md section 5: the SBDWB / SBDRB
# checksum, the +SBDIX session report and what its MO status means, +CSQ.
# Shared by the driver (acomm.drivers.iridium) and the emulator
# (acomm_sim.iridium).

from ..compat import const
from ..errors import DecodeError, EncodeError
from .atcommand import after, ints

MO_MAX = const(340)  # 9602/9603: MO 1..340 bytes, MT up to 270 (ref 5.3)
MT_MAX = const(270)
MO_SUCCESS_MAX = const(4)  # 3-4 are "reserved, success" (ISU reference, goby3, DUNE)

# +SBDIX MO status -> what it means (ref 5.2, DUNE's table); others are
# "reserved failure". "code:text" items in one constant string: one object
# on a board's heap when the modules run from a ROMFS image, where a tuple
# of (code, text) pairs took 20 tuples and their strings (frozen, either
# stays in flash). Read only to explain a failed session.
_MO_STATUS = (
    "10:call did not complete in the allowed time;"
    "11:MO message queue at the gateway is full;12:MO message has too many segments;"
    "13:session did not complete;14:invalid segment size;15:access denied;16:transceiver locked;"
    "17:gateway not responding;18:RF drop;19:protocol error;32:no network service;33:antenna fault;"
    "34:radio disabled;35:transceiver busy"
)


def mo_status_name(code):
    """What +SBDIX MO status `code` means ("MO sent" for 0..MO_SUCCESS_MAX: the driver explains failures only)."""
    if 0 <= code <= MO_SUCCESS_MAX:
        return "MO sent"
    for item in _MO_STATUS.split(";"):
        c, text = item.split(":", 1)
        if int(c) == code:
            return text
    return "reserved failure"


def checksum(data, n=None):
    # the low 16 bits of the byte sum
    s = 0
    if n is None:
        n = len(data)
    for i in range(n):
        s += data[i]
    return s & 0xFFFF


def sbdwb_data(data):
    # what follows READY: the bytes and their checksum, high byte first
    n = len(data)
    if not 1 <= n <= MO_MAX:
        raise EncodeError("an SBD MO message is 1..%d bytes, not %d" % (MO_MAX, n))
    c = checksum(data)
    return bytes(data) + bytes((c >> 8, c & 0xFF))


def sbdrb_block(data):
    # the SBDRB answer before its OK: length, bytes, checksum (big-endian)
    n = len(data)
    if n > 0xFFFF:
        raise EncodeError("an SBDRB block holds at most 65535 bytes")
    c = checksum(data)
    return bytes((n >> 8, n & 0xFF)) + bytes(data) + bytes((c >> 8, c & 0xFF))


def block_ok(buf, n):
    # whether the two bytes after the n data bytes of buf are their checksum
    return checksum(buf, n) == (buf[n] << 8) | buf[n + 1]


def parse_sbdix(line):
    # b"+SBDIX: 0, 23, 1, 5, 6, 0" -> [mo status, MOMSN, mt status, MTMSN,
    # mt length, mt queued]; raises DecodeError
    t = after(line, b"+SBDIX:")
    v = ints(t, 6) if t is not None else None
    if v is None or min(v) < 0 or v[0] > 255 or v[1] > 65535 or v[2] > 2 or v[3] > 65535:
        raise DecodeError("not a +SBDIX report: %r" % (line,))
    return v


def parse_csq(line):
    # b"+CSQ:3" -> 3 (bars, 0..5); raises DecodeError
    t = after(line, b"+CSQ:")
    v = ints(t, 1) if t is not None else None
    if v is None or not 0 <= v[0] <= 5:
        raise DecodeError("not an Iridium +CSQ answer: %r" % (line,))
    return v[0]


def parse_status(line):
    # the single digit SBDWB / SBDD answer -> int, or None
    if len(line) == 1 and 48 <= line[0] <= 57:
        return line[0] - 48
    return None
