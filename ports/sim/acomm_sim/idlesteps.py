# Which of a node's steps in the simulated World do nothing, so that the
# World may skip them and still run the same (acomm_sim.world; "How the
# World saves work" in docs/simulator.md). Each function answers for a node
# that is one plain link on a transparent driver (plain()): when its next
# step that does something is, given the step the World would have taken
# next. They read the link's, its queue's and its Discovery's state (some of
# it private: the simulator is the core's test bench); a guess is always
# checked against the link's own idle(), and whatever they cannot tell
# gives the step the World took before. Portable Python.

import sys

from acomm.compat import ticks_add, ticks_diff
from acomm.drivers.mac import Aloha, MacDriver, Tdma
from acomm.drivers.transparent import TransparentDriver

_SLOT_IDLE = 0  # acomm.link's _IDLE (a private const there): no frame or ping on the air

# MACs whose questions a skipped step may leave out: TDMA's may_start()
# depends on the time only; ALOHA's draws depend on the times it was asked
# at, so the World asks it later, at those times (World._catch_up). Only
# the MacDriver's `held` count (of ready() calls answered "not yet") comes
# out lower under TDMA: it counts the polls.
MACS = (Tdma, Aloha)

# how many max_quiet_ms an idle node may sleep at most (_idle_wake)
_IDLE_HORIZON = 4096


def _timer_steps(link, now, q):
    # how many q from now the link's first timer falls due (a guess, checked
    # by the caller), or None; reads the link's and its Discovery's fields
    disc = link.discovery
    last = getattr(link, "_last_tx", None)
    wait = getattr(disc, "_wait", None)
    due = getattr(disc, "_next", None)
    if last is not None and wait is not None:
        adv = ticks_add(last, wait)
        if due is None or ticks_diff(adv, due) < 0:
            due = adv
    if due is None:
        return None
    k = (ticks_diff(due, now) + q - 1) // q
    return k if 1 <= k <= _IDLE_HORIZON else None



def plain(sn, link):
    # the node's transparent driver when the node is one plain link
    # (no other links, its own step, no frame pump; a transport only
    # when transport_due can tell when it has work), else None: the
    # only nodes whose empty steps _idle_wake, _slot_wake and
    # _busy_wake know to skip
    node = sn.node
    if sn.extra or sn.step != node.step:
        return None
    io = node._io.get(link.name)  # [stream, frame pump or None, unsent]
    if io is not None and io[1] is not None:
        return None
    d = link.driver
    if d.__class__ is MacDriver:
        d = d.driver
    return d if isinstance(d, TransparentDriver) else None


def _earlier(a, b):
    return b if a is None or (b is not None and ticks_diff(b, a) < 0) else a


def _const(obj, name):
    # a private const of obj's module, or None (MicroPython keeps no such
    # name in the module, and a class may have no __module__ there)
    return getattr(sys.modules.get(getattr(obj.__class__, "__module__", None)), name, None)


def transport_due(sn, now):
    # When the node's transport (acomm.transport) next has work of its
    # own: the time of its first due search retry, held control frame,
    # flood rebroadcast, reassembly to forget or packet's (_packets): the
    # first time at or after which its poll() does something; None when
    # it has no timer, or False when it may have work at any step
    # (fragments to hand the link, route control waiting to be taken) or its
    # state is not what this reads (the transport changed: nothing is
    # skipped). A node with a transport is stepped every max_quiet_ms
    # otherwise, most of a routed network's steps, and they do nothing
    # when this says so. Reads private fields: the simulator is the
    # core's test bench.
    t = sn.node.transport
    if t is None:
        return None
    out = getattr(t, "_out", None)
    rx = getattr(t, "_rx", None)
    if out is None or rx is None:
        return False
    rt = t.router.routing
    due = None
    if out:
        due = _packets(sn, t, rt, now)
        if due is False:
            return False
    if rx:
        # _rx_poll forgets a reassembly once now - touched > its timeout
        timeout = _const(t, "_RX_TIMEOUT_MS")
        if timeout is None:
            return False
        for r in rx.values():
            due = _earlier(due, ticks_add(r.touched, timeout + 1))
    if rt is None:
        return due
    f = getattr(rt, "finder", rt)
    if getattr(f, "_out", None) or getattr(f, "_events", None):
        return False  # what a search or a request heard made: taken at the next poll
    searches = getattr(f, "_searches", None)
    held = getattr(rt, "_held", None)
    if searches is None or held is None:
        return False
    for s in searches.values():
        due = _earlier(due, s[1])
    for item in held:
        due = _earlier(due, item[0])
    fl = rt.flooder
    if fl is not None:
        ms = fl.next_ms(now)
        if ms is not None:
            due = _earlier(due, ticks_add(now, ms))
    return due


def _packets(sn, t, rt, now):
    # The transport's packets (its _out) when its poll does nothing for
    # them until a time: a transfer whose poll is out (the link's SACK
    # awaited: its timer, or the poll still on the air) or whose pipeline
    # is full, and a packet that waits for a route while a search for its
    # destination runs or is held off (each poll asks the router in vain
    # until a route or the destination's adverts are heard: a packet, so
    # the node is stepped), up to the packet's wait after a full relay
    # and its expiry on the transport's wall clock, which the World's
    # clock gives when the node says how (sn.wall_unit_ms: wall seconds =
    # ticks // it, as RoutedNet's nodes have). -> the first of those
    # times, or False when a poll may do more (fragments to hand the
    # link, a static route, a route or neighbour there, no search).
    unit = sn.wall_unit_ms
    pipeline = _const(t, "_PIPELINE")
    if unit is None or pipeline is None:
        return False
    held = []  # the links with a poll out, as Transport.poll finds them
    for p in t._out:
        if p.out is not None and (p.polling or p.timer is not None) and p.link not in held:
            held.append(p.link)
    due = None
    routed = None
    for p in t._out:
        due = _earlier(due, p.expiry * unit)
        if p.out is not None:
            if p.timer is not None:
                due = _earlier(due, p.timer)
            elif p.link not in held and p.inflight < pipeline:
                return False
            continue
        if routed is None:
            routed = _routed(t, rt)
            if routed is False:
                return False
        searches, routes, valid, expires, avail, links = routed
        if p.final not in searches:
            return False
        r = routes.get(p.final)
        if r is not None and r[valid] and ticks_diff(r[expires], now) > 0:
            return False  # a live route: it is looked up (and marked used) at every poll
        for name in links:
            if links[name].discovery.state(p.final) == avail:
                return False
        if p.wait is not None:
            due = _earlier(due, p.wait)
    return due


def _routed(t, rt):
    # what _packets reads of learned routing, or False when it cannot
    # (no routing, static routes, a link that does not route, fields it
    # does not know)
    if rt is None or t.router.routes:
        return False
    searches = getattr(rt, "_searches", None)
    routes = getattr(rt, "routes", None)
    valid, expires = _const(rt, "_VALID"), _const(rt, "_EXPIRES")
    links = t.router.node_links
    if searches is None or routes is None or valid is None or expires is None or not links:
        return False
    avail = None
    for name in links:
        if not rt.routes_on(links[name]):
            return False
        avail = _const(links[name].discovery, "_AVAILABLE")
    if avail is None:
        return False
    return searches, routes, valid, expires, avail, links


def _bound(w, due, now, q):
    # w, or the first step at or after `due` when it comes before w: the
    # node's steps are at now + k * q up to w, then w (None for q: every
    # step); None when `due` says "any step"
    if due is False:
        return None
    if due is None or ticks_diff(due, w) >= 0:
        return w
    if q is None:
        return due if ticks_diff(due, now) > 0 else None
    k = (ticks_diff(due, now) + q - 1) // q
    t = ticks_add(now, (k if k > 1 else 1) * q)
    return t if ticks_diff(t, w) < 0 else w


def slot_wake(sn, link, now, start, q):
    # A node with frames queued for its TDMA slot or the end of its ALOHA
    # backoff (at `start`, beyond max_quiet_ms) is stepped every
    # max_quiet_ms until then; those steps do nothing but ask the MAC
    # (ALOHA's is asked later: World._catch_up) unless a queued frame's
    # lifespan ends, an advert or a peer's loss falls due, or the
    # transport has work (transport_due).
    # -> the first of those steps at which a frame expires, the advert
    # falls due or the transport has work, else `start`; None when a loss
    # may fall due before (stepped as before).
    d = plain(sn, link)
    if d is None or not d.ready(now):
        return None
    if link.discovery.loss_due(start):
        return None
    due = transport_due(sn, now)
    if due is False:
        return None
    m = ticks_diff(start, now) // q  # the steps at now + k * q, k = 1..m
    first = None
    for req in link.queue:
        if first is None or ticks_diff(req.deadline, first) < 0:
            first = req.deadline
    w = start
    if first is not None and ticks_diff(start, first) >= 0:
        k = (ticks_diff(first, now) + q - 1) // q
        if k < 1:
            k = 1
        if k <= m:
            w = ticks_add(now, k * q)
    if not link.idle(w):
        # an advert falls due while the frames wait: from its step on the
        # node is stepped at every step (the link is busy), each asking the MAC
        a = _link_wake(link, now, q)
        if ticks_diff(a, w) < 0:
            w = a
    if isinstance(link.driver.mac, Aloha):
        # each skipped step asked ALOHA's may_start(): asked later
        sn.replay = (now, q, link.driver)
    return _bound(w, due, now, q)

def busy_wake(sn, link, now, q):
    # A link that is not idle is stepped at every step (q ms apart). For a
    # plain node those steps do nothing but ask its MAC, until the first
    # of: the driver's airtime ends (a frame on the air), the MAC lets it
    # send what it has (a frame queued, an ACK owed, an advert due), an
    # awaited acknowledgement's or a queued frame's time runs out, an
    # advert or a peer's loss falls due, or the transport's timer
    # (transport_due). -> that step, or None (the next step) when it
    # cannot tell. ALOHA's questions on the skipped steps are asked
    # later, at their times (World._catch_up).
    d = plain(sn, link)
    if d is None:
        return None
    fl = link._fl
    md = link.driver
    mac = md.mac if md.__class__ is MacDriver else None
    if mac is not None and not isinstance(mac, MACS):
        return None
    if fl.state != _SLOT_IDLE:
        # on the air: the MAC is not asked until the driver is ready
        if d.ready(now):
            return None
        w = d._busy_until
        mac = None
    else:
        if fl.req is not None or not d.ready(now):
            return None  # between a ranging job's pings; a driver not ready with nothing on the air
        disc = link.discovery
        last = link._last_tx
        wait = getattr(disc, "_wait", None)
        if wait is None:
            return None
        due = last is None or ticks_diff(now, last) >= wait
        w = None if due else ticks_add(last, wait)  # the advert
        if due or len(link.queue) or link._pending_acks:
            # something to send: it goes when the MAC lets it
            if mac is None:
                return None
            w = mac.next_start(now)
            if w is None or ticks_diff(w, now) <= 0:
                return None
    for e in link._acks._e:
        w = _earlier(w, e[0].deadline)
        w = _earlier(w, e[4])
    for req in link.queue:
        w = _earlier(w, req.deadline)
    w = _earlier(w, link.discovery._next)
    if w is None or ticks_diff(w, now) <= 0:
        return None
    w = _bound(w, transport_due(sn, now), now, None)
    if w is not None and isinstance(mac, Aloha):
        sn.replay = (now, q, md)
    return w


def idle_wake(sn, link, now, q):
    # A node stepped again and again every max_quiet_ms with nothing to
    # do: its next step that does something is the first of those at
    # which its link is no longer idle (an advert or a peer's loss
    # falls due, or its transport's timer: transport_due). For a node
    # whose steps in between do nothing at all (one link, a transport
    # with nothing in progress, a transparent driver that is ready, an
    # empty queue, no MAC, TDMA or ALOHA) that
    # step is found here, and the ones before it are skipped: the node
    # does the same things at the same times. Anything that reaches it
    # (bytes, a task, run()) wakes it earlier, as before. Under ALOHA
    # those steps asked the MAC whether it may send (it draws a new backoff
    # when the old one ran out): World._catch_up asks it, at the same
    # times, before the node's next step.
    cap = ticks_add(now, q)
    md = link.driver
    if md.__class__ is not MacDriver or md.mac is None:
        md = None
    elif not isinstance(md.mac, MACS):
        return cap
    d = plain(sn, link)
    if d is None or len(link.queue) or not d.ready(now):
        return cap
    due = transport_due(sn, now)
    if due is False:
        return cap
    if md is not None and isinstance(md.mac, Aloha):
        # each skipped step asked ALOHA's may_start(): asked later
        sn.replay = (now, q, md)
    # link.idle(t) turns False once a timer is due and stays so. First
    # a guess from the timers themselves (the advert's and the loss
    # check's), kept when idle() agrees at that step and the one before;
    # else a search for the first multiple of q, up to _IDLE_HORIZON
    return _bound(_link_wake(link, now, q), due, now, q)


def _link_wake(link, now, q):
    # the first step now + k * q at which the idle link has work
    k = _timer_steps(link, now, q)
    if k is not None and not link.idle(ticks_add(now, k * q)) and (k == 1 or link.idle(ticks_add(now, (k - 1) * q))):
        return ticks_add(now, k * q)
    lo, hi = 0, _IDLE_HORIZON
    if link.idle(ticks_add(now, hi * q)):
        return ticks_add(now, hi * q)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if link.idle(ticks_add(now, mid * q)):
            lo = mid
        else:
            hi = mid
    return ticks_add(now, hi * q)
