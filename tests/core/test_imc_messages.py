# IMC messages: round trips of every message in the table, nesting, lists,
# unknown ids, defaults and the errors of bad values.

import struct

from acomm import imc
from acomm.codec.crc import crc16
from acomm.errors import DecodeError, EncodeError
from acomm.imc import enums, fp64, messages, wire
from acomm.prng import Prng
from checks import DOUBLE, need_double

REQUIRED = (150, 151, 152, 550, 814, 815, 816, 817, 818, 515, 516)


def _text(rng, n):
    return "".join(chr(0x20 + rng.below(95)) for _ in range(n))


def _value(rng, code, depth):
    # a random value of a field type that survives a round trip exactly
    if code <= wire.I64:
        lo, hi = wire.INTS[code][2], wire.INTS[code][3]
        pick = rng.below(4)
        if pick == 0:
            return lo
        if pick == 1:
            return hi
        return lo + (((rng.next32() << 32) | rng.next32()) % (hi - lo + 1))
    if code == wire.FP32:
        return struct.unpack("<f", struct.pack("<f", (rng.next32() - 0x80000000) / 64.0))[0]
    if code == wire.FP64:
        bits = ((rng.next32() << 32) | rng.next32()) & 0xBFFFFFFFFFFFFFFF  # finite
        return fp64.to_float(bits)
    if code == wire.TEXT:
        return _text(rng, rng.below(20))
    if code == wire.RAW:
        return rng.bytes(rng.below(40))
    if code == wire.MSG:
        if depth > 2 or rng.chance(0.3):
            return None
        return _random_msg(rng, rng.below(3), depth + 1)
    return [_random_msg(rng, 0, depth + 1) for _ in range(rng.below(4) if depth < 3 else 0)]


def _random_msg(rng, kind, depth=0):
    # kind 0: a small flat message, else any message of the table
    ids = messages.known_ids()
    mgid = (150, 550, 816, 151)[rng.below(4)] if kind == 0 else ids[rng.below(len(ids))]
    mgid, name, fields = messages.by_id(mgid)
    m = {"abbrev": name}
    for fname, code in fields:
        m[fname] = _value(rng, code, depth)
    return m


def _round_trip(m, **hdr):
    for big in (False, True):
        data = imc.encode(m, big=big, **hdr)
        p = imc.decode(data)
        assert p.msg == m, (p.msg, m)
        assert p.big == big
        assert imc.decode_inline(imc.encode_inline(m, big), big) == m
        # packet re-encodes to the same bytes
        assert p.encode(big) == data


def test_required_messages_are_known():
    for mgid in REQUIRED:
        assert imc.by_id(mgid) is not None, mgid
        assert imc.by_name(imc.by_id(mgid)[1])[0] == mgid


def test_round_trip_the_listed_messages():
    e = enums
    cases = (
        {"abbrev": "Heartbeat"},
        {"abbrev": "Announce", "sys_name": "buoy-1", "sys_type": e.SYSTEM_USV, "owner": 0xFFFF, "lat": 0.7222, "lon": -0.1527, "height": 0.5, "services": "imc+udp://10.0.0.9:6002/;imc+any://acoustic/operation"},
        {"abbrev": "AnnounceService", "service": "imc+udp://1.2.3.4:6002/", "service_type": e.SRV_TYPE_EXTERNAL | e.SRV_TYPE_LOCAL},
        {"abbrev": "Abort"},
        {"abbrev": "UamTxFrame", "seq": 65535, "sys_dst": "broadcast", "flags": e.UTF_ACK | e.UTF_FORCED, "data": bytes(range(256))},
        {"abbrev": "UamRxFrame", "sys_src": "unknown", "sys_dst": "buoy-1", "flags": e.URF_PROMISCUOUS, "data": b""},
        {"abbrev": "UamTxStatus", "seq": 3, "value": e.UTS_INV_ADDR, "error": "no such system"},
        {"abbrev": "UamRxRange", "seq": 3, "sys": "auv-2", "value": 1234.5},
        {"abbrev": "UamTxRange", "seq": 4, "sys_dst": "auv-2", "timeout": 10.0},
        {"abbrev": "TransmissionRequest", "req_id": 1, "comm_mean": e.CMEAN_SATELLITE, "destination": "ccu", "deadline": 1700000123.456, "range": 0.0, "data_mode": e.DMODE_RAW, "msg_data": None, "txt_data": "", "raw_data": b"\x00\xff"},
        {"abbrev": "TransmissionStatus", "req_id": 1, "status": e.TSTAT_PERMANENT_FAILURE, "range": -1.0, "info": "Transmission timed out"},
    )
    seen = set()
    for m in cases:
        _round_trip(m, src=0x4001, dst=0x0016, timestamp=1700000000.5, src_ent=3, dst_ent=0xFF)
        seen.add(imc.by_name(m["abbrev"])[0])
    assert seen == set(REQUIRED)


def test_round_trip_every_message_in_the_table():
    need_double("IMC's fp64 fields")
    rng = Prng(21)
    for mgid in messages.known_ids():
        name, fields = messages.by_id(mgid)[1:]
        for _ in range(3):
            m = {"abbrev": name}
            for fname, code in fields:
                m[fname] = _value(rng, code, 0)
            _round_trip(m, src=rng.below(0x10000), dst=rng.below(0x10000), timestamp=imc.F64.seconds(rng.next32(), rng.below(1000000)))


def test_field_names_are_the_abbrevs_dune_and_imcpy_use():
    # TelemetryMsg's text field is "source" (its abbrev; the XML name is
    # "Source"), as in DUNE's JSON and imcpy; every field name is an abbrev
    # in lower case
    names = [f for f, _ in imc.by_name("TelemetryMsg")[2]]
    assert names == ["type", "req_id", "ttl", "code", "destination", "source", "acknowledge", "status", "data"]
    for mgid in messages.known_ids():
        for fname, _ in messages.by_id(mgid)[2]:
            assert fname == fname.lower(), (mgid, fname)
    m = {"abbrev": "TelemetryMsg", "type": 2, "req_id": 7, "ttl": 60, "code": 3, "destination": "ccu",
         "source": "buoy-1", "acknowledge": 1, "status": 1, "data": b"\x01\x02"}
    p = imc.decode(imc.encode(m))
    assert p.msg == m and p.msg["source"] == "buoy-1" and "Source" not in p.msg


def test_exact_round_trip_of_fp64_fields():
    rng = Prng(4)
    for _ in range(200):
        lat = imc.F64(((rng.next32() << 32) | rng.next32()) & 0xBFFFFFFFFFFFFFFF)
        m = {"abbrev": "IridiumMsgRx", "origin": "x", "htime": imc.F64.seconds(rng.next32()), "lat": lat, "lon": 0, "data": b""}
        p = imc.decode(imc.encode(m), exact=True)
        assert p.msg["lat"] == lat and p.msg["lon"] == imc.F64(0)
        assert p.msg["htime"].micros() % 1000000 == 0


def test_missing_fields_take_imc_defaults():
    p = imc.decode(imc.encode({"abbrev": "TransmissionRequest", "req_id": 9}))
    assert p.msg == {
        "abbrev": "TransmissionRequest",
        "req_id": 9,
        "comm_mean": 0,
        "destination": "",
        "deadline": 0.0,
        "range": 0.0,
        "data_mode": 0,
        "msg_data": None,
        "txt_data": "",
        "raw_data": b"",
    }
    assert p.msg == imc.decode(imc.encode({"abbrev": "TransmissionRequest", "req_id": 9, "msg_data": None})).msg


def test_nested_inline_messages():
    inner = {"abbrev": "UamTxFrame", "seq": 1, "sys_dst": "auv", "flags": 0, "data": b"x"}
    req = {"abbrev": "AcousticRequest", "req_id": 5, "destination": "auv", "timeout": 60.0, "range": 0.0, "type": 3, "msg": inner}
    tr = {"abbrev": "TransmissionRequest", "req_id": 7, "msg_data": req}
    data = imc.encode(tr, src=1, dst=2, timestamp=5)
    got = imc.decode(data).msg
    assert got["msg_data"]["msg"] == inner
    assert got["msg_data"]["abbrev"] == "AcousticRequest"
    # the inner ids are in the packet's byte order
    i = data.find(struct.pack("<H", 215))
    assert i > 20 and data[i + 2 : i + 4] == struct.pack("<H", 5)
    be = imc.encode(tr, src=1, dst=2, timestamp=5, big=True)
    assert be.find(struct.pack(">H", 215)) > 20
    assert imc.decode(be).msg == got


def test_nesting_depth_is_bounded_both_ways():
    m = {"abbrev": "Abort"}
    for _ in range(imc.MAX_DEPTH):
        m = {"abbrev": "AcousticMessage", "message": m}
    imc.decode(imc.encode(m))  # MAX_DEPTH levels of inline: fine
    deep = {"abbrev": "AcousticMessage", "message": m}
    try:
        imc.encode(deep)
        assert False, "too deep encoded"
    except EncodeError:
        pass
    # a dict that contains itself ends in the same error, not a recursion crash
    loop = {"abbrev": "AcousticMessage"}
    loop["message"] = loop
    try:
        imc.encode(loop)
        assert False, "loop encoded"
    except EncodeError:
        pass
    # 1000 levels from the wire: 206 ids back to back
    payload = struct.pack("<H", 206) * 1000 + struct.pack("<H", 0xFFFF)
    try:
        imc.decode(_packet(206, payload[2:]))
        assert False, "too deep decoded"
    except DecodeError:
        pass


def test_message_list():
    ann = {"abbrev": "Announce", "sys_name": "a", "sys_type": 0, "owner": 1, "lat": 0.0, "lon": 0.0, "height": 0.0, "services": ""}
    ann2 = dict(ann, sys_name="b", owner=2)
    for links in ([], [ann], [ann, ann2, {"abbrev": "Heartbeat"}]):
        m = {"abbrev": "VehicleLinks", "localname": "gw", "links": links}
        _round_trip(m, src=1)
    data = imc.encode({"abbrev": "VehicleLinks", "localname": "gw", "links": (ann,)})
    assert imc.decode(data).msg["links"] == [ann]
    for bad in ([None], "abc", [1]):
        try:
            imc.encode({"abbrev": "VehicleLinks", "links": bad})
            assert False, bad
        except EncodeError:
            pass
    # a count that lies, and a null inside a list
    for payload in (b"\x00\x00" + b"\xff\xff", b"\x00\x00" + b"\x02\x00" + b"\x96\x00", b"\x00\x00\x01\x00\xff\xff"):
        try:
            imc.decode(_packet(650, payload))
            assert False, payload
        except DecodeError:
            pass


def _packet(mgid, payload, big=False):
    o = ">" if big else "<"
    body = struct.pack(o + "HHHQHBHB", 0xFE54, mgid, len(payload), 0, 1, 2, 3, 4) + payload
    return body + struct.pack(o + "H", crc16(body))


def test_unknown_id_is_skipped_with_its_size():
    for big in (False, True):
        data = _packet(999, b"opaque bytes", big)
        p = imc.decode(data)
        assert p.msg is None and p.mgid == 999 and p.payload == b"opaque bytes"
        assert (p.src, p.src_ent, p.dst, p.dst_ent) == (1, 2, 3, 4) and p.big == big
        # forwarded unchanged, but never in the other order
        assert p.encode(big) == data
        try:
            p.encode(not big)
            assert False, "order changed"
        except EncodeError:
            pass
    # inside a message nothing gives the size: an error
    try:
        imc.decode(_packet(206, struct.pack("<H", 999) + b"xx"))
        assert False, "unknown inline decoded"
    except DecodeError as e:
        assert "999" in str(e)


def test_trailing_fields_of_a_newer_revision_are_ignored():
    p = imc.decode(_packet(816, b"\x07\x00\x09\x00\x00" + b"newer"))
    assert p.msg == {"abbrev": "UamTxStatus", "seq": 7, "value": 9, "error": ""}
    try:
        imc.decode_inline(imc.encode_inline({"abbrev": "Abort"}) + b"x")
        assert False, "trailing inline accepted"
    except DecodeError:
        pass
    assert imc.decode_inline(b"\xff\xff") is None and imc.encode_inline(None) == b"\xff\xff"


def test_define_a_third_party_message():
    imc.define(4001, "TestPing", "seq:uint16 note:plaintext temp:int16 stamp:fp64")
    m = {"abbrev": "TestPing", "seq": 1, "note": "hi", "temp": -40, "stamp": 12.5}
    _round_trip(m)
    imc.define(4001, "TestPing2", "seq:uint32")
    assert imc.decode(imc.encode({"abbrev": "TestPing2", "seq": 70000})).msg["seq"] == 70000
    try:
        imc.by_name("TestPing")
        assert False, "old name kept"
    except EncodeError:
        pass
    for bad in ((4002, "X", "a:float"), (4002, "X", "a:uint8 a:uint8"), (4002, "X", "abbrev:uint8"), (0xFFFF, "X", "")):
        try:
            imc.define(*bad)
            assert False, bad
        except ValueError:
            pass


def test_bad_values_raise_encode_errors():
    tx = {"abbrev": "UamTxFrame", "seq": 1, "sys_dst": "a", "flags": 0, "data": b""}
    bads = (
        {"abbrev": "NoSuchMessage"},
        {"seq": 1},
        dict(tx, seq=65536),
        dict(tx, seq=-1),
        dict(tx, seq=1.0),
        dict(tx, flags=None),
        dict(tx, sys_dst=b"a"),
        dict(tx, data="text"),
        dict(tx, data=[1, 2]),
        dict(tx, data=bytes(65514)),
        dict(tx, data=bytes(65510)),  # fits as rawdata, not in a packet
        dict(tx, sdt_dst="typo"),
        {"abbrev": "UamRxRange", "value": "1"},
        {"abbrev": "Announce", "lat": "north"},
        {"abbrev": "TransmissionRequest", "msg_data": {"abbrev": "Nope"}},
        {"abbrev": "TransmissionRequest", "msg_data": 5},
        {"abbrev": "AcousticMessage", "message": {"abbrev": "Abort", "x": 1}},
        "not a dict",
        None,
        {"abbrev": ["list"]},
    )
    if DOUBLE:  # beyond fp32; a float32 board has no such number (it reads inf)
        bads += ({"abbrev": "UamRxRange", "value": 1e39},)
    for m in bads:
        try:
            imc.encode(m)
            assert False, repr(m)[:80]
        except EncodeError:
            pass
    # fp32 limits: the largest single passes, infinities pass as infinities
    big = struct.unpack("<f", b"\xff\xff\x7f\x7f")[0]
    for v in (big, -big, float("inf")):
        p = imc.decode(imc.encode({"abbrev": "UamRxRange", "value": v}))
        assert p.msg["value"] == v


def test_text_must_be_utf8():
    m = {"abbrev": "UamTxStatus", "seq": 1, "value": 0, "error": "é ok"}
    assert imc.decode(imc.encode(m)).msg == m
    try:
        imc.decode(_packet(816, b"\x01\x00\x00\x02\x00\xff\xfe"))
        assert False, "bad utf-8 decoded"
    except DecodeError:
        pass
