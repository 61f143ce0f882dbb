# Length-prefixed framing (acomm.frame.lenframe): the TCP links' stream format.
from acomm import frame
from acomm.errors import DecodeError, EncodeError
from acomm.frame.lenframe import LenDecoder, append_frame
from acomm.prng import Prng


def test_append_frame_layout_and_bounds():
    out = bytearray()
    append_frame(out, b"abc")
    append_frame(out, bytes(300))
    assert out[:5] == b"\x00\x03abc"
    assert out[5:7] == b"\x01\x2c" and len(out) == 5 + 2 + 300
    for bad in (b"", bytes(65)):
        try:
            append_frame(out, bad, 64)
            assert False, "accepted %d bytes" % len(bad)
        except EncodeError:
            pass
    assert len(out) == 307  # a refused frame leaves nothing behind


def test_frames_split_anywhere():
    rng = Prng(5)
    dec = LenDecoder(200)
    for _ in range(200):
        frames = [rng.bytes(rng.range(1, 200)) for _ in range(rng.range(1, 5))]
        stream = bytearray()
        for f in frames:
            append_frame(stream, f, 200)
        out = []
        i = 0
        while i < len(stream):
            step = rng.range(1, 9)
            dec.feed(bytes(stream[i : i + step]), out)
            i += step
        assert out == frames
        assert dec.pending == 0
    assert dec.frames > 200


def test_one_byte_at_a_time_keeps_partial_state():
    dec = LenDecoder(16)
    out = []
    data = b"\x00\x05hello\x00\x01!"
    for i in range(len(data)):
        dec.feed(data[i : i + 1], out)
        if i == 0:
            assert dec.pending == 1 and out == []
        if i == 4:
            assert dec.pending == 3 and out == []
    assert out == [b"hello", b"!"]


def test_lying_length_is_refused_after_good_frames():
    dec = LenDecoder(64)
    out = []
    good = frame.encode_raw(frame.Frame(frame.DATA, 1, 2, 0, b"ok"))
    stream = bytearray()
    append_frame(stream, good)
    stream.extend(b"\x10\x00" + bytes(20))  # 4096 bytes announced, max 64
    try:
        dec.feed(bytes(stream), out)
        assert False, "a length above max_frame was accepted"
    except DecodeError:
        pass
    assert out == [good]  # what came before the bad length is kept
    assert dec.bad_lengths == 1
    # failed until reset: no guessing where the next frame starts
    try:
        dec.feed(b"\x00\x01x", out)
        assert False
    except DecodeError:
        pass
    assert out == [good]
    dec.reset()
    dec.feed(b"\x00\x01x", out)
    assert out == [good, b"x"]


def test_zero_length_and_text_are_refused():
    for junk in (b"\x00\x00abc", b"GET / HTTP/1.0\r\n\r\n"):
        dec = LenDecoder(1024)
        out = []
        try:
            dec.feed(junk, out)
            assert False, "accepted %r" % junk
        except DecodeError:
            pass
        assert out == [] and dec.bad_lengths == 1


def test_max_frame_bounds():
    for bad in (0, 65536):
        try:
            LenDecoder(bad)
            assert False
        except EncodeError:
            pass
    dec = LenDecoder(3)
    out = []
    dec.feed(b"\x00\x03abc", out)
    assert out == [b"abc"]
