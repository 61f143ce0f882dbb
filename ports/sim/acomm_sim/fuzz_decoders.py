# Fuzz targets for acomm's pure decoders (acomm_sim.fuzz has the engine).
# Each builds its corpus with acomm's own encoders and checks, beyond "only
# acomm errors escape", what its format promises: a raw frame that decodes
# encodes back to the same bytes, an RS correction is a codeword within the
# corrected distance, the stream decoders resynchronise on the next valid
# frame after garbage.

from acomm import frame as fr
from acomm.transport import segment
from acomm.errors import AcommError
from acomm.prng import Prng

from .fuzz_base import Failure, Target


def _node_id(rng):
    # a node id, a quarter of them 256..65534 (three bytes on the water)
    return rng.range(256, 65535) if rng.chance(0.25) else rng.below(255)


def _frame_target():
    rng = Prng(101)
    corpus = []
    for i in range(32):
        src = rng.below(20) if i % 3 else (_node_id(rng) if i < 24 else rng.range(256, 65535))
        dst = (src + 1 + rng.below(250)) % 255 if rng.chance(0.8) else fr.BROADCAST
        if i >= 24 and i % 2:
            dst = rng.range(256, 65535)
        corpus.append(fr.encode_raw(fr.Frame(rng.below(8), src, dst, rng.below(64), rng.bytes(rng.below(40)), rng.below(16))))

    def run(data, rng):
        if data and data[0] & 1:
            f = fr.decode_elided(data[1:], 3, 4)
            if fr.encode_elided(f) != bytes(data[1:]):
                raise Failure("elided frame does not encode back to its bytes")
            return
        f = fr.decode_raw(data)
        if fr.encode_raw(f) != bytes(data):
            raise Failure("raw frame %r does not encode back to its bytes" % (f,))
        if fr.raw_addresses(data) != (f.src, f.dst):
            raise Failure("raw_addresses disagrees with decode_raw")

    return Target("frame", corpus, run)


def _segment_target():
    rng = Prng(102)
    corpus = []
    for i in range(16):
        head, first = segment.frag_header(rng.chance(0.3), rng.below(2), rng.below(2), rng.below(300))
        corpus.append(bytes((head,)) + first + rng.bytes(rng.range(1, 30)))
        head, body = segment.sack(rng.below(2), rng.below(2), rng.below(256), rng.bytes(rng.below(9)))
        corpus.append(bytes((head,)) + body)
    head, body = segment.sack_complete(0, 1, 7, 0x1234)
    corpus.append(bytes((head,)) + body)
    head, body = segment.sack_refused(1, 0, segment.REFUSE_FULL)
    corpus.append(bytes((head,)) + body)
    for _ in range(8):
        # a packet header with its relay fields, behind a first byte of 0xFE
        relay = (_node_id(rng), _node_id(rng), rng.range(1, 17), rng.below(70000))
        corpus.append(b"\xfe" + segment.packet_header(rng.below(65536), rng.below(5000), rng.chance(0.5), relay))

    def run(data, rng):
        if data and data[0] == 0xFE:
            segment.decode_packet_header(data[1:])
        elif data:
            segment.decode(data[0] & 0x0F if data[0] < 0x80 else data[0], data[1:])

    return Target("segment", corpus, run)


def _catalog_target(name):
    from acomm.catalog import load

    cat = load(name)
    # valid inputs: what the decoder makes of random bytes, packed again
    rng = Prng(name_seed(name))
    corpus = []
    tries = 0
    while len(corpus) < 24 and tries < 4000:
        tries += 1
        try:
            msgs = cat.unpack(rng.bytes(1 + rng.below(12)))
            if msgs:
                corpus.append(cat.pack(msgs))
        except AcommError:
            pass

    def run(data, rng):
        msgs = cat.unpack(data)
        # what decodes packs again, and that packs to a stable form: a
        # value the decoder gives must be one the encoder takes
        again = cat.pack(msgs)
        if cat.pack(cat.unpack(again)) != again:
            raise Failure("%s: repacking is not stable" % name)

    return Target("catalog." + name, corpus, run)


def name_seed(s):
    h = 7
    for c in s.encode():
        h = (h * 31 + c) & 0xFFFF
    return h


def _seaware_target():
    from acomm.catalog import seaware

    rng = Prng(103)
    corpus = []
    for m in seaware.CATALOG.messages:
        try:
            body = None
            for _ in range(200):
                try:
                    got = seaware.CATALOG.unpack(bytes((m.msg_id,)) + rng.bytes(rng.below(9)))
                    if len(got) == 1:
                        body = seaware.CATALOG.pack(got)
                        break
                except AcommError:
                    pass
            if body is not None:
                corpus.append(seaware.encode_packet(rng.below(128), body))
        except AcommError:
            pass

    def run(data, rng):
        seaware.decode(data)

    return Target("seaware", corpus, run)


def _compress_target():
    from acomm.codec.compress import compress, decompress

    rng = Prng(104)
    texts = [b"status depth 12.5 heading 270 " * 3, b"\x00" * 90, bytes(range(64)) * 2, b"hello hello hello",
             b'{"lat": 42.1, "lon": 3.2, "lat": 42.1}']
    for _ in range(8):
        texts.append(rng.bytes(rng.below(40)) * (1 + rng.below(3)))
    corpus = [compress(t) for t in texts]

    def run(data, rng):
        out = decompress(data, 512)
        if len(out) > 512:
            raise Failure("decompressed %d bytes, max_out 512" % len(out))

    return Target("compress", corpus, run)


def _fec_target():
    from acomm.codec.fec import ReedSolomon

    rs = ReedSolomon(8)
    rng = Prng(105)
    corpus = [rs.encode(rng.bytes(1 + rng.below(60))) for _ in range(12)]

    def run(data, rng):
        data = data[:255]
        msg, nerr = rs.decode_count(data)
        cw = rs.encode(msg)
        diff = 0
        for i in range(len(cw)):
            if cw[i] != data[i]:
                diff += 1
        if len(cw) != len(data) or diff != nerr or 2 * nerr > 8:
            raise Failure("RS corrected %d bytes but the codeword differs in %d" % (nerr, diff))

    return Target("fec", corpus, run)


def _resync(feed, probe, want, rounds):
    # feeds `probe` until `want` comes out; Failure after `rounds` tries
    for _ in range(rounds):
        if want in feed(probe):
            return
    raise Failure("no resynchronisation after %d valid frames" % rounds)


def _slip_target():
    from acomm.frame import slip

    rng = Prng(106)
    frames = [rng.bytes(1 + rng.below(60)) + b"\xc0\xdb" for _ in range(8)]
    corpus = [slip.encode(f) for f in frames]
    probe = slip.encode(b"probe \xc0 \xdb frame")

    def run(data, rng):
        d = slip.SlipDecoder(128)

        def feed(x):
            out = []
            d.feed(x, out)
            for f in out:
                if not 0 < len(f) <= 128:
                    raise Failure("SLIP frame of %d bytes" % len(f))
            return out

        feed(data)
        _resync(feed, probe, b"probe \xc0 \xdb frame", 2)

    return Target("slip", corpus, run)


def _lenframe_target():
    from acomm.frame import lenframe

    rng = Prng(107)
    corpus = []
    for _ in range(8):
        out = bytearray()
        for _ in range(1 + rng.below(3)):
            lenframe.append_frame(out, rng.bytes(1 + rng.below(50)))
        corpus.append(bytes(out))

    def run(data, rng):
        d = lenframe.LenDecoder(256)
        out = []
        d.feed(data, out)
        for f in out:
            if not len(f) <= 256:
                raise Failure("frame of %d bytes past max_frame" % len(f))

    return Target("lenframe", corpus, run)


def _imc_msgs():
    return (
        {"abbrev": "UamTxFrame", "seq": 7, "sys_dst": "lauv-xplore-1", "flags": 1, "data": b"hello"},
        {"abbrev": "Heartbeat"},
        {"abbrev": "TransmissionRequest", "req_id": 3,
         "msg_data": {"abbrev": "AcousticMessage", "message": {"abbrev": "Abort"}}},
    )


def _imc_target():
    from acomm import imc

    corpus = []
    for i, m in enumerate(_imc_msgs()):
        corpus.append(imc.encode(m, src=0x1234, dst=0xFFFF, timestamp=1700000000 + i, big=bool(i & 1)))

    def run(data, rng):
        imc.decode(data, exact=rng.chance(0.5))

    return Target("imc", corpus, run)


def _imc_stream_target():
    from acomm import imc

    corpus = [imc.encode(m, src=0x1234, dst=0xFFFF, timestamp=1700000000) for m in _imc_msgs()]
    probe = imc.encode({"abbrev": "UamTxFrame", "seq": 99, "sys_dst": "x", "flags": 0, "data": b"probe"})
    cap = 512

    def run(data, rng):
        sp = imc.StreamParser(cap)

        def feed(x):
            # a packet of an id acomm does not know comes back with msg None
            return [p.msg.get("seq") for p in sp.feed(x) if p.msg is not None and p.msg.get("abbrev") == "UamTxFrame"]

        feed(data)
        # a header that lies about its size may hold up to cap bytes
        _resync(feed, probe, 99, cap // len(probe) + 3)

    return Target("imc.stream", corpus, run)


def _auth_target():
    # Sealed frames (acomm.frame.auth) through a link's framing, raw and elided:
    # only acomm errors escape, and a frame that verifies must be one that
    # was sealed: same type, addresses and payload (the sequence number and
    # the other flags are not covered). An 8-byte tag keeps a chance
    # forgery out of a million inputs.
    from acomm.frame.auth import Auth
    from acomm.link.framing import LinkFraming
    from acomm.link.names import AddressMap

    key = b"fuzzing key 0123456789"
    rng = Prng(103)
    corpus = []
    sealed = []
    for i in range(16):
        elided = i % 2 == 1
        src = 1 + rng.below(14)
        dst = None if rng.chance(0.2) else (src % 14) + 1
        tx = LinkFraming(src, elided, AddressMap(True, 255), 120)
        tx.set_auth(Auth(key, 8))
        ftype = (fr.DATA, fr.SEGMENT, fr.ACK, fr.ADVERT)[rng.below(4)]
        payload = rng.bytes(rng.below(30))
        _, data = tx.encode(ftype, dst, rng.below(16), payload)
        corpus.append(bytes((1 if elided else 0, src, 255 if dst is None else dst)) + data)
        sealed.append((ftype, src, dst, payload))

    def run(data, rng):
        if len(data) < 3:
            return
        elided, src, dst = data[0] & 1, data[1], data[2]
        rx = LinkFraming(0, bool(elided), AddressMap(True, 255), 120)
        rx.set_auth(Auth(key, 8))
        f, fsrc, fdst = rx.decode(src, dst, data[3:])
        if f.authed and (f.ftype, fsrc, fdst, bytes(f.payload)) not in sealed:
            raise Failure("a frame that was never sealed verified: %r" % (f,))

    return Target("auth", corpus, run)


def _route_target():
    # route control and floods (acomm.transport.routing): what decodes encodes back to the same bytes
    from acomm.transport import flood as F
    from acomm.transport import routing as W

    rng = Prng(136)
    corpus = []
    for _ in range(8):
        corpus.append(W.encode_request(rng.below(256), _node_id(rng), rng.below(65535), _node_id(rng),
                                       rng.below(65536), rng.below(64), rng.below(70000)))
        corpus.append(W.encode_reply(_node_id(rng), rng.below(65535), _node_id(rng), rng.below(64),
                                     rng.below(70000), rng.below(1100000)))
        corpus.append(W.encode_error([(_node_id(rng), rng.below(65535)) for _ in range(rng.range(1, 17))]))
    for _ in range(8):
        corpus.append(F.encode_flood(_node_id(rng), rng.below(256), rng.below(64),
                                     rng.bytes(rng.range(1, F.MAX_DATA))))

    def run(data, rng):
        got = W.decode(data)
        if got[0] == "request":
            again = W.encode_request(*got[1:])
        elif got[0] == "reply":
            again = W.encode_reply(*got[1:])
        elif got[0] == "flood":
            again = F.encode_flood(*got[1:])
        else:
            again = W.encode_error(got[1])
        if again != bytes(data):
            raise Failure("route control %r does not encode back to its bytes" % (got,))

    return Target("route", corpus, run)


def targets():
    out = [_frame_target(), _segment_target(), _route_target()]
    from acomm.catalog import MODULES

    for m in MODULES:
        out.append(_catalog_target(m))
    out += [_seaware_target(), _compress_target(), _fec_target(), _slip_target(), _lenframe_target(),
            _imc_target(), _imc_stream_target(), _auth_target()]
    return out
