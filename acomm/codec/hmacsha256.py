# HMAC-SHA256 (RFC 2104) on hashlib.sha256, which both runtimes have:
# MicroPython has no hmac module. Keys longer than the 64-byte block are
# hashed first, shorter ones padded with zeros.

from hashlib import sha256

_BLOCK = 64


def _pad(key, x):
    out = bytearray(_BLOCK)
    for i in range(len(key)):
        out[i] = key[i] ^ x
    for i in range(len(key), _BLOCK):
        out[i] = x
    return out


class HmacKey:
    # The key's two padded blocks are made once: each tag then costs two
    # hashes and no per-byte Python work on the key.
    def __init__(self, key):
        key = bytes(key)
        if len(key) > _BLOCK:
            key = sha256(key).digest()
        self._ipad = bytes(_pad(key, 0x36))
        self._opad = bytes(_pad(key, 0x5C))

    def digest(self, *parts):
        # the HMAC of the concatenated parts (bytes-like), 32 bytes
        h = sha256(self._ipad)
        for p in parts:
            h.update(p)
        o = sha256(self._opad)
        o.update(h.digest())
        return o.digest()


def hmac_sha256(key, msg):
    return HmacKey(key).digest(msg)


def same(a, b):
    # compare tags in time that does not depend on where they differ
    if len(a) != len(b):
        return False
    d = 0
    for i in range(len(a)):
        d |= a[i] ^ b[i]
    return d == 0
