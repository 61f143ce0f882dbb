# Duplicate suppression at the receiver: a frame whose (key, sequence)
# was seen within the last `window_ms` is a copy (a retry whose first
# acknowledgement was lost, or an echo). The link's key is the source and
# destination (senders number frames per destination). Memory is bounded: `slots` recent
# sequence numbers per key, and at most `max_sources` keys (beyond that
# the table starts afresh, which can only let a copy through, never drop new
# data).

from ..compat import const, ticks_diff

_DEFAULT_SLOTS = const(8)


class DuplicateFilter:
    def __init__(self, window_ms=60000, slots=_DEFAULT_SLOTS, max_sources=255):
        self.window_ms = window_ms
        self._slots = slots
        self._max = max_sources
        self._recent = {}  # src -> list of [seq, time]

    def seen(self, src, seq, now):
        lst = self._recent.get(src)
        if lst is None:
            if len(self._recent) >= self._max:
                self._recent.clear()
            lst = []
            self._recent[src] = lst
        for e in lst:
            if e[0] == seq and ticks_diff(now, e[1]) < self.window_ms:
                e[1] = now
                return True
            if e[0] == seq:
                e[1] = now  # same number, but long ago: new data
                return False
        if len(lst) >= self._slots:
            lst.pop(0)
        lst.append([seq, now])
        return False
