# One Link per interface: the low-level transport of seed 000 section III.
#
# A Link wraps a sans-IO driver and gives the layers above the eight
# primitives: capability advertisement, frame received, frame transmission
# request, request status, ranging request and range received, cancellation,
# and link availability. It owns the bounded priority transmit queue, frames
# payloads (raw acomm frames on links without addressing or integrity, the
# one-byte elided header on modems that have both), acknowledges frames on
# raw links, suppresses duplicates, and runs node discovery. The ranging job
# is in acomm.link.ranging, loaded by the first range(). set_reply() leaves a frame in a modem that
# answers interrogations by itself; overhear=True hands up DATA frames
# addressed to other nodes (passive listening), never acknowledging them.
#
# The link is non-preemptive and half-duplex: one frame (or ping) is on the
# air at a time; the next is chosen only when the driver is ready again, so a
# new alarm waits for at most the frame already on the air.
#
# Every accepted request ends with exactly one final status (transmitted,
# delivered, expired, canceled, failed); refusals are reported as `failed`
# at once. Events go to `listener(event_tuple)` (see acomm.events).

from .. import frame as fr
from ..compat import const, ticks_add, ticks_diff
from .acktable import AckTable
from .dedup import DuplicateFilter
from .framing import LinkFraming
from .discovery import Discovery, decode_advert, encode_advert
from ..errors import AcommError, DecodeError
from .names import AddressMap
from .txqueue import TxQueue, TxRequest

# these modules' codes, as private constants (inlined: no slot in this
# module's dict on a board); tests/cpython/test_const_copies.py checks them
_CAP_ADDRESSING = const(1)  # acomm.drivers.caps
_CAP_DISCOVERY = const(8)  # acomm.drivers.caps
_CAP_RELIABLE = const(2)  # acomm.drivers.caps
_CAP_DELIVERY = const(32)  # acomm.drivers.caps
_MAX_AWAITING = const(8)  # acomm.drivers.evologics: bursts awaiting their report
_MAX_LIFESPAN_MS = const(0x10000000)  # acomm.link.txqueue

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_AVAILABLE = const(1)
_CANCELED = const(7)
_DELIVERED = const(5)
_EV_AVAILABILITY = const(22)
_EV_CAPS = const(23)
_EV_DELIVERED = const(3)
_EV_DRIVER_DOWN = const(7)
_EV_DRIVER_UP = const(6)
_EV_RANGE = const(5)
_FAIL_REASON = const(2)
_HANDLE = const(1)
_RANGE_METRES = const(3)
_RX_DATA = const(3)
_RX_DST = const(2)
_RX_SRC = const(1)
_EV_RECEIVED = const(21)
_EV_REFUSED = const(28)
_EV_SEGMENT = const(25)
_EV_CONTROL = const(29)
_EV_REPLIED = const(8)
_EV_RX = const(1)
_EV_STATUS = const(20)
_EV_TX_DONE = const(2)
_EV_TX_FAILED = const(4)
_EXPIRED = const(6)
_FAILED = const(8)
_QUEUED = const(1)
_TRANSMITTED = const(4)
_TRANSMITTING = const(2)
_UNAVAILABLE = const(2)
_WAITING = const(3)

BROADCAST = "*"  # destination name meaning every node on the link
_MAX_PENDING_ACKS = const(4)
_IDLE = const(0)  # the transmission slot's states
_SENDING = const(1)  # a frame or ping is on the air
_K_DATA = const(0)  # what the slot holds: a request's frame,
_K_ADVERT = const(1)  # an advert,
_K_ACK = const(2)  # a link ACK,
_K_PING = const(3)  # or a ranging job's ping


class _Inflight:
    # The one frame (or ping) on the air.
    # canceled: the request already has its final status (canceled, or
    # acknowledged before the driver reported the end of transmission); the
    # slot stays busy until the driver is done with the frame.
    # fields: req, handle, state, seq, dst_id, canceled, kind

    def __init__(self):
        self.clear()

    def clear(self):
        self.req = None
        self.handle = None
        self.state = _IDLE
        self.seq = 0
        self.dst_id = None
        self.canceled = False
        self.kind = _K_DATA  # what is in the slot: _K_DATA, _K_ADVERT, _K_ACK or _K_PING


class Link:
    # acomm.link.neighbours.Neighbours, set by a transport that learns routes: adverts and heard frames feed it
    neighbours = None
    overhear_segments = False  # set by a transport that learns routes: see _on_rx

    def __init__(
        self,
        name,
        driver,
        node_id,
        names,
        listener=None,
        queue_capacity=32,
        advert_period_ms=60000,
        lost_after=3,
        ack_timeout_ms=None,
        max_retries=2,
        aging_ms=0,
        addr_map=None,
        dup_window_ms=60000,
        ack_window=4,
        overhear=False,
        medium=None,
        fec=0,
    ):
        self.name = name
        # the kind of link ("acoustic", "satellite", "gsm", "ip", "radio"):
        # the transport's medium choice matches it as well as the name
        self.medium = medium or name
        self.driver = driver
        if getattr(driver, "advert_encoder", 0) is None:
            # a driver that announces the node itself (acomm.drivers.datagram)
            # sends this layer's ADVERT payload
            driver.advert_encoder = encode_advert
        self.node_id = node_id
        self.names = names
        self.listener = listener
        self.queue = TxQueue(queue_capacity, aging_ms)
        self.discovery = Discovery(advert_period_ms, lost_after, seed=node_id * 7919 + 1)
        self.addr_map = addr_map if addr_map is not None else AddressMap(True, driver.broadcast_addr)
        self.elided = driver.caps.has(_CAP_ADDRESSING)
        # who confirms delivery: the modem (its own acks, on elided links
        # of reliable modems) or this link (acomm ACK frames)
        self.modem_acks = self.elided and driver.caps.has(_CAP_RELIABLE)
        self.framing = LinkFraming(node_id, self.elided, self.addr_map, driver.caps.mtu_tx, not self.modem_acks, fec)
        self.seq_mod = self.framing.seq_mod
        # acomm.link.guard.Guard when the node has a key (Node.set_auth)
        self.guard = None
        self.max_retries = max_retries
        self.dup_window_ms = dup_window_ms
        self.overhear = overhear
        if ack_timeout_ms is None:
            # the frame's way there and the ack's way back, with a margin; behind ALOHA the ack is
            # a frame like any other at the peer and waits out its random backoff first (a wait
            # shorter than that resends into the late ack, on a half-duplex modem deaf to it)
            ack_timeout_ms = 2 * driver.caps.latency_ms + 1000 + getattr(getattr(driver, "mac", None),
                                                                         "max_backoff_ms", 0)
        self.ack_timeout_ms = ack_timeout_ms
        self._fl = _Inflight()
        # a modem that reports delivery by itself keeps a list of frames
        # awaiting their report (EvoLogics bursts) and takes that many in a
        # row: the window must not hold one back until the others' reports
        if self.modem_acks and driver.caps.flags & _CAP_DELIVERY and ack_window < _MAX_AWAITING:
            ack_window = _MAX_AWAITING
        self._acks = AckTable(ack_window)
        self._dups = DuplicateFilter(dup_window_ms)
        self._active = {}  # req_id -> TxRequest, accepted and not yet final
        self._seqs = {}  # destination id (None: broadcast) -> next sequence number
        self._last_tx = None
        self._pending_acks = []  # (dst_id, seq) link acks to send first
        self._caps = None
        self.stats = {
            "tx_frames": 0,
            "rx_frames": 0,
            "rx_bad": 0,
            "rx_not_for_us": 0,
            "rx_duplicates": 0,
            "refused": 0,
            "adverts_sent": 0,
            "acks_sent": 0,
            "retries": 0,
            "rx_own": 0,
            "tx_refused": 0,
        }

    # -- capability advertisement ---------------------------------------------
    @property
    def caps(self):
        # What the layers above may rely on: the driver's figures, with the
        # MTU reduced by acomm's framing, and the link's own services added.
        c = self.driver.caps.copy()
        ovh = self.framing.worst_overhead
        c.mtu_tx = max(c.mtu_tx - ovh, 0)
        c.mtu_rx = max(c.mtu_rx - ovh, 0)
        c.flags |= _CAP_DISCOVERY | _CAP_RELIABLE
        return c

    def advertise_caps(self):
        c = self.caps
        self._caps = c
        self._emit((_EV_CAPS, self, c))
        return c

    def _check_caps_changed(self):
        c = self.caps
        if self._caps is not None and c != self._caps:
            self._caps = c
            self._emit((_EV_CAPS, self, c))

    # -- helpers ----------------------------------------------------------------
    def _emit(self, ev):
        if self.listener is not None:
            self.listener(ev)

    def _status(self, req_id, status, reason=""):
        self._emit((_EV_STATUS, self, req_id, status, reason))

    def _final(self, req, status, reason=""):
        # The single exit for accepted requests.
        if self._active.pop(req.req_id, None) is None:
            raise AcommError("request %d finished twice" % req.req_id)
        self._status(req.req_id, status, reason)

    def _refuse(self, req_id, reason):
        self._status(req_id, _FAILED, reason)
        return False

    def mtu_for(self, dst_id):
        return self.framing.mtu_for(dst_id)

    def addressable(self, nid):
        # whether this link can put a frame to node nid on the air
        return nid != self.node_id and (not self.elided or self.addr_map.addr_of(nid) is not None)

    def _resolve(self, dst):
        # destination name -> node id (None for broadcast); raises on unknown
        if dst == BROADCAST:
            return None
        nid = self.names.id_of(dst)
        if nid is None:
            raise AcommError("unknown destination %r" % (dst,))
        if nid == self.node_id:
            raise AcommError("destination %r is this node" % (dst,))
        if self.elided and self.addr_map.addr_of(nid) is None:
            raise AcommError("no %s address for %r" % (self.name, dst))
        return nid

    # -- frame transmission request ----------------------------------------------
    def request(self, now, req_id, dst, data, lifespan_s, priority=10, ack=False, retries=None, ftype=fr.DATA,
                seq=None):
        """Queues one frame of data (bytes) for dst (a node name or BROADCAST), to leave within
        lifespan_s seconds, priority 1 (first) .. 16. -> True when accepted: `queued` follows and
        then exactly one final status (`delivered` needs ack=True and a link or modem ack). False
        when refused: `failed` with the reason was already emitted. Never raises for bad input.
        retries: tries after the first when unacknowledged (None: the link's max_retries; 0 for a
        schedule that must not repeat itself). ftype: DATA for applications, SEGMENT for the
        transport, which also gives seq: the frame header's sequence field carries the first bits
        of its segments (acomm.transport.segment)."""
        if not 0 <= req_id <= 0xFFFF:
            return self._refuse(req_id & 0xFFFF, "request id outside 0..65535")
        if req_id in self._active:
            return self._refuse(req_id, "request id %d is already in use" % req_id)
        if not 1 <= priority <= 16:
            return self._refuse(req_id, "priority %d outside 1..16" % priority)
        life_ms = int(lifespan_s * 1000)
        if life_ms <= 0:
            return self._refuse(req_id, "lifespan must be positive")
        if life_ms > _MAX_LIFESPAN_MS:
            return self._refuse(req_id, "lifespan longer than %d s" % (_MAX_LIFESPAN_MS // 1000))
        try:
            dst_id = self._resolve(dst)
        except AcommError as e:
            return self._refuse(req_id, str(e))
        mtu = self.mtu_for(dst_id)
        if len(data) > mtu:
            return self._refuse(req_id, "%d bytes exceed the %s MTU of %d" % (len(data), self.name, mtu))
        req = TxRequest(req_id, dst_id, priority, ticks_add(now, life_ms), bytes(data))
        # retries left (a broadcast cannot be acknowledged), sequence number, frame type, and the
        # counter its first copy was sealed with (every copy carries it: acomm.frame.auth)
        req.meta = [(self.max_retries if retries is None else retries) if (ack and dst_id is not None) else -1, seq, ftype,
                    0]
        return self._enqueue(req, now)

    def _enqueue(self, req, now):
        out = self.queue.push(req, now)
        if out is req:
            return self._refuse(req.req_id, "transmit queue full of higher-priority requests")
        self._active[req.req_id] = req
        self._status(req.req_id, _QUEUED)
        if out is not None:
            self._final(out, _FAILED, "evicted from a full queue by a higher-priority request")
        return True

    # -- the modem's automatic reply ----------------------------------------------
    def set_reply(self, now, payload):
        # An elided DATA frame (fresh sequence number, to whoever asks) that
        # the modem sends by itself in its reply to the next interrogation;
        # None clears it. Raises AcommError where the modem cannot do this.
        q = getattr(self.driver, "queue_reply", None)
        if q is None or not self.elided:
            raise AcommError("%s: the modem cannot queue a reply" % self.name)
        if payload is not None:
            if len(payload) > self.mtu_for(0):
                raise AcommError("%d bytes exceed the %s MTU of %d" % (len(payload), self.name, self.mtu_for(0)))
            payload = self.framing.encode(fr.REPLY, None, self._next_seq(), payload)[1]
        q(now, payload)

    # -- cancellation -------------------------------------------------------------
    def cancel(self, now, req_id, reason="canceled"):
        """Cancels request req_id -> True when it was still open: its one final status is then
        `canceled` (a frame already on the air is not called back; its outcome is dropped)."""
        req = self.queue.cancel(req_id)
        if req is not None:
            self._final(req, _CANCELED, reason)
            return True
        fl = self._fl
        if fl.req is not None and fl.req.req_id == req_id and not fl.canceled:
            # The bytes may already be on the air; we stop caring about them.
            fl.canceled = True
            self._final(fl.req, _CANCELED, reason)
            if fl.state == _IDLE:  # a ranging job between pings
                fl.clear()
            return True
        req = self._acks.by_req_id(req_id)
        if req is not None:
            self._final(req, _CANCELED, reason)  # a late ack will match nothing
            return True
        return False

    # -- availability -------------------------------------------------------------
    def availability(self, name):
        nid = self.names.id_of(name)
        return self.discovery.state(nid) if nid is not None else 0

    def _heard(self, nid, now, period_ms=None):
        if nid is None or nid == self.node_id:
            return
        nb = self.neighbours
        if nb is not None:
            nb.heard(now, nid, period_ms or 0)
        if self.discovery.heard(nid, now, period_ms) == _AVAILABLE:
            self._emit((_EV_AVAILABILITY, self, self.names.learn(nid), _AVAILABLE))

    # -- time ---------------------------------------------------------------------
    def poll(self, now):
        d = self.driver
        d.poll(now)
        self._handle_driver_events(now)
        for nid in self.discovery.poll(now):
            self._emit((_EV_AVAILABILITY, self, self.names.name_of(nid), _UNAVAILABLE))
        fl = self._fl
        for req, expired in self._acks.due(now):
            if expired:
                self._final(req, _EXPIRED, "lifespan ended before delivery was confirmed")
            else:
                self._retry_or_fail(req, now, "no acknowledgement")
        for req in self.queue.expire(now):
            self._final(req, _EXPIRED, "lifespan ended in the queue")
        if fl.state == _IDLE and fl.kind == _K_PING and fl.req is not None:
            # a ranging job between two pings
            from .ranging import finish, ping_next

            if ticks_diff(now, fl.req.deadline) >= 0:
                finish(self, fl.req)
            elif d.ready(now):
                ping_next(self, now)
                self._handle_driver_events(now)
        elif fl.state == _IDLE and d.ready(now):
            self._start_next(now)
            self._handle_driver_events(now)

    def idle(self, now):
        # True when poll(now) has nothing of its own to do: nothing on the
        # air or awaited, no link ack owed, no advert or loss due. Queued
        # requests may still wait (for the driver, or a MAC's turn). The
        # simulator uses it to step quiet nodes less often.
        fl = self._fl
        if fl.state != _IDLE or fl.req is not None or len(self._acks) or self._pending_acks:
            return False
        return not (self.discovery.advert_due(now, self._last_tx) or self.discovery.loss_due(now))

    def feed(self, now, data):
        self.driver.feed(now, data)
        self._handle_driver_events(now)

    def take_output(self):
        return self.driver.take_output()

    def _retry_or_fail(self, req, now, reason):
        if req.meta[0] > 0:
            req.meta[0] -= 1
            self.stats["retries"] += 1
            out = self.queue.push(req, now)
            if out is req:
                self._final(req, _FAILED, reason + "; queue full for the retry")
            else:
                self._status(req.req_id, _QUEUED, reason + "; retrying")
                if out is not None:
                    self._final(out, _FAILED, "evicted from a full queue by a higher-priority request")
        else:
            self._final(req, _FAILED, reason)

    # -- transmission -------------------------------------------------------------
    def _next_seq(self, dst_id=None):
        # One counter per destination: a receiver then sees consecutive
        # numbers from us, so its duplicate filter (a few recent numbers
        # per source) never mistakes a new frame for a copy of one sent 16
        # frames earlier because the frames to other nodes in between
        # advanced a shared counter. Broadcasts and modem replies (to
        # whoever asks) share the None counter. At most 256 entries: node
        # ids are 0..254.
        s = self._seqs.get(dst_id, 0)
        self._seqs[dst_id] = (s + 1) % self.seq_mod
        return s

    def _send_control(self, now, kind, ftype, dst_id, seq, payload, ctr=0):
        # Adverts and link acks (ctr: the acknowledged frame's counter): no
        # request behind them, so a driver refusal is only counted.
        fl = self._fl
        try:
            addr, data = self.framing.encode(ftype, dst_id, seq, payload, 0, ctr)
            fl.handle = self.driver.send(now, addr, data, False)
        except AcommError:
            fl.clear()
            self.stats["tx_refused"] += 1
            return False
        fl.kind = kind
        fl.state = _SENDING
        return True

    def _start_next(self, now):
        fl = self._fl
        d = self.driver
        if self._pending_acks:
            dst_id, seq, ctr = self._pending_acks.pop(0)
            if self._send_control(now, _K_ACK, fr.ACK, dst_id, seq, b"", ctr):
                self.stats["acks_sent"] += 1
            return
        if self._acks.full():
            nxt = self.queue.peek(now)
            if nxt is not None and nxt.meta[0] >= 0:
                return  # wait for an ack slot (and a free sequence number)
        req = self.queue.pop(now)
        if req is None:
            if self.discovery.advert_due(now, self._last_tx):
                # counted as sent even when refused, so a stuck driver is not
                # asked again on every poll
                self._last_tx = now
                self.discovery.advert_sent()
                advert = encode_advert(self.node_id, self.discovery.period_ms)
                if self._send_control(now, _K_ADVERT, fr.ADVERT, None, self._next_seq(), advert):
                    self.stats["adverts_sent"] += 1
            return
        fl.req = req
        fl.canceled = False
        if req.meta[0] == -2:
            from .ranging import ping_next

            ping_next(self, now)
            return
        want_ack = req.meta[0] >= 0
        a = self.framing.auth
        # a retry keeps its sequence number so the receiver can drop the copy
        seq = req.meta[1]
        if seq is None:
            seq = self._next_seq(req.dst)
            if want_ack:
                while self._acks.seq_in_use(req.dst, seq):
                    seq = self._next_seq(req.dst)
            req.meta[1] = seq
        flags = fr.F_ACK_REQ if (want_ack and not self.modem_acks) else 0
        try:
            addr, data = self.framing.encode(req.meta[2], req.dst, seq, req.data, flags, req.meta[3])
            fl.handle = d.send(now, addr, data, want_ack and self.modem_acks)
        except AcommError as e:
            fl.clear()
            self._final(req, _FAILED, "driver refused the frame: %s" % e)
            return
        if want_ack and a is not None:
            # a resend is the same frame: same counter, same tag (sealed once)
            req.meta[3] = a.last
        fl.kind = _K_DATA
        fl.seq = seq
        fl.dst_id = req.dst
        fl.state = _SENDING
        self._last_tx = now
        self.stats["tx_frames"] += 1
        self._status(req.req_id, _TRANSMITTING)

    # -- events from the driver ---------------------------------------------------
    def _handle_driver_events(self, now):
        for ev in self.driver.take_events():
            code = ev[0]
            if code == _EV_RX:
                self._on_rx(now, ev[_RX_SRC], ev[_RX_DST], ev[_RX_DATA])
            elif code == _EV_TX_DONE:
                self._on_tx_done(now, ev[_HANDLE])
            elif code == _EV_DELIVERED:
                self._on_delivered(now, ev[_HANDLE])
            elif code == _EV_TX_FAILED:
                self._on_tx_failed(now, ev[_HANDLE], ev[_FAIL_REASON])
            elif code == _EV_RANGE:
                if self._fl.kind == _K_PING and ev[_HANDLE] == self._fl.handle:
                    from .ranging import result

                    result(self, now, ev[_RANGE_METRES])
            elif code == _EV_DRIVER_UP or code == _EV_DRIVER_DOWN:
                self._check_caps_changed()
            elif code == _EV_REPLIED:
                # our reply went out: everyone around heard us, so the
                # advert can wait (a CADDY diver never sends otherwise)
                self._last_tx = now

    def _on_tx_done(self, now, handle):
        fl = self._fl
        if fl.state != _SENDING or handle != fl.handle or fl.kind == _K_PING:
            return
        if fl.kind != _K_DATA:  # advert or link ack: nothing to report
            fl.clear()
            return
        req = fl.req
        if fl.canceled:
            fl.clear()
            return
        fl.clear()
        if req.meta[0] >= 0:
            # the channel is free again: wait for the ack off the air
            self._acks.add(req, handle, req.dst, req.meta[1], ticks_add(now, self.ack_timeout_ms))
            self._status(req.req_id, _WAITING)
        else:
            self._final(req, _TRANSMITTED)

    def _on_delivered(self, now, handle):
        fl = self._fl
        if fl.state == _SENDING and fl.kind == _K_DATA and handle == fl.handle:
            if not fl.canceled:
                # confirmed before the end of transmission was reported
                fl.canceled = True
                self._final(fl.req, _DELIVERED)
            return
        req = self._acks.by_handle(handle)
        if req is not None:
            self._final(req, _DELIVERED)

    def _on_tx_failed(self, now, handle, reason):
        fl = self._fl
        if fl.state == _IDLE or handle != fl.handle:
            req = self._acks.by_handle(handle)
            if req is not None:
                self._retry_or_fail(req, now, reason)
            return
        if fl.kind == _K_PING:
            from .ranging import result

            result(self, now, None)
            return
        req = fl.req
        kind = fl.kind
        canceled = fl.canceled
        fl.clear()
        if kind == _K_DATA and req is not None and not canceled:
            self._retry_or_fail(req, now, reason)

    def _on_rx(self, now, src_addr, dst_addr, data):
        self.stats["rx_frames"] += 1
        try:
            f, src, dst = self.framing.decode(src_addr, dst_addr, data)
        except DecodeError:
            self.stats["rx_bad"] += 1
            return
        if src == self.node_id:
            # our own frame echoed back, or another node configured with our
            # id: never hand it up as received
            self.stats["rx_own"] += 1
            return
        if f.payload is None:
            # a genuine copy of a frame taken before (its counter was seen): acknowledged
            # again, since our ack may be what was lost, and never handed up again
            self.stats["rx_duplicates"] += 1
            if dst == self.node_id and len(self._pending_acks) < _MAX_PENDING_ACKS:
                self._pending_acks.append((src, f.seq, f.ctr))
            return
        if f.ftype == fr.ACK and f.flags & fr.F_AUTH:
            # A sealed ACK carries no counter: its tag is bound to the counter the request was
            # sealed with, so it is checked against the request it would confirm (a recording
            # of it confirms only that request again). Inline: a method costs the board heap
            if dst != self.node_id:
                self.stats["rx_not_for_us"] += 1
                return
            fl = self._fl
            if fl.state == _SENDING and fl.kind == _K_DATA and not fl.canceled and fl.dst_id == src and fl.seq == f.seq:
                req = fl.req  # the ack beat our own end-of-transmission estimate
            else:
                req = self._acks.by_ack(src, f.seq, False)
            if req is None:
                return  # late: the request is settled
            if not self.framing.auth.ack_tag(src, dst, f.seq, req.meta[3], f.payload):
                self.stats["rx_bad"] += 1
                if self.guard is not None:
                    self.guard.count("ack")
                return
            self._heard(src, now)
            if req is fl.req:
                fl.canceled = True  # the slot frees at EV_TX_DONE
            else:
                self._acks.by_req_id(req.req_id)
            self._final(req, _DELIVERED)
            return
        g = self.guard
        if g is not None and not f.authed and g.strict:
            # strict mode (acomm.link.guard): no control frame, and no node
            # heard, on the word of a frame without a valid tag
            if g.refuses_frame(f):
                return
            src_heard = None
        else:
            src_heard = src
        if f.ftype == fr.ADVERT:
            try:
                nid, period = decode_advert(f.payload)
            except DecodeError:
                self.stats["rx_bad"] += 1
                return
            if self.elided and src_addr is not None and nid != src:
                self.addr_map.set(nid, src_addr)
                src = nid
            self._heard(src, now, period)
            return
        self._heard(src_heard, now)
        mine = dst is None or dst == self.node_id
        if f.ftype == fr.SEGMENT:
            # the transport's: it numbers and acknowledges its own fragments. On a link that
            # routes it also hears the ones between two others, to offer a shorter way
            # (acomm.transport.routing.Routing.overheard)
            if mine or self.overhear_segments:
                self._emit((_EV_SEGMENT, self, src, dst, f.seq, f.payload, f.authed))
            return
        if f.ftype == fr.CONTROL:
            # route control (acomm.transport.routing): the transport's too. A reply to one
            # neighbour asks for an acknowledgement, so a copy sent again is dropped here
            if not mine:
                return
            if f.flags & fr.F_ACK_REQ and dst is not None:
                if len(self._pending_acks) < _MAX_PENDING_ACKS:
                    self._pending_acks.append((src, f.seq, f.ctr))
                if self._dups.seen(src * 257 + dst, f.seq, now):
                    self.stats["rx_duplicates"] += 1
                    return
            if f.authed:
                self.framing.auth.commit()  # on file before it is acted on: no restart makes it fresh
            self._emit((_EV_CONTROL, self, src, f.payload, f.authed))
            return
        data = f.ftype == fr.DATA or f.ftype == fr.REPLY
        if not mine:
            self.stats["rx_not_for_us"] += 1
            if not self.overhear or not data:
                return
        if f.ftype == fr.ACK:
            fl = self._fl
            if fl.state == _SENDING and fl.kind == _K_DATA and not fl.canceled and fl.dst_id == src and fl.seq == f.seq:
                # the ack beat our own end-of-transmission estimate: the
                # request is done; the slot frees at EV_TX_DONE
                fl.canceled = True
                self._final(fl.req, _DELIVERED)
                return
            req = self._acks.by_ack(src, f.seq)
            if req is not None:
                self._final(req, _DELIVERED)
            return
        if not data:
            return
        if mine and f.flags & fr.F_ACK_REQ and dst is not None and len(self._pending_acks) < _MAX_PENDING_ACKS:
            # acknowledge duplicates too: our earlier ack may have been lost
            self._pending_acks.append((src, f.seq, f.ctr))
        # senders number frames per destination (_next_seq), and modem
        # replies and broadcasts on one more counter: one filter key each
        # (node ids are at most 65534: one key per pair and kind)
        if f.ftype == fr.REPLY:
            key = src * 65537 + 65536
        else:
            key = src * 65537 + (255 if dst is None else dst)
        if self._dups.seen(key, f.seq, now):
            self.stats["rx_duplicates"] += 1
            return
        if self.guard is not None and not self.guard.admits(f.payload, f.authed, self.framing.auth):
            self.stats["refused"] += 1
            self._emit((_EV_REFUSED, self, self.names.name_of(src), self.guard.REFUSED))
            return
        if f.authed:
            # its counter on file before the application has it: after a restart no
            # recording of it is fresh again (a command's was written by the guard)
            self.framing.auth.commit()
        ev = (_EV_RECEIVED, self, self.names.name_of(src), BROADCAST if dst is None else self.names.name_of(dst),
              f.payload)
        # with a key, whether the frame's tag verified
        self._emit(ev if self.guard is None else ev + (f.authed,))

    # -- ranging (seed 000's ranging request and range received) ------------------
    def range(self, now, req_id, names, lifespan_s, priority=2):
        """Pings each node named in turn (names: a list), within lifespan_s seconds -> True when
        accepted. Then one EV_RANGE_RECEIVED (names, metres: None where none answered) and a final
        status: `delivered` with at least one range, else `failed`; refusals as for request()."""
        from .ranging import request

        return request(self, now, req_id, names, lifespan_s, priority)
