# The CADDY catalog against seed 003: one test per row of the section 5
# tables and of the section 6.1 message tables (field widths, ranges,
# quantization), each message's total size with its 4-bit id, the summary
# table, round trips, the checksum and the status / command / alarm / chat
# messages.

from acomm.codec.bits import BitReader, BitWriter
from acomm.catalog import caddy, load
from acomm.errors import CRCError, DecodeError, EncodeError
from acomm.prng import Prng
from checks import raises
from codec_gen import boundary_values, random_values, same, same_values

C = caddy.CATALOG


def _row(f, bits, lo, hi, res=None):
    # one table row: width, range and (for reals) the quantization step
    assert f.max_bits == f.min_bits == bits, (f.name, f.max_bits, bits)
    inner = getattr(f, "field", f)
    assert abs(inner.lo - lo) < 1e-9 and abs(inner.hi - hi) < 1e-9, (f.name, inner.lo, inner.hi)
    if res is not None:
        assert abs(inner.res - res) < 1e-9, (f.name, inner.res, res)
        # every value of the range comes back within half a step
        for v in boundary_values(f) + [lo + (hi - lo) * k / 17 for k in range(18)]:
            w = BitWriter(bytearray(4))
            f.encode(w, v)
            got = f.decode(BitReader(w.getvalue()))
            assert same(f, v, got), (f.name, v, got)


def _offset_rows(nested):
    assert nested.max_bits == 20
    for axis in nested.message.fields:
        _row(axis, 10, -51.1, 51.2, 0.1)


def _layout(m, widths):
    # the table, top to bottom: Message ID 4, then the fields; and the total
    assert C.id_bits == 4
    assert [f.max_bits for f in m.fields] == widths, (m.name, [f.max_bits for f in m.fields])
    assert C.bits(m) == 4 + sum(widths)
    assert m.min_bits == m.max_bits  # fixed size: always exactly the budget
    data = C.pack([(m, random_values(m, Prng(m.msg_id + 1)))])
    assert len(data) == (C.bits(m) + 7) // 8


# --- section 5, first table: navigation data size and quantization ---------


def test_s5_speed_4_bits_0_to_1_ms_about_006():
    f = caddy.speed()
    _row(f, 4, 0, 1, 1 / 15)
    assert 0.06 < f.res < 0.07


def test_s5_heading_course_10_bits_0_to_360_about_035():
    f = caddy.heading()
    _row(f, 10, 0, 360, 360 / 1023)
    assert 0.35 < f.res < 0.353


def test_s5_depth_7_bits_at_05_m():
    f = caddy.depth()
    _row(f, 7, 0, 63.5, 0.5)
    # 64 m is past the 128th code: the field saturates there (documented)
    w = BitWriter(bytearray(1))
    f.encode(w, 64)
    assert f.decode(BitReader(w.getvalue())) == 63.5


def test_s5_position_offset_x_y_10_bits_each_at_01_m():
    _row(caddy.offset_axis("x"), 10, -51.1, 51.2, 0.1)
    _offset_rows(caddy.offset("p"))


def test_s5_lat_position_init_22_bits_at_1_arcsec():
    f = caddy.lat_init()
    _row(f, 22, -90, 90, 1 / 3600)
    # code = (lat + 90) * 3600
    w = BitWriter(bytearray(3))
    f.encode(w, 45.0 + 30 / 3600)
    assert BitReader(w.getvalue()).read(22) == 135 * 3600 + 30


def test_s5_lon_position_init_22_bits_at_1_arcsec():
    f = caddy.lon_init()
    _row(f, 22, -180, 180, 1 / 3600)
    w = BitWriter(bytearray(3))
    f.encode(w, -180 + 1 / 3600)
    assert BitReader(w.getvalue()).read(22) == 1
    w = BitWriter(bytearray(3))
    f.encode(w, 180)
    assert BitReader(w.getvalue()).read(22) == 360 * 3600


# --- section 5, second table: legacy encodings -----------------------------


def test_legacy_init_dddm1m2m1m2_22_bits_at_1_arcsec():
    f = caddy.legacy_init("lat")
    _row(f, 22, 0, 360, 1 / 3600)
    # the same codes as lat_init once +90 is added
    a = BitWriter(bytearray(3))
    b = BitWriter(bytearray(3))
    caddy.lat_init().encode(a, 43.5081)
    f.encode(b, 43.5081 + 90)
    assert a.getvalue() == b.getvalue()


def test_legacy_minimum_m3m4_7_bits_at_001_arcsec():
    _row(caddy.legacy_minimum("s"), 7, 0, 0.99, 0.01)


def test_legacy_large_m2m1m2m3m4_18_bits_at_001_arcsec():
    _row(caddy.legacy_large("s"), 18, 0, 599.99, 0.01)


def test_legacy_medium_m1m2m3m4_13_bits_at_001_arcsec():
    _row(caddy.legacy_medium("s"), 13, 0, 59.99, 0.01)


def test_legacy_kml_m1m2m3_10_bits_at_01_arcsec():
    _row(caddy.legacy_kml("s"), 10, 0, 59.9, 0.1)


def test_legacy_predefined_messages_5_bits_0_to_31():
    f = caddy.PREDEFINED.fields[0].field
    _row(f, 5, 0, 31)
    _layout(caddy.PREDEFINED, [5 + 6])
    for code in range(32):
        data = C.pack([(caddy.PREDEFINED, {"code": code})])
        assert C.unpack(data)[0][1] == {"code": code}


def test_legacy_checksum_6_bits_crc6():
    # CRC-6/CDMA2000-A catalogue check value
    assert caddy.crc6_bytes(b"123456789") == 0x0D
    assert caddy.crc6(0x31, 8) == caddy.crc6_bytes(b"1")
    assert all(0 <= caddy.crc6(c, 5) <= 63 for c in range(32))
    # every single-bit error in the 11 checked bits is caught
    good = C.pack([(caddy.PREDEFINED, {"code": 19})])
    for bit in range(4, 15):
        bad = bytearray(good)
        bad[bit >> 3] ^= 0x80 >> (bit & 7)
        e = raises(DecodeError, C.unpack, bytes(bad))
        assert isinstance(e, CRCError) and e.message == "predefined" and e.field == "code"
    # all zero bits are never a valid checked field
    assert caddy.crc6(0, 5) != 0


def test_sonar_offset_footnote_16_bits():
    f = caddy.sonar_offset("d")
    assert f.max_bits == 16
    for axis in f.message.fields:
        _row(axis, 8, -12.7, 12.8, 0.1)


# --- section 6.1: every message at exactly its bit budget -----------------


def test_61_diver_transmits_modem_reply_21_bits():
    m = caddy.DIVER_REPLY
    _layout(m, [10, 7])
    _row(m.field("heading"), 10, 0, 360, 360 / 1023)
    _row(m.field("depth"), 7, 0, 63.5, 0.5)
    assert C.bits(m) == 21


def test_61_buddy_pings_pladypos_25_bits():
    m = caddy.BUDDY_PING
    _layout(m, [7, 10, 4])
    _row(m.field("depth"), 7, 0, 63.5, 0.5)
    _row(m.field("course"), 10, 0, 360, 360 / 1023)
    _row(m.field("speed"), 4, 0, 1, 1 / 15)
    assert C.bits(m) == 25


def test_61_buddy_pings_pladypos_with_diver_offset_45_bits():
    m = caddy.BUDDY_PING_DIVER
    _layout(m, [7, 10, 4, 20])
    _offset_rows(m.field("diver"))
    assert C.bits(m) == 45


def test_61_pladypos_replies_60_bits():
    m = caddy.PLADYPOS_REPLY
    _layout(m, [2, 20, 10, 4, 20])
    _row(m.field("quant"), 2, 0, 3)
    _offset_rows(m.field("pladypos"))
    _row(m.field("course"), 10, 0, 360, 360 / 1023)
    _row(m.field("speed"), 4, 0, 1, 1 / 15)
    _offset_rows(m.field("diver"))
    assert C.bits(m) == 60
    assert caddy.scaled_offset(51.2, 3) == 256 and caddy.scaled_offset(-3.0, 0) == -3.0


def test_61_buddy_interrogates_diver_45_bits():
    m = caddy.BUDDY_TO_DIVER
    _layout(m, [7, 20, 10, 4])
    _row(m.field("depth"), 7, 0, 63.5, 0.5)
    _offset_rows(m.field("buddy"))
    _row(m.field("course"), 10, 0, 360, 360 / 1023)
    _row(m.field("speed"), 4, 0, 1, 1 / 15)
    assert C.bits(m) == 45


def test_61_buddy_interrogates_diver_with_diver_offset_65_bits():
    m = caddy.BUDDY_TO_DIVER_EXT
    _layout(m, [7, 20, 10, 4, 20])
    _offset_rows(m.field("diver"))
    assert C.bits(m) == 65


def test_61_buddy_replies_with_diver_position_24_bits():
    m = caddy.DIVER_POSITION
    _layout(m, [20])
    _offset_rows(m.field("diver"))
    assert C.bits(m) == 24


def test_61_summary_table():
    # exchange, bits, bits when Buddy sees the diver (the "(45)"), and the
    # messages that carry them; None for a bare USBL ping
    rows = (
        ("PlaDyPos -> Diver", 0, 0, None, None),
        ("Diver -> PlaDyPos", 21, 21, caddy.DIVER_REPLY, caddy.DIVER_REPLY),
        ("Buddy -> PlaDyPos", 25, 45, caddy.BUDDY_PING, caddy.BUDDY_PING_DIVER),
        ("PlaDyPos -> Buddy", 60, 60, caddy.PLADYPOS_REPLY, caddy.PLADYPOS_REPLY),
        ("Buddy -> Diver", 45, 65, caddy.BUDDY_TO_DIVER, caddy.BUDDY_TO_DIVER_EXT),
        ("Diver -> Buddy", 21, 21, caddy.DIVER_REPLY, caddy.DIVER_REPLY),
        ("PlaDyPos -> Buddy", 0, 0, None, None),
        ("Buddy -> PlaDyPos", 24, 24, caddy.DIVER_POSITION, caddy.DIVER_POSITION),
    )
    total = total_seen = 0
    for name, bits, bits_seen, m, m_seen in rows:
        got = 0 if m is None else C.bits(m)
        got_seen = 0 if m_seen is None else C.bits(m_seen)
        assert (got, got_seen) == (bits, bits_seen), (name, got, got_seen)
        total += got
        total_seen += got_seen
    assert (total, total_seen) == (196, 236)


# --- catalog, round trips, the other messages ----------------------------------


def test_catalog_fits_the_4_bit_id_space():
    assert load("caddy") is C
    assert C.name == "caddy" and C.id_bits == 4 and len(C.messages) <= 16
    assert sorted(m.msg_id for m in C.messages) == list(range(len(C.messages)))


def test_every_message_round_trips_random_and_boundary_values():
    rng = Prng(33)
    for m in C.messages:
        for _ in range(60):
            v = random_values(m, rng)
            got = C.unpack(C.pack([(m, v)]))
            assert len(got) == 1 and got[0][0] is m and same_values(m, v, got[0][1]), (m.name, v)


def test_one_interrogation_cycle_packs_into_one_frame():
    rng = Prng(34)
    cycle = (caddy.DIVER_REPLY, caddy.BUDDY_PING, caddy.PLADYPOS_REPLY, caddy.BUDDY_TO_DIVER, caddy.DIVER_POSITION)
    items = [(m, random_values(m, rng)) for m in cycle]
    data = C.pack(items)
    assert len(data) == (21 + 25 + 60 + 45 + 24 + 7) // 8
    for (m, v), (gm, gv) in zip(items, C.unpack(data)):
        assert gm is m and same_values(m, v, gv)


def test_origin_is_six_bytes():
    m = caddy.ORIGIN
    _layout(m, [22, 22])
    v = {"lat": 45.80778, "lon": 15.96722}
    got = m.decode(m.encode(v))
    assert abs(got["lat"] - v["lat"]) <= 0.5 / 3600 and abs(got["lon"] - v["lon"]) <= 0.5 / 3600
    assert C.bits(m) == 48


def test_diver_status_optional_measurements():
    m = caddy.DIVER_STATUS
    assert C.bits(m) == 4 + 9 + 7 + 9
    v = {"heart_rate": 72, "breathing_rate": None, "body_temp": 36.6}
    got = m.decode(m.encode(v))
    assert got["heart_rate"] == 72 and got["breathing_rate"] is None and abs(got["body_temp"] - 36.6) < 0.051
    assert len(C.pack([(m, {"heart_rate": None, "breathing_rate": None, "body_temp": None})])) == 1
    e = raises(EncodeError, m.encode, {"heart_rate": 250, "breathing_rate": None, "body_temp": None})
    assert e.field == "heart_rate"


def test_commands_and_alarms():
    for m, labels, key in ((caddy.COMMAND, caddy.COMMANDS, "command"), (caddy.ALARM, caddy.ALARMS, "alarm")):
        assert len(labels) == 16 and C.bits(m) == 8
        for lab in labels:
            assert C.unpack(C.pack([(m, {key: lab})])) == [(m, {key: lab})]
    for need in ("low_air", "out_of_air", "decompression", "lost_buddy", "emergency_ascent"):
        assert need in caddy.ALARMS
    raises(EncodeError, caddy.ALARM.encode, {"alarm": "shark"})


def test_chat_in_the_6_bit_alphabet():
    m = caddy.CHAT
    assert C.bits(m) == 4 + 6 * caddy.CHAT_CHARS
    assert m.check_mtu(31, C.id_bits) <= 31 * 8  # the modem's payload limit
    line = "need air, ascending!"
    assert len(line) == 20
    data = C.pack([(m, {"text": line})])
    assert len(data) == (4 + 21 * 6 + 7) // 8
    assert C.unpack(data) == [(m, {"text": line})]
    e = raises(EncodeError, m.encode, {"text": "Need air"})
    assert e.message == "chat" and e.field == "text"


def test_random_bytes_raise_only_decode_errors():
    rng = Prng(35)
    for _ in range(1500):
        data = rng.bytes(rng.range(0, 40))
        try:
            C.unpack(data)
        except DecodeError as e:
            assert isinstance(e.messages, list)


def _doc_rows():
    # the CADDY table of docs/codec.md: id, name, bits ("a..b" when variable)
    f = __file__
    i = f.rfind("/")
    fh = open((f[:i] if i >= 0 else ".") + "/../../docs/codec.md")
    try:
        text = fh.read()
    finally:
        fh.close()
    rows = []
    for line in text[text.index("## CADDY"):].split("\n"):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and cells[0].isdigit():
            rows.append((int(cells[0]), cells[1].strip("`"), cells[3], float(cells[4])))
    return rows


def test_the_documented_table_matches_the_catalog():
    rows = _doc_rows()
    assert len(rows) == len(C.messages)
    for msg_id, name, bits, limit in rows:
        m = C.by_id(msg_id)
        assert m is not None and m.name == name, (msg_id, name)
        lo, hi = C.id_bits + m.min_bits, C.bits(m)
        assert bits == (str(hi) if lo == hi else "%d..%d" % (lo, hi)), (name, bits)
        assert abs(C.limit_bits(m) - limit) < 0.05, (name, limit)
