# CRC-32 (IEEE 802.3, the one of zlib, PNG and binascii): polynomial
# 0x04C11DB7 used reflected (0xEDB88320), initial value and final xor
# 0xFFFFFFFF; check value 0xCBF43926 for b"123456789". Incremental like
# zlib.crc32: crc32(b, crc32(a)) == crc32(a + b).
#
# The persistent store protects records of up to 64 KiB with it, where a
# CRC-16 would miss one corrupted record in 65536. binascii.crc32 is C code
# on CPython and on every MicroPython port built with EXTRA_FEATURES (rp2,
# esp32, stm32, unix), so we use it when it gives the right answers. The
# pure twin is for builds without it: a 16-entry table (64 bytes) and two
# steps per byte, slow, but small. On 32-bit boards its values exceed the
# 31-bit small ints and allocate, which is tolerable only as a fallback.

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


crc32 = crc32_pure

try:
    from binascii import crc32 as _c

    # Some builds return a signed value or ignore the start value: check.
    if _c(b"123456789") == 0xCBF43926 and _c(b"6789", _c(b"12345")) == 0xCBF43926:
        crc32 = _c
except ImportError:
    pass
