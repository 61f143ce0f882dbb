# Seaware control set (seed 002, Table I) and its compact packet. Plain
# functions with bare asserts: pytest on CPython, tools/mp_runtests.py on
# MicroPython.

from acomm.catalog import seaware as S
from acomm.codec.crc import crc16
from acomm.errors import CRCError, DecodeError, EncodeError
from acomm.prng import Prng
from checks import raises

# Table I: request tag, reply tag, request bytes, reply bytes (the sizes
# include the 1-byte header and the 2-byte CRC).
TABLE_I = (
    ("start_mission", 0, "start_mission_ack", 128, 4, 4),
    ("stop_mission", 1, "stop_mission_ack", 129, 4, 4),
    ("get_mission_state", 2, "mission_state", 130, 4, 19),
    ("get_vehicle_state", 3, "vehicle_state", 131, 4, 7),
    ("rendezvous_on", 4, "rendezvous_on_ack", 132, 4, 4),
    ("rendezvous_off", 5, "rendezvous_off_ack", 133, 4, 4),
)

# field specs of the two replies with data: (name, kind, lo, hi, res)
MISSION_SPEC = (
    ("status", "enum", ("idle", "executing", "completed", "aborted"), None, None),
    ("completion", "int", 0, 100, None),
    ("leg", "int", 0, 255, None),
    ("lat_udeg", "int", -90000000, 90000000, None),
    ("lon_udeg", "int", -180000000, 180000000, None),
    ("depth", "fixed", 0, 409.5, 0.1),
    ("vel_n", "fixed", -4.095, 4.095, 0.002),
    ("vel_e", "fixed", -4.095, 4.095, 0.002),
    ("vel_d", "fixed", -1.023, 1.023, 0.002),
)
VEHICLE_SPEC = (
    ("temperature", "fixed", -20, 107.5, 0.5),
    ("battery", "int", 0, 100, None),
    ("voltage", "fixed", 0, 51.1, 0.1),
)


def _boundary(spec, which):
    # which: 0 min, 1 one step inside min, 2 one step inside max, 3 max
    d = {}
    for name, kind, lo, hi, res in spec:
        if kind == "enum":
            d[name] = lo[(0, 1, len(lo) - 2, len(lo) - 1)[which]]
        elif kind == "int":
            d[name] = (lo, lo + 1, hi - 1, hi)[which]
        else:
            d[name] = (lo, lo + res, hi - res, hi)[which]
    return d


def _random(spec, rng):
    d = {}
    for name, kind, lo, hi, res in spec:
        if kind == "enum":
            d[name] = lo[rng.below(len(lo))]
        elif kind == "int":
            d[name] = lo + rng.below(hi - lo + 1)
        else:
            d[name] = lo + (hi - lo) * rng.below(1000001) / 1000000
    return d


def _same(spec, a, b):
    for name, kind, lo, hi, res in spec:
        if kind == "fixed":
            assert abs(a[name] - b[name]) <= res / 2 + 1e-9, (name, a[name], b[name])
        else:
            assert a[name] == b[name], (name, a[name], b[name])


def test_table_i_tags_and_sizes():
    for req, qtag, rep, rtag, qlen, rlen in TABLE_I:
        q = S.BY_NAME[req]
        r = S.BY_NAME[rep]
        assert q.id == qtag and r.id == rtag and rtag == qtag + S.REPLY
        assert S.REPLY_OF[req] is r
        assert len(S.encode(1, q)) == qlen
        assert S.CATALOG.bits(q) == (qlen - 3) * 8
        assert S.CATALOG.bits(r) == (rlen - 3) * 8
    assert len(S.encode(1, S.MISSION_STATE, _boundary(MISSION_SPEC, 0))) == 19
    assert len(S.encode(1, S.VEHICLE_STATE, _boundary(VEHICLE_SPEC, 3))) == 7
    for name in ("start_mission_ack", "stop_mission_ack", "rendezvous_on_ack", "rendezvous_off_ack"):
        assert len(S.encode(1, name)) == 4
    assert S.INVALID_CRC.id == 255 and len(S.encode(1, S.INVALID_CRC)) == 4
    assert S.CATALOG.id_bits == 8


def test_reply_bodies_fill_their_budget_exactly():
    # 15 and 3 data bytes, no padding bit wasted and no variable part
    assert S.MISSION_STATE.max_bits == S.MISSION_STATE.min_bits == 120
    assert S.VEHICLE_STATE.max_bits == S.VEHICLE_STATE.min_bits == 24
    for m in S.REQUESTS:
        assert m.max_bits == 0


def _spec(m):
    return MISSION_SPEC if m is S.MISSION_STATE else VEHICLE_SPEC


def test_every_message_round_trips_in_a_packet():
    for m in S.REQUESTS + S.REPLIES:
        v = _boundary(_spec(m), 0) if m.max_bits else {}
        for addr in (0, 1, 126, 127):
            src, got, out = S.decode(S.encode(addr, m, v))
            assert src == addr and got is m
            if not m.max_bits:
                assert out == {}


def test_reply_boundaries_round_trip():
    for m in (S.MISSION_STATE, S.VEHICLE_STATE):
        spec = _spec(m)
        for which in range(4):
            v = _boundary(spec, which)
            src, got, out = S.decode(S.encode(7, m, v))
            assert got is m
            _same(spec, v, out)


def test_reply_random_round_trip():
    rng = Prng(2002)
    for m in (S.MISSION_STATE, S.VEHICLE_STATE):
        spec = _spec(m)
        for _ in range(200):
            v = _random(spec, rng)
            _same(spec, v, S.decode(S.encode(3, m, v))[2])


def test_reply_out_of_range_is_an_encode_error():
    for which, field, bad in ((0, "completion", 101), (0, "leg", 256), (3, "lat_udeg", 90000001), (0, "depth", -1.0)):
        v = _boundary(MISSION_SPEC, which)
        v[field] = bad
        raises(EncodeError, S.encode, 1, S.MISSION_STATE, v)
    v = _boundary(VEHICLE_SPEC, 0)
    v["battery"] = -1
    raises(EncodeError, S.encode, 1, S.VEHICLE_STATE, v)


def test_compact_packet_layout():
    # header: 7-bit address MSB first, compressed flag in bit 0; CRC-16/ARC
    # of header + payload, big-endian
    p = S.encode_packet(5, b"\x00")
    assert p[0] == 0x0A and p[1] == 0
    c = crc16(p[:2])
    assert p[2] == c >> 8 and p[3] == c & 0xFF
    assert p == b"\x0a\x00\xa0\x06"  # pinned
    assert S.encode(5, "start_mission") == p
    assert S.encode_packet(127, b"", True)[0] == 0xFF
    assert S.encode_packet(0, b"", False)[0] == 0x00


def test_compact_packet_round_trip():
    rng = Prng(7)
    for addr in range(128):
        for comp in (False, True):
            payload = bytes(rng.below(256) for _ in range(rng.below(20)))
            assert S.decode_packet(S.encode_packet(addr, payload, comp)) == (addr, comp, payload)


def test_compact_packet_bad_address():
    raises(EncodeError, S.encode_packet, 128, b"\x00")
    raises(EncodeError, S.encode_packet, -1, b"\x00")


def test_bad_crc_is_crc_error_on_every_bit():
    p = S.encode(9, S.VEHICLE_STATE, _boundary(VEHICLE_SPEC, 2))
    for i in range(len(p) * 8):
        bad = bytearray(p)
        bad[i >> 3] ^= 0x80 >> (i & 7)
        e = raises(CRCError, S.decode, bytes(bad))
        assert isinstance(e, DecodeError)


def test_truncated_is_decode_error():
    p = S.encode(9, S.MISSION_STATE, _boundary(MISSION_SPEC, 1))
    for n in range(len(p)):
        raises(DecodeError, S.decode, p[:n])
    raises(DecodeError, S.decode_packet, b"\x01\x02")


def test_valid_crc_bad_content_is_decode_error():
    # unknown tag, truncated body, two messages, compressed, empty payload
    for payload, comp in ((b"\x06", False), (b"\x7f", False), (b"\x82\x00", False), (b"\x00\x00", False), (b"\x00", True), (b"", False)):
        e = raises(DecodeError, S.decode, S.encode_packet(1, payload, comp))
        assert not isinstance(e, CRCError)


def test_random_bytes_raise_only_decode_error():
    rng = Prng(255)
    ok = 0
    for _ in range(2000):
        if rng.below(2):
            data = bytes(rng.below(256) for _ in range(rng.below(24)))
        else:
            # valid CRC around random content, at the lengths of real bodies
            n = (0, 1, 1, 2, 4, 16, 17)[rng.below(7)]
            data = S.encode_packet(rng.below(128), bytes(rng.below(256) for _ in range(n)))
        try:
            S.decode(data)
            ok += 1
        except DecodeError:
            pass
    assert ok > 0  # some random payloads are valid messages


def test_invalid_crc_reply():
    p = S.invalid_crc_reply(12)
    assert len(p) == 4 and p[1] == 255
    src, m, v = S.decode(p)
    assert src == 12 and m is S.INVALID_CRC and v == {}


def test_catalog_loads_by_name():
    from acomm import catalog

    assert catalog.load("seaware") is S.CATALOG
