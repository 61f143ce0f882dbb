from acomm import frame
from acomm.frame import slip
from acomm.errors import DecodeError, EncodeError
from acomm_sim.fakeuart import uart_pair
from acomm.prng import Prng


def test_escapes_and_overhead():
    data = bytes([1, 0xC0, 2, 0xDB, 3])
    enc = slip.encode(data)
    assert enc == bytes([0xC0, 1, 0xDB, 0xDC, 2, 0xDB, 0xDD, 3, 0xC0])
    assert slip.encoded_len(data) == len(enc)


def test_roundtrip_random_frames_split_anywhere():
    rng = Prng(21)
    dec = slip.SlipDecoder(64)
    for _ in range(300):
        frames = [rng.bytes(rng.range(1, 64)) for _ in range(rng.range(1, 4))]
        stream = b"".join(slip.encode(f) for f in frames)
        out = []
        i = 0
        while i < len(stream):
            step = rng.range(1, 7)
            dec.feed(stream[i : i + step], out)
            i += step
        assert out == frames


def test_noise_between_frames_resyncs():
    dec = slip.SlipDecoder(64)
    out = []
    good = frame.encode_raw(frame.Frame(frame.DATA, 1, 2, 3, b"hello"))
    dec.feed(b"\x01\x02garbage" + slip.encode(good) + b"\xdb\x00noise" + slip.encode(good), out)
    # noise before the first END is taken for a frame; the CRC rejects it
    decoded = []
    for f in out:
        try:
            decoded.append(frame.decode_raw(f))
        except DecodeError:
            pass
    assert [d.payload for d in decoded] == [b"hello", b"hello"]
    assert dec.bad_escapes == 1


def test_oversize_frames_are_dropped_and_counted():
    dec = slip.SlipDecoder(8)
    out = []
    dec.feed(slip.encode(bytes(20)) + slip.encode(b"ok"), out)
    assert out == [b"ok"]
    assert dec.oversize == 1


def test_encode_into_small_buffer():
    try:
        slip.encode_into(bytearray(4), b"\xc0\xc0")
        assert False
    except EncodeError:
        pass
    buf = bytearray(6)
    assert slip.encode_into(buf, b"\xc0\xc0") == 6


def test_over_fakeuart_with_split_writes():
    a, b = uart_pair()
    a.set_faults(split=3)
    dec = slip.SlipDecoder(64)
    out = []
    for k in range(5):
        a.write(slip.encode(bytes([k]) * 10))
    for _ in range(200):
        chunk = b.read()
        if chunk:
            dec.feed(chunk, out)
        a.clock.advance(1)
    assert out == [bytes([k]) * 10 for k in range(5)]
