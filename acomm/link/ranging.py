# The ranging job of a Link (seed 000's "ranging request" and "range
# received"): one request that pings each named node in turn through the
# link's one transmission slot, and reports the ranges together. A mixin of
# Link, kept apart so link.py stays readable; it uses the link's slot
# (self._fl), queue, names and statuses.
#
# The slot's states are defined here because both modules use them.

from ..drivers.caps import CAP_RANGING
from ..compat import const, ticks_add, ticks_diff
from ..errors import AcommError
from .txqueue import TxRequest

# acomm.events' codes, as private constants: inlined, they cost a board no
# RAM (imported, each took a slot in this module's dict)
_DELIVERED = const(5)
_EV_RANGE_RECEIVED = const(24)
_FAILED = const(8)
_TRANSMITTING = const(2)

SLOT_IDLE = const(0)
SLOT_SENDING = const(1)  # a frame or ping is on the air
MAX_LIFESPAN_MS = const(1 << 28)  # 3.1 days: the queue's wrap-safe horizon


class Ranging:
    def range(self, now, req_id, names, lifespan_s, priority=2):
        """Pings each node named; EV_RANGE_RECEIVED (metres, None where none answered), then a final status."""
        if not self.driver.caps.has(CAP_RANGING):
            return self._refuse(req_id, "%s cannot measure range" % self.name)
        if req_id in self._active:
            return self._refuse(req_id, "request id %d is already in use" % req_id)
        life_ms = int(lifespan_s * 1000)
        if life_ms <= 0 or life_ms > MAX_LIFESPAN_MS:
            return self._refuse(req_id, "lifespan must be positive and below %d s" % (MAX_LIFESPAN_MS // 1000))
        if not names:
            return self._refuse(req_id, "no node to range")
        ids = []
        for n in names:
            try:
                nid = self._resolve(n)
            except AcommError as e:
                return self._refuse(req_id, str(e))
            if nid is None:
                return self._refuse(req_id, "cannot range the broadcast address")
            ids.append(nid)
        req = TxRequest(req_id, None, priority, ticks_add(now, life_ms), b"")
        # meta: [-2 marks ranging, (ids, results, next index)]
        req.meta = [-2, (ids, [None] * len(ids), [0])]
        return self._enqueue(req, now)

    def _ping_next(self, now):
        fl = self._fl
        req = fl.req
        ids, _, idx = req.meta[1]
        nid = ids[idx[0]]
        fl.kind = 3
        fl.state = SLOT_SENDING
        if idx[0] == 0:
            self._status(req.req_id, _TRANSMITTING)
        self._last_tx = now
        try:
            fl.handle = self.driver.ping(now, self.addr_map.addr_of(nid))
        except AcommError:
            fl.handle = None
            self._range_result(now, None)  # this node gets no range; go on

    def _range_result(self, now, metres):
        fl = self._fl
        req = fl.req
        ids, results, idx = req.meta[1]
        results[idx[0]] = metres
        idx[0] += 1
        if fl.canceled:
            fl.clear()
            return
        if idx[0] < len(ids) and ticks_diff(now, req.deadline) < 0:
            # the job stays in the slot (kind 3, state idle); poll() sends the
            # next ping when the driver is ready
            fl.state = SLOT_IDLE
            if self.driver.ready(now):
                self._ping_next(now)
            return
        self._finish_range(req)

    def _finish_range(self, req):
        ids, results, _ = req.meta[1]
        self._fl.clear()
        names = [self.names.name_of(i) for i in ids]
        self._emit((_EV_RANGE_RECEIVED, self, req.req_id, names, results))
        got = 0
        for r in results:
            if r is not None:
                got += 1
        if got:
            self._final(req, _DELIVERED, "%d of %d ranges" % (got, len(ids)))
        else:
            self._final(req, _FAILED, "no range reply")

