# IMC 5.4 wire primitives (docs/imc.md, ref/imc.md section 1): the 20-byte
# header, the CRC-16/ARC footer, both byte orders, and one writer and one
# reader for the field types. Every multi-byte value, the header, length
# prefixes and inline message ids included, goes in the packet's byte order.
# We emit little-endian (what every LSTS host sends) and read either: the
# sync word tells which.
#
# MicroPython's struct does not range-check, so every integer is checked
# here before it is packed, and every read checks that the bytes are there.

import struct

from ..compat import const
from ..errors import DecodeError, EncodeError
from . import fp64

SYNC = const(0xFE54)
HEADER_SIZE = const(20)
OVERHEAD = const(22)  # header + CRC
MAX_PACKET = const(65535)  # DUNE_IMC_CONST_MAX_SIZE, header and CRC included
MAX_PAYLOAD = const(65513)
NULL_ID = const(0xFFFF)  # inline "no message"
SYNC_LE = b"\x54\xfe"  # a little-endian packet's first two bytes
SYNC_BE = b"\xfe\x54"

# Field type codes; the names are IMC's own (the XML's type attribute).
I8 = const(0)
U8 = const(1)
I16 = const(2)
U16 = const(3)
I32 = const(4)
U32 = const(5)
I64 = const(6)
FP32 = const(7)
FP64 = const(8)
TEXT = const(9)
RAW = const(10)
MSG = const(11)
MSGLIST = const(12)

TYPE_CODES = {
    "int8": I8,
    "uint8": U8,
    "int16": I16,
    "uint16": U16,
    "int32": I32,
    "uint32": U32,
    "int64": I64,
    "fp32": FP32,
    "fp64": FP64,
    "plaintext": TEXT,
    "rawdata": RAW,
    "message": MSG,
    "message-list": MSGLIST,
}

# per integer code: struct letter, size, lowest, highest
INTS = (
    ("b", 1, -0x80, 0x7F),
    ("B", 1, 0, 0xFF),
    ("h", 2, -0x8000, 0x7FFF),
    ("H", 2, 0, 0xFFFF),
    ("i", 4, -0x80000000, 0x7FFFFFFF),
    ("I", 4, 0, 0xFFFFFFFF),
    ("q", 8, -0x8000000000000000, 0x7FFFFFFFFFFFFFFF),
)
# formats per byte order (0 little, 1 big), made once
_FMT = (
    tuple("<" + t[0] for t in INTS) + ("<f", "<Q", "<HHHQHBHB", "<H"),
    tuple(">" + t[0] for t in INTS) + (">f", ">Q", ">HHHQHBHB", ">H"),
)
_F32 = const(7)
_U64 = const(8)
_HDR = const(9)
_CRC = const(10)
# Built at import from a string: a float literal this large cannot be
# frozen (mpy-tool also emits every float constant for single-precision
# object layouts, where it overflows), and the string keeps every digit
# where mpy-tool's %.16g would change it by an ulp.
_F32_OVER = float("3.4028235677973366e38")


def check_int(code, v):
    # v as the wire's integer for type code, or EncodeError.
    if not isinstance(v, int):
        raise EncodeError("%r is not an int" % (v,))
    t = INTS[code]
    if v < t[2] or v > t[3]:
        raise EncodeError("%d outside %s [%d, %d]" % (v, ("int8", "uint8", "int16", "uint16", "int32", "uint32", "int64")[code], t[2], t[3]))
    return v


class Writer:
    # Appends fields to a bytearray in one byte order.

    def __init__(self, big=False, reserve=0):
        # reserve: zero bytes up front, for a header written last
        self.big = 1 if big else 0
        self.out = bytearray(reserve)

    def int(self, code, v):
        self.out += struct.pack(_FMT[self.big][code], check_int(code, v))

    def u16(self, v):
        self.int(U16, v)

    def f32(self, v):
        if not isinstance(v, (int, float)):
            raise EncodeError("%r is not a number" % (v,))
        v = float(v)
        # Finite values from 2**128 - 2**103 up round to infinity: CPython's
        # struct raises, MicroPython's packs inf. Refuse them on both (on a
        # single-precision build the bound is inf and never reached).
        if v == v and v != v * 2 and (v >= _F32_OVER or v <= -_F32_OVER):
            raise EncodeError("%r beyond fp32 range" % (v,))
        self.out += struct.pack(_FMT[self.big][_F32], v)

    def f64(self, v):
        self.out += struct.pack(_FMT[self.big][_U64], fp64.bits_of(v))

    def raw(self, b):
        if not isinstance(b, (bytes, bytearray, memoryview)):
            raise EncodeError("%r is not bytes" % (type(b).__name__,))
        if len(b) > MAX_PAYLOAD:
            raise EncodeError("%d bytes, at most %d" % (len(b), MAX_PAYLOAD))
        self.u16(len(b))
        self.out += b

    def header(self, mgid, size, ts_bits, src, src_ent, dst, dst_ent):
        for code, v in ((U16, mgid), (U16, size), (U16, src), (U8, src_ent), (U16, dst), (U8, dst_ent)):
            check_int(code, v)
        struct.pack_into(_FMT[self.big][_HDR], self.out, 0, SYNC, mgid, size, ts_bits, src, src_ent, dst, dst_ent)

    def crc(self, v):
        self.out += struct.pack(_FMT[self.big][_CRC], v)


class Reader:
    # Reads fields from buf[pos:end] in one byte order; DecodeError when a
    # field would run past end.

    def __init__(self, buf, pos, end, big):
        self.buf = buf
        self.pos = pos
        self.end = end
        self.big = 1 if big else 0

    def need(self, n):
        p = self.pos
        if p + n > self.end:
            raise DecodeError("truncated: %d bytes needed, %d left" % (n, self.end - p))
        self.pos = p + n
        return p

    def int(self, code):
        p = self.need(INTS[code][1])
        return struct.unpack_from(_FMT[self.big][code], self.buf, p)[0]

    def u16(self):
        p = self.need(2)
        return struct.unpack_from(_FMT[self.big][U16], self.buf, p)[0]

    def f32(self):
        p = self.need(4)
        return struct.unpack_from(_FMT[self.big][_F32], self.buf, p)[0]

    def f64_bits(self):
        p = self.need(8)
        return struct.unpack_from(_FMT[self.big][_U64], self.buf, p)[0]

    def raw(self):
        n = self.u16()
        p = self.need(n)
        return bytes(self.buf[p : p + n])

    def text(self):
        b = self.raw()
        try:
            return str(b, "utf-8")
        except (UnicodeError, ValueError):
            raise DecodeError("plaintext is not UTF-8") from None


def sync_order(b0, b1):
    # The byte order (False little, True big) that the first two bytes of a
    # packet announce, or None if they are no IMC sync.
    if b0 == 0x54 and b1 == 0xFE:
        return False
    if b0 == 0xFE and b1 == 0x54:
        return True
    return None


def read_header(buf, pos, big):
    # (mgid, size, ts_bits, src, src_ent, dst, dst_ent) of the header at pos.
    return struct.unpack_from(_FMT[1 if big else 0][_HDR], buf, pos)[1:]


def read_crc(buf, pos, big):
    return struct.unpack_from(_FMT[1 if big else 0][_CRC], buf, pos)[0]
