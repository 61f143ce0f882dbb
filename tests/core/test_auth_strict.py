# Strict mode (acomm.link.guard), the default with a network key: frames
# built by hand as an attacker without the key would put them on the air
# (forged ACKs, SACKs of every kind, polls, adverts, modem replies,
# fragment floods, oversized lengths, a decompression bomb, replays, tag
# guesses) are refused and counted by kind at the link and at the
# transport, and the same forgeries in open mode show what strict mode
# stops. A genuine sealed frame of each kind still works.
from acomm import frame as fr
from acomm.transport import segment as sg
from acomm.frame.auth import Auth
from acomm.apps.policy import commands
from acomm.link.guard import UNSEALED_RX
from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST
from acomm_sim.clock import ManualClock
from acomm.events import (AVAILABLE, DELIVERED, EV_AVAILABILITY, EV_PACKET, EV_PACKET_STATUS, EV_RECEIVED, FAILED,
                          WAITING)
from acomm.link import Link
from acomm.link.framing import LinkFraming
from acomm.link.names import AddressMap, NameTable
from acomm.prng import Prng
from acomm.transport import Transport
from acomm_sim.attacker import Attacker
from acomm_sim.world import World
from linkcheck import Recorder
from scripted_driver import ScriptedDriver

KEY = b"0123456789abcdef0123456789abcdef"


def _link(strict=True):
    # node 1 on a modem that addresses frames and leaves acks to acomm
    clk = ManualClock(1000)
    names = NameTable()
    names.add("me", 1)
    names.add("diver", 2)
    drv = ScriptedDriver(CAP_ADDRESSING | CAP_BROADCAST)
    rec = Recorder()
    link = Link("acoustic", drv, 1, names, rec, advert_period_ms=600000)
    link.framing.set_auth(Auth(KEY))
    link.guard = commands(strict)
    return clk, drv, rec, link


def _peer(node_id=2):
    # the diver's framing, with the key: what a genuine peer puts on the air
    f = LinkFraming(node_id, True, AddressMap(True, 0), 32, True)
    f.set_auth(Auth(KEY))
    return f


def _plain(ftype, seq, payload=b"", flags=0):
    # an elided frame without F_AUTH: what anyone can send
    return fr.encode_elided(fr.Frame(ftype, 0, 0, seq, payload, flags))


def _waiting(clk, drv, rec, link):
    link.request(clk(), 1, "diver", b"hi", 60, ack=True)
    link.poll(clk())
    h, addr, data, _ = drv.sent[-1]
    drv.finish(h)
    link.poll(clk())
    assert rec.statuses(1)[-1] == WAITING
    return fr.decode_elided(data, 1, 2).seq


def test_a_forged_ack_is_refused_and_a_sealed_one_delivers():
    clk, drv, rec, link = _link()
    seq = _waiting(clk, drv, rec, link)
    drv.receive(2, 1, _plain(fr.ACK, seq))
    # with F_AUTH and a guessed tag
    drv.receive(2, 1, _plain(fr.ACK, seq, bytes(4), fr.F_AUTH))
    link.poll(clk())
    assert rec.statuses(1)[-1] == WAITING
    assert link.guard.refused == {"ack": 2} and link.framing.auth.stats["bad_tag"] == 1
    # the diver's ACK: its tag is bound to the counter the request was sealed with
    peer = _peer()
    f = peer.decode(1, 2, drv.sent[-1][2])[0]
    drv.receive(2, 1, peer.encode(fr.ACK, 1, seq, b"", 0, f.ctr)[1])
    link.poll(clk())
    assert rec.statuses(1)[-1] == DELIVERED


def test_open_mode_takes_the_forged_ack():
    clk, drv, rec, link = _link(strict=False)
    seq = _waiting(clk, drv, rec, link)
    drv.receive(2, 1, _plain(fr.ACK, seq))
    link.poll(clk())
    assert rec.statuses(1)[-1] == DELIVERED and link.guard.refused == {}


def test_a_forged_advert_cannot_move_an_id_or_make_a_node_available():
    for strict in (True, False):
        clk, drv, rec, link = _link(strict)
        # modem address 9 claims node id 2: the diver's traffic would go to 9
        drv.receive(9, 0, _plain(fr.ADVERT, 3, bytes((2, 10))))
        link.poll(clk())
        assert link.addr_map.addr_of(2) == (2 if strict else 9)
        assert link.discovery.state(2) != AVAILABLE if strict else link.discovery.state(2) == AVAILABLE
    assert link.guard.refused == {}
    clk, drv, rec, link = _link()
    drv.receive(9, 0, _plain(fr.ADVERT, 3, bytes((2, 10))))
    # unsealed chat is delivered, marked unauthenticated, and makes no one available
    drv.receive(2, 1, _plain(fr.DATA, 4, b"chat"))
    link.poll(clk())
    assert link.guard.refused == {"advert": 1}
    assert [e[4:] for e in rec.of(EV_RECEIVED)] == [(b"chat", False)]
    assert not rec.of(EV_AVAILABILITY)
    # the genuine advert, sealed: heard, and the map is unchanged
    peer = _peer()
    drv.receive(2, 0, peer.encode(fr.ADVERT, None, 5, bytes((2, 10)))[1])
    drv.receive(2, 1, peer.encode(fr.DATA, 1, 6, b"sealed")[1])
    link.poll(clk())
    assert link.discovery.state(2) == AVAILABLE and link.addr_map.addr_of(2) == 2
    assert rec.of(EV_RECEIVED)[-1][4:] == (b"sealed", True)


def test_unsealed_replies_sacks_and_polls_are_refused_at_the_link():
    clk, drv, rec, link = _link()
    seen = []
    link.listener = seen.append
    drv.receive(2, 1, _plain(fr.REPLY, 1, b"pos"))
    head, body = sg.sack_complete(0, 1, 1, 7)
    drv.receive(2, 1, _plain(fr.SEGMENT, head, body))
    head, body = sg.frag_header(True, 0, 1, 0)
    drv.receive(2, 1, _plain(fr.SEGMENT, head, body))  # a bare poll: only the index
    link.poll(clk())
    assert link.guard.refused == {"reply": 1, "sack": 1, "poll": 1}
    assert not [e for e in seen if e[0] != EV_AVAILABILITY]
    # a sealed reply is delivered
    drv.receive(2, 1, _peer().encode(fr.REPLY, None, 2, b"pos")[1])
    link.poll(clk())
    assert [e[4:] for e in seen if e[0] == EV_RECEIVED] == [(b"pos", True)]


def test_replays_and_tag_guesses_at_the_link():
    clk, drv, rec, link = _link()
    peer = _peer()
    sealed = peer.encode(fr.DATA, 1, 3, b"once")[1]
    drv.receive(2, 1, sealed)
    link.poll(clk())
    clk.advance(120000)  # past the duplicate filter
    drv.receive(2, 1, sealed)
    replay = bytearray(sealed)
    replay[0] = (replay[0] & 0xF0) | 11  # another sequence number: the tag covers it
    drv.receive(2, 1, bytes(replay))
    # to another node: the same bytes towards node 3 do not verify there
    odrv = ScriptedDriver(CAP_ADDRESSING | CAP_BROADCAST)
    other = Link("acoustic", odrv, 3, link.names, None, advert_period_ms=600000)
    other.framing.set_auth(Auth(KEY))
    other.guard = commands()
    odrv.receive(2, 3, sealed)
    other.poll(clk())
    # tag guessing: 2000 random counters and tags on a frame to us
    rng = Prng(5)
    for _ in range(2000):
        drv.receive(2, 1, _plain(fr.DATA, 5, b"forged" + rng.bytes(7), fr.F_AUTH))
        link.poll(clk())
    link.poll(clk())
    assert [e[4] for e in rec.of(EV_RECEIVED)] == [b"once"]
    st = link.framing.auth.stats  # half the guesses name the key phase this node does not hold
    assert st["replayed"] == 1 and st["bad_tag"] + st["no_key"] == 2001 and st["no_key"] > 900
    assert other.framing.auth.stats["bad_tag"] == 1 and other.stats["rx_bad"] == 1


# -- the transport -----------------------------------------------------------------


def _net(strict=True):
    # SeaTrac nodes: topside (2) and auv (1) with the key; the auv far out of
    # range, so nothing the topside sends it ever arrives
    w = World(seed=3)
    nodes = {}
    for name, nid, x in (("auv", 1, 5000), ("topside", 2, 100)):
        nodes[name] = w.add(name, nid, "seatrac", position=(x, 0, 5), link_opts={"advert_period_ms": 600000})
        nodes[name].node.set_auth(Auth(KEY), commands(), strict=strict)
        Transport.of(nodes[name].node, wall=lambda: w.now() // 1000)
    return w, nodes["topside"], nodes["auv"]


def _outgoing(w, top, data=b"x" * 40):
    t = top.node.transport
    pid = t.send(w.now(), "auv", data, 600, 5)
    t.poll(w.now())
    p = [q for q in t._out if q.pid == pid][0]
    return pid, p


def _statuses(sn, pid):
    return [e[2] for e in sn.events if e[0] == EV_PACKET_STATUS and e[1] == pid]


def test_forged_sacks_never_complete_fail_or_advance_a_transfer():
    for strict in (True, False):
        w, top, auv = _net(strict)
        t = top.node.transport
        link = top.node.links["acoustic"]
        pid, p = _outgoing(w, top)
        o = p.out
        # completion, put on the water as from the auv by a transceiver near
        # the topside once its fragment has left (a half-duplex modem hears
        # nothing while it sends)
        w.run(60000, until=lambda: link.stats["tx_frames"] and link.idle(w.now()))
        head, body = sg.sack_complete(o.lane, o.gen, o.count, pid)
        Attacker(w.channel, 9, (120, 0, 5)).send(w.now(), 1, 2, _plain(fr.SEGMENT, head, body))
        w.run(3000)
        if not strict:
            assert _statuses(top, pid)[-1] == DELIVERED  # reported delivered; it never arrived
            continue
        # the same at the transport, and a bitmap and a refusal
        t.on_segment(w.now(), link, 1, 2, head, body, False)
        head, body = sg.sack(o.lane, o.gen, 1, b"\xff")
        t.on_segment(w.now(), link, 1, 2, head, body, False)
        head, body = sg.sack_refused(o.lane, o.gen, sg.REFUSE_TOO_BIG)
        t.on_segment(w.now(), link, 1, 2, head, body, False)
        assert top.node.guard.refused == {"sack": 4}
        assert o.base == 0 and not any(o.acked) and not o.complete and o.refused is None
        assert _statuses(top, pid)[-1] not in (DELIVERED, FAILED)
    # open mode: a forged refusal fails the packet, a forged bitmap skips fragments
    w, top, auv = _net(False)
    t = top.node.transport
    pid, p = _outgoing(w, top, bytes(range(200)))
    o = p.out
    head, body = sg.sack(o.lane, o.gen, 2, b"\x01")
    t.on_segment(w.now(), top.node.links["acoustic"], 1, 2, head, body, False)
    assert o.base == 2
    head, body = sg.sack_refused(o.lane, o.gen, sg.REFUSE_TOO_BIG)
    t.on_segment(w.now(), top.node.links["acoustic"], 1, 2, head, body, False)
    assert _statuses(top, pid)[-1] == FAILED


def _frag0(pid, body, compressed=False, length=None):
    h, first = sg.frag_header(True, 0, 0, 0)
    hdr = sg.packet_header(pid, len(body) if length is None else length, compressed)
    return h, first + hdr + body


def test_floods_of_unsealed_fragments_keep_to_their_share():
    w, top, auv = _net()
    t = auv.node.transport
    link = auv.node.links["acoustic"]
    # fragment 0s from 40 claimed sources on both lanes
    for src in range(3, 43):
        for lane in (0, 1):
            h, first = sg.frag_header(False, lane, 0, 0)
            t.on_segment(w.now(), link, src, 1, h, first + sg.packet_header(src, 60) + bytes(20), False)
    # UNSEALED_RX of them taken (held, unanswered), the rest refused
    assert auv.node.guard.refused == {"flood": 80 - UNSEALED_RX}
    # no SACK went out for any of them
    assert not len(link.queue)
    # a sealed transfer from the topside still finds room and is answered
    h, b = _frag0(9, b"hello")
    t.on_segment(w.now(), link, 2, 1, h, b, True)
    assert [e[3:5] for e in auv.events if e[0] == EV_PACKET] == [(b"hello", True)]
    assert [r.data for r in link.queue] == [sg.sack_complete(0, 0, 1, 9)[1]]
    # an unsealed fragment can neither join nor restart the sealed lane
    events = len(auv.events)
    h, first = sg.frag_header(False, 0, 1, 0)
    t.on_segment(w.now(), link, 2, 1, h, first + sg.packet_header(10, 3) + b"bad", False)
    assert auv.node.guard.refused["fragment"] == 1 and len(auv.events) == events
    # the lane still holds the sealed packet's completion: a sealed poll gets it again
    h, first = sg.frag_header(True, 0, 0, 0)
    t.on_segment(w.now(), link, 2, 1, h, first, True)
    assert [r.data for r in link.queue][-1] == sg.sack_complete(0, 0, 1, 9)[1]


def test_an_unsealed_packet_is_delivered_marked_and_never_answered():
    w, top, auv = _net()
    t = auv.node.transport
    h, b = _frag0(4, b"chat")
    t.on_segment(w.now(), auv.node.links["acoustic"], 7, 1, h, b, False)
    assert [e[3:5] for e in auv.events if e[0] == EV_PACKET] == [(b"chat", False)]
    assert not len(auv.node.links["acoustic"].queue)  # no SACK


def test_oversized_lengths_and_a_decompression_bomb_cost_nothing():
    from acomm.codec.compress import compress

    for authed in (False, True):
        w, top, auv = _net()
        t = auv.node.transport
        link = auv.node.links["acoustic"]
        h, b = _frag0(1, bytes(20), length=sg.MAX_LENGTH)  # 2 MiB announced
        t.on_segment(w.now(), link, 2, 1, h, b, authed)
        # 1 MiB of zeros announced, in 8 bytes: compress(bytes(100)) under a bigger header
        v = (1 << 20) << 2 | 2
        bomb = bytes((v & 0x7F | 0x80, (v >> 7) & 0x7F | 0x80, (v >> 14) & 0x7F | 0x80, v >> 21))
        bomb += compress(bytes(100))[2:]
        assert len(bomb) == 7
        h, b = _frag0(2, bomb, compressed=True)
        h = sg.frag_header(True, 1, 0, 0)[0]
        t.on_segment(w.now(), link, 2, 1, h, b, authed)
        assert t.stats["rx_bad"] == 2 and not [e for e in auv.events if e[0] == EV_PACKET]
        assert sum(r.size for r in t._rx.values()) <= 2 * (t.max_packet + 16)


def test_a_sealed_sack_cannot_be_turned_into_a_refusal():
    # a bitmap SACK (base 0, one bitmap byte) and a refusal are both 2
    # bytes; the C bit rides in the sequence field, which the tag covers
    clk, drv, rec, link = _link()
    head, body = sg.sack(0, 1, 0, b"\x02")
    data = bytearray(_peer().encode(fr.SEGMENT, 1, head, body)[1])
    data[0] |= 4  # C: complete / refused
    drv.receive(2, 1, bytes(data))
    link.poll(clk())
    assert link.framing.auth.stats["bad_tag"] == 1 and link.stats["rx_bad"] == 1
