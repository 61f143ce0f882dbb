# Messages and catalogs of acomm.codec: sizes, round trips (also at unaligned
# positions), errors that name the message and field, catalog declaration
# rules, pack/unpack back to back, the padding rule, partial tails that keep
# the messages before them, unknown ids, and random-bytes fuzzing.

from acomm.codec.bits import BitReader, BitWriter
from acomm.codec.fields import Array, Bool, Bytes, Enum, Fixed, Nested, Optional, UInt
from acomm.codec.message import Catalog, Message
from acomm.codec.text6 import Text6
from acomm.errors import DecodeError, EncodeError
from acomm.prng import Prng
from checks import raises
from codec_gen import random_values, same_values

POS = Message("pos", 0, (Fixed("x", -51.1, 51.2, 0.1), Fixed("y", -51.1, 51.2, 0.1)))

BIG = Message("big", 0, (UInt("a", 0, 255), Bool("b")))  # id 0: 9 body bits
NAV = Message("nav", 1, (Fixed("heading", 0, 360, 360 / 1023), Fixed("depth", 0, 63.5, 0.5), Nested("pos", POS)))
PING = Message("ping", 2, ())
CHAT = Message("chat", 3, (Text6("text", 20),))
MIXED = Message(
    "mixed",
    9,
    (
        Enum("mode", ("idle", "run", "dock")),
        Optional(UInt("leg", 0, 99)),
        Bytes("blob", 5),
        Array(Nested("track", POS), 3),
        Array(Bool("flags"), 4, fixed=True),
    ),
)
CAT = Catalog("test", 4, (BIG, NAV, PING, CHAT, MIXED))


def test_sizes_are_known_at_declaration():
    assert NAV.max_bits == NAV.min_bits == 10 + 7 + 20
    assert abs(NAV.limit_bits - (10 + 7 + 20)) < 1e-6
    assert PING.max_bits == PING.min_bits == 0 and PING.limit_bits == 0
    assert CHAT.max_bits == 120 and CHAT.min_bits == 6
    assert MIXED.max_bits == 2 + 8 + (3 + 40) + (2 + 60) + 4
    assert MIXED.min_bits == 2 + 1 + 3 + 2 + 4
    assert CAT.bits(NAV) == 41 and CAT.bits("chat") == 124
    assert abs(CAT.limit_bits(NAV) - (NAV.limit_bits + 2.321928)) < 1e-5


def test_round_trips_random_values():
    rng = Prng(21)
    for m in CAT.messages:
        for _ in range(80):
            v = random_values(m, rng)
            data = m.encode(v)
            assert len(data) <= (m.max_bits + 7) // 8
            assert same_values(m, v, m.decode(data)), (m.name, v)


def test_encode_into_and_decode_from_at_unaligned_positions():
    rng = Prng(22)
    buf = bytearray(64)
    for shift in range(1, 9):
        w = BitWriter(buf)
        w.write(1, shift)
        v = random_values(MIXED, rng)
        MIXED.encode_into(w, v)
        w.write(5, 3)
        r = BitReader(w.getvalue())
        assert r.read(shift) == 1
        assert same_values(MIXED, v, MIXED.decode_from(r))
        assert r.read(3) == 5


def test_encode_errors_name_message_and_field():
    e = raises(EncodeError, NAV.encode, {"heading": 10, "depth": 70, "pos": {"x": 0, "y": 0}})
    assert e.message == "nav" and e.field == "depth" and str(e).startswith("nav.depth: ")
    e = raises(EncodeError, NAV.encode, {"heading": 10, "pos": {"x": 0, "y": 0}})
    assert e.field == "depth" and e.detail == "missing"
    e = raises(EncodeError, NAV.encode, {"heading": 10, "depth": 1, "pos": 5})
    assert e.field.startswith("pos"), e.field
    e = raises(EncodeError, NAV.encode, [1, 2, 3])
    assert "dict" in str(e)
    e = raises(EncodeError, NAV.encode, {"heading": None, "depth": 1, "pos": {"x": 0, "y": 0}})
    assert e.field == "heading"
    e = raises(EncodeError, MIXED.encode, {"mode": "fly"})
    assert str(e).startswith("mixed.mode: ")
    # a writer that is too small is named too
    w = BitWriter(bytearray(2))
    e = raises(EncodeError, NAV.encode_into, w, {"heading": 1, "depth": 1, "pos": {"x": 0, "y": 0}})
    assert e.message == "nav" and e.field is not None


def test_decode_errors_name_message_and_field():
    data = NAV.encode({"heading": 1, "depth": 1, "pos": {"x": 0, "y": 0}})
    e = raises(DecodeError, NAV.decode, data[:3])
    assert e.message == "nav" and e.field == "pos.x", e.field
    assert str(e).startswith("nav.pos.x: ")
    e = raises(DecodeError, NAV.decode, data + b"\x00")
    assert "trailing" in str(e)
    bad = bytearray(data)
    bad[-1] |= 1  # a non-zero padding bit
    raises(DecodeError, NAV.decode, bytes(bad))


def test_duplicate_field_names_are_rejected():
    raises(ValueError, Message, "m", 0, (UInt("a", 0, 1), Bool("a")))


def test_check_mtu():
    assert CHAT.check_mtu(16, id_bits=4) == 124
    assert CHAT.check_mtu(15) == 120
    e = raises(EncodeError, CHAT.check_mtu, 15, 4)
    assert e.message == "chat" and "124" in str(e)


def test_catalog_declaration_rules():
    raises(ValueError, Catalog, "c", 4, (BIG, Message("big", 1, ())))
    raises(ValueError, Catalog, "c", 4, (BIG, Message("other", 0, (UInt("a", 0, 255),))))
    raises(ValueError, Catalog, "c", 4, (BIG, Message("far", 16, ())))
    raises(ValueError, Catalog, "c", 4, (BIG, Message("neg", -1, ())))
    # id 0 must never fit inside trailing padding
    raises(ValueError, Catalog, "c", 4, (Message("tiny", 0, (UInt("a", 0, 7),)),))
    Catalog("c", 4, (Message("ok", 0, (UInt("a", 0, 15),)),))
    Catalog("c", 8, (Message("empty", 0, ()),))
    assert CAT["nav"] is NAV and CAT.by_id(3) is CHAT and CAT.by_id(4) is None


def test_pack_back_to_back_without_padding_between():
    rng = Prng(23)
    for _ in range(60):
        items = []
        bits = 0
        for _ in range(rng.range(1, 6)):
            m = CAT.messages[rng.below(len(CAT.messages))]
            v = random_values(m, rng)
            items.append((m, v))
            w = BitWriter(bytearray(64))
            m.encode_into(w, v)
            bits += 4 + w.bit_length
        data = CAT.pack(items)
        assert len(data) == (bits + 7) // 8, (len(data), bits)
        got = CAT.unpack(data)
        assert len(got) == len(items)
        for (m, v), (gm, gv) in zip(items, got):
            assert gm is m and same_values(m, v, gv)


def test_pack_by_name_and_exact_bits():
    data = CAT.pack([("ping", {}), ("ping", {}), (BIG, {"a": 0xA5, "b": True})])
    # 0010 0010 0000 10100101 1: 21 bits, then 3 zero bits of padding
    assert data == bytes([0x22, 0x0A, 0x58]), data
    assert [(m.name, v) for m, v in CAT.unpack(data)] == [("ping", {}), ("ping", {}), ("big", {"a": 0xA5, "b": True})]
    assert CAT.pack([]) == b"" and CAT.unpack(b"") == []


def test_pack_rejects_foreign_messages():
    other = Message("nav", 1, ())
    raises(EncodeError, CAT.pack, [(other, {})])
    raises(EncodeError, CAT.pack, [("nope", {})])


def test_padding_rule():
    one = CAT.pack([("ping", {})])  # 4 bits + 4 zero bits
    assert one == b"\x20" and len(CAT.unpack(one)) == 1
    # padding that is not zero is not padding
    e = raises(DecodeError, CAT.unpack, b"\x21")
    assert len(e.messages) == 1
    # a whole zero byte after the frame starts an id-0 message, cut short
    e = raises(DecodeError, CAT.unpack, b"\x20\x00")
    assert e.message == "big" and len(e.messages) == 1


def test_partial_tail_keeps_the_messages_before_it():
    rng = Prng(24)
    items = [(m, random_values(m, rng)) for m in (NAV, CHAT, BIG, MIXED, NAV)]
    data = CAT.pack(items)
    full = CAT.unpack(data)
    for cut in range(len(data)):
        try:
            got = CAT.unpack(data[:cut])
        except DecodeError as e:
            got = e.messages
            assert e.catalog == "test" and "test." in str(e)
        # whatever came back is a prefix of the full decode
        assert len(got) < len(full) or cut == len(data)
        for (m, v), (fm, fv) in zip(got, full):
            assert m is fm and v == fv


def test_unknown_id_keeps_earlier_messages():
    w = BitWriter(bytearray(8))
    CAT.pack_into(w, [("ping", {}), ("big", {"a": 1, "b": False})])
    w.write(7, 4)  # no message has id 7
    w.write(0xFF, 8)
    e = raises(DecodeError, CAT.unpack, w.getvalue())
    assert "unknown message id 7" in str(e) and e.field == "id" and e.message is None
    assert [m.name for m, _ in e.messages] == ["ping", "big"]


def test_random_bytes_raise_only_decode_errors():
    rng = Prng(25)
    ok = bad = 0
    for _ in range(1500):
        data = rng.bytes(rng.range(0, 24))
        try:
            got = CAT.unpack(data)
            ok += 1
            assert isinstance(got, list)
        except DecodeError as e:
            assert isinstance(e.messages, list)
            bad += 1
        for m in CAT.messages:
            try:
                m.decode_from(BitReader(data))
            except DecodeError:
                pass
    assert ok and bad


def test_decoded_random_frames_round_trip():
    # anything unpack accepts re-packs to the same bits
    rng = Prng(26)
    seen = 0
    for _ in range(3000):
        data = rng.bytes(rng.range(1, 8))
        try:
            got = CAT.unpack(data)
        except DecodeError:
            continue
        seen += 1
        assert CAT.pack(got) == data, (data, got)
    assert seen > 10
