# Route discovery without I/O (issue 36, third part): a node's side of
# AODV-style searches (RFC 3561) over acomm.transport.routewire's messages,
# into its acomm.transport.routetable.RouteTable. acomm.transport.routing
# runs it on a node (docs/routing.md).
#
#   find(now, dest)        start a search (a flooded request); retried
#                          `tries` times, search_ms apart, then given up
#   heard(now, link, hop, payload)
#                          a CONTROL frame's payload from neighbour `hop`
#   hop_failed(now, hop, link)
#                          the link could not deliver to hop: its routes
#                          turn invalid and an error names them
#   take() -> [(not_before, link, to, payload)]  what to send; to is a hop
#                          id or BROADCAST; a rebroadcast waits a random
#                          0..jitter_ms, so neighbours that heard the same
#                          request do not answer into each other
#   events: ("found", dest, cost) and ("unreachable", dest) in take_events()
#   searching(dest)        whether a search for dest runs (not after it gave up)
#
# With ring > 0 a search's first request goes no further than `ring` relays
# (its hop count starts at MAX_HOPS - ring); the next tries flood the whole
# network. tries counts the ring.
#
# A search given up is held off for hold_ms: find() does nothing for that
# destination until then, so a node that keeps asking for an unreachable
# one floods a request per hold_ms, not one per call.
#
# Requests: each node rebroadcasts an (origin, id) at most once (a bounded
# cache of the last `seen_cap`), adds the cost of the hop it came over, and
# learns the reverse route to the origin from it. Only the destination
# answers (no intermediate replies: simpler, and never an answer from a
# stale route); it raises its own sequence number to at least the one asked
# for. Replies go back hop by hop along the reverse routes, each hop
# learning the forward route. Errors: a node drops every route through the
# failed hop and broadcasts one error; a neighbour that routed those
# destinations through the sender drops them too and passes the error on,
# once (errors carry the raised sequence numbers, so a repeat changes
# nothing and stops there).
#
# hop_cost(now, link, hop) -> ETX x 16 x the link's airtime factor (an
# int), or None for a neighbour with no figure yet, which costs `unknown_cost`.

from ..compat import const, ticks_add, ticks_diff
from ..errors import DecodeError
from ..prng import Prng
from . import routewire as W
from .routetable import SEQ_MOD, seq_newer

BROADCAST = const(255)


class RouteFinder:
    def __init__(self, node_id, table, hop_cost, links=("acoustic",), tries=3, search_ms=60000,
                 lifetime_ms=600000, jitter_ms=2000, unknown_cost=32, seen_cap=32, seed=1, hold_ms=0, ring=0):
        self.node_id = node_id
        self.table = table
        self.hop_cost = hop_cost
        self.links = tuple(links)  # requests and errors go out on each
        self.tries = tries
        self.search_ms = search_ms
        self.lifetime_ms = lifetime_ms
        self.jitter_ms = jitter_ms
        self.unknown_cost = unknown_cost
        self.seen_cap = seen_cap
        self.hold_ms = hold_ms
        self.ring = ring
        self.seq = 0  # this node's own destination sequence number
        self._rid = 0
        self._rng = Prng(seed)
        self._seen = []  # (origin, request id), oldest first
        self._searches = {}  # dest -> [tries left (-1: given up, held off), next try at]
        self._out = []
        self._events = []
        self.stats = {"requests": 0, "rebroadcasts": 0, "replies": 0, "errors": 0, "bad": 0, "duplicates": 0}

    # -- asking ----------------------------------------------------------------------------------
    def find(self, now, dest):
        """Start (or keep) a search for dest; a live route answers at once with a "found" event."""
        r = self.table.lookup(now, dest)
        if r is not None:
            self._events.append(("found", dest, r[2]))
            return
        if dest not in self._searches:
            self._searches[dest] = [self.tries, now]
            self.poll(now)

    def searching(self, dest):
        """Whether a search for dest is running (False when none was asked, or it gave up)."""
        s = self._searches.get(dest)
        return s is not None and s[0] >= 0

    def _request(self, now, dest, ttl=0):
        self._rid = (self._rid + 1) % 256
        self.seq = (self.seq + 1) % SEQ_MOD
        known = self.table.seq(dest)
        # a ring of ttl relays: the count starts that far below MAX_HOPS, where relays stop
        payload = W.encode_request(self._rid, self.node_id, self.seq, dest, known if known >= 0 else W.UNKNOWN_SEQ,
                                   W.MAX_HOPS - ttl if ttl else 0, 0)
        self._remember((self.node_id, self._rid))
        for link in self.links:
            self._out.append((now, link, BROADCAST, payload))
        self.stats["requests"] += 1

    def poll(self, now):
        """Retries and give-ups of the searches that are due."""
        for dest in list(self._searches):
            s = self._searches[dest]
            if ticks_diff(now, s[1]) < 0:
                continue
            if s[0] < 0:
                del self._searches[dest]  # held off long enough: the next find() asks again
                continue
            if s[0] == 0:
                self._events.append(("unreachable", dest))
                if self.hold_ms > 0:
                    s[0] = -1
                    s[1] = ticks_add(now, self.hold_ms)
                else:
                    del self._searches[dest]
                continue
            # the first try of a search asks only within `ring` relays (AODV's expanding ring):
            # a route that broke, or a node that moved, is mostly still near, and a ring costs the
            # nodes around, not the whole network; it waits a tenth of search_ms per relay
            ttl = self.ring if s[0] == self.tries else 0
            s[0] -= 1
            s[1] = ticks_add(now, self.search_ms * ttl // 10 if ttl else self.search_ms)
            self._request(now, dest, ttl)

    # -- hearing ---------------------------------------------------------------------------------
    def heard(self, now, link, hop, payload):
        """A route control payload from neighbour hop on link; bad bytes are counted and dropped."""
        try:
            m = W.decode(payload)
        except DecodeError:
            self.stats["bad"] += 1
            return
        if m[0] == "request":
            self._on_request(now, link, hop, m)
        elif m[0] == "reply":
            self._on_reply(now, link, hop, m)
        elif m[0] == "error":
            self._on_error(now, link, hop, m[1])
        else:
            self.stats["bad"] += 1  # a flood's, which is acomm.transport.flood's to take

    def _cost(self, now, link, hop):
        c = self.hop_cost(now, link, hop)
        return self.unknown_cost if c is None else c

    def _remember(self, key):
        self._seen.append(key)
        if len(self._seen) > self.seen_cap:
            self._seen.pop(0)

    def _on_request(self, now, link, hop, m):
        _, rid, origin, oseq, dest, dseq, hops, cost = m
        if origin == self.node_id:
            self.stats["duplicates"] += 1
            return
        cost = cost + self._cost(now, link, hop)
        # the reverse route, to the origin through the hop it came by; from every copy, not only
        # the first: the first to arrive is the luckiest draw of the jitter, often a detour, and
        # the reply, which goes back by these routes, is lost more often the more hops it takes
        self.table.offer(now, origin, hop, link, cost, oseq, self.lifetime_ms)
        if (origin, rid) in self._seen:
            self.stats["duplicates"] += 1
            return
        self._remember((origin, rid))
        if hop != origin:
            self.table.offer(now, hop, hop, link, self._cost(now, link, hop), -1, self.lifetime_ms)
        if dest == self.node_id:
            if dseq != W.UNKNOWN_SEQ and seq_newer(dseq, self.seq):
                self.seq = dseq
            self.seq = (self.seq + 1) % SEQ_MOD
            self._out.append((now, link, hop, W.encode_reply(self.node_id, self.seq, origin, 0, 0, self.lifetime_ms)))
            self.stats["replies"] += 1
            return
        if hops >= W.MAX_HOPS:
            return
        later = ticks_add(now, self._rng.below(self.jitter_ms + 1)) if self.jitter_ms else now
        fwd = W.encode_request(rid, origin, oseq, dest, dseq, hops + 1, cost)
        for out_link in self.links:
            self._out.append((later, out_link, BROADCAST, fwd))
        self.stats["rebroadcasts"] += 1

    def _on_reply(self, now, link, hop, m):
        _, dest, dseq, origin, hops, cost, lifetime = m
        cost = cost + self._cost(now, link, hop)
        self.table.offer(now, dest, hop, link, cost, dseq, lifetime)
        if origin == self.node_id:
            if dest in self._searches:
                del self._searches[dest]  # found (even after a give-up: a late reply is news)
            r = self.table.lookup(now, dest)
            if r is not None:
                self._events.append(("found", dest, r[2]))
            return
        back = self.table.lookup(now, origin)
        if back is None or hops >= W.MAX_HOPS:
            return  # no way back: the origin will ask again
        self._out.append((now, back[1], back[0], W.encode_reply(dest, dseq, origin, hops + 1, cost, lifetime)))

    def _on_error(self, now, link, hop, lost):
        dropped = []
        for dest, seq in lost:
            r = self.table.lookup(now, dest)
            if r is not None and r[0] == hop and r[1] == link:
                x = self.table.invalidate_dest(now, dest)
                if x is not None:
                    dropped.append(x)
        # routes not through that hop stand, and the error stops here when none was
        self._error(now, dropped)

    def hop_failed(self, now, hop, link):
        """The link could not deliver to hop: its routes turn invalid, one error goes out."""
        self._error(now, self.table.invalidate(now, hop, link))

    def _error(self, now, lost):
        lost = [x for x in lost if x[1] >= 0]  # a neighbour's own route has no number to name
        while lost:
            chunk, lost = lost[:W.MAX_ERRORS], lost[W.MAX_ERRORS:]
            payload = W.encode_error(chunk)
            for link in self.links:
                self._out.append((now, link, BROADCAST, payload))
            self.stats["errors"] += 1

    # -- what to send ------------------------------------------------------------------------------
    def take(self):
        out, self._out = self._out, []
        return out

    def take_events(self):
        out, self._events = self._events, []
        return out

