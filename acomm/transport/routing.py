# Learned routes on a running node (issue 36): joins the route table and the
# route finder to the transport's links. Imported only when the transport is
# made with routing=..., so a board that does not route pays nothing.
#
# Which links route: those whose medium is in `media` (acoustic by default):
# they carry adverts, so a neighbour is known, and a route there is found
# by a flooded request. Other links (satellite, a cable) keep the static
# rule: the destination is the hop.
#
# The metric of a hop is its ETX x 16 (acomm.link.neighbours, one table per
# routing link, fed by the link's adverts and heard frames and by the
# transport's polls, answered or not) times the link's airtime factor: the
# seconds a 64-byte frame takes there, latency included, at least 1. A
# neighbour without a figure yet counts as ETX 2.
#
# A packet for a destination no route names waits while its search runs;
# the finder gives up after its tries and then holds off (hold_ms) before
# searching again, so an unreachable node costs a request per hold_ms, not
# a flood per poll. Route control frames go out as the link's CONTROL
# frames, sealed like every frame when the node has a key; their statuses
# are the transport's, not the application's.
#
# Floods (acomm.transport.flood) go out on the same links, as the same
# CONTROL frames: each node hands a new one up once and passes it on once.

from ..compat import const, ticks_diff
from ..errors import AcommError
from .routefinder import BROADCAST, RouteFinder
from .routetable import RouteTable

_CONTROL = const(4)  # acomm.frame.CONTROL
_AVAILABLE = const(1)
_UNAVAILABLE = const(2)
_EV_AVAILABILITY = const(22)
_TRANSMITTED = const(4)
_FAILED = const(8)
_REPLY_KIND = const(2)  # acomm.transport.routewire.REPLY
_FLOOD_KIND = const(0)  # acomm.transport.routewire.FLOOD
_UNKNOWN_ETX16 = const(32)
_CONTROL_PRIORITY = const(3)
_CONTROL_LIFESPAN_S = const(30)
_MAX_HELD = const(16)  # rebroadcasts waiting for their jitter; more are dropped (a flood has other copies)


class Routing:
    def __init__(self, node_id, names, links, next_id, media=("acoustic",), capacity=32, tries=3,
                 search_ms=60000, hold_ms=60000, lifetime_ms=600000, jitter_ms=None, seed=None, ring=3):
        """links: name -> Link (the node's, read live); next_id(): a fresh link request id."""
        self.names = names
        self.node_links = links
        self._next_id = next_id
        self.media = tuple(media)
        self.table = RouteTable(capacity)
        self.finder = RouteFinder(node_id, self.table, self.hop_cost, links=(), tries=tries, search_ms=search_ms,
                                  lifetime_ms=lifetime_ms, jitter_ms=jitter_ms or 0, hold_ms=hold_ms, ring=ring,
                                  seed=node_id + 1 if seed is None else seed)
        self.flooder = None  # acomm.transport.flood.Flooder, made by the first flood sent or heard
        self._seed = node_id + 7 if seed is None else seed + 6
        self._nlinks = -1
        self._auto_jitter = jitter_ms is None
        self._held = []  # (not before, link name, to, payload)
        # link request id -> None (a broadcast) or (link name, hop id, payload, sent again): the
        # control frames whose statuses stop here
        self._rids = {}
        self.stats = {"control_sent": 0, "control_bytes": 0, "control_dropped": 0, "replies_rerouted": 0}

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
        """ETX x 16 of the hop times its airtime factor (an int >= 16)."""
        link = self.node_links.get(link_name)
        if link is None:
            return None
        e = self.neighbours(link).etx16(now, hop)
        c = link.driver.caps  # the driver's own: Link.caps copies them, and this runs per packet and poll
        ms = c.latency_ms + (512000 // c.bitrate if c.bitrate else 60000)  # 64 bytes
        return (_UNKNOWN_ETX16 if e is None else e) * (1 + ms // 1000)

    # -- the next hop ------------------------------------------------------------------------
    def hop_on(self, now, link, final):
        """The next hop towards final on a routing link: final itself when heard there (unless a
        learned route by this link is cheaper), else that route's hop, else None."""
        r = self.table.lookup(now, final)
        if r is not None and r[1] != link.name:
            r = None
        if r is not None and link.discovery.state(r[0]) == _UNAVAILABLE:
            # discovery has missed the hop's adverts: the route is broken, and says so
            self.finder.hop_failed(now, r[0], link.name)
            r = None
        if link.discovery.state(final) == _AVAILABLE:
            # heard directly; a poor direct link loses to a cheaper learned route
            if r is None or r[0] == final or self.hop_cost(now, link.name, final) <= r[2]:
                return final
        return None if r is None else r[0]

    def search(self, now, final):
        """No link has a way to final: start (or keep) its search, unless the last one gave up
        within hold_ms (the packet waits either way)."""
        self._sync_links()
        if self.finder.links:
            self.finder.find(now, final)

    def learn(self, now, link, origin, hop):
        """Traffic from origin came in by hop on link: a route back to origin, for free."""
        if origin != hop and self.routes_on(link) and self.table.lookup(now, origin) is None:
            self.table.offer(now, origin, hop, link.name, self.hop_cost(now, link.name, hop) * 2, -1,
                             self.finder.lifetime_ms)

    def attempt(self, now, link, hop, answered):
        """A poll to hop on link was answered, or not (ETX's evidence); three unanswered in a row
        (the transport's stall) also call hop_failed."""
        if self.routes_on(link):
            self.neighbours(link).attempt(now, hop, answered)
            if answered:
                self.table.refresh(now, hop, link.name, self.finder.lifetime_ms)

    def hop_failed(self, now, link, hop, window_ms):
        """hop did not answer on link for window_ms: unless it was heard within that window and an
        advert period (alive: its answers were lost to collisions, and the transfer goes on
        trying), routes through it turn invalid and an error goes out. -> True when they did."""
        if not self.routes_on(link):
            return False
        d = link.discovery
        heard = d.last_heard(hop)
        if heard is not None and ticks_diff(now, heard) < window_ms + d.period_ms:
            return False
        self.finder.hop_failed(now, hop, link.name)
        # and discovery learns it now, not after its missed adverts: a destination it still calls
        # heard would keep being tried directly instead of searched for. Done here, on the table
        # the console reads, so that a board that does not route pays no method for it
        e = d.nodes.get(hop)
        if e is not None and e[2] == _AVAILABLE:
            e[2] = _UNAVAILABLE
            link._emit((_EV_AVAILABILITY, link, self.names.name_of(hop), _UNAVAILABLE))
        return True

    # -- control frames ----------------------------------------------------------------------
    def heard(self, now, link, src, payload):
        """A CONTROL frame's payload from neighbour src on link -> [(origin, data)] of a flood
        heard for the first time (else [])."""
        if not self.routes_on(link):
            return ()
        if payload and payload[0] >> 6 == _FLOOD_KIND:
            fl = self._flooding()
            fl.heard(now, link.name, src, payload)
            return [(e[1], e[2]) for e in fl.take_events()]
        self.finder.heard(now, link.name, src, payload)
        return ()

    def flood(self, now, data, hops_limit=None):
        """Floods data to every node (acomm.transport.flood.Flooder.send) -> its id."""
        self._sync_links()
        if not self.finder.links:
            raise AcommError("no link floods: none is %s" % " or ".join(self.media))
        return self._flooding().send(now, data, hops_limit)  # EncodeError (an AcommError) for bad data

    def _sync_links(self):
        # the routing links' names, for the finder's floods (links can be added after the transport)
        links = self.node_links
        if len(links) != self._nlinks:
            self._nlinks = len(links)
            self.finder.links = tuple(n for n in links if self.routes_on(links[n]))
        if self._auto_jitter:
            # a rebroadcast waits 0..jitter: wide enough that the neighbours that heard one request
            # seldom start within one short frame of each other (they would collide at the next
            # hop: acoustic modems rarely sense the carrier), 2 x (neighbours + 2) short frames
            j = 0
            for n in self.finder.links:
                link = links[n]
                bps = link.driver.caps.bitrate or 100
                nb = link.neighbours
                k = 2 * (2 + (0 if nb is None else len(nb.table))) * (128000 // bps + 200)
                if k > j:
                    j = k
            self.finder.jitter_ms = j
        fl = self.flooder
        if fl is not None:
            fl.links = self.finder.links
            fl.jitter_ms = self.finder.jitter_ms

    def _flooding(self):
        # the flooder, made on first use: a node that never sees a flood never loads the module
        fl = self.flooder
        if fl is None:
            from .flood import Flooder

            fl = self.flooder = Flooder(self.finder.node_id, links=self.finder.links,
                                        jitter_ms=self.finder.jitter_ms, seed=self._seed)
        return fl

    def poll(self, now):
        """The finder's retries, and the control frames that are due, onto their links."""
        f = self.finder
        self._sync_links()
        f.poll(now)
        f.take_events()  # the waiting packets ask again at the transport's next poll
        fl = self.flooder
        if fl is not None:
            fl.poll(now)
            for link_name, to, payload in fl.take():
                self._send(now, link_name, to, payload)
        held = self._held
        for item in f.take():
            if len(held) < _MAX_HELD:
                held.append(item)
            else:
                self.stats["control_dropped"] += 1
        if not held:
            return
        keep = []
        for item in held:
            if ticks_diff(now, item[0]) < 0:
                keep.append(item)
            else:
                self._send(now, item[1], item[2], item[3])
        self._held = keep

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
        if again or payload[0] >> 6 != _REPLY_KIND:
            return True
        r = self.table.lookup(now, payload[4])  # a reply's origin (acomm.transport.routewire)
        if r is not None and (r[0] != hop or r[1] != link_name):
            self.stats["replies_rerouted"] += 1
            self._send(now, r[1], r[0], payload, True)
        return True
