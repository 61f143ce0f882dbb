# Driver for IP links: UDP datagrams, or frames over TCP connections. It is
# sans-IO like the modem drivers, so the same code runs under the CPython
# socket ports (acomm_cpython.udp, acomm_cpython.tcp) and on a MicroPython
# board with a socket module. The port does the I/O:
#
#   feed_from(now, endpoint, frame)     one datagram (or one TCP frame) came in
#   take_datagrams() -> [(handle, endpoint, frame)]   what to send, and where
#   sent(now, handle, error=None)       the port's word on each entry taken
#   connection_up/down(now, endpoint)   TCP connections (streams=True only)
#
# An endpoint is whatever the port's socket calls a peer address (a
# (host, port) tuple on CPython), used only as a dictionary key here.
#
# The IP link has no addressing or integrity of its own in acomm's sense, so
# the Link above sends raw acomm frames (node ids + CRC) and this driver
# routes them by the node ids in their header: a table maps node id ->
# endpoint. Static entries come from configuration and are never displaced;
# with learn=True the sender of every valid frame is learned (its source
# node id -> the endpoint it came from), which is how nodes that found each
# other by multicast talk unicast afterwards. The learned part holds at
# most `capacity` nodes; when full the one heard longest ago is forgotten.
#
# What comes in and is refused, with the counter in `stats`:
#   rx_garbage   not a raw acomm frame (too short or long, wrong version,
#                bad CRC, reserved address): foreign traffic or noise
#   rx_own       our own node id as source (our multicast looped back)
#   rx_refused   a node id configured statically at another endpoint:
#                someone else claiming to be that node
#   rx_unknown   learn=False and the sender is not in the static table
#
# Broadcast frames go to the broadcast endpoints (multicast group, subnet
# broadcast) and to each static peer (which may sit beyond the LAN); on
# TCP to every connection. A unicast frame to a node with no endpoint goes
# to `default` when set (a TCP client's server), else the send is refused
# ("no endpoint for node N") and the link reports the request failed.
#
# announce_ms > 0 (with node_id set): when no broadcast has left for that
# long, the driver sends an acomm ADVERT itself. Its payload is the link
# layer's (acomm.link.discovery.encode_advert): the Link hands its encoder
# to the driver (advert_encoder), as a driver sits below the link layer. The Link advertises only
# after silence; a node busy talking unicast to one peer would otherwise
# stay unknown to the rest of the LAN. A new TCP connection is announced at
# once, so the far end can route to us before we have anything to say.

from .. import frame as fr
from .caps import CAP_BROADCAST, Capabilities
from ..compat import const, ticks_diff
from ..errors import DecodeError, EncodeError
from ..events import EV_DRIVER_DOWN, EV_DRIVER_UP, EV_RX, EV_TX_DONE, EV_TX_FAILED
from .base import SansIO

_QUEUE_CAP = const(64)  # entries waiting for the port to take them


class DatagramDriver(SansIO):
    """UDP datagrams or TCP frames to peers' endpoints; the port does the I/O (feed_from, take_datagrams, sent)."""

    def __init__(
        self,
        node_id=None,
        peers=None,
        broadcast=(),
        learn=True,
        capacity=32,
        mtu=1024,
        bitrate=1000000,
        latency_ms=20,
        announce_ms=0,
        streams=False,
        default=None,
        tx_timeout_ms=2000,
        model="udp",
        advert_encoder=None,
    ):
        SansIO.__init__(self)
        if not fr.RAW_OVERHEAD_WIDE < mtu <= 65535:
            raise EncodeError("mtu %d outside %d..65535" % (mtu, fr.RAW_OVERHEAD_WIDE + 1))
        self.node_id = node_id
        self.mtu = mtu
        self.learn = learn
        self.capacity = capacity
        self.announce_ms = announce_ms
        # f(node_id, period_ms) -> an ADVERT's payload; the Link sets it
        self.advert_encoder = advert_encoder
        self.streams = streams
        self.default = default
        self.tx_timeout_ms = tx_timeout_ms
        self.caps = Capabilities(
            manufacturer="generic",
            model=model,
            mtu_tx=mtu,
            mtu_rx=mtu,
            bitrate=bitrate,
            latency_ms=latency_ms,
            flags=CAP_BROADCAST,
        )
        self.broadcast_addr = None
        self.broadcast_endpoints = list(broadcast)
        self._static = {}
        self._learned = {}  # node id -> [endpoint, ticks last heard]
        for nid in peers or ():
            self.set_peer(nid, peers[nid])
        self._connected = []  # TCP endpoints up (streams=True)
        self._queue = []  # (handle or None, endpoint, frame)
        # the link's one frame in flight: [handle, entries not yet reported,
        # entries sent, last error, ticks handed over]
        self._inflight = None
        self._handle = 0
        self._last_bcast = None
        self._announce_now = False
        self.stats = {
            "rx_datagrams": 0,
            "rx_garbage": 0,
            "rx_own": 0,
            "rx_refused": 0,
            "rx_unknown": 0,
            "learned": 0,
            "moved": 0,
            "forgotten": 0,
            "tx_datagrams": 0,
            "tx_errors": 0,
            "tx_timeouts": 0,
            "no_route": 0,
            "announcements": 0,
            "announce_dropped": 0,
        }

    # -- the endpoint table ------------------------------------------------------
    def set_peer(self, node_id, endpoint):
        # A static entry (configuration): never displaced or forgotten.
        if not 0 <= node_id <= fr.MAX_ADDR or node_id == fr.BROADCAST:
            raise EncodeError("node id %d is not a node id" % node_id)
        self._static[node_id] = endpoint
        self._learned.pop(node_id, None)

    def endpoint_of(self, node_id):
        # Where a frame to node_id goes now, or None.
        ep = self._static.get(node_id)
        if ep is None:
            e = self._learned.get(node_id)
            if e is not None:
                ep = e[0]
        if ep is not None and self.streams and ep not in self._connected:
            ep = None
        if ep is None and self.default is not None and (not self.streams or self.default in self._connected):
            ep = self.default
        return ep

    def nodes_at(self, endpoint):
        # node ids known at endpoint (static and learned)
        out = [k for k in self._static if self._static[k] == endpoint]
        return out + [k for k in self._learned if self._learned[k][0] == endpoint]

    def learned(self):
        return dict((k, self._learned[k][0]) for k in self._learned)

    def _accept(self, now, ep, src):
        st = self._static.get(src)
        if st is not None:
            if st == ep:
                return True
            self.stats["rx_refused"] += 1
            return False
        if not self.learn or ep is None:
            self.stats["rx_unknown"] += 1
            return False
        e = self._learned.get(src)
        if e is None:
            if len(self._learned) >= self.capacity and not self._forget_oldest():
                self.stats["rx_unknown"] += 1
                return False
            self._learned[src] = [ep, now]
            self.stats["learned"] += 1
            return True
        if e[0] != ep:
            # a restarted node on a new port, a TCP client reconnected
            e[0] = ep
            self.stats["moved"] += 1
        e[1] = now
        return True

    def _forget_oldest(self):
        old = None
        for k in self._learned:
            if old is None or ticks_diff(self._learned[k][1], self._learned[old][1]) < 0:
                old = k
        if old is None:
            return False
        del self._learned[old]
        self.stats["forgotten"] += 1
        return True

    # -- connections (TCP) -------------------------------------------------------
    def connection_up(self, now, endpoint, default=False):
        if endpoint not in self._connected:
            self._connected.append(endpoint)
            if len(self._connected) == 1:
                self._events.append((EV_DRIVER_UP,))
        if default:
            self.default = endpoint
        if self.node_id is not None:
            self._announce_now = True

    def connection_down(self, now, endpoint, reason="connection lost"):
        if endpoint not in self._connected:
            return
        self._connected.remove(endpoint)
        for k in [k for k in self._learned if self._learned[k][0] == endpoint]:
            del self._learned[k]
        q = self._queue
        keep = [e for e in q if e[1] != endpoint]
        if len(keep) != len(q):
            gone = [e for e in q if e[1] == endpoint]
            self._queue = keep
            for e in gone:
                self.sent(now, e[0], reason)
        if not self._connected:
            self._events.append((EV_DRIVER_DOWN, reason))

    @property
    def connections(self):
        return len(self._connected)

    # -- the driver interface ----------------------------------------------------
    def ready(self, now):
        return self._inflight is None and (not self.streams or len(self._connected) > 0)

    def _broadcast_to(self):
        if self.streams:
            return list(self._connected)
        eps = list(self.broadcast_endpoints)
        for k in self._static:
            if self._static[k] not in eps:
                eps.append(self._static[k])
        return eps

    def send(self, now, addr, data, ack=False):
        # addr is None (raw frames): the destination is in the frame.
        if self._inflight is not None:
            raise EncodeError("a frame is still being sent")
        if len(data) > self.mtu:
            raise EncodeError("%d bytes exceed the MTU of %d" % (len(data), self.mtu))
        try:
            dst = fr.raw_addresses(data)[1]
        except DecodeError as e:
            raise EncodeError("not a raw acomm frame (fec is not for IP links): %s" % e)
        if dst == fr.BROADCAST:
            eps = self._broadcast_to()
            if not eps:
                self.stats["no_route"] += 1
                raise EncodeError("no endpoint to broadcast to")
            self._last_bcast = now
        else:
            ep = self.endpoint_of(dst)
            if ep is None:
                self.stats["no_route"] += 1
                raise EncodeError("no endpoint for node %d" % dst)
            eps = (ep,)
        if len(self._queue) + len(eps) > _QUEUE_CAP:
            raise EncodeError("the port is not taking datagrams")
        self._handle = (self._handle + 1) & 0xFFFF
        h = self._handle
        data = bytes(data)
        for ep in eps:
            self._queue.append((h, ep, data))
        self._inflight = [h, len(eps), 0, None, now]
        return h

    def feed(self, now, data):
        # The byte-stream entry of the driver interface: one frame from the
        # default endpoint. Ports call feed_from.
        self.feed_from(now, self.default, data)

    def feed_from(self, now, endpoint, data):
        st = self.stats
        st["rx_datagrams"] += 1
        if len(data) > self.mtu:
            st["rx_garbage"] += 1
            return
        try:
            src = fr.raw_addresses(data)[0]
        except DecodeError:
            st["rx_garbage"] += 1
            return
        if src == self.node_id:
            st["rx_own"] += 1
            return
        if self._accept(now, endpoint, src):
            self._events.append((EV_RX, None, None, bytes(data)))

    def poll(self, now):
        fl = self._inflight
        if fl is not None and ticks_diff(now, fl[4]) >= self.tx_timeout_ms:
            # the port never reported: do not hold the link for ever
            self._queue = [e for e in self._queue if e[0] != fl[0]]
            self._inflight = None
            self.stats["tx_timeouts"] += 1
            self._events.append((EV_TX_FAILED, fl[0], "the port did not send the frame"))
        if self.node_id is None or self.advert_encoder is None:
            return
        if self._last_bcast is None:
            # the clock starts now: the link adverts at once by itself
            self._last_bcast = now
        if self._announce_now or (self.announce_ms > 0 and ticks_diff(now, self._last_bcast) >= self.announce_ms):
            self._announce(now)

    def _announce(self, now):
        self._announce_now = False
        self._last_bcast = now
        eps = self._broadcast_to()
        if not eps:
            return
        if len(self._queue) + len(eps) > _QUEUE_CAP:
            self.stats["announce_dropped"] += 1
            return
        period = self.announce_ms if self.announce_ms > 0 else 60000
        data = fr.encode_raw(fr.Frame(fr.ADVERT, self.node_id, fr.BROADCAST, 0, self.advert_encoder(self.node_id, period)))
        for ep in eps:
            self._queue.append((None, ep, data))
        self.stats["announcements"] += 1

    def take_datagrams(self):
        # Entries to send, oldest first; the port reports each with sent().
        q = self._queue
        if not q:
            return q
        self._queue = []
        return q

    def sent(self, now, handle, error=None):
        if error is None:
            self.stats["tx_datagrams"] += 1
        else:
            self.stats["tx_errors"] += 1
        fl = self._inflight
        if handle is None or fl is None or fl[0] != handle:
            return  # an announcement, or a frame that already timed out
        fl[1] -= 1
        if error is None:
            fl[2] += 1
        else:
            fl[3] = error
        if fl[1] > 0:
            return
        self._inflight = None
        if fl[2]:
            self._events.append((EV_TX_DONE, handle))
        else:
            self._events.append((EV_TX_FAILED, handle, "not sent: %s" % fl[3]))
