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


# Iridium system time (AT-MSSTM): a count of 90 ms frames from the current
# era's epoch, in hex, or "no network service" before the unit has
# registered. Era 2 began 2014-05-11 14:23:55 UTC (RockBLOCK's -MSSTM page;
# era 1: 2007-03-08 03:50:21, ISU AT Command Reference 7.17); its 32-bit
# count would have run out in August 2026, and Iridium moved the network to
# era 3, whose epoch is 2025-02-14 18:14:17 UTC (MetOcean's bulletin on the
# re-epoch, rolled out from January 2026). The epoch is not broadcast: a
# driver is told it (time_epoch_s, seconds from 2020-01-01 UTC).
_ERA3_S = const(161720057)  # 2025-02-14 18:14:17 UTC from 2020-01-01 (era 2: -178018565)
# the answer is sent within 4 frames of the count (0.36 s, ISU reference),
# the count is a whole frame (0.09 s), and the line takes a few ms more
_MSSTM_UNC_MS = const(500)


def parse_msstm(line, epoch_s=None):
    """'-MSSTM: <hex>' -> (secs from 2020-01-01 UTC, ms), None for 'no network service'; DecodeError else.
    epoch_s: the era's epoch in seconds from 2020-01-01 UTC (None: era 3's)."""
    if not line.startswith(b"-MSSTM:"):
        raise DecodeError("not a -MSSTM line")
    v = line[7:].strip()
    if v.startswith(b"no network"):
        return None
    if not 1 <= len(v) <= 8:
        raise DecodeError("bad -MSSTM count")
    try:
        # in two halves: a board keeps each product a small integer
        hi = int(v[:-4], 16) if len(v) > 4 else 0
        lo = int(v[-4:], 16)
    except ValueError:
        raise DecodeError("bad -MSSTM count")
    # count * 90 ms = hi * 65536 * 90 ms + lo * 90 ms; 65536 frames = 5898.24 s
    ms = hi * 240 + lo * 90
    return (_ERA3_S if epoch_s is None else epoch_s) + hi * 5898 + ms // 1000, ms % 1000

