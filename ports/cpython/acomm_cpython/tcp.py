# TCP links on CPython: the socket side of acomm.drivers.datagram with
# streams=True. Each acomm frame travels length-prefixed (acomm.frame.lenframe).
#
# TcpServerPort listens and serves up to max_clients connections at once
# (more are accepted and closed at once, counted as refused). Each
# connection is an endpoint of the driver; the node behind it is learned
# from its first frame (the client announces itself on connecting).
#
# TcpClientPort keeps one connection to a server with TcpStream (doubling
# back-off between attempts). While it is down the driver is not ready, so
# transmission requests wait in the link's bounded queue and either go once
# the server is back or end `expired` when their lifespan runs out.
#
# On either side, a length of 0 or above the driver's MTU means the peer
# does not speak this framing: the connection is closed and counted
# (bad_lengths); a client then reconnects. Each connection's send buffer is
# bounded; a frame that does not fit is reported failed, never cut.
#
# tcp_server_link / tcp_client_link make the driver and the port and add
# the link to a node.

import errno
import socket

from acomm.drivers.datagram import DatagramDriver
from acomm.errors import DecodeError
from acomm.frame.lenframe import HEADER_LEN, LenDecoder, append_frame

from .streams import TcpStream
from .udp import resolve

_CHUNK = 4096
_READ_BURST = 16  # reads per connection per pump


class _Conn:
    __slots__ = ("sock", "endpoint", "dec", "out")

    def __init__(self, sock, endpoint, max_frame):
        self.sock = sock
        self.endpoint = endpoint
        self.dec = LenDecoder(max_frame)
        self.out = bytearray()


def _new_stats():
    return {"accepted": 0, "refused": 0, "closed": 0, "bad_lengths": 0, "rx_frames": 0, "tx_frames": 0, "send_full": 0}


def _frame_out(d, now, h, out, data, limit):
    # Appends one frame to a send buffer, or reports why it cannot.
    if len(out) + HEADER_LEN + len(data) > limit:
        d.sent(now, h, "send buffer full")
        return False
    append_frame(out, data, d.mtu)
    d.sent(now, h)
    return True


class TcpServerPort:
    def __init__(self, driver, bind=("0.0.0.0", 0), max_clients=8, send_buffer=1 << 16):
        self.driver = driver
        self.max_clients = max_clients
        self.send_buffer = send_buffer
        self.conns = {}  # endpoint -> _Conn
        self.stats = _new_stats()
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            # a restarted server takes its port back at once
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind(resolve(bind))
            s.listen(max_clients)
            s.setblocking(False)
        except BaseException:
            s.close()
            raise
        self.listener = s

    @property
    def address(self):
        return self.listener.getsockname()

    def filenos(self):
        """The listener and every connection: what an event loop waits on for reading."""
        return (self.listener.fileno(),) + tuple(c.sock.fileno() for c in self.conns.values())

    def pending(self):
        """Bytes framed for the connections but not yet taken by their sockets."""
        return sum(len(c.out) for c in self.conns.values())

    def pump(self, now):
        d = self.driver
        self._accept(now)
        for c in list(self.conns.values()):
            self._read(now, c)
        for h, ep, data in d.take_datagrams():
            c = self.conns.get(ep)
            if c is None:
                d.sent(now, h, "not connected")
            elif _frame_out(d, now, h, c.out, data, self.send_buffer):
                self.stats["tx_frames"] += 1
            else:
                self.stats["send_full"] += 1
        for c in list(self.conns.values()):
            self._flush(now, c)

    def _accept(self, now):
        while True:
            try:
                sock, addr = self.listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return  # e.g. ECONNABORTED: the client gave up already
            if len(self.conns) >= self.max_clients:
                sock.close()
                self.stats["refused"] += 1
                continue
            sock.setblocking(False)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            c = _Conn(sock, addr, self.driver.mtu)
            self.conns[addr] = c
            self.stats["accepted"] += 1
            self.driver.connection_up(now, addr)

    def _read(self, now, c):
        d = self.driver
        frames = []
        for _ in range(_READ_BURST):
            try:
                data = c.sock.recv(_CHUNK)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                data = b""
            if not data:
                self._drop(now, c, "connection closed by the peer")
                break
            try:
                c.dec.feed(data, frames)
            except DecodeError as e:
                self.stats["bad_lengths"] += 1
                self._drop(now, c, "bad stream: %s" % e)
                break
        for f in frames:
            self.stats["rx_frames"] += 1
            d.feed_from(now, c.endpoint, f)

    def _flush(self, now, c):
        if not c.out:
            return
        try:
            n = c.sock.send(c.out)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as e:
            self._drop(now, c, "send failed: %s" % (errno.errorcode.get(e.errno, e),))
            return
        del c.out[:n]

    def _drop(self, now, c, reason):
        if self.conns.pop(c.endpoint, None) is None:
            return
        c.sock.close()
        self.stats["closed"] += 1
        self.driver.connection_down(now, c.endpoint, reason)

    def close(self, now=0):
        for c in list(self.conns.values()):
            self._drop(now, c, "server closed")
        self.listener.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class TcpClientPort:
    def __init__(self, driver, host, port, backoff_s=(0.5, 10.0), send_buffer=1 << 16):
        self.driver = driver
        self.endpoint = resolve((host, port))
        self.stream = TcpStream(self.endpoint[0], self.endpoint[1], backoff_s, max_pending=send_buffer)
        self.send_buffer = send_buffer
        self.dec = LenDecoder(driver.mtu)
        self.stats = _new_stats()
        self._up = False
        self._connects = 0

    @property
    def connected(self):
        return self._up

    def filenos(self):
        """The connection's socket while it is up (see TcpStream.filenos)."""
        return self.stream.filenos()

    def pending(self):
        """Bytes written but not yet taken by the socket."""
        return self.stream.pending()

    def pump(self, now):
        d = self.driver
        s = self.stream
        ep = self.endpoint
        chunks = []
        for _ in range(_READ_BURST):
            data = s.read(_CHUNK)  # also makes the connection when due
            if not data:
                break
            chunks.append(data)
        if s.connects != self._connects:
            # a new connection (the old one may have gone unseen in between)
            self._connects = s.connects
            if self._up:
                d.connection_down(now, ep, "reconnected")
            self._up = True
            self.dec.reset()
            self.stats["accepted"] += 1
            d.connection_up(now, ep, default=True)
        frames = []
        for data in chunks:
            try:
                self.dec.feed(data, frames)
            except DecodeError:
                self.stats["bad_lengths"] += 1
                s.drop()
                break
        for f in frames:
            self.stats["rx_frames"] += 1
            d.feed_from(now, ep, f)
        self._check_down(now)
        for h, _, data in d.take_datagrams():
            if not s.connected:
                d.sent(now, h, "not connected")
                continue
            out = bytearray()
            if _frame_out(d, now, h, out, data, self.send_buffer - s.pending):
                s.write(out)
                self.stats["tx_frames"] += 1
            else:
                self.stats["send_full"] += 1
        self._check_down(now)

    def _check_down(self, now):
        if self._up and not self.stream.connected:
            self._up = False
            self.stats["closed"] += 1
            self.driver.connection_down(now, self.endpoint, "connection lost")

    def close(self, now=0):
        self.stream.close()
        self._check_down(now)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _driver(node, mtu, announce_ms, model):
    return DatagramDriver(node_id=node.node_id, mtu=mtu, announce_ms=announce_ms, streams=True, model=model)


def tcp_server_link(node, name="tcp", bind=("0.0.0.0", 0), max_clients=8, mtu=1024, announce_ms=0, advert_period_ms=10000, **link_options):
    # Adds a link that serves TCP clients; returns (link, port).
    driver = _driver(node, mtu, announce_ms, "tcp server")
    port = TcpServerPort(driver, bind, max_clients)
    link_options.setdefault("medium", "ip")
    return node.add_link(name, driver, port, advert_period_ms=advert_period_ms, **link_options), port


def tcp_client_link(node, host, port, name="tcp", backoff_s=(0.5, 10.0), mtu=1024, announce_ms=0, advert_period_ms=10000, **link_options):
    # Adds a link that keeps a TCP connection to host:port; returns (link, port).
    driver = _driver(node, mtu, announce_ms, "tcp client")
    p = TcpClientPort(driver, host, port, backoff_s)
    link_options.setdefault("medium", "ip")
    return node.add_link(name, driver, p, advert_period_ms=advert_period_ms, **link_options), p
