from acomm.codec.compress import compress, decompress
from acomm.errors import DecodeError
from acomm.prng import Prng

LOG = (
    b"t00.10 depth 7.5m air 204 hr 70\n"
    b"t00.20 depth 9.9m air 203 hr 69\n"
    b"t00.30 depth 11.9m air 203 hr 69\n"
)

CHAT = b"diver 2: need air, ascending now. surface: boat at north buoy, stop at 5m for 3 min"


def _text(nlines, seed=4):
    # dive-log-like lines built from integers (same bytes on both runtimes)
    rng = Prng(seed)
    out = bytearray()
    depth, air = 40, 205
    for k in range(nlines):
        depth += rng.below(7) - 3
        air -= rng.below(2)
        out.extend(b"t%02d.%d0 depth %d.%dm air %d hr %d\n" % (k // 6, k % 6, depth // 10, depth % 10, air, 60 + rng.below(30)))
    return bytes(out)


def _samples():
    rng = Prng(11)
    return [b"", b"A", b"ab", LOG, CHAT, bytes(300), rng.bytes(64), _text(8), bytes(range(256)) + bytes(range(256))]


def test_round_trip():
    for s in _samples():
        c = compress(s)
        assert decompress(c, len(s)) == s
        assert decompress(c, len(s) + 100) == s


def test_round_trip_other_buffers():
    s = _text(10)
    assert decompress(compress(bytearray(s)), len(s)) == s
    assert decompress(compress(memoryview(s)), len(s)) == s
    c = compress(s)
    assert decompress(bytearray(c), len(s)) == s
    assert decompress(memoryview(b"xx" + c)[2:], len(s)) == s


def test_empty_and_tiny_are_stored():
    assert compress(b"") == b"\x00"
    assert compress(b"A") == b"\x04A"
    assert decompress(b"\x00", 0) == b""


def test_pinned_vectors():
    # the same bytes on both runtimes (and across versions: a change to
    # the format or to the compressor's choices shows up here)
    assert compress(LOG).hex() == (
        "86037430302e313020646570746820372e356d20616972203230342068722037300a"
        "afb32c7392e39c733ccd8e710cf1cc4c6c0110"
    )
    assert compress(bytes([0x80, 1, 2]) * 4).hex() == "314000405e10"
    assert compress(bytes(100)).hex() == "920300c062"


def test_incompressible_expansion_bound():
    rng = Prng(5)
    for n in (1, 2, 31, 32, 100, 1000, 4095, 4096, 5000):
        s = rng.bytes(n)
        c = compress(s)
        hdr = 1 if n < 32 else (2 if n < 4096 else 3)
        assert len(c) <= n + hdr
        assert decompress(c, n) == s


def test_all_zero_and_text_shrink():
    z = bytes(2000)
    c = compress(z)
    assert len(c) < 10
    assert decompress(c, 2000) == z
    t = _text(40)
    c = compress(t)
    assert len(c) * 3 < len(t)
    assert decompress(c, len(t)) == t
    c = compress(CHAT)
    assert len(c) < len(CHAT)


def test_seven_and_eight_bit_literals():
    # ASCII input uses 7-bit literals (mode 2), anything else 8-bit (mode 1)
    t = _text(4)
    assert compress(t)[0] & 3 == 2
    b = bytes([200]) + t
    assert compress(b)[0] & 3 == 1
    assert decompress(compress(b), len(b)) == b


def test_max_out_is_enforced():
    t = _text(6)
    c = compress(t)
    for lim in (0, 1, len(t) - 1):
        try:
            decompress(c, lim)
        except DecodeError:
            continue
        assert False, lim
    # a header claiming 1 MiB is refused before anything is allocated
    bomb = bytes([0x82, 0x80, 0x80, 0x02]) + bytes(10)
    try:
        decompress(bomb, 65536)
        assert False
    except DecodeError:
        pass


def _raises_or_bounded(c, max_out):
    try:
        out = decompress(c, max_out)
    except DecodeError:
        return 0
    assert len(out) <= max_out
    return 1


def test_truncated_streams_raise():
    for s in (LOG, _text(6), bytes(300), CHAT):
        c = compress(s)
        for k in range(len(c)):
            try:
                decompress(c[:k], 4096)
                assert False, k
            except DecodeError:
                pass


def test_trailing_bytes_and_bad_headers():
    c = compress(LOG)
    for bad in (c + b"\x00", c + b"\x01", b"\x03", b"\x07", b"\x80", b"\x80\x00", b"\x84\x00A", b"\x08A"):
        try:
            decompress(bad, 4096)
            assert False, bad
        except DecodeError:
            pass


def test_reference_before_start():
    # 4 bytes, 8-bit literals; the first token is a match at offset 1:
    # bits 10 (match) 1 (gamma 1: offset class 0) 000000 (low bits) 1 (len 2)
    bad = bytes([0x11, 0b10100000, 0b01000000])
    try:
        decompress(bad, 100)
        assert False
    except DecodeError:
        pass
    # a match that runs past the stated length
    bad = bytes([0x09, 0b00000000, 0b01101000])  # 2 bytes: literal 0, then rep len 2
    try:
        decompress(bad, 100)
        assert False
    except DecodeError:
        pass


def test_every_single_byte_corruption():
    # never another exception, never more than max_out
    for s in (LOG, _text(5), bytes([0x80, 1, 2]) * 6):
        c = compress(s)
        decoded = 0
        for i in range(len(c)):
            for x in (1, 2, 0x10, 0x80, 0xFF, 0x5A):
                bad = bytearray(c)
                bad[i] ^= x
                decoded += _raises_or_bounded(bad, len(s) + 8)
        # most damage is caught by the strict end-of-stream check
        assert decoded < len(c) * 6


def test_random_input_only_decode_error():
    rng = Prng(9)
    for _ in range(300):
        n = rng.range(0, 40)
        _raises_or_bounded(rng.bytes(n), 200)
