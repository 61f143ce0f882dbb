# The transport's record store in RAM (tests, nodes without storage): a
# module of its own, imported only by what uses it, so that a board whose
# packets live in a file store (acomm.transport.store) does not carry its
# class and methods on the heap.

from ..compat import const
from ..errors import StoreFull

_REC_OVERHEAD = const(12)  # acomm.transport.store's record header and CRC, as packetstore counts it


class MemoryStore:
    """A record store in RAM with acomm.transport.store.Store's interface (put, delete, get, length, keys).

    For tests and nodes without storage. A capacity makes it apply a file
    store's limit (each record counted with the file's header and CRC);
    put() beyond it raises StoreFull and changes nothing.
    """

    def __init__(self, capacity_bytes=None, max_record=65535):
        self._d = {}
        self.capacity_bytes = capacity_bytes
        self.max_record = max_record
        self.live_bytes = 0

    def put(self, key, data):
        old = self._d.get(key)
        grow = len(data) + _REC_OVERHEAD - (0 if old is None else len(old) + _REC_OVERHEAD)
        if self.capacity_bytes is not None and self.live_bytes + grow > self.capacity_bytes:
            raise StoreFull("store full")
        self._d[key] = bytes(data)
        self.live_bytes += grow

    def delete(self, key):
        old = self._d.pop(key, None)
        if old is not None:
            self.live_bytes -= len(old) + _REC_OVERHEAD

    def get(self, key):
        return self._d.get(key)

    def length(self, key):
        d = self._d.get(key)
        return None if d is None else len(d)

    def keys(self):
        return list(self._d)
