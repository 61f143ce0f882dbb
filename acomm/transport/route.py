# Which link and next hop carry a packet of the transport (seed 000 section
# V: the transport picks the link from the capability adverts and the link
# availability the links report).
#
# The next hop is the static route for the final destination (routes: final
# name -> next hop name, e.g. diver -> auv -> buoy), else the destination
# itself. The candidate links are those the packet's medium allows (None or
# "any": every link; a name or a kind such as "acoustic" or "satellite":
# the links of that name or kind; "all" is the transport's: one copy per
# link), that have an address for the hop, and whose discovery has not
# declared the hop lost. Among them, in this order:
#   1. not stalled before stalled: the transport's polls went unanswered on
#      a stalled link and nothing has been heard from the hop there since;
#   2. for urgent packets (priority <= urgent) the expected time to get the
#      packet there (the link's latency plus its size at the link's bit
#      rate), then its cost (size x cost per byte); for the others the cost
#      first, then the time;
#   3. the hop heard on the link before not heard yet (a satellite link
#      carries no adverts, so this only breaks ties).
# So a nearby node is reached acoustically, for free, and Iridium carries
# the packet when the acoustic path is gone.
#
# With learned routes (`routing`, acomm.transport.routing.Routing; only when
# the transport was made with routing on, and never for a destination with
# a static route): on a routing link the hop is the destination when it is
# heard there, else the learned route's next hop when that route leaves by
# this link, else the link is no candidate. Next come the links that do
# not route (satellite: the destination is the hop there). When none of
# these can carry it, a search starts and the packet waits for its route
# (until it expires): a destination in range answers the search itself,
# so a blind direct try would only spend airtime.

from ..compat import const, ticks_diff

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_AVAILABLE = const(1)
_UNAVAILABLE = const(2)
_DIRECT = const(0)  # every allowed link, the destination as the hop
_LEARNED = const(1)  # routing links only, by their learned or heard hop
_UNROUTED = const(2)  # links that do not route only

MEDIUM_ANY = "any"
MEDIUM_ALL = "all"


class Router:
    def __init__(self, names, links, routes=None, urgent=4):
        self.names = names
        self.node_links = links  # link name -> Link, the node's (read live)
        self.routes = dict(routes or {})  # final destination name -> next hop name
        self.urgent = urgent
        self._stalled = {}  # (link name, hop id) -> ticks when the transport gave up there
        self.routing = None  # acomm.transport.routing.Routing, when routes are learned

    def next_hop(self, final):
        names = self.names
        hop_name = self.routes.get(names.name_of(final))
        if hop_name is None:
            return final
        return names.id_of(hop_name)

    def links(self, medium):
        # the links a medium allows, in the node's order
        out = []
        links = self.node_links
        for name in links:
            link = links[name]
            if medium is None or medium == MEDIUM_ANY or medium == MEDIUM_ALL or medium == name or medium == link.medium:
                out.append(link)
        return out

    def stall(self, link, hop, now):
        self._stalled[(link.name, hop)] = now

    def _reach(self, link, hop):
        st = link.discovery.state(hop)
        if st == _UNAVAILABLE:
            return None
        since = self._stalled.get((link.name, hop))
        if since is not None:
            heard = link.discovery.last_heard(hop)
            if heard is None or ticks_diff(heard, since) <= 0:
                return 1, 1
            del self._stalled[(link.name, hop)]
        return 0, 0 if st == _AVAILABLE else 1

    def choose(self, final, size, priority, medium, now=0):
        # -> (link, next hop id), or None while no allowed link can reach it
        hop = self.next_hop(final)
        if hop is None:
            return None
        rt = self.routing
        if rt is None or hop != final:
            return self._best(hop, size, priority, medium, now, _DIRECT)
        # learned routes first, then the links that do not route (satellite);
        # else a search, and the packet waits for its route
        r = self._best(final, size, priority, medium, now, _LEARNED)
        if r is None:
            r = self._best(final, size, priority, medium, now, _UNROUTED)
            if r is None:
                rt.search(now, final)
        return r

    def _best(self, final, size, priority, medium, now, mode):
        rt = self.routing
        best = None
        for link in self.links(medium):
            hop = final
            if mode != _DIRECT:
                if rt.routes_on(link) != (mode == _LEARNED):
                    continue
                if mode == _LEARNED:
                    hop = rt.hop_on(now, link, final)
                    if hop is None:
                        continue
            if not link.addressable(hop):
                continue
            reach = self._reach(link, hop)
            if reach is None:
                continue
            # the driver's own figures: Link.caps copies them (a Capabilities and its table grown
            # six times on a board's heap, per link and choice) to change only the MTUs and flags
            c = link.driver.caps
            ms = c.latency_ms + (size * 8000 // c.bitrate if c.bitrate else 1 << 30)
            money = size * c.cost_tx
            if priority <= self.urgent:
                score = (reach[0], ms, money, reach[1])
            else:
                score = (reach[0], money, ms, reach[1])
            if best is None or score < best[0]:
                best = (score, link, hop)
        return None if best is None else (best[1], best[2])
