# The IMC stream parser on noisy, cut and lying input, and a fuzz loop over
# the whole decoder where only acomm's errors may come out.

import struct

from acomm import imc
from acomm.codec.crc import crc16
from acomm.errors import DecodeError, EncodeError
from acomm.prng import Prng

TX = {"abbrev": "UamTxFrame", "seq": 7, "sys_dst": "lauv-xplore-1", "flags": 1, "data": b"hello"}


def _pkt(seq, big=False, data=b"hello"):
    return imc.encode(dict(TX, seq=seq, data=data), src=0x1234, dst=0xFFFF, timestamp=1700000000, big=big)


def _seqs(pkts):
    return [p.msg["seq"] for p in pkts]


def _feed_all(sp, data, chunk):
    out = []
    for i in range(0, len(data), chunk):
        out += sp.feed(data[i : i + chunk])
    return out


def test_packets_between_noise_in_any_chunking():
    rng = Prng(1)
    stream = b""
    noise_total = 0
    for seq in range(20):
        noise = rng.bytes(rng.below(30))
        noise_total += len(noise)
        stream += noise + _pkt(seq, big=bool(seq & 1))
    for chunk in (1, 2, 7, 64, len(stream)):
        sp = imc.StreamParser(capacity=256)
        got = _feed_all(sp, stream, chunk)
        assert _seqs(got) == list(range(20)), chunk
        assert [p.big for p in got] == [bool(s & 1) for s in range(20)]
        c = sp.counters()
        assert c["packets"] == 20 and c["unknown"] == 0 and c["bad_payload"] == 0
        # every byte is in a packet, skipped, or still held
        assert c["skipped"] + sp.pending() == noise_total, (chunk, c, sp.pending())


def test_fake_syncs_and_bad_crc_resync():
    good = _pkt(1)
    damaged = bytearray(_pkt(2))
    damaged[25] ^= 1
    stream = b"\x54\xfe\x54" + bytes(damaged) + b"\xfe\x54\x00" + good + b"\x54"
    sp = imc.StreamParser(capacity=128)
    got = sp.feed(stream)
    assert _seqs(got) == [1]
    assert sp.bad_crc >= 1
    # the trailing 0x54 may start a sync: held, not counted yet
    assert sp.pending() == 1
    got = sp.feed(b"\x00" * 3)
    assert got == [] and sp.pending() == 0


def test_truncated_packet_then_a_whole_one():
    cut = _pkt(1)[:30]
    sp = imc.StreamParser(capacity=128)
    got = sp.feed(cut + _pkt(2))
    assert _seqs(got) == [2]
    assert sp.bad_crc == 1
    assert sp.skipped == 30


def test_lying_size_within_capacity_holds_then_releases():
    liar = bytearray(_pkt(1))
    liar[4:6] = struct.pack("<H", 150)  # says 150 payload bytes, has 25
    sp = imc.StreamParser(capacity=512)
    assert sp.feed(bytes(liar) + _pkt(2)) == []  # waiting for 172 bytes
    got = sp.feed(bytes(100))
    assert _seqs(got) == [2]
    assert sp.bad_crc == 1


def test_size_beyond_capacity_is_refused_at_once():
    liar = bytearray(_pkt(1))
    liar[4:6] = struct.pack("<H", 60000)
    sp = imc.StreamParser(capacity=128)
    got = sp.feed(bytes(liar) + _pkt(2))
    assert _seqs(got) == [2]
    assert sp.bad_size == 1 and sp.bad_crc == 0
    # a packet larger than the capacity is refused even when whole
    big = _pkt(3, data=bytes(200))
    assert sp.feed(big + _pkt(4)) and sp.bad_size == 2


def test_unknown_ids_are_passed_on_and_counted():
    body = struct.pack("<HHHQHBHB", 0xFE54, 999, 4, 0, 1, 2, 3, 4) + b"abcd"
    unknown = body + struct.pack("<H", crc16(body))
    sp = imc.StreamParser()
    got = sp.feed(unknown + _pkt(5))
    assert got[0].msg is None and got[0].mgid == 999 and got[0].payload == b"abcd"
    assert got[1].msg["seq"] == 5
    assert sp.unknown == 1 and sp.packets == 2


def test_good_crc_bad_fields_is_dropped_whole():
    # UamTxStatus whose plaintext length says 100 bytes in a 5-byte payload
    payload = b"\x07\x00\x09\x64\x00"
    body = struct.pack("<HHHQHBHB", 0xFE54, 816, len(payload), 0, 1, 2, 3, 4) + payload
    bad = body + struct.pack("<H", crc16(body))
    sp = imc.StreamParser()
    got = sp.feed(bad + _pkt(6))
    assert _seqs(got) == [6]
    assert sp.bad_payload == 1 and sp.skipped == len(bad)


def test_memory_stays_bounded_under_garbage():
    rng = Prng(2)
    sp = imc.StreamParser(capacity=64)
    for _ in range(200):
        junk = bytearray(rng.bytes(97))
        # plenty of syncs with sizes of every kind
        for i in range(0, 90, 9):
            junk[i : i + 2] = b"\x54\xfe" if rng.chance(0.5) else b"\xfe\x54"
        assert sp.feed(bytes(junk)) == []
        assert sp.pending() <= sp.capacity
    assert sp.packets == 0 and sp.bad_size > 0
    sp.feed(bytes(64))  # drains whatever a size within capacity held back
    assert _seqs(sp.feed(_pkt(9))) == [9]
    sp.reset()
    assert sp.pending() == 0


def test_exact_mode():
    sp = imc.StreamParser(exact=True)
    p = sp.feed(_pkt(1))[0]
    assert p.timestamp == imc.F64.seconds(1700000000)


def _mutate(rng, data):
    d = bytes(data)
    for _ in range(1 + rng.below(3)):
        op = rng.below(6)
        n = len(d)
        if op == 0 and n:
            i = rng.below(n)
            d = d[:i] + bytes([d[i] ^ (1 << rng.below(8))]) + d[i + 1 :]
        elif op == 1 and n:
            d = d[: rng.below(n)]
        elif op == 2:
            i = rng.below(n + 1)
            d = d[:i] + rng.bytes(1 + rng.below(4)) + d[i:]
        elif op == 3 and n >= 6:
            d = d[:4] + struct.pack("<H", rng.below(0x10000)) + d[6:]
        elif op == 4 and n > 22:
            # a length prefix or an inline id inside the payload
            i = 20 + rng.below(n - 22)
            v = (0xFFFF, 0, 1, 206, 999, rng.below(0x10000))[rng.below(6)]
            d = d[:i] + struct.pack("<H", v) + d[i + 2 :]
        elif op == 5 and n > 2:
            i = rng.below(n - 1)
            d = d[:i] + d[i + 1 :]
    if len(d) >= 22 and rng.chance(0.7):
        # fix the CRC so the field decoders see the damage, in the order
        # the sync claims
        big = d[0] == 0xFE
        d = d[:-2] + struct.pack(">H" if big else "<H", crc16(d[:-2]))
    return d


def test_fuzz_only_acomm_errors_escape():
    rng = Prng(77)
    ann = {"abbrev": "Announce", "sys_name": "a", "sys_type": 2, "owner": 1, "lat": 0.5, "lon": -0.5, "height": 1.0, "services": "x"}
    seeds = [
        _pkt(1),
        _pkt(2, big=True),
        imc.encode({"abbrev": "TransmissionRequest", "req_id": 3, "msg_data": {"abbrev": "AcousticMessage", "message": {"abbrev": "Abort"}}}),
        imc.encode({"abbrev": "VehicleLinks", "localname": "gw", "links": [ann, ann]}, big=True),
        imc.encode(ann),
        imc.encode({"abbrev": "Heartbeat"}),
    ]
    sp = imc.StreamParser(capacity=512)
    decoded = errors = 0
    stream = b""
    for _ in range(1500):
        bad = _mutate(rng, seeds[rng.below(len(seeds))])
        for exact in (False, True):
            try:
                p = imc.decode(bad, exact)
                decoded += 1
                if p.msg is not None:
                    # whatever decodes encodes again
                    imc.decode(imc.encode(p.msg, p.src, p.dst, p.timestamp, p.src_ent, p.dst_ent))
            except DecodeError:
                errors += 1
        try:
            imc.decode_inline(bad[20:-2], bad[:1] == b"\xfe")
        except DecodeError:
            pass
        stream += bad + rng.bytes(rng.below(5))
        if len(stream) > 300:
            n = 1 + rng.below(len(stream))
            sp.feed(bytes(stream[:n]))
            stream = stream[n:]
            assert sp.pending() <= sp.capacity
    assert decoded > 100 and errors > 500, (decoded, errors)
    c = sp.counters()
    assert c["packets"] > 100 and c["bad_crc"] > 50 and c["bad_payload"] > 10, c


def test_stream_rejects_a_tiny_capacity():
    try:
        imc.StreamParser(capacity=10)
        assert False, "accepted"
    except ValueError:
        pass
    try:
        imc.encode(TX, src=-1)
        assert False, "accepted"
    except EncodeError:
        pass
