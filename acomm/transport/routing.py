# Learned routes on a running node (issue 36): route control on the water,
# the route table and the searches (AODV-like, RFC 3561), joined to the
# transport's links. Imported only when the transport is made with
# routing=..., so a board that does not route pays nothing.
#
# One module of over 400 lines, and one class, on purpose: a frozen module
# still makes each of its functions, classes and instances in RAM at
# import, and this was four modules of about 70 functions and three
# objects, 3.3 KB of the buoy's heap (docs/routing.md, "Heap"). Its four
# parts, in this order:
#
# 1. On the water: the payload of a CONTROL frame (acomm.frame.CONTROL, a
#    type nothing else uses), whose header already names the hop that sent
#    it. Decoders raise only DecodeError; encoders check every range
#    themselves (struct does not on MicroPython). docs/wire-format.md,
#    "Route control", has the layout.
#
#   byte 0: kind (top 2 bits: 0 flood, 1 request, 2 reply, 3 error) and a 6-bit
#           count: the hops so far for a flood, a request or a reply, the
#           destinations for an error
#   Node ids (origin, dest) are one byte, and three for an id of 256 or
#   more (0xFF and 2 bytes, acomm.frame.addr_bytes); the sizes below are for
#   one-byte ids.
#   request (flooded), 10 bytes:
#     kind|hops  id  origin  origin_seq(2)  dest  dest_seq(2)  cost(2)
#     id: the origin's request counter (a relay drops an (origin, id) it has
#     seen); dest_seq UNKNOWN_SEQ when the origin knows none
#   reply (unicast back along the reverse path), 8 bytes:
#     kind|hops  dest  dest_seq(2)  origin  cost(2)  lifetime (4 s units, 1..255)
#   error (to the sources that used the hop), 1 + 3 per destination (1..16):
#     kind|n  (dest  dest_seq(2)) x n
#   flood (acomm.transport.flood, rebroadcast by every node), 3 + 1..18 bytes:
#     kind|hops  origin  id  data
#     id: the origin's flood counter mod 256; data is the application's;
#     encoded by acomm.transport.flood (encode_flood), decoded by both
#
#    Sequence numbers and costs are big-endian 16-bit. A request for a
#    destination whose sequence number the origin does not know carries
#    UNKNOWN_SEQ (0xFFFF, which the table therefore never hands out: its
#    numbers stay below it). Costs saturate at MAX_COST; 0xFFFF is never
#    written, and a decoder refuses it.
#
# 2. The table: destination -> [next hop, link, cost, destination sequence
#    number, expiry, valid, last used] by AODV's rules for loop freedom
#    (RFC 3561, 6.2). acomm.transport.route.Router consults it after the
#    static routes (those still win). An offer replaces what is there when
#      - there is no route, or it expired or was invalidated, or
#      - the offer's sequence number is newer (modulo 65,535, RFC 1982 style), or
#      - it is as new and cheaper.
#    An older sequence number never wins: that is what keeps routes free of
#    loops when nodes learn from stale replies. A broken hop's routes turn
#    invalid, kept with their sequence numbers raised by one (as RFC 3561
#    does) so that only fresher news restores them, and a route error names
#    them when a repair fails. One exception: when the hop was this node's
#    own (it stopped answering here, no error named it), hearing that hop
#    again before news comes restores the route as it was, number included
#    (search): on a busy acoustic channel most hops called broken are alive,
#    and nothing was announced in between that the old route could loop on. Bounded: at most `capacity` destinations; a new one takes the
#    place of an expired or invalid route first, else of the one used
#    longest ago; refused (and counted) when every route is valid and used
#    within a minute.
#
# 3. The searches. search(now, dest) floods a request, retried `tries`
#    times, search_ms apart and then twice that each time, then given up and held off for hold_ms (so a
#    node that keeps asking for an unreachable one floods a request per
#    hold_ms, not one per poll). With ring > 0 a search's first request
#    goes no further than `ring` relays (its hop count starts at MAX_HOPS -
#    ring); the next tries flood the whole network. tries counts the ring.
#    Each node rebroadcasts an (origin, id) at most once (a bounded list of
#    the last 32), after a random 0..jitter_ms so that the neighbours that
#    heard the same request do not send into each other, adds the cost of
#    the hop it came over, and learns the reverse route to the origin from
#    every copy. Only the destination answers (no intermediate replies:
#    simpler, and never an answer from a stale route); it raises its own
#    sequence number to at least the one asked for. Replies go back hop by
#    hop along the reverse routes, each hop learning the forward route.
#    Errors: a node drops every route through a hop of its own that failed
#    and repairs locally: its next packet for such a destination searches
#    from here, since custody keeps that packet in its store. Only a search
#    that gives up broadcasts an error; a neighbour that routed the
#    destination through the sender drops it too and passes the error on,
#    once (errors carry the raised sequence numbers, so a repeat changes
#    nothing and stops there). Whole-network tries wait twice as long each
#    time (binary exponential backoff, as RFC 3561 asks).
#
# 4. The links. Those whose medium (or name) is in `media` (acoustic by
#    default) route: they carry adverts, so a neighbour is known, and a
#    route there is found by a flooded request. Other links (satellite, a
#    cable) keep the static rule: the destination is the hop. The metric of
#    a hop is its ETX x 16 (acomm.link.neighbours, one table per routing
#    link, fed by the link's adverts and heard frames and by the
#    transport's polls, answered or not) times the link's airtime factor:
#    the seconds a 64-byte frame takes there, latency included, at least 1.
#    A neighbour without a figure yet counts as ETX 2. Route control goes
#    out as the link's CONTROL frames, sealed like every frame when the
#    node has a key; their statuses are the transport's, not the
#    application's. Floods (acomm.transport.flood, made by the first flood
#    sent or heard) go out on the same links, as the same CONTROL frames.
#
# Times are ticks (ms). `finder` and `table` name this object too: the
# benches and the console read rt.finder.stats and rt.table.routes, from
# when those were objects of their own.

from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError, DecodeError
from ..frame import addr_bytes, get_addr

BROADCAST = const(255)  # acomm.link.BROADCAST's node id
UNKNOWN_SEQ = const(0xFFFF)
MAX_COST = const(0xFFFE)
MAX_HOPS = const(63)
MAX_ERRORS = const(16)
LIFETIME_UNIT_MS = const(4000)
# the kinds on the water; private, so that they cost no slot in the module's dict
_FLOOD = const(0)
_REQUEST = const(1)
_REPLY = const(2)
_ERROR = const(3)

# numbers 0..65534: 0xFFFF is "unknown" on the water
_SEQ_MOD = const(65535)
_HALF = const(32767)
# a route's fields
_NEXT = const(0)  # next hop's node id
_LINK = const(1)  # the link's name
_COST = const(2)
_SEQ = const(3)  # destination sequence number, or -1 unknown
_EXPIRES = const(4)  # ticks
_VALID = const(5)  # True; None: this node's own hop broke (search may revive it); False
_USED = const(6)  # ticks last looked up or refreshed
_DEAD = const(1 << 29)  # an eviction score above every live route's
_KEEP_MS = const(60000)  # a live route used within this is never evicted

_CONTROL = const(4)  # acomm.frame.CONTROL
_AVAILABLE = const(1)
_UNAVAILABLE = const(2)
_EV_AVAILABILITY = const(22)
_TRANSMITTED = const(4)
_FAILED = const(8)
_UNKNOWN_ETX16 = const(32)
_CONTROL_PRIORITY = const(3)
_CONTROL_LIFESPAN_S = const(30)
_MAX_HELD = const(16)  # control frames waiting for their time; more are dropped (a flood has other copies)
_SEEN_CAP = const(32)  # the requests remembered as seen
_CUTS_CAP = const(8)  # the shortcuts remembered as offered: forgotten all at once when full


# -- on the water ------------------------------------------------------------------------------
# (EncodeError and Prng are imported where they are used: each name of the module takes a slot
# in its dict, which grows by 6 slots and more at a time)
def _chk(v, top, what):
    # v as a field of 0..top; top < 0: a cost, any int >= 0, saturated at MAX_COST
    if not isinstance(v, int) or v < 0 or v > top >= 0:
        from ..errors import EncodeError

        raise EncodeError("%s %r outside 0..%d" % (what, v, top) if top >= 0 else "%s %r is not a non-negative int" % (what, v))
    return MAX_COST if top < 0 and v > MAX_COST else v


def _id(v, what):
    # node id v as it goes on the water: 0..254 in a byte, 256..65534 in three
    if _chk(v, 65534, what) == 255:
        _chk(-1, 65534, what)  # 255 is the broadcast address, no node's
    return addr_bytes(v)


def encode_request(rid, origin, origin_seq, dest, dest_seq, hops, cost):
    """A route request: 10 bytes (2 more per id of 256 or more). dest_seq UNKNOWN_SEQ when the
    origin knows none; cost saturates."""
    o = _chk(origin_seq, 0xFFFE, "origin seq")
    d = _chk(dest_seq, 0xFFFF, "destination seq")
    c = _chk(cost, -1, "cost")
    k = _REQUEST << 6 | _chk(hops, MAX_HOPS, "count")
    r = _chk(rid, 255, "request id")
    if _chk(origin, 65534, "origin") < 255 and _chk(dest, 65534, "destination") < 255:  # one bytes object: relays send many
        return bytes((k, r, origin, o >> 8, o & 0xFF, dest, d >> 8, d & 0xFF, c >> 8, c & 0xFF))
    return bytes((k, r)) + _id(origin, "origin") + bytes((o >> 8, o & 0xFF)) + _id(dest, "destination") + bytes((d >> 8, d & 0xFF, c >> 8, c & 0xFF))


def encode_reply(dest, dest_seq, origin, hops, cost, lifetime_ms):
    """A route reply: 8 bytes (2 more per id of 256 or more). lifetime rounds up to 4 s units,
    4 s to 17 min."""
    units = (lifetime_ms + LIFETIME_UNIT_MS - 1) // LIFETIME_UNIT_MS
    s = _chk(dest_seq, 0xFFFE, "destination seq")
    c = _chk(cost, -1, "cost")
    k = _REPLY << 6 | _chk(hops, MAX_HOPS, "count")
    u = 1 if units < 1 else (255 if units > 255 else units)
    if _chk(origin, 65534, "origin") < 255 and _chk(dest, 65534, "destination") < 255:
        return bytes((k, dest, s >> 8, s & 0xFF, origin, c >> 8, c & 0xFF, u))
    return bytes((k,)) + _id(dest, "destination") + bytes((s >> 8, s & 0xFF)) + _id(origin, "origin") + bytes((c >> 8, c & 0xFF, u))


def encode_error(lost):
    """A route error for [(dest, seq)], 1..16 of them: 1 + 3 bytes each (5 for an id of 256 or more)."""
    if not 1 <= len(lost) <= MAX_ERRORS:
        from ..errors import EncodeError

        raise EncodeError("a route error names 1..%d destinations, not %d" % (MAX_ERRORS, len(lost)))
    out = bytearray((_ERROR << 6 | len(lost),))
    for d, s in lost:
        out.extend(_id(d, "destination"))
        s = _chk(s, 0xFFFE, "destination seq")
        out.append(s >> 8)
        out.append(s & 0xFF)
    return bytes(out)


def decode(data):
    """-> ("request", rid, origin, origin_seq, dest, dest_seq, hops, cost)
       | ("reply", dest, dest_seq, origin, hops, cost, lifetime_ms)
       | ("error", [(dest, seq), ...]) | ("flood", origin, id, hops, data);
       DecodeError for anything else."""
    if not data:
        raise DecodeError("empty route control")
    kind = data[0] >> 6
    n = data[0] & 0x3F
    if kind == _REQUEST or kind == _REPLY:
        # the same checks on both: their ids (origin and destination), sequence number and cost.
        # request: kind|hops id origin seq(2) dest seq(2) cost(2); reply: kind|hops dest seq(2)
        # origin cost(2) lifetime; an id is 1 byte or 3 (get_addr raises when it is cut short)
        q = kind == _REQUEST
        i = 2 if q else 1
        if len(data) == (10 if q else 8) and data[i] != 255 and data[i + 3] != 255:
            a, b, j = data[i], data[i + 3], i + 4  # one-byte ids: no get_addr tuples
            i += 1
        else:
            a, i = get_addr(data, i)  # request: origin; reply: dest
            b, j = get_addr(data, i + 2)  # and the other
        if len(data) != j + (4 if q else 3):
            raise DecodeError("route %s of %d bytes" % ("request" if q else "reply", len(data)))
        s = (data[i] << 8) | data[i + 1]  # request: the origin's; reply: the destination's
        c = j + 2 if q else j  # the cost: after the request's destination seq, or the reply's origin
        cost = (data[c] << 8) | data[c + 1]
        if s == UNKNOWN_SEQ or cost > MAX_COST or (not q and data[j + 2] == 0):
            raise DecodeError("route control with a reserved sequence number or cost, or no lifetime")
        if q:
            return ("request", data[1], a, s, b, (data[j] << 8) | data[j + 1], n, cost)
        return ("reply", a, s, b, n, cost, data[j + 2] * LIFETIME_UNIT_MS)
    if kind == _ERROR:
        if not 1 <= n <= MAX_ERRORS:
            raise DecodeError("route error for %d destinations" % n)
        lost = []
        i = 1
        for _ in range(n):
            d, i = get_addr(data, i)
            if i + 2 > len(data):
                raise DecodeError("route error cut short")
            s = (data[i] << 8) | data[i + 1]
            if s == UNKNOWN_SEQ:
                raise DecodeError("route error with a reserved sequence number")
            lost.append((d, s))
            i += 2
        if i != len(data):
            raise DecodeError("route error for %d destinations in %d bytes" % (n, len(data)))
        return ("error", lost)
    # kind 0, a flood: the flood's module reads it (heard() hands floods to the flooder before
    # this, so a node decodes here only route control, and loads that module only for floods)
    from .flood import decode_flood

    return decode_flood(data)


def seq_newer(a, b):
    """True when sequence number a is newer than b (modulo 65,535; -1 is older than any)."""
    if b < 0:
        return a >= 0
    if a < 0:
        return False
    d = (a - b) % _SEQ_MOD
    return 0 < d < _HALF


class Routing:
    """A node's learned routes: its table, its searches and their control frames on its links."""

    def __init__(self, node_id, names, links, next_id, media=("acoustic",), capacity=32, tries=3,
                 search_ms=60000, hold_ms=60000, lifetime_ms=600000, jitter_ms=None, seed=None, ring=3):
        """links: name -> Link (the node's, read live); next_id(): a fresh link request id."""
        self.node_id = node_id
        self.names = names
        self.node_links = links
        self._next_id = next_id
        self.media = tuple(media)
        self.capacity = capacity
        self.tries = tries
        self.search_ms = search_ms
        self.hold_ms = hold_ms
        self.lifetime_ms = lifetime_ms
        self.ring = ring
        self.jitter_ms = jitter_ms or 0
        self._auto_jitter = jitter_ms is None
        from ..prng import Prng

        self._rng = Prng(node_id + 1 if seed is None else seed)
        self._seed = node_id + 7 if seed is None else seed + 6  # the flooder's
        self.links = ()  # the routing links' names
        self._nlinks = -1
        self.seq = 0  # this node's own destination sequence number
        self._rid = 0
        self.routes = {}  # destination -> route (the fields above)
        self._searches = {}  # dest -> [tries left (-1: given up, held off), next try at]
        self._seen = []  # origin << 8 | request id, oldest first: ints, which take no heap
        self._cuts = {}  # origin << 8 | final -> ticks: the shortcuts offered (overheard)
        self._held = []  # (not before, link name, to, payload): what poll sends when due
        # link request id -> None (a broadcast) or (link name, hop id, payload, sent again): the
        # control frames whose statuses stop here
        self._rids = {}
        self.flooder = None  # acomm.transport.flood.Flooder, made by the first flood sent or heard
        self.stats = {"requests": 0, "rebroadcasts": 0, "replies": 0, "errors": 0, "bad": 0, "duplicates": 0,
                      "refused": 0, "control_sent": 0, "control_bytes": 0, "control_dropped": 0, "replies_rerouted": 0, "revived": 0,
                      "shortcuts": 0, "shortened": 0}
        self.finder = self.table = self

    # -- links and costs ------------------------------------------------------------------
    def routes_on(self, link):
        """Whether this link's packets follow learned routes."""
        return link.medium in self.media or link.name in self.media

    def neighbours(self, link):
        """The link's neighbour table (acomm.link.neighbours.Neighbours), made on first use."""
        nb = link.neighbours
        if nb is None:
            from ..link.neighbours import Neighbours

            nb = link.neighbours = Neighbours()
        return nb

    def hop_cost(self, now, link_name, hop):
        """ETX x 16 of the hop times its airtime factor (an int >= 16); 32 on a link not there."""
        link = self.node_links.get(link_name)
        if link is None:
            return _UNKNOWN_ETX16
        e = self.neighbours(link).etx16(now, hop)
        c = link.driver.caps  # the driver's own: Link.caps copies them, and this runs per packet and poll
        ms = c.latency_ms + (512000 // c.bitrate if c.bitrate else 60000)  # 64 bytes
        return (_UNKNOWN_ETX16 if e is None else e) * (1 + ms // 1000)

    # -- the table ----------------------------------------------------------------------------
    def offer(self, now, dest, next_hop, link, cost, seq, lifetime_ms):
        """A route heard of (a reply, a request's reverse path, traffic passing through). -> True
        when it is now the route to dest; AcommError for a bad id, cost or sequence number."""
        if not (0 <= dest <= 65534 and 0 <= next_hop <= 65534) or 255 in (dest, next_hop) or cost < 0 or seq >= _SEQ_MOD:
            raise AcommError("route to %r via %r: bad id, cost or sequence number" % (dest, next_hop))
        routes = self.routes
        r = routes.get(dest)
        if r is not None and r[_VALID] and ticks_diff(r[_EXPIRES], now) > 0:
            if seq_newer(r[_SEQ], seq) or (r[_SEQ] == seq and cost >= r[_COST]) or (seq < 0 <= r[_SEQ]):
                if r[_NEXT] == next_hop and r[_SEQ] == seq and cost == r[_COST]:
                    t = ticks_add(now, lifetime_ms)  # the same route, heard again
                    if ticks_diff(t, r[_EXPIRES]) > 0:
                        r[_EXPIRES] = t
                return False
        elif r is not None and r[_SEQ] >= 0 and seq_newer(r[_SEQ], seq):
            return False  # an invalid route's raised number: only fresher news restores it
        if r is None:
            if len(routes) >= self.capacity:
                # dead routes go first (scored above every live one), then the least recently used
                victim = score = None
                for d in routes:
                    x = routes[d]
                    s = ticks_diff(now, x[_USED]) + (0 if x[_VALID] and ticks_diff(x[_EXPIRES], now) > 0 else _DEAD)
                    if score is None or s > score:
                        victim, score = d, s
                if victim is None or (score < _DEAD and score < _KEEP_MS):
                    self.stats["refused"] += 1
                    return False
                del routes[victim]
            r = routes[dest] = [0, None, 0, -1, now, False, now]
        r[_NEXT] = next_hop
        r[_LINK] = link
        r[_COST] = cost
        r[_SEQ] = seq
        r[_EXPIRES] = ticks_add(now, lifetime_ms)
        r[_VALID] = True
        r[_USED] = now
        return True

    def lookup(self, now, dest):
        """-> (next hop, link name, cost) of a live route to dest, or None."""
        r = self.routes.get(dest)
        if r is None or not r[_VALID] or ticks_diff(r[_EXPIRES], now) <= 0:
            return None
        r[_USED] = now
        return r[_NEXT], r[_LINK], r[_COST]

    def broken(self, now, hop, link_name, named=None):
        """hop cannot be reached on link_name: its live routes turn invalid (only those a route
        error named, named = [(dest, seq)], when given), their numbers raised by one. A route
        error passes on the ones named that had a number; a hop of this node's own that broke
        sends none (a packet for those destinations searches from here: a local repair)."""
        routes = self.routes
        lost = []
        for d in (routes if named is None else [x[0] for x in named]):
            r = routes.get(d)
            if r is None or not r[_VALID] or ticks_diff(r[_EXPIRES], now) <= 0:
                continue
            if named is not None:
                r[_USED] = now  # an error's destinations are looked up
            if r[_NEXT] == hop and r[_LINK] == link_name:
                # None: a hop of this node's own, which search() brings back if it is heard again
                # (_EXPIRES keeps the moment); False: a neighbour's error, which only news undoes
                r[_VALID] = None if named is None else False
                if named is None:
                    r[_EXPIRES] = now
                if r[_SEQ] >= 0:
                    r[_SEQ] = (r[_SEQ] + 1) % _SEQ_MOD
                    if named is not None:
                        lost.append((d, r[_SEQ]))  # a neighbour's own route has no number to name
        # routes not through that hop stand, and an error stops here when none was. This node's
        # own broken hop sends no error: custody is hop by hop, so what was sent through here waits
        # in this node's store, and the nodes behind it lose nothing by keeping their routes to it.
        # An error at once would make every source routing through here flood a search of its
        # own, and on a busy acoustic channel most hops called broken are alive, only unheard for
        # a while. A search from here that gives up sends the error (_retry)
        while lost:
            chunk, lost = lost[:MAX_ERRORS], lost[MAX_ERRORS:]
            self._queue(now, None, BROADCAST, encode_error(chunk))
            self.stats["errors"] += 1

    # -- the next hop ------------------------------------------------------------------------
    def hop_on(self, now, link, final):
        """The next hop towards final on a routing link: final itself when heard there (unless a
        learned route by this link is cheaper), else that route's hop, else None."""
        r = self.lookup(now, final)
        if r is not None and r[1] != link.name:
            r = None
        if r is not None and link.discovery.state(r[0]) == _UNAVAILABLE:
            # discovery has missed the hop's adverts: the route is broken, and says so
            self.broken(now, r[0], link.name)
            r = None
        if link.discovery.state(final) == _AVAILABLE:
            # heard directly; a poor direct link loses to a cheaper learned route
            if r is None or r[0] == final or self.hop_cost(now, link.name, final) <= r[2]:
                return final
        return None if r is None else r[0]

    def search(self, now, final):
        """No link has a way to final: start (or keep) its search, unless a live route names it or
        the last search gave up within hold_ms (the packet waits either way)."""
        self._sync_links()
        r = self.routes.get(final)
        if r is not None and r[_VALID] is None:
            # this node's own hop towards it was called broken (its _VALID None, _EXPIRES the
            # moment): heard since, it was alive after all, only unheard for a while (its frames
            # lost to collisions, or sent while this node was sending), as most such hops on a busy
            # acoustic channel are. The route comes back as it was, and its search stops before it
            # floods the network: its ring request is often what the hop is heard rebroadcasting
            link = self.node_links.get(r[_LINK])
            h = None if link is None else link.discovery.last_heard(r[_NEXT])
            if h is not None and ticks_diff(h, r[_EXPIRES]) > 0:
                r[_VALID] = True
                if r[_SEQ] >= 0:
                    r[_SEQ] = (r[_SEQ] - 1) % _SEQ_MOD  # the number broken() raised
                r[_EXPIRES] = ticks_add(now, self.lifetime_ms)
                r[_USED] = now
                self._searches.pop(final, None)
                self.stats["revived"] += 1
                return
        if self.links and self.lookup(now, final) is None and final not in self._searches:
            self._searches[final] = [self.tries, now]
            self._retry(now)

    def searching(self, dest):
        """Whether a search for dest is running (False when none was asked, or it gave up)."""
        s = self._searches.get(dest)
        return s is not None and s[0] >= 0

    def _retry(self, now):
        # the searches' tries and give-ups that are due
        searches = self._searches
        for dest in searches:
            if ticks_diff(now, searches[dest][1]) >= 0:
                break
        else:
            return  # none due: no copy of the keys made at every poll
        for dest in list(searches):
            s = searches[dest]
            if ticks_diff(now, s[1]) < 0:
                continue
            if s[0] < 0:
                del searches[dest]  # held off long enough: the next search asks again
                continue
            if s[0] == 0:  # given up
                # a repair that failed here: now the nodes that route through this one learn it,
                # and find their own way round
                r = self.routes.get(dest)
                if r is not None and not r[_VALID] and r[_SEQ] >= 0:
                    self._queue(now, None, BROADCAST, encode_error([(dest, r[_SEQ])]))
                    self.stats["errors"] += 1
                if self.hold_ms > 0:
                    s[0] = -1
                    s[1] = ticks_add(now, self.hold_ms)
                else:
                    del searches[dest]
                continue
            # the first try of a search asks only within `ring` relays (AODV's expanding ring):
            # a route that broke, or a node that moved, is mostly still near, and a ring costs the
            # nodes around, not the whole network; it waits a tenth of search_ms per relay
            ttl = self.ring if s[0] == self.tries else 0
            # whole-network tries wait twice as long each time (AODV's binary exponential backoff):
            # over many acoustic hops a reply can take longer than search_ms, and a flood sent just
            # before it lands costs every node a frame for nothing
            n = self.tries - s[0] - (1 if self.ring else 0)
            s[0] -= 1
            s[1] = ticks_add(now, self.search_ms * ttl // 10 if ttl else self.search_ms << n)
            self._rid = (self._rid + 1) % 256
            self.seq = (self.seq + 1) % _SEQ_MOD
            r = self.routes.get(dest)
            known = -1 if r is None else r[_SEQ]
            # a ring of ttl relays: the count starts that far below MAX_HOPS, where relays stop
            self._queue(now, None, BROADCAST, encode_request(self._rid, self.node_id, self.seq, dest,
                                                             known if known >= 0 else UNKNOWN_SEQ,
                                                             MAX_HOPS - ttl if ttl else 0, 0))
            self._seen.append(self.node_id << 8 | self._rid)
            if len(self._seen) > _SEEN_CAP:
                self._seen.pop(0)
            self.stats["requests"] += 1

    # -- what the transport tells --------------------------------------------------------------
    def learn(self, now, link, origin, hop):
        """Traffic from origin came in by hop on link: a route back to origin, for free."""
        if origin != hop and self.routes_on(link) and self.lookup(now, origin) is None:
            self.offer(now, origin, hop, link.name, self.hop_cost(now, link.name, hop) * 2, -1, self.lifetime_ms)

    def attempt(self, now, link, hop, answered):
        """A poll to hop on link was answered, or not (ETX's evidence). An answer keeps the live
        routes through hop alive for lifetime_ms at least (AODV's active routes: a route in use
        does not expire under its traffic)."""
        if self.routes_on(link):
            self.neighbours(link).attempt(now, hop, answered)
            if answered:
                t = ticks_add(now, self.lifetime_ms)
                routes = self.routes
                for d in routes:
                    r = routes[d]
                    if (r[_NEXT] == hop and r[_LINK] == link.name and r[_VALID] and ticks_diff(r[_EXPIRES], now) > 0
                            and ticks_diff(t, r[_EXPIRES]) > 0):
                        r[_EXPIRES] = t

    def hop_failed(self, now, link, hop, window_ms):
        """hop did not answer on link for window_ms: unless it was heard within that window and an
        advert period (alive: its answers were lost to collisions, and the transfer goes on
        trying), routes through it turn invalid (see broken). -> True when they did."""
        if not self.routes_on(link):
            return False
        d = link.discovery
        heard = d.last_heard(hop)
        if heard is not None and ticks_diff(now, heard) < window_ms + d.period_ms:
            return False
        self.broken(now, hop, link.name)
        # and discovery learns it now, not after its missed adverts: a destination it still calls
        # heard would keep being tried directly instead of searched for. Done here, on the table
        # the console reads, so that a board that does not route pays no method for it
        e = d.nodes.get(hop)
        if e is not None and e[2] == _AVAILABLE:
            e[2] = _UNAVAILABLE
            link._emit((_EV_AVAILABILITY, link, self.names.name_of(hop), _UNAVAILABLE))
        return True

    # -- control frames ----------------------------------------------------------------------
    def heard(self, now, link, hop, payload):
        """A CONTROL frame's payload from neighbour hop on link -> [(origin, data)] of a flood
        heard for the first time (else ()); bad bytes are counted and dropped."""
        if not self.routes_on(link):
            return ()
        if payload and payload[0] >> 6 == _FLOOD:
            fl = self._flooding()
            fl.heard(now, link.name, hop, payload)
            return [(e[1], e[2]) for e in fl.take_events()]
        try:
            m = decode(payload)
        except DecodeError:
            self.stats["bad"] += 1
            return ()
        name = link.name
        st = self.stats
        if m[0] == "error":
            self.broken(now, hop, name, m[1])
            return ()
        if m[0] == "reply":
            _, dest, dseq, origin, hops, cost, lifetime = m
            leg = self.hop_cost(now, name, hop)
            cost += leg
            if not self.offer(now, dest, hop, name, cost, dseq, lifetime) and hops == 1 and origin == self.node_id:
                # hop hears dest itself (its shortcut, overheard, or dest's reply it passed on) and
                # sends it there straight: no loop can form through it, so an older number does not
                # bar that way. It is offered again under the live route's own number, which the
                # table's rule takes when cheaper. A leg with no figure yet (no poll went there, and
                # a busy node sends no adverts) counts as one transmission, not two: it was heard a
                # moment ago, and a hop that fails is called so after one stall and searched round
                if self.neighbours(link).etx16(now, hop) is None:
                    cost -= leg // 2
                r = self.routes.get(dest)
                if (r is not None and r[_VALID] and ticks_diff(r[_EXPIRES], now) > 0
                        and self.offer(now, dest, hop, name, cost, r[_SEQ], lifetime)):
                    st["shortened"] += 1
            if origin == self.node_id:
                if dest in self._searches:
                    del self._searches[dest]  # found (even after a give-up: a late reply is news)
                self.lookup(now, dest)  # the route found counts as used (eviction's order)
                return ()
            back = self.lookup(now, origin)
            if back is not None and hops < MAX_HOPS:  # else no way back: the origin will ask again
                self._queue(now, back[1], back[0], encode_reply(dest, dseq, origin, hops + 1, cost, lifetime))
            return ()
        _, rid, origin, oseq, dest, dseq, hops, cost = m
        if origin == self.node_id:
            st["duplicates"] += 1
            return ()
        cost += self.hop_cost(now, name, hop)
        # the reverse route, to the origin through the hop it came by; from every copy, not only
        # the first: the first to arrive is the luckiest draw of the jitter, often a detour, and
        # the reply, which goes back by these routes, is lost more often the more hops it takes
        self.offer(now, origin, hop, name, cost, oseq, self.lifetime_ms)
        key = origin << 8 | rid
        seen = self._seen
        if key in seen:
            st["duplicates"] += 1
            return ()
        seen.append(key)
        if len(seen) > _SEEN_CAP:
            seen.pop(0)
        if hop != origin:
            self.offer(now, hop, hop, name, self.hop_cost(now, name, hop), -1, self.lifetime_ms)
        if dest == self.node_id:
            if dseq != UNKNOWN_SEQ and seq_newer(dseq, self.seq):
                self.seq = dseq
            self.seq = (self.seq + 1) % _SEQ_MOD
            self._queue(now, name, hop, encode_reply(self.node_id, self.seq, origin, 0, 0, self.lifetime_ms))
            st["replies"] += 1
        elif hops < MAX_HOPS:
            self._queue(ticks_add(now, self._rng.below(self.jitter_ms + 1)) if self.jitter_ms else now, None, BROADCAST,
                        encode_request(rid, origin, oseq, dest, dseq, hops + 1, cost))
            st["rebroadcasts"] += 1
        return ()

    def overheard(self, now, link, src, dst, origin, final):
        """A packet from origin to final heard passing from src to dst, none of them this node. When
        src only relays it, dst is not final, and this node hears origin and final itself, the way
        through here is 2 hops against the packet's 3 or more (AODV's route shortening): a reply
        tells origin, which takes it when it is cheaper. One per origin and final each lifetime_ms
        (a shortcut not taken is not offered again at every packet)."""
        if src == origin or dst == final or not self.routes_on(link):
            return
        d = link.discovery
        if d.state(origin) != _AVAILABLE or d.state(final) != _AVAILABLE:
            return
        key = origin << 16 | final
        cuts = self._cuts
        t = cuts.get(key)
        if t is not None and ticks_diff(now, t) < self.lifetime_ms:
            return
        r = self.routes.get(final)
        c = self.hop_cost(now, link.name, final)
        if r is not None and r[_VALID] and r[_NEXT] != final and ticks_diff(r[_EXPIRES], now) > 0 and r[_COST] < c:
            return  # a learned route is cheaper than the direct hop: this node would not send straight (hop_on)
        if len(cuts) >= _CUTS_CAP:
            cuts.clear()
        cuts[key] = now
        seq = r[_SEQ] if r is not None and r[_SEQ] >= 0 else 0
        if self.neighbours(link).etx16(now, final) is None:
            c //= 2  # no figure yet: one transmission, as the origin counts its own leg (heard)
        self._queue(now, link.name, origin, encode_reply(final, seq, origin, 1, c, self.lifetime_ms))
        self.stats["shortcuts"] += 1

    def flood(self, now, data, hops_limit=None):
        """Floods data to every node (acomm.transport.flood.Flooder.send) -> its id."""
        self._sync_links()
        if not self.links:
            raise AcommError("no link floods: none is %s" % " or ".join(self.media))
        return self._flooding().send(now, data, hops_limit)  # EncodeError (an AcommError) for bad data

    def _sync_links(self):
        # the routing links' names, for requests, errors and floods (links can be added after the
        # transport)
        links = self.node_links
        if len(links) != self._nlinks:
            self._nlinks = len(links)
            self.links = tuple(n for n in links if self.routes_on(links[n]))
            for n in self.links:
                links[n].overhear_segments = True  # for overheard()
        if self._auto_jitter:
            # a rebroadcast waits 0..jitter: wide enough that the neighbours that heard one request
            # seldom start within one short frame of each other (they would collide at the next
            # hop: acoustic modems rarely sense the carrier), 2 x (neighbours + 2) short frames
            j = 0
            for n in self.links:
                link = links[n]
                bps = link.driver.caps.bitrate or 100
                nb = link.neighbours
                k = 2 * (2 + (0 if nb is None else len(nb.table))) * (128000 // bps + 200)
                if k > j:
                    j = k
            self.jitter_ms = j
        fl = self.flooder
        if fl is not None:
            fl.links = self.links
            fl.jitter_ms = self.jitter_ms

    def _flooding(self):
        # the flooder, made on first use: a node that never sees a flood never loads the module
        fl = self.flooder
        if fl is None:
            from .flood import Flooder

            fl = self.flooder = Flooder(self.node_id, links=self.links, jitter_ms=self.jitter_ms, seed=self._seed)
        return fl

    def _queue(self, at, link_name, to, payload):
        # a control frame for poll to send at `at` or later; link_name None: on every routing link
        held = self._held
        for n in (self.links if link_name is None else (link_name,)):
            if len(held) < _MAX_HELD:
                held.append((at, n, to, payload))
            else:
                self.stats["control_dropped"] += 1

    def poll(self, now):
        """The searches' retries, and the control frames that are due, onto their links."""
        self._sync_links()
        self._retry(now)
        fl = self.flooder
        if fl is not None:
            fl.poll(now)
            for link_name, to, payload in fl.take():
                self._send(now, link_name, to, payload)
        # in place, in order: a list made anew each poll would land wherever the heap has a hole
        held = self._held
        i = 0
        while i < len(held):
            item = held[i]
            if ticks_diff(now, item[0]) < 0:
                i += 1
            else:
                held.pop(i)
                self._send(now, item[1], item[2], item[3])

    def _send(self, now, link_name, to, payload, again=False):
        link = self.node_links.get(link_name)
        if link is None:
            return
        rid = self._next_id()
        dst = "*" if to == BROADCAST else self.names.name_of(to)  # acomm.link.BROADCAST
        # known before the request: its first status comes from inside request(); a unicast
        # keeps its payload, to go another way if this hop never acknowledges it
        self._rids[rid] = None if to == BROADCAST else (link_name, to, payload, again)
        # a reply or an error to one neighbour asks for the link's acknowledgement (and its
        # retries): a reply lost on one hop of many would cost the whole search again
        if link.request(now, rid, dst, payload, _CONTROL_LIFESPAN_S, _CONTROL_PRIORITY, ack=to != BROADCAST,
                        ftype=_CONTROL):
            self.stats["control_sent"] += 1
            self.stats["control_bytes"] += len(payload)
        else:
            self._rids.pop(rid, None)
            self.stats["control_dropped"] += 1

    def on_link_status(self, now, rid, status):
        """A link request's status -> True when it was a control frame's (its statuses stop here).
        A reply the hop never acknowledged goes once more, by the route the table now holds back to
        its origin, when that leaves by another hop (later copies of the request may have taught it
        one)."""
        if rid not in self._rids:
            return False
        if status < _TRANSMITTED:
            return True
        e = self._rids.pop(rid)
        if e is None or status != _FAILED:
            return True
        link_name, hop, payload, again = e
        link = self.node_links.get(link_name)
        if link is not None:
            self.attempt(now, link, hop, False)
        if again or payload[0] >> 6 != _REPLY:
            return True
        r = self.lookup(now, payload[4])  # a reply's origin
        if r is not None and (r[0] != hop or r[1] != link_name):
            self.stats["replies_rerouted"] += 1
            self._send(now, r[1], r[0], payload, True)
        return True
