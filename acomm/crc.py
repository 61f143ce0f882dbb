# Checksums used on the wire.
#
# crc16 is CRC-16/ARC: polynomial 0x8005 used reflected (0xA001), initial value
# 0, no final xor; check value 0xBB3D for b"123456789". IMC packets, the Seatrac
# serial protocol and the CADDY acoustic MAC all use it. It is incremental:
# crc16(b, crc16(a)) == crc16(a + b).
#
# The table costs 512 bytes of RAM. On MicroPython a viper twin (in its own
# module, because viper code does not compile on CPython and is optional on
# boards) runs many times faster; we pick it at import time after checking it
# against the pure version.

from array import array

from .compat import IS_MICROPYTHON


def _make_table():
    t = array("H", bytes(512))
    for i in range(256):
        c = i
        for _ in range(8):
            if c & 1:
                c = (c >> 1) ^ 0xA001
            else:
                c >>= 1
        t[i] = c
    return t


TABLE = _make_table()


def crc16_pure(data, crc=0):
    t = TABLE
    for b in data:
        crc = (crc >> 8) ^ t[(crc ^ b) & 0xFF]
    return crc


crc16 = crc16_pure

if IS_MICROPYTHON:
    try:
        from ._crc16_viper import make_crc16

        _fast = make_crc16(TABLE)
        if _fast(b"123456789", 0) == 0xBB3D and _fast(b"\xff", 0x1234) == crc16_pure(b"\xff", 0x1234):
            crc16 = _fast
    except Exception:  # no viper emitter on this build: keep the pure one
        pass


def nmea_xor(data):
    # XOR of all bytes, as in NMEA 0183 sentences (between '$' and '*').
    x = 0
    for b in data:
        x ^= b
    return x
