# Field kinds of acomm.codec: round trips of random and boundary values,
# bit widths, quantization error, strict and saturating encodes, impossible
# codes on decode, and the 6-bit alphabet. Each field is driven through a
# one-field Message, which is how fields are used.

from acomm.codec.bits import BitReader, BitWriter
from acomm.codec.fields import Array, Bool, Bytes, Enum, Fixed, Nested, Optional, UInt, Wide
from acomm.codec.message import Message
from acomm.codec.text6 import Text6
from acomm.codec import text6
from acomm.codec.fields import width
from acomm.errors import DecodeError, EncodeError
from acomm.prng import Prng
from checks import near, raises
from codec_gen import boundary_values, random_value, same


def _msg(f):
    return Message("m", 0, (f,))


def _rt(f, v):
    m = _msg(f)
    data = m.encode({f.name: v})
    return m.decode(data)[f.name]


def _bits_of(f, v):
    w = BitWriter(bytearray(64))
    _msg(f).encode_into(w, {f.name: v})
    return w.bit_length


def _enc_err(f, v):
    e = raises(EncodeError, _msg(f).encode, {f.name: v})
    assert e.message == "m" and e.field.startswith(f.name), (e.message, e.field)
    assert str(e).startswith("m." + e.field + ": "), str(e)
    return e


def _dec_err(f, code_bits):
    # decode a body made of the given (value, nbits) pieces
    w = BitWriter(bytearray(64))
    for v, n in code_bits:
        w.write(v, n)
    e = raises(DecodeError, _msg(f).decode_from, BitReader(w.getvalue()))
    assert e.field is not None and e.field.startswith(f.name), e.field
    assert str(e).startswith("m." + f.name), str(e)
    return e


def _property(f, rng, n=200):
    # random values within range, then the boundaries: each round trips
    # within the field's tolerance and never exceeds max_bits
    for _ in range(n):
        v = random_value(f, rng)
        got = _rt(f, v)
        assert same(f, v, got), (f.name, v, got)
        assert f.min_bits <= _bits_of(f, v) <= f.max_bits


def test_width_is_the_smallest_that_holds_every_code():
    assert [width(n) for n in (0, 1, 2, 3, 4, 255, 256, 1023, 1024)] == [0, 1, 2, 2, 3, 8, 9, 10, 11]
    assert width(1 << 40) == 41


def test_uint_random_and_boundaries():
    rng = Prng(11)
    for lo, hi, bits in ((0, 1, 1), (0, 255, 8), (-40, 85, 7), (5, 5, 0), (0, 100, 7), (-(1 << 39), 1 << 39, 41)):
        f = UInt("u", lo, hi)
        assert f.bits == f.max_bits == f.min_bits == bits, (lo, hi, f.bits)
        _property(f, rng, 60)
        for v in boundary_values(f):
            assert _rt(f, v) == v
            assert _bits_of(f, v) == bits


def test_uint_strict_names_the_field_and_saturates_on_request():
    f = UInt("battery", 0, 100)
    for v in (-1, 101, 1 << 70):
        e = _enc_err(f, v)
        assert "outside [0, 100]" in e.detail
    _enc_err(f, 3.0)
    _enc_err(f, "7")
    s = UInt("battery", 0, 100, saturate=True)
    assert _rt(s, -5) == 0 and _rt(s, 1000) == 100 and _rt(s, 55) == 55


def test_uint_impossible_code_is_a_decode_error():
    f = UInt("leg", 0, 4)  # 5 codes in 3 bits
    assert f.bits == 3
    e = _dec_err(f, ((5, 3),))
    assert "code 5" in e.detail
    _dec_err(f, ((7, 3),))


def test_fixed_bit_widths_and_steps():
    cases = (
        ((0, 64, 0.5), 128, 8),
        ((0, 63.5, 0.5), 127, 7),
        ((-51.1, 51.2, 0.1), 1023, 10),
        ((0, 1, 1 / 15), 15, 4),
        ((0, 360, 0.35), 1029, 11),
        ((0, 360, 360 / 1023), 1023, 10),
        ((-1, 1, 0.1), 20, 5),
        ((3, 3, 0.1), 0, 0),
    )
    for (lo, hi, res), steps, bits in cases:
        f = Fixed("x", lo, hi, res)
        assert f.steps == steps and f.bits == bits, (lo, hi, res, f.steps, f.bits)


def test_fixed_error_at_most_half_a_step_random_ranges():
    rng = Prng(5)
    for _ in range(60):
        lo = rng.range(-100000, 100000) / 100.0
        res = rng.range(1, 5000) / 1000.0
        hi = lo + res * rng.range(1, 5000) + rng.range(0, 999) / 1000.0 * res
        f = Fixed("x", lo, hi, res)
        worst = 0.0
        for _ in range(40):
            v = random_value(f, rng)
            got = _rt(f, v)
            assert lo <= got <= hi, (lo, hi, got)
            worst = max(worst, abs(got - v))
        assert worst <= res / 2 + near(abs(lo) + abs(hi)), (lo, hi, res, worst)


def test_fixed_boundaries_are_exact_and_the_max_is_reachable():
    for lo, hi, res in ((0, 64, 0.5), (-51.1, 51.2, 0.1), (0, 1, 1 / 15), (0, 360, 0.35), (0, 360, 360 / 1023), (-90, 90, 1 / 3600)):
        f = Fixed("x", lo, hi, res)
        assert _rt(f, lo) == lo
        assert _rt(f, hi) == hi, (lo, hi, res, _rt(f, hi))
        assert abs(_rt(f, lo + res) - (lo + res)) < near(abs(lo) + abs(hi))
        assert abs(_rt(f, hi - res) - (hi - res)) <= res / 2 + near(abs(lo) + abs(hi))
        # every decoded value re-encodes to itself
        for v in boundary_values(f):
            once = _rt(f, v)
            assert _rt(f, once) == once


def test_fixed_rounds_to_nearest():
    f = Fixed("x", 0, 10, 1)
    assert _rt(f, 2.49) == 2 and _rt(f, 2.5) == 3 and _rt(f, 2.51) == 3 and _rt(f, 9.6) == 10
    g = Fixed("y", -51.1, 51.2, 0.1)
    assert abs(_rt(g, 0.04)) < near(102)
    assert abs(_rt(g, -0.06) + 0.1) < near(102)


def test_fixed_strict_saturating_and_nan():
    f = Fixed("depth", 0, 63.5, 0.5)
    for v in (-0.3, 63.8, 1e9, float("nan"), float("inf")):
        _enc_err(f, v)
    _enc_err(f, "deep")
    # float noise under a thousandth of a step still counts as the bound
    assert _rt(f, 63.5 + 1e-9) == 63.5 and _rt(f, -1e-9) == 0
    s = Fixed("depth", 0, 63.5, 0.5, saturate=True)
    assert _rt(s, 70) == 63.5 and _rt(s, -2) == 0 and _rt(s, float("inf")) == 63.5
    _enc_err(s, float("nan"))


def test_fixed_impossible_code_is_a_decode_error():
    f = Fixed("x", 0, 5, 1)  # 6 codes in 3 bits
    assert f.bits == 3
    _dec_err(f, ((6, 3),))
    assert _msg(f).decode_from(BitReader(bytes([5 << 5])))["x"] == 5


def test_enum_round_trip_and_errors():
    labels = ("a", "b", "c", "d", "e")
    f = Enum("mode", labels)
    assert f.bits == 3 and abs(f.limit_bits - 2.321928) < 1e-5
    for lab in labels:
        assert _rt(f, lab) == lab
    _property(f, Prng(3), 30)
    e = _enc_err(f, "z")
    assert "'z'" in e.detail
    _enc_err(f, 0)
    _dec_err(f, ((5, 3),))
    assert Enum("one", ("only",)).bits == 0
    raises(ValueError, Enum, "dup", ("a", "a"))


def test_bool():
    f = Bool("flag")
    assert f.bits == 1
    assert _rt(f, True) is True and _rt(f, False) is False
    _enc_err(f, 1)
    _enc_err(f, None)


def test_bytes_fixed_and_variable():
    rng = Prng(8)
    fx = Bytes("key", 4, fixed=True)
    assert fx.max_bits == fx.min_bits == 32 and fx.limit_bits == 32
    _property(fx, rng, 30)
    _enc_err(fx, b"abc")
    _enc_err(fx, "abcd")
    var = Bytes("blob", 10)
    assert var.len_bits == 4 and var.max_bits == 84 and var.min_bits == 4
    _property(var, rng, 60)
    assert _rt(var, b"") == b"" and _rt(var, bytearray(b"xy")) == b"xy"
    assert _bits_of(var, b"abc") == 4 + 24
    _enc_err(var, bytes(11))
    e = _dec_err(var, ((11, 4),))
    assert "length 11" in e.detail
    # a length that lies about what follows
    _dec_err(var, ((9, 4), (0xAB, 8)))


def test_text6_code_table():
    assert text6.ALPHABET == "abcdefghijklmnopqrstuvwxyz0123456789.,?! \n"
    assert text6.END == 42
    assert text6.code_of("a") == 0 and text6.code_of("z") == 25
    assert text6.code_of("0") == 26 and text6.code_of("9") == 35
    assert [text6.code_of(c) for c in ".,?! \n"] == [36, 37, 38, 39, 40, 41]
    for c in "A@_-\t\x00é":
        assert text6.code_of(c) == 255


def test_text6_round_trip_every_character_and_end():
    f = Text6("chat", 50)
    s = text6.ALPHABET
    assert _rt(f, s) == s
    assert _bits_of(f, s) == 6 * len(s) + 6  # shorter than max: END follows
    assert _rt(f, "") == "" and _bits_of(f, "") == 6
    full = Text6("chat", 5)
    assert _rt(full, "hello") == "hello" and _bits_of(full, "hello") == 30  # no END when full
    assert full.max_bits == 30 and full.min_bits == 6
    _property(Text6("t", 12), Prng(4), 100)
    # the exact bits of "hi!" + END
    w = BitWriter(bytearray(8))
    _msg(Text6("t", 8)).encode_into(w, {"t": "hi!"})
    r = BitReader(w.getvalue())
    assert [r.read(6) for _ in range(4)] == [7, 8, 39, 42]


def test_text6_rejects_what_is_not_in_the_alphabet():
    f = Text6("chat", 10)
    e = _enc_err(f, "Hello")
    assert "'H'" in e.detail and "at 0" in e.detail
    _enc_err(f, "tab\there")
    _enc_err(f, "x" * 11)
    _enc_err(f, b"bytes")
    for code in (43, 50, 63):
        e = _dec_err(f, ((0, 6), (code, 6)))
        assert "reserved 6-bit code %d" % code in e.detail
    # running out of bits before END
    _dec_err(f, ((0, 6), (1, 6)))
    assert text6.clean("Hello, World_1!") == "hello, world?1!"


def test_text6_limit_bits():
    assert Text6("t", 0).limit_bits == 0 and Text6("t", 0).max_bits == 0
    # 1 + 42 strings of at most one character
    assert abs(Text6("t", 1).limit_bits - 5.426264754702098) < near(5.43)
    t = Text6("t", 20)
    assert 20 * 5.3923 < t.limit_bits < 20 * 5.3923 + 0.05


def test_optional():
    rng = Prng(12)
    f = Optional(Fixed("temp", -2, 40, 0.1))
    assert f.name == "temp" and f.max_bits == 10 and f.min_bits == 1
    assert _rt(f, None) is None and _bits_of(f, None) == 1
    assert abs(_rt(f, 12.34) - 12.3) < 1e-9
    _property(f, rng, 60)
    _enc_err(f, 50)
    # log2(1 + 421) values
    assert abs(f.limit_bits - 8.72109) < 1e-4


def test_array_fixed_and_bounded():
    rng = Prng(13)
    fx = Array(UInt("rpm", 0, 15), 6, fixed=True)
    assert fx.max_bits == fx.min_bits == 24 and fx.limit_bits == 24
    _property(fx, rng, 40)
    _enc_err(fx, [1, 2, 3])
    var = Array(UInt("rpm", 0, 15), 6)
    assert var.count_bits == 3 and var.max_bits == 27 and var.min_bits == 3
    _property(var, rng, 60)
    assert _rt(var, []) == []
    _enc_err(var, [0] * 7)
    e = _enc_err(var, [1, 2, 16])
    assert e.field == "rpm[2]", e.field
    _dec_err(var, ((7, 3),))
    _enc_err(var, "abc")


def test_nested_and_paths_of_errors():
    pos = Message("pos", 0, (Fixed("x", -10, 10, 0.5), Fixed("y", -10, 10, 0.5)))
    f = Nested("where", pos)
    assert f.max_bits == 12 and f.limit_bits == pos.limit_bits
    assert _rt(f, {"x": 1.0, "y": -2.5}) == {"x": 1.0, "y": -2.5}
    _property(f, Prng(14), 40)
    e = _enc_err(f, {"x": 1.0, "y": 11})
    assert e.field == "where.y" and str(e).startswith("m.where.y: "), str(e)
    e = _enc_err(f, {"x": 1.0})
    assert e.field == "where.y" and e.detail == "missing"
    track = Array(Nested("track", pos), 3)
    e = _enc_err(track, [{"x": 0, "y": 0}, {"x": 0, "y": 99}])
    assert e.field == "track[1].y", e.field
    e = _dec_err(track, ((2, 2), (0, 12)))
    assert e.field == "track[1].x", e.field


def test_wide_keeps_its_width_and_rejects_codes_past_the_inner_range():
    f = Wide(Fixed("lat", -90, 90, 1 / 3600), 22)
    assert f.bits == f.max_bits == 22 and f.field.bits == 20
    assert abs(f.limit_bits - 19.30565) < 1e-4
    _property(f, Prng(15), 60)
    assert abs(_rt(f, 45.5) - 45.5) < near(180)
    assert _bits_of(f, 0.0) == 22
    _dec_err(f, ((648001, 22),))
    _enc_err(f, 91)
    raises(ValueError, Wide, UInt("u", 0, 255), 7)


def test_declaration_errors():
    raises(ValueError, UInt, "u", 5, 4)
    raises(ValueError, Fixed, "f", 0, 1, 0)
    raises(ValueError, Fixed, "f", 1, 0, 0.1)
    raises(ValueError, Enum, "e", ())


def test_limit_bits_are_log2_of_distinct_values():
    assert UInt("u", 0, 255).limit_bits == 8
    assert abs(UInt("u", 0, 100).limit_bits - 6.658211) < 1e-6
    assert Fixed("f", 0, 63.5, 0.5).limit_bits == 7
    assert Bool("b").limit_bits == 1
    # 1 + 256 + 256**2 byte strings of at most 2 bytes
    assert abs(Bytes("b", 2).limit_bits - 16.00565) < 1e-4
    # 1 + 4 + 16 lists of at most 2 two-bit items
    assert abs(Array(UInt("u", 0, 3), 2).limit_bits - 4.392317) < 1e-6
    assert Array(UInt("z", 0, 0), 7).limit_bits == 3


def test_fixed_value_table_gives_the_computed_values():
    # a Fixed field of few codes looks its values up (on 64-bit runtimes):
    # the same floats as the computation, for every code, in random ranges
    # and at the top code that float noise pulls off hi
    rng = Prng(31)
    fields = [Fixed("a", -1.0, 1.0, 1 / 15), Fixed("b", -51.1, 51.2, 1.7), Fixed("c", 0.0, 0.3, 0.1)]
    for _ in range(200):
        lo = (rng.below(20001) - 10000) / 100.0
        steps = 1 + rng.below(80)
        res = (1 + rng.below(1000)) / 997.0
        fields.append(Fixed("r", lo, lo + steps * res, res))
    for f in fields:
        for c in range(f.ncodes):
            v = f.value(c)
            assert v == Fixed.value(f, c), (f.lo, f.hi, f.res, c)
            assert f.code(v) == c and f.lo <= v <= f.hi
