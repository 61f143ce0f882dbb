# IMC packets against the byte-exact vectors of ref/imc.md 1.6, in both byte
# orders, and the integer-only fp64 behind the timestamp.

import struct
from binascii import unhexlify

from acomm import imc
from acomm.codec.crc import crc16
from acomm.errors import CRCError, DecodeError, EncodeError
from acomm.imc import fp64
from acomm.prng import Prng
from checks import need_double

TS = 1700000000
NAME = "lauv-xplore-1"
TX = {"abbrev": "UamTxFrame", "seq": 7, "sys_dst": NAME, "flags": 1, "data": b"hello"}
TR = {
    "abbrev": "TransmissionRequest",
    "req_id": 42,
    "comm_mean": 1,
    "destination": NAME,
    "deadline": 1700000060.0,
    "range": 0.0,
    "data_mode": 0,
    "msg_data": {"abbrev": "Abort"},
    "txt_data": "",
    "raw_data": b"",
}
ANN = {
    "abbrev": "Announce",
    "sys_name": NAME,
    "sys_type": 2,
    "owner": 0xFFFF,
    "lat": 0.7222,
    "lon": -0.1527,
    "height": 10.0,
    "services": "imc+udp://10.0.0.5:6002/",
}

# (message, src_ent, dst, little-endian packet as in ref/imc.md 1.6)
VECTORS = (
    ({"abbrev": "Heartbeat"}, 0xFF, 0xFFFF, "54fe9600000000000040fc54d9413412ffffffff96af"),
    ({"abbrev": "Abort"}, 0, 0x0016, "54fe2602000000000040fc54d9413412001600ffb138"),
    (
        TX,
        0xFF,
        0xFFFF,
        "54fe2e03190000000040fc54d9413412ffffffff07000d006c6175762d78706c6f72652d3101050068656c6c6f7d95",
    ),
    (
        {"abbrev": "UamTxStatus", "seq": 7, "value": 9, "error": ""},
        0xFF,
        0xFFFF,
        "54fe3003050000000040fc54d9413412ffffffff0700090000737e",
    ),
    (
        TR,
        0xFF,
        0xFFFF,
        "54fe0302250000000040fc54d9413412ffffffff2a00010d006c6175762d78706c6f72652d31"
        "0000004ffc54d9410000000000260200000000ea7e",
    ),
    (
        ANN,
        0xFF,
        0,
        "54fe9700400000000040fc54d9413412ff0000ff0d006c6175762d78706c6f72652d3102ffff787aa52c431ce73f"
        "96b20c71ac8bc3bf000020411800696d632b7564703a2f2f31302e302e302e353a363030322f25d0",
    ),
)
# The same UamTxFrame big-endian, as pyimclsts writes it (ref/imc.md 1.6).
TX_BE = "fe54032e001941d954fc400000001234ffffffff0007000d6c6175762d78706c6f72652d3101000568656c6c6fb71e"


def _be_packet(mgid, payload, src=0x1234, src_ent=0xFF, dst=0xFFFF, dst_ent=0xFF):
    # A big-endian packet built with struct, independently of the codec.
    body = struct.pack(">HHHdHBHB", 0xFE54, mgid, len(payload), float(TS), src, src_ent, dst, dst_ent) + payload
    return body + struct.pack(">H", crc16(body))


def _be_text(s):
    return struct.pack(">H", len(s)) + s


# Big-endian twins of the vectors, field by field.
BE_VECTORS = (
    (VECTORS[0][0], _be_packet(150, b"")),
    (VECTORS[1][0], _be_packet(550, b"", src_ent=0, dst=0x16)),
    (TX, unhexlify(TX_BE)),
    (VECTORS[3][0], _be_packet(816, struct.pack(">HB", 7, 9) + _be_text(b""))),
    (
        TR,
        _be_packet(
            515,
            struct.pack(">HB", 42, 1)
            + _be_text(NAME.encode())
            + struct.pack(">dfBH", 1700000060.0, 0.0, 0, 550)
            + _be_text(b"")
            + _be_text(b""),
        ),
    ),
    (
        ANN,
        _be_packet(
            151,
            _be_text(NAME.encode()) + struct.pack(">BHddf", 2, 0xFFFF, 0.7222, -0.1527, 10.0) + _be_text(ANN["services"].encode()),
            dst=0,
        ),
    ),
)


def test_encoder_reproduces_every_vector():
    need_double("IMC's fp64 fields")
    for msg, src_ent, dst, want in VECTORS:
        got = imc.encode(msg, src=0x1234, dst=dst, timestamp=TS, src_ent=src_ent, dst_ent=0xFF)
        assert got == unhexlify(want), msg["abbrev"]
    assert len(unhexlify(VECTORS[5][3])) == 86 and len(unhexlify(VECTORS[2][3])) == 47


def test_encoder_big_endian_vector():
    assert imc.encode(TX, 0x1234, 0xFFFF, TS, big=True) == unhexlify(TX_BE)
    # crc over the big-endian bytes is another value (ref/imc.md 1.3)
    assert unhexlify(TX_BE)[-2:] == b"\xb7\x1e"
    for msg, data in BE_VECTORS:
        src_ent = 0 if msg["abbrev"] == "Abort" else 0xFF
        dst = {"Abort": 0x16, "Announce": 0}.get(msg["abbrev"], 0xFFFF)
        assert imc.encode(msg, 0x1234, dst, TS, src_ent, 0xFF, big=True) == data, msg["abbrev"]


def _check_decoded(p, msg, src_ent, dst, big):
    assert p.msg == msg, (p.msg, msg)
    assert p.mgid == imc.by_name(msg["abbrev"])[0]
    assert (p.src, p.src_ent, p.dst, p.dst_ent) == (0x1234, src_ent, dst, 0xFF)
    assert p.timestamp == 1700000000.0
    assert p.big == big
    assert p.payload is None


def test_decoder_reads_every_vector_in_both_orders():
    for i in range(len(VECTORS)):
        msg, src_ent, dst, le = VECTORS[i]
        _check_decoded(imc.decode(unhexlify(le)), msg, src_ent, dst, False)
        _check_decoded(imc.decode(BE_VECTORS[i][1]), msg, src_ent, dst, True)
        # and from any buffer type
        _check_decoded(imc.decode(bytearray(unhexlify(le))), msg, src_ent, dst, False)
        _check_decoded(imc.decode(memoryview(BE_VECTORS[i][1])), msg, src_ent, dst, True)


def test_exact_decode_keeps_fp64_bits():
    need_double("IMC's fp64 fields")
    p = imc.decode(unhexlify(VECTORS[4][3]), exact=True)
    assert p.timestamp == imc.F64(0x41D954FC40000000)
    assert p.timestamp.micros() == TS * 1000000
    assert p.msg["deadline"].micros() == 1700000060 * 1000000
    p = imc.decode(BE_VECTORS[5][1], exact=True)
    assert p.msg["lat"].bits == struct.unpack("<Q", struct.pack("<d", 0.7222))[0]
    assert p.msg["lon"].to_float() == -0.1527
    # an F64 encodes as itself
    assert imc.encode(p.msg, 0x1234, 0, p.timestamp) == unhexlify(VECTORS[5][3])


def test_timestamp_from_integers():
    need_double("IMC's fp64 fields")
    # 1.7e9 s with microseconds: the MCU's way in, exact to the bit
    t = imc.F64.seconds(TS, 250000)
    assert t.bits == struct.unpack("<Q", struct.pack("<d", 1700000000.25))[0]
    data = imc.encode({"abbrev": "Heartbeat"}, 1, 2, t)
    assert data[6:14] == struct.pack("<d", 1700000000.25)
    rng = Prng(11)
    for _ in range(300):
        s = rng.range(0, 4000000000)
        us = rng.below(1000000)
        f = imc.F64.seconds(s, us)
        # doubles near 4e9 s step by 0.5 us at most: microseconds round trip
        assert f.micros() == s * 1000000 + us
        assert f.bits == fp64.from_ratio(s * 1000000 + us, 1000000)


def _nearest_ok(num, den, bits):
    # bits is a nearest double to num/den and, on a tie, the even one:
    # checked with integers against both neighbours.
    n0, d0 = fp64.to_ratio(bits)
    err = abs(num * d0 - n0 * den) * 1  # |x - v| * den * d0
    for nb in (bits - 1, bits + 1):
        if nb < 0 or (nb >> 52) & 0x7FF == 0x7FF or (nb ^ bits) >> 63:
            continue
        n1, d1 = fp64.to_ratio(nb)
        e1 = abs(num * d1 - n1 * den)
        # compare err/(den*d0) with e1/(den*d1)
        lhs = err * d1
        rhs = e1 * d0
        assert lhs <= rhs, (num, den, hex(bits))
        if lhs == rhs:
            assert bits & 1 == 0, (num, den, hex(bits))


def test_from_ratio_rounds_to_nearest_even():
    rng = Prng(5)
    for _ in range(400):
        num = rng.next32() << rng.below(80)
        num = num * rng.next32() + rng.next32()
        den = (rng.next32() << rng.below(60)) + 1
        if rng.chance(0.5):
            num = -num
        _nearest_ok(num, den, fp64.from_ratio(num, den))
    # exact halves go to even: 2**53 + 1 lies between 2**53 and 2**53 + 2
    assert fp64.from_ratio(2**53 + 1) == fp64.from_ratio(2**53)
    assert fp64.from_ratio(2**53 + 3) == fp64.from_ratio(2**53 + 4)


def test_from_ratio_subnormals_and_limits():
    tiny = fp64.from_ratio(1, 1 << 1074)
    assert tiny == 1
    assert fp64.from_ratio(1, 1 << 1075) == 0  # a tie with 0: even
    assert fp64.from_ratio(3, 1 << 1076) == 1
    assert fp64.from_ratio(-1, 1 << 1074) == 0x8000000000000001
    # the largest normal, the smallest normal, a subnormal rounding up into it
    assert fp64.from_ratio((2**53 - 1) << 971) == 0x7FEFFFFFFFFFFFFF
    assert fp64.from_ratio(1, 1 << 1022) == 0x0010000000000000
    assert fp64.from_ratio((1 << 53) - 1, 1 << 1075) == 0x0010000000000000
    for v in (2**1024, -(2**1024)):
        try:
            fp64.from_ratio(v)
            assert False, "no error"
        except EncodeError:
            pass
    for num, den in ((1, 0), (1.5, 1), (1, -2)):
        try:
            fp64.from_ratio(num, den)
            assert False, "no error"
        except EncodeError:
            pass


def test_float_patterns_match_struct():
    need_double("IMC's fp64 fields")
    # every finite pattern reads to the float struct reads, and back
    rng = Prng(9)
    for i in range(2000):
        bits = (rng.next32() << 32) | rng.next32()
        if i % 3 == 0:
            bits &= 0x800FFFFFFFFFFFFF  # subnormals too
        x = struct.unpack("<d", struct.pack("<Q", bits))[0]
        if x != x:
            continue
        assert fp64.from_float(x) == bits, hex(bits)
        y = fp64.to_float(bits)
        assert y == x and struct.pack("<d", y) == struct.pack("<d", x), hex(bits)
    assert fp64.from_float(-0.0) == 1 << 63 and fp64.from_float(0.0) == 0
    assert fp64.from_float(float("inf")) == 0x7FF0000000000000
    assert fp64.from_float(float("-inf")) == 0xFFF0000000000000
    assert fp64.from_float(float("nan")) == fp64.NAN
    assert fp64.to_float(fp64.NAN) != fp64.to_float(fp64.NAN)
    for bad in (fp64.NAN, 0x7FF0000000000000):
        try:
            imc.F64(bad).micros()
            assert False, "no error"
        except DecodeError:
            pass


def test_bad_packets_raise_decode_errors():
    good = unhexlify(VECTORS[2][3])
    cases = [
        good[:-1],  # one short
        good + b"\x00",  # one long
        good[:19],  # shorter than a header
        b"",
        b"\x55\xfe" + good[2:],  # unknown sync
        good[:4] + b"\x1a\x00" + good[6:],  # size lies by one
        good[:4] + b"\xff\xff" + good[6:],  # size past the maximum
    ]
    for bad in cases:
        try:
            imc.decode(bad)
            assert False, bad
        except DecodeError:
            pass
    damaged = bytearray(good)
    damaged[30] ^= 0x20
    try:
        imc.decode(bytes(damaged))
        assert False, "bad crc accepted"
    except CRCError as e:
        assert "CRC" in str(e)


def test_header_fields_are_range_checked():
    for kw in ({"src": 0x10000}, {"dst": -1}, {"src_ent": 256}, {"dst_ent": "x"}, {"timestamp": "now"}, {"timestamp": 2**1100}):
        args = {"src": 1, "dst": 2, "timestamp": TS}
        args.update(kw)
        try:
            imc.encode({"abbrev": "Heartbeat"}, **args)
            assert False, kw
        except EncodeError:
            pass
