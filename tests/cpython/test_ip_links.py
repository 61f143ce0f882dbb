# UDP and TCP links with real sockets on the loopback interface (CPython):
# nodes exchange acknowledged and plain frames, find each other by
# multicast and broadcast announcements, survive garbage, and a TCP peer
# that goes away and comes back gets the requests that waited for it.
# Ports are ephemeral (bound to 0) so tests never collide; every wait is
# bounded; only outcomes are asserted, never timings.

import socket
import time

import pytest

from acomm import frame as fr
from acomm.events import (
    AVAILABLE,
    DELIVERED,
    EV_AVAILABILITY,
    EV_RECEIVED,
    EV_STATUS,
    EXPIRED,
    TRANSMITTED,
    is_final,
)
from acomm.link import BROADCAST
from acomm.node import Node
from acomm_cpython.tcp import tcp_client_link, tcp_server_link
from acomm_cpython.udp import udp_link

LO = "127.0.0.1"
TIMEOUT_S = 5


class End:
    def __init__(self, name, node_id):
        self.events = []
        self.node = Node(name, node_id, listener=self.events.append)
        self.closers = []

    def final(self, rid):
        for ev in self.events:
            if ev[0] == EV_STATUS and ev[2] == rid and is_final(ev[3]):
                return ev[3]
        return None

    def received(self):
        return [bytes(ev[4]) for ev in self.events if ev[0] == EV_RECEIVED]

    def found(self):
        return [ev[2] for ev in self.events if ev[0] == EV_AVAILABILITY and ev[3] == AVAILABLE]

    def close(self):
        for c in self.closers:
            c.close()


def run(ends, until, timeout=TIMEOUT_S):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        for e in ends:
            e.node.step()
        if until():
            return True
        time.sleep(0.002)
    return False


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("", 0))
    p = s.getsockname()[1]
    s.close()
    return p


@pytest.fixture
def ends():
    made = []

    def make(name, node_id):
        e = End(name, node_id)
        made.append(e)
        return e

    yield make
    for e in made:
        e.close()


def _udp(end, group_port, **kw):
    opts = dict(bind=(LO, 0), group=None, broadcast=None, group_port=group_port, iface=LO, ack_timeout_ms=1000)
    opts.update(kw)
    link, port = udp_link(end.node, **opts)
    end.closers.append(port)
    return link, port


# -- UDP ------------------------------------------------------------------------


def test_udp_unicast_acked_and_plain_between_static_peers(ends):
    a, b = ends("buoy", 1), ends("topside", 2)
    a.node.names.add("topside", 2)
    b.node.names.add("buoy", 1)
    la, pa = _udp(a, 0, advert_period_ms=60000)
    lb, pb = _udp(b, 0, advert_period_ms=60000)
    la.driver.set_peer(2, pb.address)
    lb.driver.set_peer(1, pa.address)
    assert pa.disc is None  # no group, no broadcast: no discovery socket
    r1 = a.node.send("ip", "topside", b"acked hello", 10, ack=True)
    r2 = a.node.send("ip", "topside", b"plain hello", 10)
    r3 = b.node.send("ip", "buoy", b"answer", 10, ack=True)
    assert run((a, b), lambda: all(x.final(r) for x, r in ((a, r1), (a, r2), (b, r3))))
    assert (a.final(r1), a.final(r2), b.final(r3)) == (DELIVERED, TRANSMITTED, DELIVERED)
    assert b.received() == [b"acked hello", b"plain hello"] and a.received() == [b"answer"]
    assert la.driver.stats["rx_garbage"] == 0 and pa.stats["send_errors"] == 0


def _multicast_or_skip(group_port):
    # the kernel must accept membership and loopback delivery on lo
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, socket.inet_aton("239.255.97.99") + socket.inet_aton(LO))
    except OSError as e:
        pytest.skip("the kernel refuses multicast on the loopback interface: %s" % e)
    finally:
        s.close()


def test_udp_discovery_by_multicast_on_loopback(ends):
    gp = free_udp_port()
    _multicast_or_skip(gp)
    a, b, c = ends("buoy", 1), ends("topside", 2), ends("diver", 3)
    links = [_udp(e, gp, group="239.255.97.99", advert_period_ms=4000)[0] for e in (a, b, c)]
    # nobody was told about anybody: the announcements find them
    assert run((a, b, c), lambda: all(len(e.found()) == 2 for e in (a, b, c)))
    assert sorted(a.found()) == ["node-2", "node-3"]
    eps = links[0].driver.learned()
    assert sorted(eps) == [2, 3] and eps[2][0] == LO
    assert links[0].driver.stats["rx_own"] >= 1  # our own announcement came back
    r1 = a.node.send("ip", "node-2", b"unicast after discovery", 10, ack=True)
    r2 = c.node.send("ip", BROADCAST, b"to everyone", 10)
    assert run((a, b, c), lambda: a.final(r1) and c.final(r2) and b"to everyone" in a.received())
    assert a.final(r1) == DELIVERED and c.final(r2) == TRANSMITTED
    assert b.received() == [b"unicast after discovery", b"to everyone"]
    assert c.received() == []  # the unicast went to node 2 only


def test_udp_discovery_by_broadcast_with_copies_dropped(ends):
    gp = free_udp_port()
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
    try:
        probe.sendto(b"probe", ("255.255.255.255", gp))
    except OSError as e:
        pytest.skip("no route for broadcast on this host: %s" % e)
    finally:
        probe.close()
    _multicast_or_skip(gp)
    a, b = ends("buoy", 1), ends("topside", 2)
    # multicast and broadcast both on: every broadcast arrives twice
    la = _udp(a, gp, group="239.255.97.99", broadcast="255.255.255.255", advert_period_ms=4000)[0]
    lb = _udp(b, gp, group="239.255.97.99", broadcast="255.255.255.255", advert_period_ms=4000)[0]
    assert len(la.driver.broadcast_endpoints) == 2
    assert run((a, b), lambda: a.found() and b.found())
    r = a.node.send("ip", BROADCAST, b"once", 10)
    assert run((a, b), lambda: a.final(r) and lb.stats["rx_duplicates"] >= 1)
    assert b.received() == [b"once"]


def test_udp_garbage_is_counted_and_the_node_keeps_working(ends):
    gp = free_udp_port()
    a, b = ends("buoy", 1), ends("topside", 2)
    a.node.names.add("topside", 2)
    la, pa = _udp(a, gp, broadcast="255.255.255.255", advert_period_ms=60000)
    lb, pb = _udp(b, gp, broadcast=None, advert_period_ms=60000)
    la.driver.set_peer(2, pb.address)
    junk = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    junk.bind((LO, 0))
    try:
        good = fr.encode_raw(fr.Frame(fr.DATA, 9, 1, 0, b"spoofed"))
        bad_crc = good[:-1] + bytes(((good[-1] ^ 0x55),))
        for d in (b"", b"M-SEARCH * HTTP/1.1\r\n\r\n", bytes(2000), bad_crc, b"\x40"):
            junk.sendto(d, pa.address)
        junk.sendto(b"\xff" * 40, (LO, gp))  # on the discovery socket too
        # a valid frame from a stranger claiming to be static node 2
        junk.sendto(fr.encode_raw(fr.Frame(fr.DATA, 2, 1, 5, b"impostor")), pa.address)
        st = la.driver.stats
        assert run((a, b), lambda: st["rx_garbage"] >= 6 and st["rx_refused"] >= 1)
    finally:
        junk.close()
    assert st["rx_garbage"] == 6 and pa.stats["oversize"] == 1
    assert a.received() == [] and la.stats["rx_bad"] == 0
    r = a.node.send("ip", "topside", b"still here", 10, ack=True)
    assert run((a, b), lambda: a.final(r))
    assert a.final(r) == DELIVERED and b.received() == [b"still here"]


# -- TCP ------------------------------------------------------------------------


def _server(end, bind=(LO, 0), **kw):
    kw.setdefault("ack_timeout_ms", 1000)
    link, port = tcp_server_link(end.node, bind=bind, **kw)
    end.closers.append(port)
    return link, port


def _client(end, addr, **kw):
    kw.setdefault("ack_timeout_ms", 1000)
    kw.setdefault("backoff_s", (0.05, 0.4))
    link, port = tcp_client_link(end.node, addr[0], addr[1], **kw)
    end.closers.append(port)
    return link, port


def test_tcp_client_and_server_exchange(ends):
    s, c1, c2 = ends("topside", 1), ends("buoy", 2), ends("diver", 3)
    ls, ps = _server(s)
    lc1 = _client(c1, ps.address)[0]
    _client(c2, ps.address)
    # each client announces itself on connecting, so the server can route
    assert run((s, c1, c2), lambda: len(s.found()) == 2 and c1.found() and c2.found())
    assert sorted(ls.driver.learned()) == [2, 3] and ps.stats["accepted"] == 2
    r1 = c1.node.send("tcp", "node-1", b"client to server", 10, ack=True)
    r2 = s.node.send("tcp", "node-3", b"server to diver", 10, ack=True)
    r3 = s.node.send("tcp", BROADCAST, b"server to all", 10)
    r4 = c2.node.send("tcp", "node-1", b"plain", 10)
    done = ((c1, r1), (s, r2), (s, r3), (c2, r4))
    assert run((s, c1, c2), lambda: all(e.final(r) for e, r in done) and b"server to all" in c1.received())
    assert [e.final(r) for e, r in done] == [DELIVERED, DELIVERED, TRANSMITTED, TRANSMITTED]
    assert sorted(s.received()) == [b"client to server", b"plain"]
    assert c2.received() == [b"server to diver", b"server to all"]
    assert c1.received() == [b"server to all"]
    assert lc1.driver.stats["rx_garbage"] == 0


def test_tcp_server_goes_away_and_queued_requests_flow_when_it_returns(ends):
    s, c = ends("topside", 1), ends("buoy", 2)
    c.node.names.add("topside", 1)
    ls, ps = _server(s)
    addr = ps.address
    lc, pc = _client(c, addr)
    assert run((s, c), lambda: c.found() and s.found())
    ps.close()
    assert run((c,), lambda: not pc.connected)
    assert not lc.driver.ready(0)
    # while the server is away: one request that cannot outlive the outage,
    # three that can
    short = c.node.send("tcp", "topside", b"too late", 0.3, ack=True)
    waiting = [c.node.send("tcp", "topside", b"queued %d" % i, 20, ack=(i != 1)) for i in range(3)]
    assert run((c,), lambda: c.final(short), timeout=2)
    assert c.final(short) == EXPIRED and [c.final(r) for r in waiting] == [None] * 3
    # the server restarts on the same port, as a new process would
    s2 = ends("topside", 1)
    _server(s2, bind=addr)
    assert run((s2, c), lambda: all(c.final(r) for r in waiting))
    assert [c.final(r) for r in waiting] == [DELIVERED, TRANSMITTED, DELIVERED]
    assert s2.received() == [b"queued 0", b"queued 1", b"queued 2"]
    assert pc.stream.connects == 2


def test_tcp_client_drops_and_comes_back_server_routes_to_it_again(ends):
    s, c = ends("topside", 1), ends("buoy", 2)
    ls, ps = _server(s)
    lc, pc = _client(c, ps.address)
    assert run((s, c), lambda: s.found() and c.found())
    first_ep = ls.driver.endpoint_of(2)
    pc.stream.drop()  # the client's connection breaks
    assert run((s, c), lambda: ls.driver.endpoint_of(2) not in (None, first_ep))
    r = s.node.send("tcp", "node-2", b"welcome back", 10, ack=True)
    assert run((s, c), lambda: s.final(r))
    assert s.final(r) == DELIVERED and c.received() == [b"welcome back"]
    assert ps.stats["closed"] == 1 and ps.stats["accepted"] == 2


def test_tcp_garbage_is_refused_and_other_clients_keep_working(ends):
    s, c = ends("topside", 1), ends("buoy", 2)
    ls, ps = _server(s, max_clients=3)
    _client(c, ps.address)
    assert run((s, c), lambda: s.found())
    talker = socket.create_connection(ps.address)
    framed = socket.create_connection(ps.address)
    extra = socket.create_connection(ps.address)  # one more than max_clients
    try:
        talker.sendall(b"GET / HTTP/1.0\r\n\r\n")  # "GE": a length of 18245
        framed.sendall(b"\x00\x05hello")  # well framed, not acomm
        assert run((s, c), lambda: ps.stats["bad_lengths"] == 1 and ls.driver.stats["rx_garbage"] == 1 and ps.stats["refused"] == 1)
        talker.settimeout(2)
        assert talker.recv(100) == b""  # closed by the server
    finally:
        for x in (talker, framed, extra):
            x.close()
    r = c.node.send("tcp", "node-1", b"unharmed", 10, ack=True)
    assert run((s, c), lambda: c.final(r))
    assert c.final(r) == DELIVERED and s.received() == [b"unharmed"]


def test_tcp_client_refuses_a_server_that_is_not_acomm(ends):
    srv = socket.socket()
    srv.bind((LO, 0))
    srv.listen(1)
    c = ends("buoy", 2)
    lc, pc = _client(c, srv.getsockname())
    try:
        assert run((c,), lambda: pc.connected)
        conn, _ = srv.accept()
        conn.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")
        assert run((c,), lambda: pc.stats["bad_lengths"] == 1 and not pc.connected)
        conn.close()
    finally:
        srv.close()
