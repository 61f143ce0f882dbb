# The IMC gateway's sockets and loop (CPython): one UDP data socket per
# ImcGateway, one discovery socket for the process, and the Announces
# (docs/imc.md, "Gateway"). The protocol is in imcgateway (sans-IO).
#
# As DUNE's UDP transport, each system's data socket binds the first free of
# five consecutive ports from 6002 (port 0: an ephemeral one). As DUNE's
# Discovery, the discovery socket binds the first free of 30100..30104 and
# joins 224.0.75.69. Every announce period each system's Announce goes, from
# its data socket (so that the source is where it listens), to 127.0.0.1 and
# to the group and the broadcast address on all five ports: the loopback
# copy names the system's loopback endpoint, the others its external one.
# Multicast loop is on (DUNE has it off) so tools on the same host, and the
# other systems of a --sim network, hear the group too.
#
# Reads are bounded: at most RECV_BUDGET datagrams per socket per step, so a
# flood delays the loop by that much and the kernel drops the rest.

import errno
import select
import socket
import time

DATA_PORT = 6002
PORT_TRIES = 5
ANNOUNCE_GROUP = "224.0.75.69"
ANNOUNCE_PORTS = (30100, 30101, 30102, 30103, 30104)
RECV_BUDGET = 64
_MAX_DATAGRAM = 65535


def primary_address():
    # the address the kernel would send to the LAN from (no packet is sent)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.connect((ANNOUNCE_GROUP, ANNOUNCE_PORTS[0]))
        return s.getsockname()[0]
    except OSError:
        return "127.0.0.1"
    finally:
        s.close()


def _bind_first(host, ports, reuse=False):
    last = None
    for p in ports:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            if reuse:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((host, p))
        except OSError as e:
            s.close()
            last = e
            continue
        s.setblocking(False)
        return s
    raise OSError(errno.EADDRINUSE, "no free port in %s..%s: %s" % (ports[0], ports[-1], last))


class ImcBridge:
    def __init__(self, gateways, clock, advance=None, host="0.0.0.0", port=DATA_PORT, iface="0.0.0.0",
                 group=ANNOUNCE_GROUP, announce_ports=ANNOUNCE_PORTS, broadcast="255.255.255.255",
                 discovery=True, log=None):
        # gateways: ImcGateway each; clock(): their `now` (their ip_clock,
        # real time); advance(): moves
        # the acomm side on (a node's step, or the simulated World) and runs
        # between reading and sending. group/broadcast None: not used.
        self.gateways = list(gateways)
        self.clock = clock
        self.advance = advance
        self.group = group
        self.broadcast = broadcast
        self.announce_ports = tuple(announce_ports)
        self.log = log
        self.stats = {"tx": 0, "send_errors": 0, "recv_errors": 0, "budget_hits": 0, "announce_loopback": 0,
                      "announce_multicast": 0, "announce_broadcast": 0, "announce_errors": 0}
        self._buf = bytearray(_MAX_DATAGRAM)
        self.socks = []
        self._urls = []  # (loopback URL, external URL) of each system's data socket
        self.disc = None
        self.multicast = False  # whether the discovery socket joined the group
        try:
            external = host if host not in ("", "0.0.0.0") else primary_address()
            local = host if host not in ("", "0.0.0.0") else "127.0.0.1"
            for i, gw in enumerate(self.gateways):
                ports = [0] if port == 0 else list(range(port + i, port + i + PORT_TRIES))
                s = _bind_first(host, ports)
                self.socks.append(s)
                p = s.getsockname()[1]
                self._urls.append(("imc+udp://%s:%d/" % (local, p), "imc+udp://%s:%d/" % (external, p)))
                if group is not None:
                    s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(iface))
                    s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 1)
                    s.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 1)
                if broadcast is not None:
                    s.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
            if discovery:
                try:
                    self.disc = _bind_first("", self.announce_ports)
                except OSError as e:
                    # five DUNEs or gateways on this host already: we still
                    # announce and serve, we only learn no one's announces
                    self._say("no discovery port: %s" % e)
            if self.disc is not None:
                if group is not None:
                    try:
                        mreq = socket.inet_aton(group) + socket.inet_aton(iface)
                        self.disc.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, mreq)
                        self.multicast = True
                    except OSError as e:
                        self._say("no multicast on %s: %s" % (iface, e))
        except BaseException:
            self.close()
            raise

    def _say(self, text):
        if self.log is not None:
            self.log(text)

    @property
    def ports(self):
        return [s.getsockname()[1] for s in self.socks]

    @property
    def discovery_port(self):
        return None if self.disc is None else self.disc.getsockname()[1]

    # -- one round ------------------------------------------------------------------
    def _read(self, sock, handle):
        view = memoryview(self._buf)
        for _ in range(RECV_BUDGET):
            try:
                n, src = sock.recvfrom_into(self._buf)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                self.stats["recv_errors"] += 1  # an ICMP error reported here: not fatal
                return
            handle(src, bytes(view[:n]))
        self.stats["budget_hits"] += 1

    def _send(self, sock, data, ep, kind=None):
        try:
            sock.sendto(data, ep)
        except OSError:
            self.stats["announce_errors" if kind else "send_errors"] += 1
            return
        self.stats[kind or "tx"] += 1

    def step(self):
        now = self.clock()
        for gw, s in zip(self.gateways, self.socks):
            self._read(s, lambda ep, data, gw=gw: gw.feed(now, ep, data))
        if self.disc is not None:
            def announce_in(ep, data):
                for gw in self.gateways:
                    gw.on_discovery(now, ep, data)

            self._read(self.disc, announce_in)
        if self.advance is not None:
            self.advance()
        now = self.clock()
        for gw, s, urls in zip(self.gateways, self.socks, self._urls):
            if gw.announce_due(now):
                self._announce(gw, s, urls)
            for ep, data in gw.take_output():
                self._send(s, data, ep)

    def _announce(self, gw, s, urls):
        local = gw.announce([urls[0]])
        external = gw.announce([urls[1]])
        for p in self.announce_ports:
            self._send(s, local, ("127.0.0.1", p), "announce_loopback")
            if self.group is not None:
                self._send(s, external, (self.group, p), "announce_multicast")
            if self.broadcast is not None:
                self._send(s, external, (self.broadcast, p), "announce_broadcast")

    def run(self, seconds=None, stop=None, period_s=0.005):
        # steps until `seconds` have passed or stop() is true; waits on the
        # sockets at most period_s between steps
        end = None if seconds is None else time.monotonic() + seconds
        rd = list(self.socks) + ([self.disc] if self.disc is not None else [])
        while (end is None or time.monotonic() < end) and (stop is None or not stop()):
            self.step()
            select.select(rd, [], [], period_s)

    def close(self):
        for s in self.socks + ([self.disc] if self.disc is not None else []):
            s.close()
        self.socks = []
        self.disc = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
