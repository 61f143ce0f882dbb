# Which of a node's steps in the simulated World do nothing, so that the
# World may skip them and still run the same (acomm_sim.world; "How the
# World saves work" in docs/simulator.md). Each function answers for a node
# that is one plain link on a transparent driver (plain()): when its next
# step that does something is, given the step the World would have taken
# next. They read the link's, its queue's and its Discovery's state (some of
# it private: the simulator is the core's test bench); a guess is always
# checked against the link's own idle(), and whatever they cannot tell
# gives the step the World took before. Portable Python.

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
    # (no other links, no transport, its own step, no frame pump),
    # else None: the only nodes whose empty steps _idle_wake,
    # _slot_wake and _busy_wake know to skip
    node = sn.node
    if sn.extra or node.transport is not None or sn.step != node.step:
        return None
    if node._pumps.get(link.name) is not None:
        return None
    d = link.driver
    if d.__class__ is MacDriver:
        d = d.driver
    return d if isinstance(d, TransparentDriver) else None

def slot_wake(sn, link, now, start, q):
    # A node with frames queued for its TDMA slot or the end of its ALOHA
    # backoff (at `start`, beyond max_quiet_ms) is stepped every
    # max_quiet_ms until then; those steps do nothing but ask the MAC
    # (ALOHA's is asked later: World._catch_up) unless a queued frame's
    # lifespan ends or a peer falls due to be declared lost.
    # -> the first of those steps at which a frame expires, else
    # `start`; None when a loss may fall due before (stepped as before).
    d = plain(sn, link)
    if d is None or not d.ready(now):
        return None
    if link.discovery.loss_due(start):
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
    if isinstance(link.driver.mac, Aloha):
        # each skipped step asked ALOHA's may_start(): asked later
        sn.replay = (now, q, link.driver)
    return w

def busy_wake(sn, link, now):
    # A link sending over a transparent driver is stepped at every step
    # until the modem's airtime has passed (the driver's _busy_until).
    # With nothing queued, no acknowledgement awaited and no peer to be
    # declared lost before then, those steps do nothing: the node's next
    # step is then. Otherwise None (the next step), as before.
    d = plain(sn, link)  # a MAC is not asked while the link sends
    if d is None or len(link.queue) or d.ready(now):
        return None
    if link._fl.state == _SLOT_IDLE or len(link._acks):
        return None
    t = d._busy_until
    if ticks_diff(t, now) <= 0 or link.discovery.loss_due(t):
        return None
    return t

def idle_wake(sn, link, now, q):
    # A node stepped again and again every max_quiet_ms with nothing to
    # do: its next step that does something is the first of those at
    # which its link is no longer idle (an advert or a peer's loss
    # falls due). For a node whose steps in between do nothing at all
    # (one link, no transport, a transparent driver that is ready, an
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
    if md is not None and isinstance(md.mac, Aloha):
        # each skipped step asked ALOHA's may_start(): asked later
        sn.replay = (now, q, md)
    # link.idle(t) turns False once a timer is due and stays so. First
    # a guess from the timers themselves (the advert's and the loss
    # check's), kept when idle() agrees at that step and the one before;
    # else a search for the first multiple of q, up to _IDLE_HORIZON
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
