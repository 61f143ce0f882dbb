# Requests that are on their way and waiting for an acknowledgement.
#
# The link does not stop while it waits: the channel is free as soon as a
# frame has left, so other frames (an alarm above all) may go meanwhile. This
# table remembers at most `window` waiting requests; the link stops starting
# new acknowledged requests while it is full, which bounds memory and keeps
# sequence numbers from being reused while still awaited.

from ..compat import ticks_diff


class AckTable:
    def __init__(self, window=4):
        self.window = window
        self._e = []  # [req, handle, dst_id, seq, ack_deadline]

    def __len__(self):
        return len(self._e)

    def full(self):
        return len(self._e) >= self.window

    def add(self, req, handle, dst_id, seq, ack_deadline):
        self._e.append([req, handle, dst_id, seq, ack_deadline])

    def _take(self, i):
        return self._e.pop(i)[0]

    def by_ack(self, dst_id, seq, take=True):
        # the request that an ACK frame (source dst_id, sequence seq) confirms;
        # take=False leaves it waiting (a sealed ACK is checked against it first)
        for i in range(len(self._e)):
            e = self._e[i]
            if e[2] == dst_id and e[3] == seq:
                return self._take(i) if take else e[0]
        return None

    def by_handle(self, handle):
        for i in range(len(self._e)):
            if self._e[i][1] == handle:
                return self._take(i)
        return None

    def by_req_id(self, req_id):
        for i in range(len(self._e)):
            if self._e[i][0].req_id == req_id:
                return self._take(i)
        return None

    def seq_in_use(self, dst_id, seq):
        for e in self._e:
            if e[2] == dst_id and e[3] == seq:
                return True
        return False

    def due(self, now):
        # (request, expired) pairs whose lifespan or ack time ran out, removed.
        out = None
        i = 0
        while i < len(self._e):
            e = self._e[i]
            expired = ticks_diff(now, e[0].deadline) >= 0
            if expired or ticks_diff(now, e[4]) >= 0:
                self._e.pop(i)
                if out is None:
                    out = []
                out.append((e[0], expired))
            else:
                i += 1
        return out or ()
