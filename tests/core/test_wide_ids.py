# Node ids of 256 and more (up to 65534): one byte on the water for 0..254,
# and for the others 0xFF then the id in 2 bytes (acomm.frame.addr_bytes), in
# the frame header, adverts, relay fields, route control and floods, and in
# the store's records and the memory of delivered packets. Here a routed
# chain of such nodes on a packet modem that carries raw frames, open and
# sealed, and each place an id of 256 or more must not be confused with the
# one-byte id it shares modulo 256 (300 and 44): the store, the memory of
# packets done, the tag and the counter file.
from acomm import frame as fr
from acomm.errors import AuthError, DecodeError
from acomm.events import EV_PACKET
from acomm.frame.auth import Auth
from acomm.link.discovery import decode_advert, encode_advert
from acomm.transport import Transport
from acomm.transport import segment as sg
from acomm.transport.memorystore import MemoryStore
from acomm.transport.packetstore import PacketStore, key_of
from acomm_sim.channel import Channel
from acomm_sim.world import World
from checks import TempDir, raises

RANGE = ((0.0, 0.0), (200.0, 0.0), (201.0, 1.0))  # heard within 200 m, never beyond
IDS = (300, 44, 65534, 1000)  # a chain; 300 and 44 share their low byte


def _wall(w):
    return lambda: w.now() // 1000


def _chain(stores=None, key=None):
    w = World(seed=3, channel=Channel(seed=3, loss_curve=RANGE))
    ns = []
    for i, nid in enumerate(IDS):
        sn = w.add("n%d" % nid, nid, "bpsk", position=(150.0 * i, 0.0, 10.0), link_opts={"advert_period_ms": 30000})
        if key is not None:
            sn.node.set_auth(Auth(key, 4), strict=True)
        st = None if stores is None else stores[i]
        sn.t = Transport.of(sn.node, store=st, wall=_wall(w), routing={"search_ms": 30000})
        ns.append(sn)
    w.run(65000)  # two advert rounds: every node knows its neighbours
    return w, ns


def _got(sn):
    return [(e[1], e[3]) for e in sn.events if e[0] == EV_PACKET]


def _flood_then_send(w, ns, flood, data):
    # 65534 floods: every other node gets it once; then 300 sends data 3 hops to 1000
    first, last = ns[0], ns[3]
    ns[2].t.flood(w.now(), flood)
    w.run(90000)
    for sn in ns:
        assert _got(sn) == ([] if sn is ns[2] else [("n65534", flood)]), sn.node.name
        del sn.events[:]
    first.t.send(w.now(), "n1000", data, 3600)
    assert w.run(400000, until=lambda: _got(last)), first.t.stats
    assert _got(last) == [("n300", data)]


def test_a_routed_chain_of_wide_ids_carries_packets_and_floods():
    w, ns = _chain()
    first, last = ns[0], ns[3]
    for sn in ns:
        d = sn.node.link("acoustic").discovery
        assert sorted(d.nodes) == sorted(x for x in IDS if abs(IDS.index(x) - ns.index(sn)) == 1)
    # a flood from 65534 reaches every other node once (a flood is not acknowledged: on a
    # quiet channel, before the packets, no copy is lost to a collision)
    _flood_then_send(w, ns, b"all surface", b"three hops by ids of two bytes")
    assert first.t.router.routing.table.lookup(w.now(), 1000)[0] == 44
    # the relays learned the way back to 300, not to 44 (its low byte)
    assert ns[2].t.router.routing.table.lookup(w.now(), 300)[0] == 44
    last.t.send(w.now(), "n300", b"and back", 3600)
    assert w.run(400000, until=lambda: _got(first))
    assert _got(first) == [("n1000", b"and back")]
    for sn in ns:
        assert sn.t.stats["rx_bad"] == 0 and sn.node.link("acoustic").stats["rx_bad"] == 0


def test_a_relay_keeps_a_wide_origins_packet_through_a_restart():
    stores = [MemoryStore() for _ in IDS]
    w, ns = _chain(stores)
    first, relay, last = ns[0], ns[1], ns[3]
    first.t.send(w.now(), "n1000", b"custody", 3600)
    # the relay (44) takes custody; 300's packet is keyed apart from 44's own
    assert w.run(400000, until=lambda: relay.t.stats["relayed"] >= 1)
    relay.node.transport = None
    t2 = Transport.of(relay.node, store=stores[1], wall=_wall(w), routing={"search_ms": 30000})
    assert [(p.origin, p.final) for p in t2._out] == [(300, 1000)]  # back from the store, not yet sent on
    assert w.run(600000, until=lambda: _got(last)), t2.stats
    assert _got(last) == [("n300", b"custody")]


def test_the_store_and_the_done_memory_tell_300_from_44():
    st = MemoryStore()
    ps = PacketStore(st)

    class P:
        body, compressed, medium, chunks, key = b"x" * 20, False, None, 0, None

    a, b = P(), P()
    a.origin, a.final, a.pid, a.prio, a.expiry = 300, 65534, 7, 5, 2000000000
    b.origin, b.final, b.pid, b.prio, b.expiry = 44, 1, 7, 5, 2000000000
    for p in (a, b):
        p.size = len(p.body)
        ps.put(p)
    assert key_of(a) != key_of(b) and key_of(a) >> 16 == 0xFF
    got = dict((s.origin, s) for s in PacketStore(st).recover())
    assert sorted(got) == [44, 300] and got[300].final == 65534 and got[300].key == key_of(a)
    assert PacketStore(st).body(key_of(a)) == b"x" * 20
    # a packet from 556 (low byte 44 too) with the same pid takes another slot
    c = P()
    c.origin, c.final, c.pid, c.prio, c.expiry, c.size = 556, 2, 7, 5, 2000000000, 20
    ps.put(c)
    assert key_of(c) not in (key_of(a), key_of(b))
    # the done memory: 300's pid 9 is not 44's, and both come back after a restart
    w = World(seed=1)
    sn = w.add("n300", 300, "bpsk", position=(0.0, 0.0, 10.0))
    store = MemoryStore()
    t = Transport.of(sn.node, store=store, wall=_wall(w))
    t._remember(300, 9, 600)
    assert t._is_done(300, 9) and not t._is_done(44, 9) and not t._is_done(556, 9)
    t._remember(44, 10, 600)
    assert t._is_done(44, 10) and not t._is_done(300, 10)
    sn.node.transport = None
    t2 = Transport.of(sn.node, store=store, wall=_wall(w))
    assert t2._is_done(300, 9) and t2._is_done(44, 10) and not t2._is_done(44, 9)
    for k in range(40):
        t2._remember(1000 + k, k, 7200, False)
    assert len(t2._done_wide) == 7 * 32 and t2._is_done(1039, 39) and not t2._is_done(300, 9)


def test_adverts_and_relay_fields_with_wide_ids():
    assert encode_advert(300, 60000) == b"\xff\x01\x2c\x0f"
    assert decode_advert(encode_advert(300, 60000)) == (300, 60000)
    assert decode_advert(b"\x2c\x0f") == (44, 60000)
    for bad in (b"\xff\x00\x2c\x0f", b"\xff\x01\x2c", b"\xff\x01\x2c\x0f\x00", b"\xff\x0f"):
        raises(DecodeError, decode_advert, bad)
    h = sg.packet_header(5, 100, False, (300, 2, 3, 600))
    assert len(h) == len(sg.packet_header(5, 100, False, (44, 2, 3, 600))) + 2
    assert sg.decode_packet_header(h).relay == (300, 2, 3, 600)
    raises(DecodeError, sg.decode_packet_header, h[:6])


def test_a_frame_sealed_by_300_is_never_taken_for_one_by_44():
    key = b"k" * 16
    a, b = Auth(key, 4), Auth(key, 4)
    body = a.seal(fr.DATA, 300, 2, b"x", seq=9)
    raises(AuthError, b.open, fr.DATA, 44, 2, body, 9)  # its low byte
    assert b.open(fr.DATA, 300, 2, body, 9)[0] == b"x"
    raises(AuthError, b.open, fr.DATA, 300, 2, body, 9)  # a replay
    # to 300 (and to everyone, from 300), never to 44
    body = a.seal(fr.DATA, 2, 300, b"y", seq=1)
    raises(AuthError, b.open, fr.DATA, 2, 44, body, 1)
    assert b.open(fr.DATA, 2, 300, body, 1)[0] == b"y"
    body = a.seal(fr.CONTROL, 300, None, b"z")
    raises(AuthError, b.open, fr.CONTROL, 44, None, body)
    assert b.open(fr.CONTROL, 300, None, body)[0] == b"z"
    # the sealed ACK binds the wide ids too; a narrow pair's tag is as it was
    assert a.ack_tag(2, 300, 1, 5) != a.ack_tag(2, 44, 1, 5) != a.ack_tag(300, 2, 1, 5)
    assert b.ack_tag(300, 2, 1, 5, a.ack_tag(300, 2, 1, 5)) and not b.ack_tag(44, 2, 1, 5, a.ack_tag(300, 2, 1, 5))


def test_the_counter_file_keeps_wide_sources_apart_through_a_restart():
    key = b"k" * 16
    with TempDir() as d:
        path = d.file("wide.auth")
        sender = Auth(key, 4)
        rx = Auth(key, 4, path=path, reserve=1)
        frames = dict((src, sender.seal(fr.DATA, src, 2, b"m%d" % src)) for src in (300, 44, 65534))
        for src in (300, 44, 65534):
            assert rx.open(fr.DATA, src, 2, frames[src])[0] == b"m%d" % src
        rx.commit()
        rx2 = Auth(key, 4, path=path)  # a restart: every window survives, 300 apart from 44
        assert sorted(rx2._rx) == [44, 300, 65534] and rx2.stats["epochs"] == 0
        for src in (300, 44, 65534):
            raises(AuthError, rx2.open, fr.DATA, src, 2, frames[src])
        # a file with one-byte sources only is laid out as before: no section for wide ones
        rx3 = Auth(key, 4, path=path, reserve=1)
        del rx3._rx[300], rx3._rx[65534]
        rx3._save()
        with open(path, "rb") as f:
            data = f.read()
        assert len(data) == 11 + 2 + 1 + 8 and Auth(key, 4, path=path).stats["epochs"] == 0
        # a wide section cut short is a damaged file: a new epoch, never a window half read
        rx2._save()
        with open(path, "rb") as f:
            data = f.read()
        with open(path, "wb") as f:
            f.write(data[:-1])
        assert Auth(key, 4, path=path).stats["epochs"] == 1


def test_a_sealed_network_of_wide_ids_in_strict_mode():
    # every node keyed and strict: routed packets, route control and a flood go sealed
    # between ids of two bytes, and nothing is refused at any link
    w, ns = _chain(key=b"s" * 16)
    _flood_then_send(w, ns, b"sealed flood", b"sealed, three hops")
    for sn in ns:
        link = sn.node.link("acoustic")
        assert link.framing.auth.stats["opened"] > 0 and link.framing.auth.stats["bad_tag"] == 0
        assert link.stats["rx_bad"] == 0 and link.stats.get("unauthed", 0) == 0, (sn.node.name, link.stats)
