# Bit packing tests (acomm.codec.bits). Plain functions with bare asserts: they run
# under pytest on CPython and under tools/mp_runtests.py on MicroPython.

from acomm.codec.bits import BitReader, BitWriter
from acomm.errors import DecodeError, EncodeError
from acomm.prng import Prng
from checks import raises as _raises


def _random_fields(rng, count):
    fields = []
    for _ in range(count):
        w = rng.range(1, 64)
        signed = rng.below(2) == 1
        pick = rng.below(8)
        if signed:
            lo = -(1 << (w - 1))
            hi = (1 << (w - 1)) - 1
        else:
            lo = 0
            hi = (1 << w) - 1
        if pick == 0:
            v = lo
        elif pick == 1:
            v = hi
        else:
            v = lo + rng.below(hi - lo + 1)
        fields.append((w, signed, v))
    return fields


def test_round_trip_random_widths_signed_and_unsigned():
    rng = Prng(31)
    buf = bytearray(600)  # 100 fields of at most 64 bits
    w = BitWriter(buf)
    for _ in range(40):
        w.reset()
        fields = _random_fields(rng, 100)
        total = 0
        for width, signed, v in fields:
            if signed:
                w.write_signed(v, width)
            else:
                w.write(v, width)
            total += width
        assert w.bit_length == total
        assert len(w) == (total + 7) // 8
        data = w.getvalue()
        assert len(data) == len(w)
        r = BitReader(data)
        for width, signed, v in fields:
            got = r.read_signed(width) if signed else r.read(width)
            assert got == v, (width, signed, v, got)
        assert r.position == total
        assert 0 <= r.remaining < 8
        # padding bits of the last byte are zero
        assert r.read(r.remaining) == 0


def test_msb_first_byte_exact():
    buf = bytearray(8)
    w = BitWriter(buf)
    w.write(0b101, 3)
    w.write(0x1F, 5)
    assert w.getvalue() == b"\xbf"
    w.reset()
    w.write(1, 1)
    assert w.getvalue() == b"\x80"
    w.reset()
    w.write(0xABC, 12)
    w.write(0xD, 4)
    assert w.getvalue() == b"\xab\xcd"
    w.reset()
    w.write_signed(-1, 4)
    w.write_signed(-8, 4)
    w.write_signed(1, 3)
    assert w.getvalue() == b"\xf8\x20"
    w.reset()
    w.write(0x0123456789ABCDEF, 64)
    assert w.getvalue() == b"\x01\x23\x45\x67\x89\xab\xcd\xef"
    r = BitReader(b"\xbf")
    assert r.read(3) == 0b101
    assert r.read(5) == 0x1F
    r = BitReader(b"\xf8")
    assert r.read_signed(4) == -1
    assert r.read_signed(4) == -8


def test_unaligned_write_bytes_and_read_bytes():
    buf = bytearray(8)
    w = BitWriter(buf)
    w.write(1, 3)
    w.write_bytes(b"\xff\x00\xaa")
    # 001 11111111 00000000 10101010 -> 0011 1111 | 1110 0000 | 0001 0101 | 0100 0000
    assert w.getvalue() == b"\x3f\xe0\x15\x40"
    assert w.bit_length == 27
    r = BitReader(w.getvalue())
    assert r.read(3) == 1
    got = r.read_bytes(3)
    assert bytes(got) == b"\xff\x00\xaa"
    assert r.remaining == 5
    # random offsets 0..7, random data
    rng = Prng(8)
    for _ in range(100):
        off = rng.below(8)
        data = rng.bytes(rng.below(20))
        wbuf = bytearray(24)
        w = BitWriter(wbuf)
        w.write(0, off)  # off may be 0: a zero-width zero writes nothing
        w.write_bytes(data)
        w.write(1, 1)
        r = BitReader(wbuf, w.bit_length)
        assert r.read(off) == 0
        assert bytes(r.read_bytes(len(data))) == data
        assert r.read(1) == 1
        assert r.remaining == 0


def test_write_bytes_accepts_bytearray_and_memoryview():
    buf = bytearray(6)
    w = BitWriter(buf)
    w.write_bytes(bytearray(b"ab"))
    w.write_bytes(memoryview(b"xcdx")[1:3])
    w.write(0xF, 4)
    w.write_bytes(memoryview(b"e"))
    assert w.getvalue() == b"abcd\xf6\x50"


def test_read_bytes_aligned_returns_the_input():
    data = b"\x00\x01hello\xff"
    r = BitReader(data)
    assert bytes(r.read_bytes(2)) == b"\x00\x01"
    assert bytes(r.read_bytes(5)) == b"hello"
    assert bytes(r.read_bytes(0)) == b""
    assert bytes(r.read_bytes(1)) == b"\xff"
    assert r.remaining == 0
    r = BitReader(bytearray(data))
    assert bytes(r.read_bytes(len(data))) == data


def test_reset_does_not_leak_old_bits():
    buf = bytearray(4)
    w = BitWriter(buf)
    w.write(0xFFFFFFFF, 32)
    assert w.getvalue() == b"\xff\xff\xff\xff"
    w.reset()
    assert w.bit_length == 0 and len(w) == 0 and w.getvalue() == b""
    w.write(0, 1)
    assert w.getvalue() == b"\x00"
    w.write(1, 1)
    assert w.getvalue() == b"\x40"
    w.write(0, 10)
    assert w.getvalue() == b"\x40\x00"
    # unaligned bytes after reset over a dirty buffer
    w.reset()
    for i in range(4):
        buf[i] = 0xFF
    w.write(0, 4)
    w.write_bytes(b"\x00\x01")
    assert w.getvalue() == b"\x00\x00\x10"
    # aligned bytes then bits over a dirty buffer
    w.reset()
    for i in range(4):
        buf[i] = 0xFF
    w.write_bytes(b"\x12")
    w.write(0, 3)
    assert w.getvalue() == b"\x12\x00"
    # a random dirty buffer never changes what a fresh writer would produce
    rng = Prng(12)
    for _ in range(100):
        fields = _random_fields(rng, 4)
        dirty = bytearray(rng.bytes(32))
        clean = bytearray(32)
        outs = []
        for b in (dirty, clean):
            bw = BitWriter(b)
            bw.write(rng.below(2), 1)  # consume a bit so both are unaligned...
            bw.reset()  # ...then start over
            for width, signed, v in fields:
                if signed:
                    bw.write_signed(v, width)
                else:
                    bw.write(v, width)
            outs.append(bw.getvalue())
        assert outs[0] == outs[1]


def test_overflow_raises_encode_error():
    buf = bytearray(2)
    w = BitWriter(buf)
    _raises(EncodeError, w.write, 0, 17)
    assert w.bit_length == 0
    w.write(0xABCD, 16)
    _raises(EncodeError, w.write, 0, 1)
    _raises(EncodeError, w.write_signed, 0, 1)
    _raises(EncodeError, w.write_bytes, b"\x00")
    assert w.getvalue() == b"\xab\xcd"
    w.reset()
    _raises(EncodeError, w.write_bytes, b"abc")  # aligned
    w.write(0, 1)
    _raises(EncodeError, w.write_bytes, b"ab")  # unaligned
    w = BitWriter(bytearray(0))
    _raises(EncodeError, w.write, 1, 1)
    w.write(0, 0)  # a zero-width zero is nothing, and fits anywhere
    assert w.bit_length == 0


def test_value_that_does_not_fit_raises_encode_error():
    w = BitWriter(bytearray(24))
    _raises(EncodeError, w.write, 8, 3)
    _raises(EncodeError, w.write, -1, 3)
    _raises(EncodeError, w.write, 1 << 64, 64)
    _raises(EncodeError, w.write, 1, 0)
    _raises(EncodeError, w.write, 0, -1)
    _raises(EncodeError, w.write_signed, 4, 3)
    _raises(EncodeError, w.write_signed, -5, 3)
    _raises(EncodeError, w.write_signed, 1 << 63, 64)
    _raises(EncodeError, w.write_signed, -(1 << 63) - 1, 64)
    _raises(EncodeError, w.write_signed, 1, 1)
    assert w.bit_length == 0  # nothing partial was written
    w.write(7, 3)
    w.write_signed(3, 3)
    w.write_signed(-4, 3)
    w.write_signed(-1, 1)
    w.write((1 << 64) - 1, 64)
    w.write_signed(-(1 << 63), 64)
    r = BitReader(w.getvalue())
    assert r.read(3) == 7
    assert r.read_signed(3) == 3
    assert r.read_signed(3) == -4
    assert r.read_signed(1) == -1
    assert r.read(64) == (1 << 64) - 1
    assert r.read_signed(64) == -(1 << 63)


def test_read_past_end_raises_decode_error():
    r = BitReader(b"\xab")
    _raises(DecodeError, r.read, 9)
    assert r.position == 0
    assert r.read(5) == 0x15
    _raises(DecodeError, r.read, 4)
    _raises(DecodeError, r.read_signed, 4)
    _raises(DecodeError, r.read_bytes, 1)  # unaligned
    _raises(DecodeError, r.skip, 4)
    _raises(DecodeError, r.skip, -1)
    _raises(DecodeError, r.read, -1)
    assert r.read(3) == 0b011
    assert r.read(0) == 0
    _raises(DecodeError, r.read, 1)
    _raises(DecodeError, r.read_bytes, 1)  # aligned
    r = BitReader(b"")
    _raises(DecodeError, r.read, 1)
    assert r.remaining == 0
    r = BitReader(b"ab")
    r.skip(8)
    assert r.read(8) == ord("b")


def test_reader_nbits_limit():
    r = BitReader(b"\xff\xff", 9)
    assert r.remaining == 9
    assert r.read(9) == 0x1FF
    _raises(DecodeError, r.read, 1)
    r = BitReader(b"\xff\xff", 12)
    _raises(DecodeError, r.read_bytes, 2)
    assert bytes(r.read_bytes(1)) == b"\xff"
    _raises(DecodeError, r.read, 5)
    assert r.read(4) == 0xF
    assert BitReader(b"\xff", 0).remaining == 0
    assert BitReader(b"\xff", 8).remaining == 8
    _raises(DecodeError, BitReader, b"\xff", 9)
    _raises(DecodeError, BitReader, b"\xff", -1)
    # the writer's bit_length round-trips as a reader limit
    buf = bytearray(4)
    w = BitWriter(buf)
    w.write(5, 3)
    r = BitReader(buf, w.bit_length)
    assert r.read(3) == 5
    _raises(DecodeError, r.read, 1)


def test_writer_on_memoryview():
    buf = bytearray(b"\xee" * 6)
    w = BitWriter(memoryview(buf)[1:5])
    w.write(0xABC, 12)
    w.write_bytes(b"\x12")
    w.write(0xD, 4)
    assert bytes(buf) == b"\xee\xab\xc1\x2d\xee\xee"
    _raises(EncodeError, w.write, 0, 9)
