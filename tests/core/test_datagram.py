# The IP links' sans-IO driver (acomm.drivers.datagram) with fake endpoints:
# routing by node id, learning senders, refusing garbage and impostors,
# announcements, TCP-style connections, and two Nodes over a fake network.
from acomm import frame as fr
from acomm.link.discovery import decode_advert, encode_advert
from acomm.drivers.datagram import DatagramDriver
from acomm.errors import EncodeError
from acomm.events import (
    AVAILABLE,
    DELIVERED,
    EV_AVAILABILITY,
    EV_DRIVER_DOWN,
    EV_DRIVER_UP,
    EV_RECEIVED,
    EV_RX,
    EV_TX_DONE,
    EV_TX_FAILED,
    EXPIRED,
    FAILED,
    TRANSMITTED,
)
from acomm.link import BROADCAST
from acomm.node import Node
from ipnet import FakeNet
from linkcheck import Recorder, check_exactly_one_final

A = ("10.0.0.1", 4001)
B = ("10.0.0.2", 4002)
C = ("10.0.0.3", 4003)
GROUP = ("239.255.97.99", 29799)


def raw(src, dst, payload=b"x", ftype=fr.DATA, seq=0):
    return fr.encode_raw(fr.Frame(ftype, src, dst, seq, payload))


def test_unicast_to_static_peer_and_statuses():
    d = DatagramDriver(node_id=1, peers={2: B})
    assert d.ready(0) and d.broadcast_addr is None
    h = d.send(0, None, raw(1, 2))
    assert not d.ready(0)  # one frame at a time, until the port reports
    assert d.take_datagrams() == [(h, B, raw(1, 2))]
    assert d.take_events() == []
    d.sent(1, h)
    assert d.take_events() == [(EV_TX_DONE, h)] and d.ready(1)
    h = d.send(2, None, raw(1, 2, seq=1))
    d.take_datagrams()
    d.sent(3, h, "network unreachable")
    ev = d.take_events()
    assert ev[0][0] == EV_TX_FAILED and ev[0][1] == h and "unreachable" in ev[0][2]
    assert d.stats["tx_datagrams"] == 1 and d.stats["tx_errors"] == 1


def test_unknown_destination_refused_and_default_used():
    d = DatagramDriver(node_id=1)
    try:
        d.send(0, None, raw(1, 7))
        assert False, "sent to a node with no endpoint"
    except EncodeError:
        pass
    assert d.stats["no_route"] == 1 and d.ready(0)
    d.default = C
    h = d.send(0, None, raw(1, 7))
    assert d.take_datagrams() == [(h, C, raw(1, 7))]


def test_broadcast_goes_to_group_and_static_peers_once_each():
    d = DatagramDriver(node_id=1, peers={2: B, 3: GROUP}, broadcast=[GROUP])
    h = d.send(0, None, raw(1, fr.BROADCAST))
    out = d.take_datagrams()
    assert sorted(e[1] for e in out) == sorted([GROUP, B])
    d.sent(1, h, "no route to host")
    assert d.take_events() == []  # one of two entries still unreported
    d.sent(1, h)
    assert d.take_events() == [(EV_TX_DONE, h)]  # one copy left: transmitted


def test_frames_that_are_not_acomm_are_counted_not_raised():
    d = DatagramDriver(node_id=1, mtu=64)
    good = raw(2, 1)
    bad_crc = good[:-1] + bytes(((good[-1] + 1) & 0xFF,))
    wrong_version = bytes((good[0] ^ 0xC0,)) + good[1:]
    for junk in (b"", b"\x40\x00", bad_crc, wrong_version, b"GET / HTTP/1.0\r\n\r\n", bytes(65)):
        d.feed_from(0, A, junk)
    assert d.stats["rx_garbage"] == 6 and d.take_events() == []
    assert d.learned() == {}
    d.feed_from(0, A, good)
    assert d.take_events() == [(EV_RX, None, None, good)]
    assert d.stats["rx_datagrams"] == 7


def test_learning_moving_and_own_frames():
    d = DatagramDriver(node_id=1)
    d.feed_from(0, A, raw(1, fr.BROADCAST))  # our multicast looped back
    assert d.stats["rx_own"] == 1 and d.learned() == {}
    d.feed_from(0, B, raw(2, fr.BROADCAST, fr.encode_raw(fr.Frame(0, 2, 1, 0, b"")), fr.ADVERT))
    assert d.learned() == {2: B} and d.endpoint_of(2) == B
    d.feed_from(5, C, raw(2, 1))  # node 2 restarted on another port
    assert d.endpoint_of(2) == C and d.stats["moved"] == 1
    assert d.nodes_at(C) == [2] and d.nodes_at(B) == []
    assert len(d.take_events()) == 2


def test_static_entries_refuse_impostors():
    d = DatagramDriver(node_id=1, peers={2: B})
    d.feed_from(0, C, raw(2, 1))
    assert d.stats["rx_refused"] == 1 and d.take_events() == []
    assert d.endpoint_of(2) == B
    d.feed_from(0, B, raw(2, 1))
    assert len(d.take_events()) == 1


def test_learn_off_accepts_only_the_table():
    d = DatagramDriver(node_id=1, peers={2: B}, learn=False)
    d.feed_from(0, C, raw(3, 1))
    assert d.stats["rx_unknown"] == 1 and d.take_events() == [] and d.endpoint_of(3) is None
    d.feed_from(0, B, raw(2, 1))
    assert len(d.take_events()) == 1


def test_learned_table_is_bounded_oldest_forgotten():
    d = DatagramDriver(node_id=1, capacity=3)
    for i in range(3):
        d.feed_from(i * 10, ("10.0.1.%d" % i, 5000), raw(10 + i, 1))
    d.feed_from(40, ("10.0.1.0", 5000), raw(10, 1))  # node 10 heard again
    d.feed_from(50, ("10.0.1.9", 5000), raw(19, 1))
    assert sorted(d.learned()) == [10, 12, 19]  # 11 was heard longest ago
    assert d.stats["forgotten"] == 1 and d.stats["learned"] == 4
    d = DatagramDriver(node_id=1, capacity=0)
    d.feed_from(0, A, raw(2, 1))
    assert d.stats["rx_unknown"] == 1 and d.take_events() == []


def test_port_that_never_reports_frees_the_driver():
    d = DatagramDriver(node_id=1, peers={2: B}, tx_timeout_ms=500)
    h = d.send(0, None, raw(1, 2))
    d.poll(499)
    assert d.take_events() == [] and not d.ready(499)
    d.poll(500)
    ev = d.take_events()
    assert ev[0][0] == EV_TX_FAILED and ev[0][1] == h
    assert d.ready(500) and d.take_datagrams() == []  # its entry withdrawn
    d.sent(501, h)  # too late: ignored
    assert d.take_events() == []


def test_send_refuses_what_is_not_a_raw_frame():
    d = DatagramDriver(node_id=1, peers={2: B}, mtu=32)
    for bad in (b"\x00hello", raw(1, 2, bytes(40))):
        try:
            d.send(0, None, bad)
            assert False
        except EncodeError:
            pass
    assert d.ready(0)


def test_announcements_top_up_adverts():
    d = DatagramDriver(node_id=4, broadcast=[GROUP], announce_ms=1000, advert_encoder=encode_advert)
    d.poll(0)
    assert d.take_datagrams() == []  # at start the link's own advert goes
    d.poll(1000)
    out = d.take_datagrams()
    assert len(out) == 1 and out[0][0] is None and out[0][1] == GROUP
    f = fr.decode_raw(out[0][2])
    assert f.ftype == fr.ADVERT and f.src == 4 and f.dst == fr.BROADCAST
    assert decode_advert(f.payload) == (4, 4000)  # adverts count periods in 4 s
    d.sent(1000, None)
    d.poll(1999)
    assert d.take_datagrams() == []
    h = d.send(1900, None, raw(4, fr.BROADCAST))  # the link's own broadcast
    d.take_datagrams()
    d.sent(1900, h)
    d.poll(2500)
    assert d.take_datagrams() == []  # heard 600 ms ago: no need
    d.poll(2900)
    assert len(d.take_datagrams()) == 1 and d.stats["announcements"] == 2
    # without a node id the driver cannot speak for the node
    d = DatagramDriver(broadcast=[GROUP], announce_ms=1000, advert_encoder=encode_advert)
    d.poll(5000)
    assert d.take_datagrams() == []


def test_connections_gate_sending_and_fail_what_they_take_down():
    d = DatagramDriver(node_id=1, streams=True, advert_encoder=encode_advert)
    assert not d.ready(0)
    d.connection_up(0, A)
    d.connection_up(0, B)
    assert d.take_events() == [(EV_DRIVER_UP,)] and d.ready(0) and d.connections == 2
    d.poll(0)  # a new connection is announced at once
    ann = d.take_datagrams()
    assert sorted(e[1] for e in ann) == sorted([A, B])
    d.feed_from(1, A, raw(2, 1))
    d.take_events()
    assert d.endpoint_of(2) == A
    h = d.send(2, None, raw(1, fr.BROADCAST))
    assert sorted(e[1] for e in d.take_datagrams()) == sorted([A, B])
    d.sent(3, h)  # A's copy went
    d.connection_down(3, B)  # the queue had none left for B; nothing to fail
    assert d.take_events() == []
    d.sent(3, h)  # B's copy reported by the port after all
    assert d.take_events() == [(EV_TX_DONE, h)]
    h = d.send(4, None, raw(1, 2))
    d.connection_down(5, A)
    ev = d.take_events()
    assert ev[0] == (EV_TX_FAILED, h, "not sent: connection lost") and ev[1][0] == EV_DRIVER_DOWN
    assert d.endpoint_of(2) is None and d.learned() == {} and not d.ready(5)
    # a client: everything goes to the server, whatever node is behind it
    d.connection_up(6, C, default=True)
    assert d.endpoint_of(9) == C


# -- two Nodes over the fake network -------------------------------------------


def _nodes(net, ids=(1, 2), **link_opts):
    out = []
    for nid in ids:
        n = Node("n%d" % nid, nid, listener=Recorder())
        d = DatagramDriver(node_id=nid, announce_ms=link_opts.get("advert_period_ms", 1000))
        ep = ("10.0.0.%d" % nid, 4000 + nid)
        port = net.port(d, ep)
        opts = {"advert_period_ms": 1000, "ack_timeout_ms": 300}
        opts.update(link_opts)
        n.add_link("ip", d, port, **opts)
        out.append(n)
    return out


def _run(nodes, t0, t1, step=10):
    t = t0
    while t <= t1:
        for n in nodes:
            n.step(t)
        t += step
    return t


def test_nodes_discover_by_multicast_then_talk_unicast():
    net = FakeNet(GROUP)
    a, b = _nodes(net)
    t = _run((a, b), 0, 200)
    assert "node-2" in [e[2] for e in a.listeners[0].of(EV_AVAILABILITY) if e[3] == AVAILABLE]
    assert a.links["ip"].driver.learned() == {2: ("10.0.0.2", 4002)}
    sent = []

    def watch(src, dst, data):
        sent.append(dst)
        return False

    net.lose = watch
    r1 = a.send("ip", "node-2", b"acked", 10, ack=True, now=t)
    r2 = a.send("ip", "node-2", b"plain", 10, now=t)
    r3 = b.send("ip", BROADCAST, b"to all", 10, now=t)
    t = _run((a, b), t, t + 300)
    assert a.listeners[0].final(r1) == DELIVERED and a.listeners[0].final(r2) == TRANSMITTED
    assert b.listeners[0].final(r3) == TRANSMITTED
    got_b = [bytes(e[4]) for e in b.listeners[0].of(EV_RECEIVED)]
    got_a = [bytes(e[4]) for e in a.listeners[0].of(EV_RECEIVED)]
    assert got_b == [b"acked", b"plain"] and got_a == [b"to all"]
    # unicast frames went to b's endpoint, not to the group
    assert sent.count(("10.0.0.2", 4002)) >= 2
    assert a.links["ip"].driver.stats["rx_own"] >= 1  # our adverts came back


def test_garbage_and_impostors_are_counted_and_nodes_keep_working():
    net = FakeNet(GROUP)
    a, b = _nodes(net)
    t = _run((a, b), 0, 200)
    da = a.links["ip"].driver
    la = a.links["ip"]
    net.inject(C, ("10.0.0.1", 4001), b"\x00\x01garbage")
    net.inject(C, GROUP, b"M-SEARCH * HTTP/1.1\r\n")
    bad = bytearray(raw(2, 1, b"damaged"))
    bad[4] ^= 0xFF
    net.inject(C, ("10.0.0.1", 4001), bytes(bad))
    t = _run((a, b), t, t + 50)
    assert da.stats["rx_garbage"] == 3
    # a valid frame from a stranger claiming node 2: learn=True takes it as
    # node 2 moving; a static peer would refuse it
    da.set_peer(2, ("10.0.0.2", 4002))
    net.inject(C, ("10.0.0.1", 4001), raw(2, 1, b"I am node 2"))
    t = _run((a, b), t, t + 50)
    assert da.stats["rx_refused"] == 1
    assert b"I am node 2" not in [bytes(e[4]) for e in a.listeners[0].of(EV_RECEIVED)]
    r = a.send("ip", "node-2", b"still fine", 10, ack=True, now=t)
    t = _run((a, b), t, t + 300)
    assert a.listeners[0].final(r) == DELIVERED
    assert [bytes(e[4]) for e in b.listeners[0].of(EV_RECEIVED)] == [b"still fine"]
    assert la.stats["rx_bad"] == 0  # the driver stopped garbage before the link


def test_every_request_ends_once_when_the_port_fails():
    net = FakeNet(GROUP)
    a, b = _nodes(net, advert_period_ms=60000)
    t = _run((a, b), 0, 100)
    port = net.ports[("10.0.0.1", 4001)]
    port.refuse = "network is unreachable"
    rids = [a.send("ip", "node-2", b"m%d" % i, 1, ack=(i % 2 == 0), now=t) for i in range(4)]
    rids.append(a.send("ip", "node-9", b"nobody", 1, now=t))  # never heard of
    t = _run((a, b), t, t + 1500)
    rec = a.listeners[0]
    check_exactly_one_final(rec, rids)
    assert [rec.final(r) for r in rids] == [FAILED] * 5
    assert "unreachable" in rec.reasons(rids[1])[-1]


def test_requests_wait_while_disconnected_and_expire_or_flow():
    # the TCP client's case, without sockets: nothing is connected, so the
    # link queues; a request whose lifespan ends first expires, the rest
    # go when the connection comes up
    n = Node("n1", 1, listener=Recorder())
    n.names.add("srv", 2)
    d = DatagramDriver(node_id=1, streams=True)

    class Port:
        def __init__(self):
            self.out = []

        def pump(self, now):
            for h, ep, data in d.take_datagrams():
                self.out.append((ep, data))
                d.sent(now, h)

    port = Port()
    n.add_link("tcp", d, port, advert_period_ms=60000)
    short = n.send("tcp", "srv", b"short", 0.5, now=0)
    long_ = n.send("tcp", "srv", b"long", 10, now=0)
    _run((n,), 0, 1000)
    assert n.listeners[0].final(short) == EXPIRED and n.listeners[0].final(long_) is None
    assert port.out == []
    d.connection_up(1000, ("srv", 1), default=True)
    _run((n,), 1000, 1100)
    assert n.listeners[0].final(long_) == TRANSMITTED
    payloads = [fr.decode_raw(x[1]).payload for x in port.out]
    assert b"long" in payloads and b"short" not in payloads
    check_exactly_one_final(n.listeners[0], [short, long_])
