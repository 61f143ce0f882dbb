# The name table: canonical system names <-> node ids <-> interface addresses.
#
# A node has a canonical name (a string, as in seed 000) and a network-wide
# node id (0..254 and 256..65534, what acomm's raw frame header and adverts
# carry; 255 is broadcast). Each
# interface may address nodes differently (a Micro-Modem knows 1..15, an
# Iridium modem an IMEI), so each link keeps its own id <-> address map.
# Entries come from static configuration and from adverts heard on the links.
# Capacity is bounded: a table holds at most `capacity` names; learning a new
# one when full is refused (static entries are never displaced).

from ..errors import AcommError


class NameTable:
    def __init__(self, capacity=64):
        self._cap = capacity
        self._by_name = {}
        self._by_id = {}

    def add(self, name, node_id):
        if not 0 <= node_id <= 65534 or node_id == 255:
            raise AcommError("node id %d is not 0..254 or 256..65534" % node_id)
        old = self._by_id.get(node_id)
        if old is not None and old != name:
            del self._by_name[old]
        if name not in self._by_name and len(self._by_name) >= self._cap:
            raise AcommError("name table full (%d entries)" % self._cap)
        prev = self._by_name.get(name)
        if prev is not None and prev != node_id:
            del self._by_id[prev]
        self._by_name[name] = node_id
        self._by_id[node_id] = name

    def id_of(self, name):
        return self._by_name.get(name)

    def name_of(self, node_id):
        # Unknown ids still get a stable name, so a frame from a node that was
        # never configured can be reported.
        n = self._by_id.get(node_id)
        return n if n is not None else "node-%d" % node_id

    def learn(self, node_id):
        # Called when a node is heard: gives it a name if it has none yet.
        if node_id in self._by_id:
            return self._by_id[node_id]
        if len(self._by_name) >= self._cap:
            return "node-%d" % node_id
        name = "node-%d" % node_id
        if name in self._by_name:  # that name is configured for another id
            return name
        self.add(name, node_id)
        return name

    def names(self):
        return list(self._by_name)

    def __len__(self):
        return len(self._by_name)


class AddressMap:
    # Per-link map between node ids and interface addresses. By default the
    # interface address is the node id (raw links, EvoLogics); drivers with a
    # smaller address space configure explicit entries.
    def __init__(self, identity=True, broadcast=None):
        self._identity = identity
        self._to_addr = {}
        self._to_id = {}
        self.broadcast = broadcast

    def set(self, node_id, addr):
        old = self._to_addr.get(node_id)
        if old is not None:
            self._to_id.pop(old, None)
        self._to_addr[node_id] = addr
        self._to_id[addr] = node_id

    def addr_of(self, node_id):
        a = self._to_addr.get(node_id)
        if a is None and self._identity:
            return node_id
        return a

    def id_of(self, addr):
        i = self._to_id.get(addr)
        if i is None and self._identity and isinstance(addr, int) and 0 <= addr <= 254:
            return addr
        return i
