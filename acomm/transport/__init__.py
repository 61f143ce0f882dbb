# The high-level transport (seed 000 section V): packets of any size up to
# max_packet, kept in a store until delivered or expired, compressed when
# that helps, fragmented to the MTU of the link chosen for them, sent with
# selective-repeat ARQ (acomm.transport.arq) and relayed hop by hop on static routes.
#
#   t = Transport.of(node, store=None, routes={"buoy": "auv"}, wall=time.time)
#   pid = t.send(now, "buoy", data, lifespan_s, priority, medium=None)
#   node.step(now)                        # polls the transport too
#
# Events to the node's listener: (EV_PACKET_STATUS, pid, status, reason)
# with queued, transmitted (a relay took custody), delivered (the
# destination has it all), expired, failed; and (EV_PACKET, src, dst, data)
# for every packet that arrived whole and decoded. Every packet send()
# accepted gets exactly one of the final statuses; one it refuses (the
# store's overflow rule, acomm.transport.packetstore) gets `failed` at once.
#
# medium: None or "any" (the best link, acomm.transport.route), a link's name or kind
# ("acoustic", "satellite"), or "all": a copy on every link, the first to
# arrive counts (IMC's TransmissionRequest comm_mean ALL); the receiver
# delivers it once.
#
# The store keeps each packet until it is final, so a restart resumes what
# was pending. Lifespans are kept in wall-clock seconds (wall(): time.time
# on both runtimes): the millisecond ticks of the node restart from zero.
#
# A hop's transfer runs on one of two lanes per neighbour, so an urgent
# packet never waits behind a long one for more than the fragment on the
# air. Three polls in a row without an answer mark the link as stalled
# towards that neighbour; when another link is then better, the transfer
# starts over there (fail-over: acoustic to satellite).
#
# Receiving: fragments in, reassembly per (link, neighbour, lane), selective
# acknowledgements out, whole packets up (or into the store, at a relay).
# Bounds: at most _MAX_RX reassemblies at a time (a sender beyond that is
# refused "receiver full" and tries again later), each of at most
# max_packet bytes, dropped after _RX_TIMEOUT_MS without a fragment; and
# DONE_MEMORY delivered or relayed (origin, packet id) pairs, each until
# its lifespan is over, so a packet sent again (its SACK was lost, the
# sender restarted before it came, a relay's store kept a copy through an
# outage) is acknowledged and not delivered twice. They are kept in the
# store too (acomm.transport.packetstore), so a receiver that restarts
# still knows them (docs/transport.md, "Exactly once").
#
# The transport is given what it uses: the node's id, name table and links
# (a live dict: links added later are used too), an id allocator for link
# requests and a callback for its events. Transport.of(node) takes them
# from a Node and attaches the transport to it; the node then hands it the
# links' SEGMENT frames and the statuses of its requests, and polls it.

from . import segment as sg
from .arq import Outgoing, Reassembly
from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError, DecodeError, StoreFull
from .packetstore import PacketStore, key_of
from .route import MEDIUM_ALL, Router

# these modules' codes, as private constants (inlined: no slot in this
# module's dict on a board); tests/cpython/test_const_copies.py checks them
_SEGMENT = const(5)  # acomm.frame
_K_SACK = const(8)  # acomm.transport.segment: a segment header's SACK bit
_DONE_MEMORY = const(32)  # acomm.transport.packetstore
_MAX_LIFESPAN_MS = const(0x10000000)  # acomm.link.txqueue: the longest a link queues a request

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_DELIVERED = const(5)
_EV_PACKET_STATUS = const(26)
_EXPIRED = const(6)
_FAILED = const(8)
_QUEUED = const(1)
_TRANSMITTED = const(4)
_WAITING = const(3)
_CAP_DELIVERY = const(32)  # acomm.drivers.caps

_EV_PACKET = const(27)
_EV_REFUSED = const(28)
_EV_RELAY_STATUS = const(30)
_SACK_PRIORITY = const(2)
_SACK_LIFESPAN_S = const(60)  # a SACK older than this is stale: the sender polls again
_RX_TIMEOUT_MS = const(600000)
_MAX_RX = const(8)
_PIPELINE = const(3)  # fragments of one transfer in a link queue at a time
_STALL_POLLS = const(3)  # unanswered polls in a row before trying another link
_FULL_WAIT_MS = const(60000)  # a relay that was full is asked again after this
# what a fragment's link request is (Transport._reqs)
_F_POLL = const(1)  # it carries the round's poll
_F_REPORTED = const(2)  # the modem reports its delivery (acomm.transport.delivery)
_F_LEFT = const(4)  # reported, and it has left the modem: its report is to come
# what a report means for the transfer (acomm.transport.delivery)
_REPORTS_ACK = const(2)  # Outgoing.reports: the reports are the acknowledgement
_REPORT_COMPLETE = const(1)
_REPORT_NEW_ROUND = const(2)
_REPORT_REPOLL = const(3)

class _Packet:
    # A packet this node sends or relays. Made with origin, final, pid, prio,
    # expiry and size (body, medium, compressed and relayed when they are not
    # the defaults); its transfer's state starts at the class's defaults
    # below. On MicroPython an instance's attribute table grows by one
    # reallocation at a time (8 for 22 names set at once, the last of 184 B):
    # the allocations a relaying buoy, its heap fragmented, failed first.
    # With the defaults a packet waiting in the store sets 8 (chunks too):
    # 64 B of table, where 12 took 96, on every packet a buoy holds while
    # its uplink is down.
    out = link = hop = timer = polled = wait = group = body = medium = key = None  # key: the store's, origins from 256
    inflight = polling = misses = chunks = 0
    compressed = relayed = False


# every field, for a copy of a packet (MEDIUM_ALL)
_FIELDS = ("origin", "final", "pid", "prio", "expiry", "body", "compressed", "medium", "out", "link", "hop",
           "inflight", "polling", "polled", "timer", "relayed", "misses", "wait", "group", "chunks", "size", "key")


def _memory(t, origin, pid):
    # -> (transport t's entries for origin's packets done there, an entry's
    # size, the start of pid's entry): 5 bytes each, origins of 256 or more 7
    # (the origin in 3). A function, not a method: one entry less in the class dict of every board
    if origin < 255:
        return t._done, 5, bytes((origin, pid >> 8, pid & 0xFF))
    if t._done_wide is None:
        t._done_wide = bytearray()
    return t._done_wide, 7, bytes((255, origin >> 8, origin & 0xFF, pid >> 8, pid & 0xFF))  # as acomm.frame.addr_bytes


def _wall_default():
    import time

    return int(time.time())


def _restamp(data, life):
    # Fragment 0 (its index byte, then the packet header) of a packet with relay fields (flag
    # R) with their life left, the header's last 2 bytes, set to life: stamped again each time
    # fragment 0 is handed to the link, so that the relay, counting from its arrival, misses
    # only this copy's wait and flight, not the rounds lost before it. Out of Transport._request
    # on purpose: that function's frame is already too big for MicroPython's stack and is
    # allocated on the heap at each call, and more locals and a try block there raised the
    # routing buoy's heap_min by 512 bytes.
    try:
        k = 1 + sg.decode_packet_header(data[1:]).size
    except DecodeError:
        return data  # a header cut short by a tiny fragment: the receiver refuses it anyway
    if life > 0xFFFF:
        life = 0xFFFF
    return data[: k - 2] + bytes((life >> 8, life & 0xFF)) + data[k:]


class Transport:
    _done_wide = None  # _memory(): made by the first origin of 256 or more
    def __init__(self, node_id, names, links, next_id, emit, store=None, routes=None, wall=None, max_packet=65536,
                 compress=True, urgent=4, routing=None):
        """node_id: this node's id; names: its acomm.link.names.NameTable; links: name -> Link (read
        live); next_id(): a fresh link request id; emit(ev): where the transport's events go. store:
        a packetstore backend (a MemoryStore when None); wall(): the wall clock in seconds (lifespans).
        routing: None (static routes only), True or a dict of acomm.transport.routing.Routing's
        options: routes are then learned (static ones still win)."""
        self.node_id = node_id
        self.names = names
        self._next_id = next_id
        self._emit = emit
        self.guard = None  # acomm.link.guard.Guard and acomm.frame.auth.Auth with a key: Node.set_auth sets them
        self.auth = None
        if store is None:
            # imported here: a board with a file store never loads it
            from .memorystore import MemoryStore

            store = MemoryStore()
        self.packets = PacketStore(store, urgent)
        self.router = Router(names, links, routes, urgent)
        if routing is not None and routing is not False:  # True, or a dict of options ({} too)
            # imported here: a board that does not route never loads it
            from .routing import Routing

            self.router.routing = Routing(node_id, names, links, next_id, **(routing if routing is not True else {}))
        self.wall = wall or _wall_default
        self.max_packet = max_packet
        self.compress = compress
        self._out = []  # _Packet, pending, most urgent first
        self._lanes = {}  # (link name, hop id) -> [packet or None, packet or None]
        self._gens = {}  # (link name, hop id, lane) -> generation of its last transfer
        self._reqs = {}  # link request id -> (packet or None once abandoned, fragment index, poll flag)
        self._rtt = {}  # (link name, hop id) -> [smoothed poll-to-SACK time, its mean deviation], ms
        self.stats = {"sent": 0, "delivered": 0, "expired": 0, "failed": 0, "received": 0, "relayed": 0,
                      "fragments": 0, "resent": 0, "sacks": 0, "rx_bad": 0, "rx_dup": 0, "refused": 0, "refused_unauthed": 0,
                      "store_full": 0, "failovers": 0, "done_forgotten": 0}
        self._rx = {}  # (link name, src id, lane) -> Reassembly
        # (origin, pid) pairs delivered or relayed here, with the minute
        # (16 bits, wrapping) until which a copy may still come: 5 bytes each
        # as the store keeps them (32 tuples in a list took 640 B of heap)
        self._done = bytearray()
        self._sacks = {}  # link request id -> (link, neighbour id, SACK bytes, tries)
        self._quiet = False  # the segment at hand is unsealed, strict mode: no SACK for it
        self._recover()

    @classmethod
    def of(cls, node, **options):
        """A Transport over the node's links and names, its events to the node's listeners, attached
        to the node (acomm.node.Node.attach) -> the Transport. options: as for Transport()."""
        t = cls(node.node_id, node.names, node.links, node.next_req_id, node.emit, **options)
        node.attach(t)
        if node.wallclock is not None:
            node.wallclock.on_step(t.clock_stepped)
        return t

    def clock_stepped(self, delta_s):
        """The wall clock stepped forward by delta_s (acomm.wallclock: a first fix, a port clock set
        forward): every packet held keeps the time it had left, so none expires early for it."""
        # one whose expiry came from before this run (the store) gets the step too: it then lives
        # longer than its lifespan by what the clock was behind, never shorter
        for p in self._out:
            p.expiry += delta_s

    @property
    def store(self):
        return self.packets.store

    @property
    def routes(self):
        return self.router.routes

    # -- the API ---------------------------------------------------------------
    def send(self, now, dst, data, lifespan_s, priority=10, medium=None):
        """Stores a packet for dst -> its id; one final EV_PACKET_STATUS follows. AcommError for wrong arguments."""
        final = self.names.id_of(dst)
        if final is None or final == self.node_id:
            raise AcommError("no such destination %r" % (dst,))
        if not 1 <= priority <= 16 or lifespan_s <= 0:
            raise AcommError("priority 1..16 and a positive lifespan, please")
        if len(data) > self.max_packet:
            raise AcommError("%d bytes exceed the %d-byte packet limit" % (len(data), self.max_packet))
        if medium is not None and not self.router.links(medium):
            raise AcommError("no link for medium %r" % (medium,))
        p = self._packet(self.node_id, final, 0, priority, self.wall() + int(lifespan_s), bytes(data), False,
                         medium)
        try:
            p.pid = self.packets.next_pid()
        except AcommError:  # StoreFull, or another StoreError (no name of its own here: the buoy's heap)
            # refused below; the id is not reserved, but nothing went out with it
            p.pid = self.packets.pid = (self.packets.pid + 1) & 0xFFFF
        self.stats["sent"] += 1
        why = self._keep(p)
        if why is not None:
            self.stats["failed"] += 1
            self._emit((_EV_PACKET_STATUS, p.pid, _FAILED, why))
            return p.pid
        self._status(p, _QUEUED, "")
        return p.pid

    def pending(self):
        return [p.pid for p in self._out if not p.relayed and (p.group is None or p.group[0] is p)]

    def _packet(self, origin, final, pid, prio, expiry, body, compressed, medium):
        p = _Packet()
        p.origin, p.final, p.pid, p.prio, p.expiry = origin, final, pid, prio, expiry
        # set only when not the class's default: a packet back from the
        # store (no body in RAM, no medium) keeps 8 attributes, 64 B of table
        if body is not None:
            p.body = body
        if medium is not None:
            p.medium = medium
        if compressed:
            p.compressed = True
        if origin != self.node_id:
            p.relayed = True
        # only the origin compresses: a relay forwards the body as the
        # origin chose it (a second try would not shrink it and costs a
        # relay its compression tables, 2.5 KiB, on every packet)
        if body is not None and not compressed and not p.relayed and self.compress and len(body) > 16:
            from ..codec.compress import compress  # loaded by the first packet of its own

            z = compress(body)
            if len(z) < len(body):
                p.body, p.compressed = z, True
        p.size = 0 if p.body is None else len(p.body)
        return p

    def _keep(self, p):
        # -> None when kept, else why not: "store full" (the overflow rule, or no room on the
        # file system), or what else the store said (an I/O error, a file system gone read-only)
        if not self.packets.room(p):
            self.stats["store_full"] += 1
            return "store full"
        try:
            self.packets.put(p)
        except StoreFull:
            self.stats["store_full"] += 1
            return "store full"
        except AcommError as e:  # another StoreError: an I/O error, a file system gone read-only
            self.stats["store_full"] += 1
            return str(e)
        # from now on the body is in the store only, read back while the
        # packet is sent: a buoy holding packets while its uplink is down
        # keeps their headers in RAM, not their bodies
        p.body = None
        self._queue(p)
        return None

    def _queue(self, p):
        if p.medium != MEDIUM_ALL:
            self._out.append(p)
        else:
            # one copy per link, sharing the stored record and the id
            group = []
            for link in self.router.links(MEDIUM_ALL):
                c = _Packet()
                for k in _FIELDS:
                    setattr(c, k, getattr(p, k))
                c.medium, c.group = link.name, group
                group.append(c)
                self._out.append(c)
        self._out.sort(key=lambda q: q.prio)

    def _recover(self):
        # packets back from the store mean a life before this one with
        # transfers cut short: their lanes are probed first (_start)
        self._resumed = False
        for s in self.packets.recover():
            self._resumed = True
            p = self._packet(s.origin, s.final, s.pid, s.prio, s.expiry, None, s.compressed, s.medium)
            p.chunks, p.size = s.chunks, s.size
            if s.origin > 254:
                p.key = s.key
            self._queue(p)
        if self.packets.done_wide:
            self._done_wide = bytearray(self.packets.done_wide[-7 * _DONE_MEMORY :])
        d = self._done = bytearray(self.packets.done[-5 * _DONE_MEMORY :])
        for i in range(0, len(d), 5):
            if d[i + 3] == 0xFF and d[i + 4] == 0xFF:
                # an older store's pair, whose lifespan nobody wrote down: an hour from now
                u = (self.wall() // 60 + 60) & 0xFFFF
                d[i + 3], d[i + 4] = u >> 8, u & 0xFF

    # -- statuses --------------------------------------------------------------------
    def _status(self, p, status, reason):
        if not p.relayed:
            self._emit((_EV_PACKET_STATUS, p.pid, status, reason))
        elif status == _EXPIRED or status == _FAILED:
            # the origin heard `transmitted` when this node took custody: only here is it known
            self._emit((_EV_RELAY_STATUS, self.names.name_of(p.origin), p.pid, status, reason))

    def _final(self, now, p, status, reason=""):
        group = p.group
        if group is not None:
            if status == _FAILED and len(group) > 1:
                group.remove(p)  # the other copies may still make it
                self._drop(now, p)
                return
            for c in group:
                self._drop(now, c)
        else:
            self._drop(now, p)
        self.packets.delete(p)
        name = {_DELIVERED: "delivered", _TRANSMITTED: "delivered", _EXPIRED: "expired", _FAILED: "failed"}[status]
        self.stats[name] += 1
        self._status(p, status, reason)

    def _drop(self, now, p):
        if p in self._out:
            self._out.remove(p)
        self._abandon(now, p)

    def _abandon(self, now, p):
        # stop p's transfer: its lane, its fragments still in a link queue
        if p.out is not None:
            lanes = self._lanes.get((p.link.name, p.hop))
            if lanes is not None and lanes[p.out.lane] is p:
                lanes[p.out.lane] = None
            p.out = None
        p.timer = None
        p.inflight = p.polling = p.misses = 0
        for rid in [r for r in self._reqs if self._reqs[r][0] is p]:
            self._reqs[rid] = (None, 0, 0)  # its final status still comes: swallow it
            p.link.cancel(now, rid, "transfer abandoned")

    # -- starting a transfer ------------------------------------------------------------
    def _start(self, p, now):
        if p.wait is not None:
            if ticks_diff(now, p.wait) < 0:
                return
            p.wait = None
        r = self.router.choose(p.final, p.size, p.prio, p.medium, now)
        if r is None:
            return
        link, hop = r
        lanes = self._lanes.setdefault((link.name, hop), [None, None])
        lane = 0 if lanes[0] is None else (1 if lanes[1] is None else None)
        if lane is None:
            return
        gk = (link.name, hop, lane)
        # the first transfer on this lane since a start that resumed
        # packets: the receiver may hold half of one (acomm.transport.arq probe())
        first = self._resumed and gk not in self._gens
        gen = 1 - self._gens.get(gk, 1)
        self._gens[gk] = gen
        relay = None
        if p.relayed or p.final != hop:
            relay = (p.origin, p.final, p.prio, p.expiry - self.wall())
        # a queued packet's body is in the store (_keep, _recover): the
        # fragments are read back as they go
        head = sg.packet_header(p.pid, p.size, p.compressed, relay)
        blob = self.packets.blob(key_of(p), head)
        if blob is None or len(blob) != len(head) + p.size:
            self._final(now, p, _FAILED, "lost from the store")
            return
        # a modem that reports delivery by itself acknowledges fragments
        # (acomm.transport.delivery: loaded only there, never on the buoy)
        try:
            if link.modem_acks and link.driver.caps.flags & _CAP_DELIVERY:
                from .delivery import ReportedOutgoing

                p.out = ReportedOutgoing(blob, link.mtu_for(hop) - sg.FRAG_HEADER, lane, gen, p.pid, hop == p.final)
            else:
                p.out = Outgoing(blob, link.mtu_for(hop) - sg.FRAG_HEADER, lane, gen, p.pid)
        except ValueError as e:
            self._final(now, p, _FAILED, str(e))
            return
        lanes[lane] = p
        p.link, p.hop = link, hop
        if first:
            p.out.probe()
        else:
            p.out.new_round()

    # -- sending -------------------------------------------------------------------
    def poll(self, now):
        rt = self.router.routing
        if rt is not None:
            rt.poll(now)  # route control first: a search's request before the packets that wait for it
        wall = self.wall()
        for p in list(self._out):
            if p not in self._out:
                continue  # a copy that went with its group
            if wall >= p.expiry:
                self._final(now, p, _EXPIRED, "lifespan over")
            elif p.out is None:
                self._start(p, now)
        # a link with a poll out waits for the SACK: a half-duplex modem
        # that sends another transfer's fragment meanwhile is deaf to it
        held = []
        for p in self._out:
            if p.out is not None and (p.polling or p.timer is not None) and p.link not in held:
                held.append(p.link)
        for p in list(self._out):
            if p.out is not None:
                self._pump(p, now, p.link in held)
                # one poll out per link: a second lane's poll right behind
                # it would be on the air when the first one's SACK comes
                if p.out is not None and p.polling and p.link not in held:
                    held.append(p.link)
        self._rx_poll(now)

    def _pump(self, p, now, held):
        o = p.out
        if p.timer is not None:
            if ticks_diff(now, p.timer) < 0:
                return
            # no SACK came: ask again, or elsewhere when the link has stalled
            p.timer = None
            p.misses += 1
            rt = self.router.routing
            if rt is not None:
                rt.attempt(now, p.link, p.hop, False)
            if p.misses >= _STALL_POLLS:
                p.misses = 0
                self.router.stall(p.link, p.hop, now)
                if rt is not None:
                    # the stall's window: the unanswered polls' waits
                    rt.hop_failed(now, p.link, p.hop, _STALL_POLLS * self._sack_timeout(p))
                r = self.router.choose(p.final, p.size, p.prio, p.medium, now)
                # elsewhere: another link, or (learning routes) another hop or a search to wait for
                if (r is not None and (r[0] is not p.link or r[1] != p.hop)) or (r is None and rt is not None):
                    self.stats["failovers"] += 1
                    self._abandon(now, p)
                    return
            self.stats["resent"] += 1
            self._request(p, now, o.repoll())
            return
        while p.inflight < _PIPELINE and not held:
            if o.sent_in_round == len(o.round) - 1 and p.inflight and o.reports != _REPORTS_ACK:
                # the poll goes last: the link queue may reorder, and a
                # fragment after the poll would be on the air (deaf, half-
                # duplex) when the SACK comes back
                return
            nf = o.next_fragment()
            if nf is None:
                return
            self._request(p, now, nf)
            if p.out is not o:
                return  # it failed (a record of its body was lost)

    def _request(self, p, now, nf):
        index, head, data = nf
        if data is None:
            self._final(now, p, _FAILED, "lost from the store")
            return
        rid = self._next_id()
        life = p.expiry - self.wall()
        if life < 1:
            life = 1
        elif life > _MAX_LIFESPAN_MS // 1000:
            # a fragment waits in the link's queue 3 days at most; the packet
            # keeps its own expiry here (a lifespan of weeks, or an expiry
            # from another epoch, would have the link refuse every fragment)
            life = _MAX_LIFESPAN_MS // 1000
        if not index and len(data) > 1 and data[1] & 0x80:
            data = _restamp(data, life)
        poll = sg.is_poll(head)
        # confirmed by the modem's own delivery report? (acomm.transport.delivery)
        rep = p.out.reports and p.out.report_wanted(len(data), poll)
        # known before the request: its `queued` (or a refusal) comes from inside request(), and is ours
        self._reqs[rid] = (None, 0, 0)
        if p.link.request(now, rid, self.names.name_of(p.hop), data, life, p.prio, ack=rep, retries=0,
                          ftype=_SEGMENT, seq=head):
            self._reqs[rid] = (p, index, (_F_POLL if poll else 0) | (_F_REPORTED if rep else 0))
            p.inflight += 1
            if poll:
                p.polling += 1
            self.stats["fragments"] += 1

    def on_link_status(self, now, rid, status, reason):
        # -> True when the request was the transport's
        if self._sack_status(now, rid, status):
            return True
        rt = self.router.routing
        if rt is not None and rt.on_link_status(now, rid, status):
            return True
        r = self._reqs.get(rid)
        if r is None:
            return False
        p, index, f = r
        if status < _TRANSMITTED:
            if status == _WAITING and f & _F_REPORTED and not f & _F_LEFT and p is not None:
                # a reported fragment left the modem, its report is to come:
                # the modem takes the next one meanwhile (acomm.transport.delivery)
                p.inflight -= 1
                self._reqs[rid] = (p, index, f | _F_LEFT)
            return True
        del self._reqs[rid]
        if p is None:
            return True
        if not f & _F_LEFT:
            p.inflight -= 1
        o = p.out
        if f & _F_REPORTED:
            if o is not None:
                # the modem's report (acomm.transport.delivery): are others to come?
                more = False
                for q in self._reqs.values():
                    if q[0] is p and q[2] & _F_REPORTED:
                        more = True
                        break
                a = o.reported(index, status == _DELIVERED, more)
                if a == _REPORT_COMPLETE:
                    self._final(now, p, _DELIVERED, "")
                elif a == _REPORT_NEW_ROUND:
                    o.new_round()
                elif a == _REPORT_REPOLL:
                    p.timer = now
            return True
        if f & _F_POLL:
            p.polling -= 1
            if o is not None:
                if status == _TRANSMITTED:
                    p.polled = now
                    p.timer = ticks_add(now, self._sack_timeout(p))
                else:
                    p.timer = now  # the poll never went: ask again at once
        return True

    # -- how long to wait for a SACK -----------------------------------------------
    # The link's ack timeout is sized for a full frame there and an ack
    # back, and a poll is answered by a short SACK: after a lost poll or SACK
    # the sender would sit idle for most of it. So, as TCP does, the time
    # from a poll's end to its SACK is measured per link and neighbour
    # (only for rounds without a repoll, whose SACK could answer either),
    # and the wait is the smoothed time plus four deviations, at least
    # twice the smoothed time and 1 s more (a receiver's modem may be busy
    # a moment), at most twice the link's ack timeout. Each poll left
    # unanswered doubles it, to that cap (RFC 6298's backoff): only SACKs
    # that came in time are sampled, so the smoothed time learns the quick
    # ones, and a receiver whose SACK waits out a random MAC backoff
    # answers later; polling again at the same short wait puts the repoll
    # on the air just as that SACK arrives.
    def _sack_timeout(self, p):
        e = self._rtt.get((p.link.name, p.hop))
        cap = 2 * p.link.ack_timeout_ms
        if e is None:
            return p.link.ack_timeout_ms
        t = (e[0] + max(4 * e[1], e[0], 1000)) << p.misses
        return cap if t > cap else t

    def _rtt_sample(self, p, ms):
        k = (p.link.name, p.hop)
        e = self._rtt.get(k)
        if e is None:
            self._rtt[k] = [ms, ms // 2]
        else:
            err = ms - e[0]
            e[0] += err // 8
            e[1] += ((err if err > 0 else -err) - e[1]) // 4

    def _on_sack(self, now, link, src, s):
        lanes = self._lanes.get((link.name, src))
        p = None if lanes is None else lanes[s.lane]
        if p is None or p.out is None or p.out.gen != s.gen:
            self.stats["rx_bad"] += 1
            return
        if not p.out.on_sack(s):
            # a completion of an older packet on this lane: the receiver
            # kept a stale generation; start over on the other one
            self._abandon(now, p)
            return
        if p.polled is not None and p.misses == 0:
            self._rtt_sample(p, ticks_diff(now, p.polled))
        if self.router.routing is not None:
            self.router.routing.attempt(now, link, src, True)
        p.timer = p.polled = None
        p.misses = 0
        # the answer can come before the link reports the poll sent (a
        # short poll and SACK on a link with slow statuses): that poll is
        # answered, so its status must neither hold the link nor start a
        # wait for a SACK that has already come
        for rid in self._reqs:
            q = self._reqs[rid]
            if q[0] is p and q[2] & _F_POLL:
                self._reqs[rid] = (p, q[1], q[2] & ~_F_POLL)
                p.polling -= 1
        o = p.out
        if o.refused is not None:
            self.stats["refused"] += 1
            if o.refused == sg.REFUSE_FULL:
                # the relay's store is full: it never drops what it took,
                # so room comes back as those packets leave; ask later
                self._abandon(now, p)
                p.wait = ticks_add(now, _FULL_WAIT_MS)
            else:
                self._final(now, p, _FAILED, "refused: %s" % sg.refuse_name(o.refused))
        elif o.complete:
            self._final(now, p, _TRANSMITTED if p.final != src else _DELIVERED, "")
        else:
            o.new_round()

    # -- receiving: fragments in, reassembly per (link, neighbour, lane), SACKs out,
    # whole packets up (or into the store, at a relay) ----------------------------
    def _rx_poll(self, now):
        for k in [k for k in self._rx if ticks_diff(now, self._rx[k].touched) > _RX_TIMEOUT_MS]:
            del self._rx[k]

    def on_control(self, now, link, src, payload, authed=False):
        """A CONTROL frame's payload from neighbour src on link (route control and floods; dropped
        without routing). A flood new here goes up as (EV_PACKET, origin, "*", data[, authed])."""
        rt = self.router.routing
        if rt is None:
            return
        for origin, data in rt.heard(now, link, src, payload):
            g = self.guard
            if g is not None and not g.admits(data, authed, self.auth):
                self.stats["refused_unauthed"] += 1
                self._emit((_EV_REFUSED, link, self.names.name_of(origin), g.REFUSED))
                continue
            ev = (_EV_PACKET, self.names.name_of(origin), "*", data)
            self._emit(ev if g is None else ev + (authed,))

    def flood(self, now, data, hops_limit=None):
        """Sends data (1..18 bytes, acomm.transport.flood) to every node within hops_limit hops, each
        taking it once as (EV_PACKET, origin, "*", data). Needs routing on; AcommError otherwise, or
        for data that does not fit. No status follows: a flood is not acknowledged."""
        rt = self.router.routing
        if rt is None:
            raise AcommError("flooding needs the transport made with routing on")
        return rt.flood(now, data, hops_limit)

    def on_segment(self, now, link, src, dst, head, payload, authed=False):
        if dst is not None and dst != self.node_id:
            # between two other nodes, heard on a link that routes (acomm.link): only a first
            # fragment's packet header matters here, to offer its origin a shorter way
            rt = self.router.routing
            g = self.guard
            if (rt is not None and not head & _K_SACK and len(payload) > 4 and payload[0] == 0
                    and (authed or g is None or not g.strict)):
                try:
                    h = sg.decode_packet_header(payload[1:])
                except DecodeError:
                    return
                if h.relay is not None:
                    rt.overheard(now, link, src, dst, h.relay[0], h.relay[1])
            return
        try:
            s = sg.decode(head, payload)
        except DecodeError:
            self.stats["rx_bad"] += 1
            return
        key = (link.name, src, s.lane)
        g = self.guard
        # strict mode (acomm.link.guard): 0 refused, 2 unsealed (taken, never answered)
        v = 1 if g is None or not g.strict else g.admits_segment(self._rx, key, s, authed)
        if not v:
            return
        self._quiet = v == 2
        if s.is_sack:
            self.stats["sacks"] += 1
            self._on_sack(now, link, src, s)
            return
        r = self._rx.get(key)
        if not s.payload:
            self._answer_poll(now, link, src, s, r)
            return
        if r is None or r.gen != s.gen:
            if len(self._rx) >= _MAX_RX:
                self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, sg.REFUSE_FULL))
                return
            r = self._rx[key] = Reassembly(s.gen, self.max_packet + 16, now)
        index = r.index_of(s.index)
        if r.refused is not None:
            if index != 0:
                if s.poll:
                    self._answer_poll(now, link, src, s, r)
                return  # the rest of a refused transfer: dropped
            # a fragment 0 starts the packet over: judged afresh (and a
            # forged refusal cannot block the real sender's lane)
            r = self._rx[key] = Reassembly(s.gen, self.max_packet + 16, now)
        if not authed:
            r.unauthed = True  # the packet is as trusted as its weakest fragment
        try:
            first = r.header is None
            r.add(index, s.payload, now)
        except DecodeError:
            self.stats["rx_bad"] += 1
            return self._refuse(now, link, src, s, key, sg.REFUSE_TOO_BIG)
        if first and r.header is not None and not self._can_take(r.header):
            # a relay without room says so before the rest is sent
            return self._refuse(now, link, src, s, key, sg.REFUSE_FULL)
        if r.done_pid is None and r.complete():
            if not self._arrived(now, link, src, r):
                return self._refuse(now, link, src, s, key, sg.REFUSE_FULL)
        if s.poll:
            self._answer_poll(now, link, src, s, r)

    def _refuse(self, now, link, src, s, key, reason):
        # The fragments go, a marker stays: the refusal may be sent while
        # the sender is still on the air with the rest of its round (half-
        # duplex: deaf), so its poll gets the refusal again, not "all
        # missing", which would have it send everything once more.
        m = Reassembly(s.gen, 0, now)
        m.refused = reason
        m.unauthed = self._rx[key].unauthed
        self._rx[key] = m
        self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, reason))

    def _answer_poll(self, now, link, src, s, r):
        if r is None or r.gen != s.gen:
            # a bare poll for a transfer we have nothing of (our memory of
            # it timed out, or this node restarted): all is missing
            self._sack(now, link, src, sg.sack(s.lane, s.gen, 0))
        elif r.refused is not None:
            self._sack(now, link, src, sg.sack_refused(s.lane, s.gen, r.refused))
        elif r.done_pid is not None:
            self._sack(now, link, src, sg.sack_complete(s.lane, s.gen, r.count, r.done_pid))
        else:
            b, bm = r.bitmap()
            self._sack(now, link, src, sg.sack(s.lane, s.gen, b, bm))

    def _can_take(self, h):
        if h.relay is None or h.relay[1] == self.node_id:
            return True  # for this node: delivered, never stored
        q = _Packet()  # not yet whole: what the store's overflow rule judges
        q.size, q.prio, q.medium, q.origin, q.final = h.length, h.relay[2], None, h.relay[0], h.relay[1]
        if self.packets.room(q):
            return True
        self.stats["store_full"] += 1
        return False

    def _arrived(self, now, link, src, r):
        # -> False when a packet to relay found no room in the store
        try:
            blob = r.blob()
            h = r.header
            body = blob[h.size :]
            if h.relay is not None:
                origin, final, prio, life = h.relay
                # the life left now, not when fragment 0 came: else each hop's
                # transfer time adds to the lifespan
                life -= ticks_diff(now, r.born) // 1000
                if self.router.routing is not None and origin != self.node_id:
                    self.router.routing.learn(now, link, origin, src)  # the way back, for free
            else:
                origin, final, prio, life = src, self.node_id, 8, 3600
        except DecodeError:
            return self._bad(r)
        if final != self.node_id:
            # a relay keeps the body as the origin sent it: it is not
            # decompressed here (the fragments' CRCs already vouch for the
            # bytes, and the destination checks the rest)
            if not self._is_done(origin, h.pid):
                p = self._packet(origin, final, h.pid, prio, self.wall() + life, body, h.compressed, None)
                # custody, even of a packet of ours that a routing loop brought back after a relay
                # took it: its origin (this node) heard `transmitted` then, and hears nothing more
                p.relayed = True
                if self._keep(p) is not None:
                    return False
                self.stats["relayed"] += 1
                self._remember(origin, h.pid, life)
        elif self._is_done(origin, h.pid):
            self.stats["rx_dup"] += 1
        else:
            data = body
            if h.compressed:
                # imported here: a relay that only forwards never loads it
                from ..codec.compress import decompress

                try:
                    data = decompress(body, self.max_packet)
                except DecodeError:
                    return self._bad(r)
            self._remember(origin, h.pid, life, False)
            names = self.names
            g = self.guard
            if g is not None and not g.admits(data, not r.unauthed, self.auth):
                self.stats["refused_unauthed"] += 1
                self._emit((_EV_REFUSED, None, names.name_of(origin), g.REFUSED))
            else:
                self.stats["received"] += 1
                ev = (_EV_PACKET, names.name_of(origin), names.name_of(final), data)
                self._emit(ev if g is None else ev + (not r.unauthed,))
            # saved after the application has it: a power cut in between
            # gives at worst a second delivery, never a packet acknowledged
            # that nobody saw
            self._save_done()
        r.done_pid = h.pid
        r.frags = {}  # the memory goes; the lane remembers only the completion
        return True

    def _bad(self, r):
        self.stats["rx_bad"] += 1
        r.frags.clear()
        r.size = 0
        r.count = None
        r.header = None
        return True

    def _is_done(self, origin, pid):
        # whether (origin, pid) is among the entries remembered: a hit must
        # start on an entry's boundary (the pattern can straddle two)
        d, w, pat = _memory(self, origin, pid)
        i = d.find(pat)
        while i >= 0 and i % w:
            i = d.find(pat, i + 1)
        return i >= 0

    def _remember(self, origin, pid, life_s, save=True):
        # (origin, pid) is done here; a copy can still come until its
        # lifespan (life_s from now, as the packet says) is over. When the
        # memory is full the entry forgotten is the one whose copies stop
        # soonest: an expired one first (its copies are gone, relays drop
        # them), else the earliest, counted as done_forgotten (a copy of
        # it could then be delivered twice)
        d, w, pat = _memory(self, origin, pid)
        now_min = self.wall() // 60
        if len(d) >= w * _DONE_MEMORY:
            j = 0
            least = 0x10000
            for i in range(w - 2, len(d), w):
                left = (((d[i] << 8) | d[i + 1]) - now_min) & 0xFFFF
                left = left - 0x10000 if left & 0x8000 else left  # minutes still to run, wrap-safe
                if left < least:
                    j, least = i + 2 - w, left
            if least > 0:
                self.stats["done_forgotten"] += 1
            d[j : j + w] = b""
        until = (now_min + (max(0, life_s) + 59) // 60 + 1) & 0xFFFF
        d.extend(pat)
        d.extend(bytes((until >> 8, until & 0xFF)))
        if save:
            self._save_done()

    def _save_done(self):
        try:
            self.packets.save_done(self._done, self._done_wide)
        except AcommError:  # StoreFull or another StoreError; its room is kept; a store that still says no costs only the memory
            self.stats["store_full"] += 1

    def _sack(self, now, link, src, seg, tries=0):
        # seg: (head, bytes) from acomm.transport.segment
        if self._quiet and not tries:
            return
        rid = self._next_id()
        # known before the request: its `queued` (or a refusal, not tried again: tries 2) comes from
        # inside request(); a constant tuple, so a SACK allocates nothing more for it
        self._sacks[rid] = (None, None, None, 2)
        if link.request(now, rid, self.names.name_of(src), seg[1], _SACK_LIFESPAN_S, _SACK_PRIORITY, ftype=_SEGMENT,
                        seq=seg[0]):
            self._sacks[rid] = (link, src, seg, tries)

    def _sack_status(self, now, rid, status):
        # -> True when rid was one of our SACKs
        sk = self._sacks.get(rid)
        if sk is None:
            return False
        if status >= _TRANSMITTED:
            del self._sacks[rid]
            # a modem that refused it (busy acknowledging the fragment it
            # just received) gets it again, twice at most
            if status == _FAILED and sk[3] < 2:
                self._sack(now, sk[0], sk[1], sk[2], sk[3] + 1)
        return True

