# Checksums used on the wire.
#
# crc16 is CRC-16/ARC: polynomial 0x8005 used reflected (0xA001), initial value
# 0, no final xor; check value 0xBB3D for b"123456789". IMC packets, the Seatrac
# serial protocol and the CADDY acoustic MAC all use it. It is incremental:
# crc16(b, crc16(a)) == crc16(a + b).
#
# On MicroPython a viper twin (in its own module, because viper code does not
# compile on CPython and is optional on boards) runs many times faster; we
# pick it at import time after checking it against the pure version.

from ..compat import IS_MICROPYTHON

# On MicroPython the pure CRC goes a nibble at a time on a 16-entry table
# (32 bytes): it runs when the modules are loaded from a filesystem, where
# every constant is copied into the heap, and the byte table took 528 B of
# the buoy's (a frame of 30-340 bytes, at 80 bit/s to a few kbit/s on the
# air: its speed is not the limit). Frozen firmware runs the viper twin on
# the byte table (_crc16_table), which stays in flash there.
if IS_MICROPYTHON:
    _NIBBLES = b"\x00\x00\x01\xcc\x01\xd8\x00\x14\x01\xf0\x00\x3c\x00\x28\x01\xe4\x01\xa0\x00\x6c\x00\x78\x01\xb4\x00\x50\x01\x9c\x01\x88\x00\x44"

    def crc16_pure(data, crc=0):
        t = _NIBBLES
        for b in data:
            i = ((crc ^ b) & 15) << 1
            crc = (crc >> 4) ^ t[i] ^ (t[i + 1] << 8)
            i = ((crc ^ (b >> 4)) & 15) << 1
            crc = (crc >> 4) ^ t[i] ^ (t[i + 1] << 8)
        return crc

else:
    # CPython has the RAM: a tuple of ints is the faster table there
    import struct

    from ._crc16_table import TABLE_LE

    TABLE = struct.unpack("<256H", TABLE_LE)

    def crc16_pure(data, crc=0):
        t = TABLE
        for b in data:
            crc = (crc >> 8) ^ t[(crc ^ b) & 0xFF]
        return crc


crc16 = crc16_pure

if IS_MICROPYTHON:
    try:
        from ._crc16_viper import make_crc16

        _fast = make_crc16()
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
