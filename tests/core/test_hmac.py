# acomm.codec.hmacsha256 against the test vectors of RFC 4231 (HMAC-SHA256),
# including the truncated tag of case 5 and the keys longer than a block.
from acomm.codec.hmacsha256 import HmacKey, hmac_sha256, same


def _h(s):
    return bytes.fromhex(s.replace(" ", ""))


CASES = (
    (b"\x0b" * 20, b"Hi There",
     "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7"),
    (b"Jefe", b"what do ya want for nothing?",
     "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843"),
    (b"\xaa" * 20, b"\xdd" * 50,
     "773ea91e36800e46854db8ebd09181a72959098b3ef8c122d9635514ced565fe"),
    (_h("0102030405060708090a0b0c0d0e0f10111213141516171819"), b"\xcd" * 50,
     "82558a389a443c0ea4cc819899f2083a85f0faa3e578f8077a2e3ff46729665b"),
    (b"\xaa" * 131, b"Test Using Larger Than Block-Size Key - Hash Key First",
     "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54"),
    (b"\xaa" * 131,
     b"This is a test using a larger than block-size key and a larger than block-size data. "
     b"The key needs to be hashed before being used by the HMAC algorithm.",
     "9b09ffa71b942fcb27635fbcd5b0e944bfdc63644f0713938a7f51535c3a35e2"),
)


def test_rfc4231_vectors():
    for key, msg, want in CASES:
        assert hmac_sha256(key, msg) == _h(want)


def test_rfc4231_case_5_truncated_to_128_bits():
    got = hmac_sha256(b"\x0c" * 20, b"Test With Truncation")[:16]
    assert got == _h("a3b6167473100ee06e0c796c2955552b")


def test_parts_hash_as_their_concatenation():
    k = HmacKey(b"Jefe")
    assert k.digest(b"what do ya ", b"want ", b"for nothing?") == _h(CASES[1][2])
    assert k.digest(b"what do ya want for nothing?") == k.digest(memoryview(b"what do ya want for nothing?"))


def test_same_compares_whole_tags():
    assert same(b"\x01\x02\x03\x04", bytearray(b"\x01\x02\x03\x04"))
    assert not same(b"\x01\x02\x03\x04", b"\x01\x02\x03\x05")
    assert not same(b"\x01\x02\x03", b"\x01\x02\x03\x04")
