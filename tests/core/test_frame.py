# Link frame tests (acomm.frame). Plain functions with bare asserts: they run
# under pytest on CPython and under tools/mp_runtests.py on MicroPython.

import binascii

from acomm import frame as F
from acomm.codec.crc import crc16
from acomm.errors import CRCError, DecodeError, EncodeError
from acomm.prng import Prng
from checks import raises as _raises


def _hex(b):
    return binascii.hexlify(bytes(b)).decode()


def _unhex(s):
    return binascii.unhexlify(s)


def _root():
    # repo root from this file's path, with string ops only (no os.path on
    # MicroPython); __file__ may be relative ("tests/core/test_frame.py").
    f = __file__
    i = f.rfind("/")
    d = f[:i] if i >= 0 else "."
    return d + "/../.."


def _with_crc(body):
    body = bytes(body)
    c = crc16(body)
    return body + bytes([c >> 8, c & 0xFF])


def _decode_error_only(fn, *args):
    # Calls fn; returns the Frame when it decoded, None when it raised a
    # DecodeError; anything else fails the test.
    try:
        return fn(*args)
    except Exception as e:  # noqa: BLE001 - the point is to catch everything
        assert isinstance(e, DecodeError), repr(e)
        return None


# -- the documented examples ------------------------------------------------


def _doc_examples():
    f = open(_root() + "/docs/wire-format.md")
    try:
        text = f.read()
    finally:
        f.close()
    rows = []
    in_table = False
    for line in text.split("\n"):
        line = line.strip()
        if not line.startswith("|"):
            in_table = False
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        if cells[:3] == ["ex", "form", "hex"]:
            assert cells == ["ex", "form", "hex", "type", "src", "dst", "seq", "flags", "payload_hex"], cells
            in_table = True
            continue
        if not in_table or cells[0].startswith("-"):
            continue
        assert len(cells) == 9, line
        rows.append(cells)
    return rows


def test_doc_examples_decode_and_encode():
    rows = _doc_examples()
    assert len(rows) >= 8
    kinds = {}
    for ex, form, hx, t, src, dst, seq, flags, pl in rows:
        data = _unhex(hx)
        assert _hex(data) == hx, "hex must be lowercase without spaces: " + hx
        payload = b"" if pl == "-" else _unhex(pl)
        want = F.Frame(int(t), int(src), int(dst), int(seq), payload, int(flags))
        if form == "raw":
            got = F.decode_raw(data)
            enc = F.encode_raw(want)
            assert len(enc) == len(payload) + F.raw_overhead(want.src, want.dst), ex
            kinds["raw_wide" if data[0] & 0x20 else "raw_short"] = 1
            if want.dst == F.BROADCAST:
                kinds["raw_bcast"] = 1
        else:
            assert form == "elided", form
            got = F.decode_elided(data, want.src, want.dst)
            enc = F.encode_elided(want)
            kinds["elided_flags" if want.flags else "elided_plain"] = 1
            if want.dst == F.BROADCAST:
                kinds["elided_bcast"] = 1
        assert got == want, "example %s: decoded %r, table says %r" % (ex, got, want)
        assert _hex(enc) == hx, "example %s: encoder gives %s, table says %s" % (ex, _hex(enc), hx)
        if not payload:
            kinds["empty"] = 1
        if want.flags:
            kinds["flags"] = 1
        if want.ftype == F.ACK and not want.flags & F.F_ACK_REQ:
            kinds["ack"] = 1
        if want.ftype == F.ADVERT:
            kinds["advert"] = 1
    for k in ("raw_short", "raw_wide", "raw_bcast", "elided_plain", "elided_flags", "elided_bcast", "empty", "flags", "ack", "advert"):
        assert k in kinds, "no example of " + k


# -- round trips --------------------------------------------------------------


def _random_addrs(rng):
    # a third each: short ids, one-byte ids, any ids (mostly escaped)
    top = (15, 254, F.MAX_ADDR)[rng.below(3)]
    src = rng.below(top + 1)
    dst = rng.below(top + 1)
    if src == F.BROADCAST:
        src = 256
    if dst == src or rng.below(8) == 0:
        dst = F.BROADCAST
    return src, dst


def test_raw_round_trip_10000_random_frames():
    rng = Prng(2024)
    buf = bytearray(40 + F.RAW_OVERHEAD_MAX)
    wide = short = bcast = escaped = 0
    for _ in range(10000):
        src, dst = _random_addrs(rng)
        fr = F.Frame(rng.below(8), src, dst, rng.below(64), rng.bytes(rng.below(41)), rng.below(16))
        n = F.encode_raw_into(buf, fr.ftype, fr.src, fr.dst, fr.seq, fr.payload, fr.flags)
        assert n == len(fr.payload) + F.raw_overhead(src, dst)
        if n - len(fr.payload) == F.RAW_OVERHEAD_WIDE:
            wide += 1
        elif n - len(fr.payload) > F.RAW_OVERHEAD_WIDE:
            escaped += 1
        else:
            short += 1
        if dst == F.BROADCAST:
            bcast += 1
        got = F.decode_raw(memoryview(buf)[:n])
        assert got == fr, (got, fr)
    assert wide > 1000 and short > 1000 and bcast > 1000 and escaped > 1000


def test_elided_round_trip_10000_random_frames():
    rng = Prng(4242)
    buf = bytearray(42)
    with_flags = 0
    for _ in range(10000):
        src, dst = _random_addrs(rng)
        flags = rng.below(16) if rng.below(2) else 0
        fr = F.Frame(rng.below(8), src, dst, rng.below(16), rng.bytes(rng.below(41)), flags)
        n = F.encode_elided_into(buf, fr.ftype, fr.seq, fr.payload, fr.flags)
        assert n == len(fr.payload) + (2 if flags else 1)
        if flags:
            with_flags += 1
        got = F.decode_elided(buf[:n], src, dst)
        assert got == fr, (got, fr)
    assert with_flags > 3000


def test_encode_raw_into_preallocated_buffer():
    buf = bytearray(b"\xee" * 64)
    payload = b"\x01\x02\x03"
    n = F.encode_raw_into(buf, F.DATA, 3, 5, 9, payload)
    assert n == 8
    assert bytes(buf[:n]) == F.encode_raw(F.Frame(F.DATA, 3, 5, 9, payload))
    assert buf[n:] == bytearray(b"\xee" * (64 - n))  # nothing written past the frame
    # reuse the same buffer for a wide frame, payload given as a memoryview
    src = bytearray(b"..payload..")
    n = F.encode_raw_into(buf, F.CONTROL, 200, 7, 63, memoryview(src)[2:9], F.F_AUTH)
    assert n == 7 + F.RAW_OVERHEAD_WIDE
    assert F.decode_raw(buf[:n]) == F.Frame(F.CONTROL, 200, 7, 63, b"payload", F.F_AUTH)
    # exactly fitting buffer
    exact = bytearray(F.RAW_OVERHEAD_SHORT)
    assert F.encode_raw_into(exact, F.ACK, 1, 2, 0, b"") == 5
    assert F.decode_raw(exact) == F.Frame(F.ACK, 1, 2, 0)


def test_encode_elided_into_preallocated_buffer():
    buf = bytearray(b"\xee" * 8)
    n = F.encode_elided_into(buf, F.DATA, 9, b"hi")
    assert bytes(buf[:n]) == b"\x09hi"
    assert buf[n:] == bytearray(b"\xee" * 5)
    n = F.encode_elided_into(buf, F.DATA, 15, b"hi", F.F_ACK_REQ)
    assert bytes(buf[:n]) == b"\x8f\x08hi"


def test_decoders_accept_any_buffer_type():
    raw = F.encode_raw(F.Frame(F.DATA, 3, 5, 9, b"hi"))
    for d in (raw, bytearray(raw), memoryview(raw), memoryview(b"zz" + raw)[2:]):
        fr = F.decode_raw(d)
        assert fr == F.Frame(F.DATA, 3, 5, 9, b"hi")
        assert isinstance(fr.payload, bytes)
        assert F.check_raw(d) == 3
    el = b"\x8f\x08hi"
    for d in (el, bytearray(el), memoryview(el)):
        fr = F.decode_elided(d, 3, 5)
        assert fr == F.Frame(F.DATA, 3, 5, 15, b"hi", F.F_ACK_REQ)
        assert isinstance(fr.payload, bytes)


def test_broadcast_is_destination_equals_source_on_the_wire():
    for src in (0, 7, 15):
        raw = F.encode_raw(F.Frame(F.ADVERT, src, F.BROADCAST, 1))
        assert len(raw) == 5
        assert raw[2] == (src << 4) | src
        assert F.decode_raw(raw).dst == F.BROADCAST
    for src in (16, 100, 254):
        raw = F.encode_raw(F.Frame(F.ADVERT, src, F.BROADCAST, 1))
        assert len(raw) == 6
        assert raw[2] == src and raw[3] == src
        assert F.decode_raw(raw).dst == F.BROADCAST
    # a wide peer forces the wide header even for a short source
    raw = F.encode_raw(F.Frame(F.DATA, 3, 16, 0))
    assert raw[0] & 0x20 and raw[2] == 16 and raw[3] == 3


def test_overhead_constants():
    assert F.raw_overhead(0, 15) == F.RAW_OVERHEAD_SHORT == 5
    assert F.raw_overhead(15, F.BROADCAST) == 5
    assert F.raw_overhead(16, F.BROADCAST) == F.RAW_OVERHEAD_WIDE == 6
    assert F.raw_overhead(3, 200) == 6
    assert F.raw_overhead(200, 3) == 6
    assert F.raw_overhead(3, 256) == F.raw_overhead(256, 3) == 8
    assert F.raw_overhead(256, F.BROADCAST) == F.raw_overhead(300, 1000) == F.RAW_OVERHEAD_MAX == 10
    assert F.ELIDED_OVERHEAD == 1
    assert len(F.encode_elided(F.Frame(F.DATA, 1, 2, 0))) == 1
    assert len(F.encode_elided(F.Frame(F.DATA, 1, 2, 0, b"", F.F_FRAG))) == 2


def test_frame_equality_and_repr():
    a = F.Frame(F.DATA, 1, 2, 3, b"x", 4)
    assert a == F.Frame(F.DATA, 1, 2, 3, bytearray(b"x"), 4)
    assert not (a == F.Frame(F.DATA, 1, 2, 3, b"y", 4))
    assert not (a == F.Frame(F.DATA, 1, 2, 3, b"x", 5))
    assert not (a == "frame")
    assert "1->2" in repr(a)


# -- encoder errors -----------------------------------------------------------


def test_encode_errors_raw():
    buf = bytearray(64)

    def enc(t=F.DATA, src=3, dst=5, seq=0, payload=b"", flags=0, b=buf):
        return F.encode_raw_into(b, t, src, dst, seq, payload, flags)

    assert enc() == 5
    for kw in (
        {"t": -1},
        {"t": 8},
        {"flags": -1},
        {"flags": 16},
        {"seq": -1},
        {"seq": 64},
        {"src": -1},
        {"src": 255},
        {"src": 255, "dst": F.BROADCAST},
        {"src": 65535},
        {"dst": -1},
        {"dst": 65535},
        {"src": 3, "dst": 3},
        {"src": 200, "dst": 200},
        {"b": bytearray(4)},
        {"payload": b"x" * 60},  # 65 bytes into 64
        {"src": 20, "payload": b"x" * 59},  # wide: 65 bytes
    ):
        try:
            enc(**kw)
        except Exception as e:  # noqa: BLE001
            assert isinstance(e, EncodeError), (kw, e)
        else:
            assert False, "no EncodeError for %r" % kw
    # the boundaries themselves are fine
    assert enc(t=7, flags=15, seq=63) == 5
    assert enc(src=254, dst=0) == 6
    assert enc(src=0, dst=254) == 6
    assert enc(src=256, dst=0) == 8
    assert enc(src=65534, dst=300) == 10
    assert enc(src=300, dst=F.BROADCAST) == 10
    assert enc(payload=b"x" * 59) == 64
    assert enc(src=20, payload=b"x" * 58) == 64
    # encode_raw (allocating) checks the same things
    _raises(EncodeError, F.encode_raw, F.Frame(F.DATA, 4, 4, 0))
    _raises(EncodeError, F.encode_raw, F.Frame(F.DATA, 4, 5, 64))


def test_encode_errors_elided():
    buf = bytearray(8)
    for args in (
        (buf, -1, 0, b""),
        (buf, 8, 0, b""),
        (buf, 0, -1, b""),
        (buf, 0, 16, b""),  # elided sequence is 4 bits
        (buf, 0, 0, b"", -1),
        (buf, 0, 0, b"", 16),
        (buf, 0, 0, b"x" * 8),  # 9 bytes into 8
        (buf, 0, 0, b"x" * 7, 1),  # 9 bytes into 8 with the flags byte
        (bytearray(0), 0, 0, b""),
        (bytearray(1), 0, 0, b"", 1),
    ):
        _raises(EncodeError, F.encode_elided_into, *args)
    assert F.encode_elided_into(buf, 7, 15, b"x" * 7) == 8
    assert F.encode_elided_into(buf, 7, 15, b"x" * 6, 15) == 8
    _raises(EncodeError, F.encode_elided, F.Frame(F.DATA, 1, 2, 16))


# -- bad input ----------------------------------------------------------------


def test_random_bytes_raise_only_decode_error():
    rng = Prng(99)
    for _ in range(5000):
        data = rng.bytes(rng.below(41))
        fr = _decode_error_only(F.decode_raw, data)
        if fr is not None:  # a 1 in 2**18 fluke: it must then be canonical
            assert F.encode_raw(fr) == data
        fr = _decode_error_only(F.decode_elided, data, 1, 2)
        if fr is not None:
            assert F.encode_elided(fr) == data
        _decode_error_only(F.check_raw, data)


def test_truncations_of_valid_frames():
    frames = (
        F.Frame(F.DATA, 3, 5, 9, b"hello"),
        F.Frame(F.DATA, 3, 200, 33, b"hello", F.F_ACK_REQ),
        F.Frame(F.ACK, 5, 3, 9),
        F.Frame(F.ADVERT, 100, F.BROADCAST, 5),
    )
    for fr in frames:
        raw = F.encode_raw(fr)
        for n in range(len(raw)):
            e = _raises(DecodeError, F.decode_raw, raw[:n])
            _raises(DecodeError, F.check_raw, raw[:n])
            if n >= 6:
                assert isinstance(e, CRCError)
        # and from the front: a receiver that started late
        for n in range(1, len(raw)):
            _decode_error_only(F.decode_raw, raw[n:])
    # random frames, every truncation: only DecodeError, never anything else
    rng = Prng(7)
    for _ in range(150):
        src, dst = _random_addrs(rng)
        raw = F.encode_raw(F.Frame(rng.below(8), src, dst, rng.below(64), rng.bytes(rng.below(12)), rng.below(16)))
        for n in range(len(raw)):
            assert _decode_error_only(F.decode_raw, raw[:n]) is None
    # elided: losing the flags byte is detected; shorter payloads are the
    # container's business (the modem's CRC)
    el = F.encode_elided(F.Frame(F.DATA, 3, 5, 9, b"hi", F.F_FRAG))
    _raises(DecodeError, F.decode_elided, el[:0], 3, 5)
    _raises(DecodeError, F.decode_elided, el[:1], 3, 5)
    for n in range(2, len(el) + 1):
        assert F.decode_elided(el[:n], 3, 5).payload == b"hi"[: n - 2]


def test_corrupted_lengths_and_bits():
    raw = F.encode_raw(F.Frame(F.DATA, 3, 5, 9, b"hello"))
    _raises(CRCError, F.decode_raw, raw + b"\x00")
    _raises(CRCError, F.decode_raw, raw[:4] + raw[5:])  # a byte lost inside
    _raises(CRCError, F.decode_raw, raw[:4] + b"\x00" + raw[4:])  # a byte gained
    _raises(CRCError, F.decode_raw, raw + raw)  # two frames glued together
    for i in range(len(raw) * 8):
        b = bytearray(raw)
        b[i >> 3] ^= 0x80 >> (i & 7)
        _raises(DecodeError, F.decode_raw, b)
    # a short header whose W bit is set by damage needs 6 bytes: still a DecodeError
    b = bytearray(F.encode_raw(F.Frame(F.ACK, 1, 2, 0)))
    b[0] |= 0x20
    _raises(DecodeError, F.decode_raw, b)
    _raises(DecodeError, F.decode_raw, _with_crc(b[:3]))  # W set, 5 bytes in all
    for n in range(5):
        _raises(DecodeError, F.decode_raw, b"\x40" * n)


def test_wrong_versions_are_rejected_even_with_good_crc():
    body = bytearray(F.encode_raw(F.Frame(F.DATA, 3, 5, 9, b"hi"))[:-2])
    for v in (0, 2, 3):
        body[0] = (body[0] & 0x3F) | (v << 6)
        e = _raises(DecodeError, F.decode_raw, _with_crc(body))
        assert not isinstance(e, CRCError)
        _raises(DecodeError, F.check_raw, _with_crc(body))
    body[0] = (body[0] & 0x3F) | 0x40
    assert F.decode_raw(_with_crc(body)) == F.Frame(F.DATA, 3, 5, 9, b"hi")


def test_escaped_ids_in_wide_header():
    # 0xFF starts an id of two more bytes, 256..65534: one written with
    # fewer bytes, 65535, or one that runs into the CRC is refused
    for addrs in ((255, 0, 255, 3), (255, 0, 16, 3), (3, 255, 0, 254), (255, 255, 255, 3), (255, 1), (3, 255, 1)):
        data = _with_crc(bytes([0x60, 0x01]) + bytes(addrs))
        e = _raises(DecodeError, F.decode_raw, data)
        assert not isinstance(e, CRCError)
        _raises(DecodeError, F.raw_addresses, data)
    data = _with_crc(bytes([0x60, 0x01, 255, 1, 0, 3]) + b"x")
    assert F.decode_raw(data) == F.Frame(F.DATA, 3, 256, 1, b"x")
    assert F.raw_addresses(data) == (3, 256) and F.check_raw(data) == 6
    data = _with_crc(bytes([0x60, 0x01, 254, 255, 0xFF, 0xFE]))
    assert F.decode_raw(data) == F.Frame(F.DATA, 65534, 254, 1)
    # every id the API can give has one encoding, and get_addr reads it back
    for a in (0, 15, 254, 256, 4095, 65534):
        b = F.addr_bytes(a)
        assert len(b) == (1 if a < 255 else 3) and F.get_addr(b, 0) == (a, len(b))
        if a > 15:  # in a wide header, as the destination
            assert F.encode_raw(F.Frame(F.DATA, 1, a, 0))[2 : 2 + len(b)] == b
    for b in (b"", b"\xff", b"\xff\x01", b"\xff\x00\xff", b"\xff\xff\xff"):
        _raises(DecodeError, F.get_addr, b, 0)


def test_non_canonical_wide_header_for_short_addresses():
    for dst, src in ((5, 3), (3, 3), (0, 15), (15, 15)):
        data = _with_crc(bytes([0x60, 0x01, dst, src]))
        e = _raises(DecodeError, F.decode_raw, data)
        assert not isinstance(e, CRCError)
    # one address above 15 makes the wide header the canonical one
    assert F.decode_raw(_with_crc(bytes([0x60, 0x01, 16, 15]))) == F.Frame(F.DATA, 15, 16, 1)


def test_elided_flags_byte_must_be_1_to_15():
    _raises(DecodeError, F.decode_elided, b"\x89\x00", 3, 5)
    _raises(DecodeError, F.decode_elided, b"\x89\x00hi", 3, 5)
    for fb in (0x10, 0x80, 0xFF):
        _raises(DecodeError, F.decode_elided, bytes([0x89, fb]), 3, 5)
    _raises(DecodeError, F.decode_elided, b"\x89", 3, 5)
    _raises(DecodeError, F.decode_elided, b"", 3, 5)
    for fb in range(1, 16):
        assert F.decode_elided(bytes([0x89, fb]), 3, 5).flags == fb


def test_spare_types_are_passed_up():
    for t in (5, 6, 7):
        fr = F.Frame(t, 1, 2, 3, b"?")
        assert F.decode_raw(F.encode_raw(fr)).ftype == t
        assert F.decode_elided(F.encode_elided(fr), 1, 2).ftype == t


def test_encode_elided_is_encode_elided_into():
    # the allocating form builds its bytes without a buffer: the same bytes
    # and the same errors, for any payload type
    buf = bytearray(48)
    rng = Prng(77)
    for _ in range(2000):
        flags = rng.below(16) if rng.below(2) else 0
        body = rng.bytes(rng.below(41))
        fr = F.Frame(rng.below(8), 1, 2, rng.below(16), body, flags)
        n = F.encode_elided_into(buf, fr.ftype, fr.seq, body, flags)
        for p in (body, bytearray(body), memoryview(b"zz" + body)[2:]):
            fr.payload = p
            got = F.encode_elided(fr)
            assert isinstance(got, bytes) and got == bytes(buf[:n])
    for ftype, seq, flags in ((8, 0, 0), (-1, 0, 0), (0, 16, 0), (0, -1, 0), (0, 0, 16), (0, 0, -1)):
        _raises(EncodeError, F.encode_elided, F.Frame(ftype, 1, 2, seq, b"x", flags))
