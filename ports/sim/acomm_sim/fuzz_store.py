# Fuzz target for the store's recovery (acomm_sim.fuzz has the engine):
# valid store files are written with acomm.transport.store.Store on a real file, a
# case writes a mutated copy to disk and reopens it. Oracle: only acomm
# errors escape open/keys/get/recover; every record that survives is one
# that was written, byte for byte, under its key; and the reopened store
# still takes a put that survives the next reopen. PacketStore.recover()
# then runs over what survived.

import os

from acomm.errors import AcommError
from acomm.transport.packetstore import PacketStore
from acomm.prng import Prng
from acomm.transport.store import Store

from .fuzz_base import Failure


def _rm(p):
    try:
        os.remove(p)
    except OSError:
        pass


class StoreTarget:
    name = "store"

    def __init__(self, tmpdir=None):
        base = (tmpdir or "/tmp") + "/acomm-fuzz-%d" % (Prng(id(self) & 0xFFFF).next32() & 0xFFFFFF)
        self.path = base + ".store"
        self.written = {}  # key -> [every value put under it]
        self.corpus = []
        rng = Prng(201)
        for n in range(4):
            self._clean()
            s = Store(self.path, capacity_bytes=4096, max_record=200, sync=False)
            ps = PacketStore(s)
            for i in range(6 + n * 3):
                k = rng.below(12) if n & 1 else (rng.below(4) << 24) | rng.below(40)
                v = rng.bytes(rng.below(60))
                self.written.setdefault(k, []).append(v)
                s.put(k, v)
                if rng.chance(0.2):
                    s.delete(k)
            ps.next_pid()  # the packet store's id-limit record
            s.close()
            with open(self.path, "rb") as f:
                self.corpus.append(f.read())
        self._clean()

    def _clean(self):
        _rm(self.path)
        _rm(self.path + ".tmp")

    def run(self, data, rng):
        self._clean()
        try:
            with open(self.path, "wb") as f:
                f.write(data)
            self._check(rng)
        finally:
            self._clean()

    def _check(self, rng):
        s = Store(self.path, capacity_bytes=4096, max_record=200, sync=False)
        try:
            for k in s.keys():
                v = s.get(k)
                if v is None:
                    continue  # found corrupt on read: dropped, allowed
                if k == 0xFFFFFF and len(v) == 2:
                    continue  # the id-limit record PacketStore wrote
                if bytes(v) not in self.written.get(k, ()):
                    raise Failure("record under key 0x%x was never written" % k)
            PacketStore(s).recover()
            v = b"after recovery"
            s.put(0xABCDE, v)
        finally:
            s.close()
        s = Store(self.path, capacity_bytes=4096, max_record=200, sync=False)
        try:
            if s.get(0xABCDE) != v:
                raise Failure("a put after recovery did not survive a reopen")
        finally:
            s.close()


def targets(tmpdir=None):
    return [StoreTarget(tmpdir)]
