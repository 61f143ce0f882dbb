# The writer that tests/cpython/test_packet_crash.py kills: the transport's
# packet records (acomm.transport.packetstore) on an acomm.transport.store file. It accepts
# packets of up to 1500 bytes (up to 7 records of 256 bytes each) and
# finishes them at random, and reports each operation before it starts
# ("B...") and after it returned ("E..."; "F..." when the store was full),
# so the test knows which packets were acknowledged and which one was cut.
#
#   python packet_crash_writer.py PATH SEED [piecewise]

import io
import random
import sys

import acomm.transport.store
from acomm.errors import StoreFull
from acomm.transport.packetstore import PacketStore
from acomm.transport.store import Store
from store_crash_writer import Piecewise

CAPACITY = 48 * 1024
MAX_RECORD = 256


class Pkt:
    # what PacketStore needs of a transport packet
    __slots__ = ("key", "origin", "final", "pid", "prio", "expiry", "body", "compressed", "medium", "chunks", "size")

    def __init__(self, pid, body):
        self.origin, self.final, self.pid, self.prio, self.expiry = 2, 1, pid, 5, 2000000000
        self.key = (2 << 16) | pid
        self.body, self.compressed, self.medium, self.chunks = body, False, None, 0
        self.size = len(body)


def body(pid):
    # verifiable: derived from the packet id only
    n = 1 + (pid * 193) % 1500
    return bytes((pid * 131 + i * 7) & 0xFF for i in range(n))


def main(path, seed):
    rng = random.Random(seed)
    ps = PacketStore(Store(path, capacity_bytes=CAPACITY, max_record=MAX_RECORD))
    live = {}
    for s in ps.recover():
        live[s.pid] = Pkt(s.pid, ps.body(s.key))
        live[s.pid].chunks = s.chunks
    out = sys.stdout

    def say(line):
        out.write(line + "\n")
        out.flush()

    say("R")
    while True:
        if live and rng.random() < 0.4:
            pid = rng.choice(sorted(live))
            say("BD %d" % pid)
            ps.delete(live.pop(pid))
            say("ED %d" % pid)
        else:
            pid = ps.next_pid()
            p = Pkt(pid, body(pid))
            say("BP %d" % pid)
            try:
                ps.put(p)
            except StoreFull:
                say("FP %d" % pid)
                continue
            live[pid] = p
            say("EP %d" % pid)


if __name__ == "__main__":
    if sys.argv[3:] == ["piecewise"]:
        acomm.transport.store.open = lambda path, mode="r": Piecewise(io.open(path, mode, buffering=0))
    main(sys.argv[1], int(sys.argv[2]))
