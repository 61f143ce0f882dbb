# CRC-32 (IEEE 802.3, the one of zlib, PNG and binascii): polynomial
# 0x04C11DB7 used reflected (0xEDB88320), initial value and final xor
# 0xFFFFFFFF; check value 0xCBF43926 for b"123456789". Incremental like
# zlib.crc32: crc32(b, crc32(a)) == crc32(a + b).
#
# The persistent store protects records of up to 64 KiB with it, where a
# CRC-16 would miss one corrupted record in 65536. binascii.crc32 is C code
# on CPython and on every MicroPython port built with EXTRA_FEATURES (rp2,
# esp32, stm32, unix), so we use it when it gives the right answers. The
# pure twin (acomm.codec._crc32_pure, imported only when it is needed) is
# for builds without it.

try:
    from binascii import crc32 as _c

    # Some builds return a signed value or ignore the start value: check.
    if not (_c(b"123456789") == 0xCBF43926 and _c(b"6789", _c(b"12345")) == 0xCBF43926):
        _c = None
except ImportError:
    _c = None

if _c is not None:
    crc32 = _c
else:
    from ._crc32_pure import crc32_pure as crc32
