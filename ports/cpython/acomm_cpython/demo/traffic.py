# The demo's bookkeeping of every application packet: which request carried
# it, when it was queued, when it was last put on the air, when (and
# whether) it arrived. Rows go to acomm_sim.metrics.PacketLog, which gives
# PDR, latency with bootstrap intervals, jitter and the CSV.
#
# A receiver does not see request ids, only (source, destination, payload).
# Of the sends with that key that have been on the air and are not matched
# yet, the one put on the air most recently is the one arriving: a link has
# one frame on the air at a time, so an older unmatched copy is one that was
# lost (a lost heartbeat is not credited with a later one's arrival), and in
# a backlog that drains after an outage each frame arrives before the next
# identical one leaves.
from acomm.events import STATUS_NAMES, TRANSMITTING, is_final
from acomm_sim.metrics import PacketLog


class Traffic:
    def __init__(self, link_name="acoustic"):
        self.link_name = link_name
        self.log = PacketLog()
        self._by_req = {}  # (node, req_id) -> entry
        self._waiting = {}  # (src, dst, payload) -> [entry, ...] not matched yet
        self._n = 0
        # watch(node name, request id, dst, data, class, now): every send
        # (acomm demo --web shows the buoy's in the console's log)
        self.watch = None

    def send(self, sn, dst, data, cls, lifespan_s, priority, ack, now):
        # entry: [pid, on_air_at, cls, final status name or None, received_at]
        rid = sn.node.send(self.link_name, dst, data, lifespan_s, priority, ack, now=now)
        pid = self._n
        self._n += 1
        entry = [pid, None, cls, None, None]
        self.log.sent(pid, cls, "%s>%s" % (sn.name, dst), sn.name, dst, len(data), now)
        self._by_req[(sn.name, rid)] = entry
        self._waiting.setdefault((sn.name, dst, bytes(data)), []).append(entry)
        if self.watch is not None:
            self.watch(sn.name, rid, dst, data, cls, now)
        return entry

    def status(self, node_name, req_id, status, now):
        e = self._by_req.get((node_name, req_id))
        if e is None:
            return None
        if status == TRANSMITTING:
            e[1] = now
        elif is_final(status):
            e[3] = STATUS_NAMES[status]
        return e

    def received(self, src, dst, data, now):
        # -> the matched entry, or None (not one of ours: adverts never get here)
        cands = self._waiting.get((src, dst, bytes(data)))
        if not cands:
            return None
        best = None
        for e in cands:
            if e[1] is not None and (best is None or e[1] > best[1]):
                best = e
        if best is None:
            best = cands[0]  # heard before its TRANSMITTING status was seen
        cands.remove(best)
        best[4] = now
        self.log.received(best[0], now)
        return best

