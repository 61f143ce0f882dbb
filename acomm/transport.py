# The high-level transport (seed 000 section V): packets of any size up to
# max_packet, kept in a store until delivered or expired, compressed when
# that helps, fragmented to the MTU of the link chosen for them, sent with
# selective-repeat ARQ (acomm.arq) and relayed hop by hop on static routes.
#
#   t = Transport(node, store=None, routes={"buoy": "auv"}, wall=time.time)
#   pid = t.send(now, "buoy", data, lifespan_s, priority, medium=None)
#   node.step(now); t.poll(now)           # or Node.step does both
#
# Events to the node's listener: (EV_PACKET_STATUS, pid, status, reason)
# with queued, transmitted (a relay took custody), delivered (the
# destination has it all), expired, failed; and (EV_PACKET, src, dst, data)
# for every packet that arrived whole and decoded.
#
# The store (acomm.store.Store or the in-memory one here) holds each packet
# as one record, written before send() returns and deleted when the packet
# is final, so a restart resumes what was pending. Lifespans are kept in
# wall-clock seconds (wall(): time.time on both runtimes): the millisecond
# ticks of the node restart from zero with it.
#
# A hop's transfer runs on one of two lanes per neighbour, so an urgent
# packet never waits behind a long one for more than the fragment on the air.

from . import segment as sg
from .arq import Outgoing, Reassembly
from .compress import compress, decompress
from .compat import const, ticks_add, ticks_diff
from .errors import AcommError, DecodeError
from .events import AVAILABLE, DELIVERED, EV_PACKET, EV_PACKET_STATUS, EXPIRED, FAILED, QUEUED, TRANSMITTED, UNAVAILABLE
from .frame import SEGMENT

_REC = const(10)  # record header: origin, final, pid(2), priority, flags, expiry(4)
_PIPELINE = const(3)  # fragments of one transfer in a link queue at a time
_SACK_PRIORITY = const(2)
_RX_TIMEOUT_MS = const(600000)  # a reassembly idle this long is dropped
_MAX_RX = const(8)  # reassemblies at a time
_DONE_MEMORY = const(32)  # delivered (origin, pid) remembered against copies


class MemoryStore:
    # The store's interface without a file (tests, nodes without storage).
    def __init__(self):
        self._d = {}

    def put(self, key, data):
        self._d[key] = bytes(data)

    def delete(self, key):
        self._d.pop(key, None)

    def get(self, key):
        return self._d.get(key)

    def keys(self):
        return list(self._d)


class _Packet:
    __slots__ = ("key", "origin", "final", "pid", "prio", "expiry", "body", "compressed", "medium", "out", "link",
                 "hop", "inflight", "timer", "relayed")


def _wall_default():
    import time

    return int(time.time())


class Transport:
    def __init__(self, node, store=None, routes=None, wall=None, max_packet=65536, compress=True, listener=None):
        self.node = node
        self.store = store if store is not None else MemoryStore()
        self.routes = dict(routes or {})  # final destination name -> next hop name
        self.wall = wall or _wall_default
        self.max_packet = max_packet
        self.compress = compress
        self.listener = listener
        self._out = []  # _Packet, pending
        self._lanes = {}  # (link name, hop id) -> [packet or None, packet or None]
        self._gens = {}  # (link name, hop id, lane) -> generation of its last transfer
        self._reqs = {}  # link request id -> (packet, fragment index, poll flag)
        self._sacks = {}  # link request id -> (link, neighbour id, SACK bytes, tries)
        self._rx = {}  # (link name, src id, lane) -> Reassembly
        self._done = []  # (origin, pid) delivered here lately
        self._pid = 0
        self.stats = {"sent": 0, "delivered": 0, "expired": 0, "failed": 0, "received": 0, "relayed": 0,
                      "fragments": 0, "resent": 0, "sacks": 0, "rx_bad": 0, "rx_dup": 0, "refused": 0}
        node.transport = self
        self._recover()

    # -- the API ---------------------------------------------------------------
    def send(self, now, dst, data, lifespan_s, priority=10, medium=None):
        final = self.node.names.id_of(dst)
        if final is None or final == self.node.node_id:
            raise AcommError("no such destination %r" % (dst,))
        if not 1 <= priority <= 16 or lifespan_s <= 0:
            raise AcommError("priority 1..16 and a positive lifespan, please")
        if len(data) > self.max_packet:
            raise AcommError("%d bytes exceed the %d-byte packet limit" % (len(data), self.max_packet))
        self._pid = (self._pid + 1) & 0xFFFF
        p = self._packet(self.node.node_id, final, self._pid, priority, self.wall() + int(lifespan_s), bytes(data),
                         False, medium)
        self._keep(p)
        self._status(p, QUEUED, "")
        return p.pid

    def _packet(self, origin, final, pid, prio, expiry, body, compressed, medium):
        p = _Packet()
        p.key = (origin << 16) | pid
        p.origin, p.final, p.pid, p.prio, p.expiry = origin, final, pid, prio, expiry
        p.body, p.compressed, p.medium = body, compressed, medium
        p.out = p.link = p.hop = p.timer = None
        p.inflight = 0
        p.relayed = origin != self.node.node_id
        if not compressed and self.compress and len(body) > 16:
            z = compress(body)
            if len(z) < len(body):
                p.body, p.compressed = z, True
        return p

    def _keep(self, p):
        rec = bytes((p.origin, p.final, p.pid >> 8, p.pid & 0xFF, p.prio, 1 if p.compressed else 0)) + \
            (p.expiry & 0xFFFFFFFF).to_bytes(4, "big") + p.body
        self.store.put(p.key, rec)  # may raise StoreFull: the packet is refused
        self._out.append(p)
        self._out.sort(key=lambda q: q.prio)

    def _recover(self):
        for key in self.store.keys():
            rec = self.store.get(key)
            if rec is None or len(rec) < _REC:
                self.store.delete(key)
                continue
            p = self._packet(rec[0], rec[1], (rec[2] << 8) | rec[3], rec[4], int.from_bytes(rec[6:10], "big"),
                             rec[_REC:], bool(rec[5] & 1), None)
            self._out.append(p)
            if p.origin == self.node.node_id and ((p.pid - self._pid) & 0xFFFF) < 0x8000:
                self._pid = p.pid  # never reuse the id of a packet still pending
        self._out.sort(key=lambda q: q.prio)

    def pending(self):
        return [p.pid for p in self._out if not p.relayed]

    # -- events ----------------------------------------------------------------
    def _emit(self, ev):
        if self.listener is not None:
            self.listener(ev)
        else:
            self.node._on_event(ev)

    def _status(self, p, status, reason):
        if not p.relayed:
            self._emit((EV_PACKET_STATUS, p.pid, status, reason))

    def _final(self, p, status, reason=""):
        if p in self._out:
            self._out.remove(p)
        self.store.delete(p.key)
        self._free_lane(p)
        for rid in [r for r in self._reqs if self._reqs[r][0] is p]:
            del self._reqs[rid]
        name = {DELIVERED: "delivered", TRANSMITTED: "delivered", EXPIRED: "expired", FAILED: "failed"}[status]
        self.stats[name] += 1
        self._status(p, status, reason)

    def _free_lane(self, p):
        if p.out is None:
            return
        lanes = self._lanes.get((p.link.name, p.hop))
        if lanes is not None and lanes[p.out.lane] is p:
            lanes[p.out.lane] = None
        p.out = None

    # -- choosing a link and a hop ------------------------------------------------
    def _route(self, p):
        # -> (link, next hop id) or None while nothing suitable is up
        hop_name = self.routes.get(self.node.names.name_of(p.final))
        hop = p.final if hop_name is None else self.node.names.id_of(hop_name)
        best = None
        for name in self.node.links:
            if p.medium is not None and p.medium != name:
                continue
            link = self.node.links[name]
            st = link.discovery.state(hop)
            if st == UNAVAILABLE:
                continue
            try:
                link._resolve(self.node.names.name_of(hop))
            except AcommError:
                continue
            c = link.caps
            # reachability first (heard from beats unknown), then speed
            score = (0 if st == AVAILABLE else 1, -(c.bitrate or 0))
            if best is None or score < best[0]:
                best = (score, link)
        return None if best is None else (best[1], hop)

    def _start(self, p, now):
        r = self._route(p)
        if r is None:
            return False
        link, hop = r
        lanes = self._lanes.setdefault((link.name, hop), [None, None])
        lane = 0 if lanes[0] is None else (1 if lanes[1] is None else None)
        if lane is None:
            return False
        gk = (link.name, hop, lane)
        gen = 1 - self._gens.get(gk, 1)
        self._gens[gk] = gen
        left = p.expiry - self.wall()
        relay = None
        if p.relayed or p.final != hop:
            relay = (p.origin, p.final, p.prio, left)
        blob = sg.packet_header(p.pid, len(p.body), p.compressed, relay) + p.body
        fragsize = link.mtu_for(hop) - sg.FRAG_HEADER
        try:
            p.out = Outgoing(blob, fragsize, lane, gen, p.pid)
        except ValueError as e:
            self._final(p, FAILED, str(e))
            return False
        lanes[lane] = p
        p.link, p.hop = link, hop
        p.out.new_round()
        return True

    # -- sending -------------------------------------------------------------------
    def poll(self, now):
        wall = self.wall()
        for p in list(self._out):
            if wall >= p.expiry:
                self._final(p, EXPIRED, "lifespan over")
            elif p.out is None:
                self._start(p, now)
        for p in list(self._out):
            if p.out is not None:
                self._pump(p, now)
        for k in [k for k in self._rx if ticks_diff(now, self._rx[k].touched) > _RX_TIMEOUT_MS]:
            del self._rx[k]

    def _pump(self, p, now):
        o = p.out
        if p.timer is not None:
            if ticks_diff(now, p.timer) < 0:
                return
            # no SACK came: ask again
            p.timer = None
            self.stats["resent"] += 1
            self._request(p, now, o.repoll())
            return
        while p.inflight < _PIPELINE:
            if o.sent_in_round == len(o.round) - 1 and p.inflight:
                # the poll goes last: the link queue may reorder, and a
                # fragment after the poll would be on the air (deaf, half-
                # duplex) when the SACK comes back
                return
            nf = o.next_fragment()
            if nf is None:
                return
            self._request(p, now, nf)

    def _request(self, p, now, nf):
        index, data = nf
        rid = self.node.next_req_id()
        life = p.expiry - self.wall()
        if life < 1:
            life = 1
        if p.link.request(now, rid, self.node.names.name_of(p.hop), data, life, p.prio, False, None, SEGMENT):
            self._reqs[rid] = (p, index, data[0] & 0x40)
            p.inflight += 1
            self.stats["fragments"] += 1

    def on_link_status(self, now, rid, status, reason):
        # -> True when the request was the transport's
        sk = self._sacks.get(rid)
        if sk is not None:
            if status >= TRANSMITTED:
                del self._sacks[rid]
                # a modem that refused it (busy acknowledging the fragment
                # it just received) gets it again, twice at most
                if status == FAILED and sk[3] < 2:
                    self._sack(now, sk[0], sk[1], sk[2], sk[3] + 1)
            return True
        r = self._reqs.get(rid)
        if r is None:
            return False
        if status < TRANSMITTED:
            return True
        del self._reqs[rid]
        p, index, poll = r
        p.inflight -= 1
        if p.out is not None and poll:
            if status == TRANSMITTED:
                p.timer = ticks_add(now, p.link.ack_timeout_ms)
            else:
                p.timer = now  # the poll never went: ask again at once
        return True

    def _on_sack(self, now, link, src, s):
        lanes = self._lanes.get((link.name, src))
        p = None if lanes is None else lanes[s.lane]
        if p is None or p.out is None or p.out.gen != s.gen:
            self.stats["rx_bad"] += 1
            return
        if not p.out.on_sack(s):
            # a completion of an older packet on this lane: the receiver
            # kept a stale generation; start over on the other one
            self._free_lane(p)
            p.timer = None
            return
        p.timer = None
        o = p.out
        if o.refused is not None:
            self.stats["refused"] += 1
            self._final(p, FAILED, "refused: %s" % sg.REFUSE_NAMES.get(o.refused, o.refused))
        elif o.complete:
            self._final(p, TRANSMITTED if p.final != src else DELIVERED, "")
        else:
            o.new_round()

    # -- receiving -------------------------------------------------------------------
    def on_segment(self, now, link, src, dst, payload):
        try:
            s = sg.decode(payload)
        except DecodeError:
            self.stats["rx_bad"] += 1
            return
        if s.is_sack:
            self.stats["sacks"] += 1
            self._on_sack(now, link, src, s)
            return
        key = (link.name, src, s.lane)
        r = self._rx.get(key)
        if r is None or r.gen != s.gen:
            if len(self._rx) >= _MAX_RX:
                self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, sg.REFUSE_FULL))
                return
            r = self._rx[key] = Reassembly(s.gen, self.max_packet + 16, now)
        try:
            r.add(s.index, s.payload, now)
        except DecodeError:
            self.stats["rx_bad"] += 1
            del self._rx[key]
            self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, sg.REFUSE_TOO_BIG))
            return
        if r.done_pid is None and r.complete():
            self._arrived(now, link, src, r)
        if s.poll or (r.done_pid is not None and s.index == r.count - 1):
            if r.done_pid is not None:
                self._sack(now, link, src, sg.sack_complete(s.lane, s.gen, r.count, r.done_pid))
            else:
                b, bm = r.bitmap()
                self._sack(now, link, src, sg.sack(s.lane, s.gen, b, bm))

    def _arrived(self, now, link, src, r):
        try:
            blob = r.blob()
            h = r.header
            body = blob[h.size :]
            if h.relay is not None:
                origin, final, prio, life = h.relay
            else:
                origin, final, prio, life = src, self.node.node_id, 8, 3600
            data = body
            if h.compressed:
                data = decompress(body, self.max_packet)
        except DecodeError:
            self.stats["rx_bad"] += 1
            r.frags.clear()
            r.size = 0
            r.count = None
            return
        r.done_pid = h.pid
        r.frags = {}  # the memory goes; the lane remembers only the completion
        if final != self.node.node_id:
            p = self._packet(origin, final, h.pid, prio, self.wall() + life, body, h.compressed, None)
            self.stats["relayed"] += 1
            self._keep(p)
            return
        k = (origin, h.pid)
        if k in self._done:
            self.stats["rx_dup"] += 1
            return
        self._done.append(k)
        if len(self._done) > _DONE_MEMORY:
            self._done.pop(0)
        self.stats["received"] += 1
        names = self.node.names
        self._emit((EV_PACKET, names.name_of(origin), names.name_of(final), data))

    def _sack(self, now, link, src, data, tries=0):
        rid = self.node.next_req_id()
        if link.request(now, rid, self.node.names.name_of(src), data, 60, _SACK_PRIORITY, False, None, SEGMENT):
            self._sacks[rid] = (link, src, data, tries)
