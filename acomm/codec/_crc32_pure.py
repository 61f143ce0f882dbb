# The pure CRC-32 (acomm.codec.crc32) for builds without binascii.crc32: a
# 16-entry table (64 bytes) and two steps per byte, slow, but small. On
# 32-bit boards its values exceed the 31-bit small ints and allocate, which
# is tolerable only as a fallback. Its own module, so that a board with
# binascii never loads it (from flash, its code and table would take heap).

from array import array


def _make_table():
    # t[i] = the CRC register after shifting the 4 bits of i through it.
    t = array("I", [0] * 16)
    for i in range(16):
        c = i
        for _ in range(4):
            c = (c >> 1) ^ 0xEDB88320 if c & 1 else c >> 1
        t[i] = c
    return t


_T = _make_table()


def crc32_pure(data, crc=0):
    t = _T
    crc ^= 0xFFFFFFFF
    for b in data:
        crc = (crc >> 4) ^ t[(crc ^ b) & 15]
        crc = (crc >> 4) ^ t[(crc ^ (b >> 4)) & 15]
    return crc ^ 0xFFFFFFFF
