# Route control on the water (acomm.transport.routewire): the four
# messages round-trip at their sizes, encoders refuse what does not fit,
# and the decoder takes only what an encoder could have written, raising
# DecodeError for everything else (random bytes included).

from acomm.errors import DecodeError, EncodeError
from acomm.prng import Prng
from acomm.transport import routing as W
from acomm.transport import flood as F
from acomm.transport.flood import encode_flood
from checks import raises


def test_request_round_trip_and_size():
    b = W.encode_request(200, 3, 65534, 17, W.UNKNOWN_SEQ, 5, 1234)
    assert len(b) == 10
    assert W.decode(b) == ("request", 200, 3, 65534, 17, W.UNKNOWN_SEQ, 5, 1234)
    assert W.decode(W.encode_request(0, 0, 0, 254, 7, 63, 10 ** 9))[-1] == W.MAX_COST  # saturates


def test_reply_round_trip_and_size():
    b = W.encode_reply(17, 42, 3, 2, 96, 60000)
    assert len(b) == 8
    assert W.decode(b) == ("reply", 17, 42, 3, 2, 96, 60000)
    assert W.decode(W.encode_reply(1, 0, 2, 0, 0, 1))[-1] == 4000  # rounds up to one unit
    assert W.decode(W.encode_reply(1, 0, 2, 0, 0, 10 ** 7))[-1] == 255 * 4000


def test_error_round_trip_and_size():
    lost = [(7, 5), (8, 0), (254, 65534)]
    b = W.encode_error(lost)
    assert len(b) == 1 + 3 * 3
    assert W.decode(b) == ("error", lost)
    assert len(W.encode_error([(i, i) for i in range(16)])) == 49


def test_encoders_refuse_what_does_not_fit():
    assert raises(EncodeError, W.encode_request, 256, 3, 1, 4, 1, 0, 0)
    assert raises(EncodeError, W.encode_request, 1, 255, 1, 4, 1, 0, 0)
    assert raises(EncodeError, W.encode_request, 1, 3, W.UNKNOWN_SEQ, 4, 1, 0, 0)  # the origin knows its own
    assert raises(EncodeError, W.encode_request, 1, 3, 1, 4, 1, 64, 0)
    assert raises(EncodeError, W.encode_request, 1, 3, 1, 4, 1, 0, -1)
    assert raises(EncodeError, W.encode_reply, 17, W.UNKNOWN_SEQ, 3, 0, 0, 4000)
    assert raises(EncodeError, W.encode_error, [])
    assert raises(EncodeError, W.encode_error, [(1, 1)] * 17)
    assert raises(EncodeError, W.encode_error, [(1, 1.5)])


def test_decoder_rejects_bad_input_only_with_decode_error():
    bad = [b"", b"\x00", bytes(3), W.encode_request(1, 2, 3, 4, 5, 6, 7)[:-1],
           W.encode_reply(1, 2, 3, 4, 5, 6) + b"\x00", b"\xc0", b"\xc1\x01\x00", b"\xc2\x01\x00\x01",
           b"\xc1\xff\x00\x01", b"\x82\x01\xff\xff\x02\x00\x00\x01", b"\x82\x01\x00\x01\x02\x00\x00\x00",
           b"\x40\x01\xff\x00\x01\x02\x00\x00\x00\x00", b"\x40\x01\x02\xff\xff\x02\x00\x00\x00\x00", bytes.fromhex("4a24e19bf6331501ffff")]
    for b in bad:
        assert raises(DecodeError, W.decode, b), b
    rng = Prng(36)
    for _ in range(3000):
        n = rng.below(14)
        b = bytes(rng.below(256) for _ in range(n))
        try:
            got = W.decode(b)
        except DecodeError:
            continue
        # whatever decodes encodes back to the same bytes
        kind = got[0]
        if kind == "request":
            again = W.encode_request(*got[1:])
        elif kind == "reply":
            again = W.encode_reply(got[1], got[2], got[3], got[4], got[5], got[6])
        elif kind == "flood":
            again = encode_flood(got[1], got[2], got[3], got[4])
        else:
            again = W.encode_error(got[1])
        assert again == b, (b, got)


def test_flood_round_trip_and_size():
    b = encode_flood(3, 200, 5, b"all up")
    assert b == bytes((0x05, 3, 200)) + b"all up"
    assert W.decode(b) == ("flood", 3, 200, 5, b"all up")
    full = encode_flood(254, 255, 63, bytearray(range(F.MAX_DATA)))
    assert len(full) == 3 + F.MAX_DATA == 21  # a sealed elided frame of 30 bytes
    # the flood's own module encodes and decodes it; routing's decode() hands floods to it
    assert F.MAX_HOPS == W.MAX_HOPS and F.decode_flood(full) == W.decode(full)
    assert W.decode(full) == ("flood", 254, 255, 63, bytes(range(F.MAX_DATA)))
    assert W.decode(encode_flood(0, 0, 0, memoryview(b"x"))) == ("flood", 0, 0, 0, b"x")
    # the other kinds decode as before
    assert W.decode(W.encode_error([(1, 2)]))[0] == "error"


def test_flood_encoder_and_decoder_refuse_what_does_not_fit():
    assert raises(EncodeError, encode_flood, 255, 1, 0, b"x")  # the broadcast id
    assert raises(EncodeError, encode_flood, 3, 256, 0, b"x")
    assert raises(EncodeError, encode_flood, 3, -1, 0, b"x")
    assert raises(EncodeError, encode_flood, 3, 1, 64, b"x")
    assert raises(EncodeError, encode_flood, 3, 1, -1, b"x")
    assert raises(EncodeError, encode_flood, 3, 1, 0, b"")
    assert raises(EncodeError, encode_flood, 3, 1, 0, bytes(F.MAX_DATA + 1))
    assert raises(EncodeError, encode_flood, 3, 1, 0, "text")
    assert raises(EncodeError, encode_flood, 3.0, 1, 0, b"x")
    for b in (b"\x00", b"\x00\x03", b"\x05\x03\x01", b"\x00\xff\x01x",
              b"\x00\x03\x01" + bytes(F.MAX_DATA + 1)):
        assert raises(DecodeError, W.decode, b), b
