# The link's ranging job (seed 000's ranging request and range received):
# Link.range() queues one request that pings each named node in turn on the
# link's transmission slot, then reports the ranges and one final status.
# A module of its own, imported by the first range(): a node that never
# ranges (a relay buoy) does not carry this code on its heap. It works on
# the Link's slot and helpers (it is part of the Link, kept apart).
#
# The job's request carries meta = [-2, (ids, results, next index)]; between
# two pings it stays in the slot (kind _K_PING, state idle) and Link.poll()
# sends the next ping when the driver is ready, or finishes the job once its
# lifespan is over.

from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError
from .txqueue import TxRequest

# the link's slot states and kinds, and acomm.events' codes, as private
# constants (tests/cpython/test_const_copies.py checks them)
_IDLE = const(0)
_SENDING = const(1)
_K_PING = const(3)
_CAP_RANGING = const(16)
_MAX_LIFESPAN_MS = const(0x10000000)
_DELIVERED = const(5)
_FAILED = const(8)
_TRANSMITTING = const(2)
_EV_RANGE_RECEIVED = const(24)


def request(link, now, req_id, names, lifespan_s, priority):
    """Link.range(): queues the job -> True when accepted, else a refusal (False, status `failed`)."""
    if not link.driver.caps.has(_CAP_RANGING):
        return link._refuse(req_id, "%s cannot measure range" % link.name)
    if req_id in link._active:
        return link._refuse(req_id, "request id %d is already in use" % req_id)
    life_ms = int(lifespan_s * 1000)
    if life_ms <= 0 or life_ms > _MAX_LIFESPAN_MS:
        return link._refuse(req_id, "lifespan must be positive and below %d s" % (_MAX_LIFESPAN_MS // 1000))
    if not names:
        return link._refuse(req_id, "no node to range")
    ids = []
    for n in names:
        try:
            nid = link._resolve(n)
        except AcommError as e:
            return link._refuse(req_id, str(e))
        if nid is None:
            return link._refuse(req_id, "cannot range the broadcast address")
        ids.append(nid)
    req = TxRequest(req_id, None, priority, ticks_add(now, life_ms), b"")
    req.meta = [-2, (ids, [None] * len(ids), [0])]
    return link._enqueue(req, now)


def ping_next(link, now):
    """Pings the job's next node (the job is in the link's slot)."""
    fl = link._fl
    req = fl.req
    ids, _, idx = req.meta[1]
    nid = ids[idx[0]]
    fl.kind = _K_PING
    fl.state = _SENDING
    if idx[0] == 0:
        link._status(req.req_id, _TRANSMITTING)
    link._last_tx = now
    try:
        fl.handle = link.driver.ping(now, link.addr_map.addr_of(nid))
    except AcommError:
        fl.handle = None
        result(link, now, None)  # this node gets no range; go on


def result(link, now, metres):
    """The driver's answer to the job's ping (metres, or None for none): the next ping, or the end."""
    fl = link._fl
    req = fl.req
    ids, results, idx = req.meta[1]
    results[idx[0]] = metres
    idx[0] += 1
    if fl.canceled:
        fl.clear()
        return
    if idx[0] < len(ids) and ticks_diff(now, req.deadline) < 0:
        fl.state = _IDLE  # Link.poll() sends the next ping when the driver is ready
        if link.driver.ready(now):
            ping_next(link, now)
        return
    finish(link, req)


def finish(link, req):
    """Ends the job: EV_RANGE_RECEIVED, then `delivered` with at least one range, else `failed`."""
    ids, results, _ = req.meta[1]
    link._fl.clear()
    names = [link.names.name_of(i) for i in ids]
    link._emit((_EV_RANGE_RECEIVED, link, req.req_id, names, results))
    got = 0
    for r in results:
        if r is not None:
            got += 1
    if got:
        link._final(req, _DELIVERED, "%d of %d ranges" % (got, len(ids)))
    else:
        link._final(req, _FAILED, "no range reply")
