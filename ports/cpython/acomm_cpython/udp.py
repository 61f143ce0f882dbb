# UDP link on CPython: the socket side of acomm.drivers.datagram.
#
# UdpPort owns two non-blocking sockets and has the pump(now) API that
# acomm.node.Node calls around each poll of the link:
#   - the unicast socket (bind, default an ephemeral port on every address)
#     sends everything, multicast and broadcast included, so a receiver
#     learns from the source address an endpoint it can answer unicast;
#   - the discovery socket, bound to group_port on every address with
#     SO_REUSEADDR/SO_REUSEPORT (so several nodes on one host share it),
#     joined to the multicast group, only receives announcements and other
#     broadcasts.
# Broadcast frames go to the multicast group and, when `broadcast` is an
# address (e.g. "255.255.255.255"), to that address as well, both on
# group_port; receivers drop the second copy (the link's duplicate filter).
#
# udp_link(node, ...) makes the driver and the port and adds the link.

import errno
import socket

from acomm.drivers.datagram import DatagramDriver

DEFAULT_GROUP = "239.255.97.99"  # organisation-local scope (RFC 2365); 97, 99: "ac"
DEFAULT_PORT = 29799
_RECV_BURST = 64  # datagrams read per socket per pump, so a flood cannot starve the node


def resolve(endpoint):
    # (host, port) with host as a dotted quad, the form recvfrom reports,
    # so that configured endpoints and learned ones compare equal.
    host, port = endpoint
    return (socket.gethostbyname(host), int(port))


class UdpPort:
    def __init__(
        self,
        driver,
        bind=("0.0.0.0", 0),
        group=DEFAULT_GROUP,
        group_port=DEFAULT_PORT,
        iface="0.0.0.0",
        broadcast="255.255.255.255",
        ttl=1,
    ):
        # group None: no multicast; broadcast None: no subnet broadcast;
        # with neither, no discovery socket (static peers only). iface: the
        # address of the interface for multicast (0.0.0.0: the kernel's
        # choice by its routes; 127.0.0.1 for the loopback).
        self.driver = driver
        self.stats = {"rx": 0, "tx": 0, "recv_errors": 0, "send_errors": 0, "oversize": 0}
        self._buf = bytearray(driver.mtu + 1)
        self._view = memoryview(self._buf)
        self.sock = None
        self.disc = None
        self._socks = []
        try:
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self.sock = s
            s.setblocking(False)
            s.bind(resolve(bind))
            eps = []
            if group is not None:
                s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(iface))
                s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, ttl)
                # other nodes on this host must hear us too
                s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
                eps.append((group, group_port))
            if broadcast is not None:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
                eps.append((broadcast, group_port))
            self._socks.append(s)
            if eps:
                self.disc = self._discovery_socket(group, group_port, iface)
                self._socks.append(self.disc)
            driver.broadcast_endpoints = eps
        except BaseException:
            self.close()
            raise

    @staticmethod
    def _discovery_socket(group, port, iface):
        d = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            d.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if hasattr(socket, "SO_REUSEPORT"):
                d.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
            d.setblocking(False)
            d.bind(("", port))
            if group is not None:
                mreq = socket.inet_aton(group) + socket.inet_aton(iface)
                d.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
        except BaseException:
            d.close()
            raise
        return d

    def filenos(self):
        """The sockets an event loop waits on for datagrams (unicast, then discovery)."""
        return tuple(s.fileno() for s in self._socks)

    @property
    def address(self):
        # (host, port) the unicast socket is bound to
        return self.sock.getsockname()

    def pump(self, now):
        d = self.driver
        buf = self._buf
        st = self.stats
        for s in self._socks:
            for _ in range(_RECV_BURST):
                try:
                    n, src = s.recvfrom_into(buf)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    # e.g. an ICMP error reported on the socket: not fatal
                    st["recv_errors"] += 1
                    break
                st["rx"] += 1
                if n >= len(buf):
                    st["oversize"] += 1  # cut by the kernel; the driver refuses it
                d.feed_from(now, src, bytes(self._view[:n]))
        for h, ep, data in d.take_datagrams():
            try:
                self.sock.sendto(data, ep)
            except OSError as e:
                st["send_errors"] += 1
                d.sent(now, h, _reason(e))
                continue
            st["tx"] += 1
            d.sent(now, h)

    def close(self):
        for s in (self.sock, self.disc):
            if s is not None:
                s.close()
        self._socks = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _reason(e):
    if isinstance(e, BlockingIOError):
        return "socket send buffer full"
    if e.errno is not None:
        return errno.errorcode.get(e.errno, str(e.errno)) + " " + (e.strerror or "")
    return str(e)


def udp_link(
    node,
    name="ip",
    bind=("0.0.0.0", 0),
    group=DEFAULT_GROUP,
    group_port=DEFAULT_PORT,
    iface="0.0.0.0",
    broadcast="255.255.255.255",
    peers=None,
    learn=True,
    mtu=1024,
    announce_ms=None,
    advert_period_ms=10000,
    **link_options
):
    # Adds a UDP link to node; returns (link, port). peers: {node id:
    # (host, port)} static endpoints. announce_ms: the driver's own adverts
    # when no broadcast left for that long (default: the advert period).
    driver = DatagramDriver(
        node_id=node.node_id,
        peers=dict((k, resolve(peers[k])) for k in peers) if peers else None,
        learn=learn,
        mtu=mtu,
        announce_ms=advert_period_ms if announce_ms is None else announce_ms,
        model="udp",
    )
    port = UdpPort(driver, bind, group, group_port, iface, broadcast)
    try:
        link_options.setdefault("medium", "ip")
        link = node.add_link(name, driver, port, advert_period_ms=advert_period_ms, **link_options)
    except BaseException:
        port.close()
        raise
    return link, port
