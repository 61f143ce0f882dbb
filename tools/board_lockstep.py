# A board's node alone in a MicroPython process, stepped in lock with a
# simulated ocean that runs elsewhere (acomm_cpython.workloads.footprint_
# workload): the heap holds only what the board holds (node, links,
# drivers, transport, store), not the emulators or the other nodes, so
# `-X heapsize=` finds the board's own smallest heap.
#
#   micropython -X heapsize=24wk tools/board_lockstep.py /path/config.py /tmp/store
#
# Protocol on stdin/stdout, binary, one exchange per simulated step:
#   in:  b"T" now(4, big-endian) then per link: length(2) bytes
#        b"Q": stop; the process prints one JSON line of figures
#   out: per link: length(2) bytes the board wrote to that UART
import gc
import sys

from acomm_mp.assemble import build
from acomm_mp.boardconfig import check


class _Port:
    # the board's side of one UART: bytes from the modem wait in `rx`
    def __init__(self):
        self.rx = b""
        self.tx = bytearray()

    def any(self):
        return len(self.rx)

    def read(self, n=256):
        if not self.rx:
            return None
        d = self.rx[:n]
        self.rx = self.rx[n:]
        return d

    def write(self, b):
        self.tx.extend(b)
        return len(b)


def _read(inp, n):
    b = inp.read(n)
    while len(b) < n:
        more = inp.read(n - len(b))
        if not more:
            raise SystemExit(3)
        b += more
    return b


def _store(path):
    from acomm.store import Store

    def open_store(st):
        # the board's store on a real file, as on its flash
        return Store(path, capacity_bytes=st["capacity"], max_record=st["max_record"])

    return open_store


def main(path, store_path):
    g = {}
    with open(path) as f:
        exec(f.read(), g)
    cfg = check(g["CONFIG"])
    # every module the board runs, loaded before the node exists: what is
    # allocated then is mostly bytecode, which firmware with the modules
    # frozen in (ports/micropython/manifest.py) keeps in flash instead
    from acomm_mp.modems import driver_class

    for lk in cfg["links"]:
        driver_class(lk["modem"])
    import acomm.store  # noqa: F401
    import acomm_mp.runloop  # noqa: F401

    gc.collect()
    code = gc.mem_alloc()
    ports = []

    def open_uart(lk):
        p = _Port()
        ports.append(p)
        return p

    clock = [0]
    board = build(cfg, open_uart, lambda: clock[0], lambda: 1000000 + clock[0] // 1000, _store(store_path),
                  listener=lambda ev: None, say=lambda s: None)
    gc.collect()
    base = gc.mem_alloc()
    peak = base
    inp = sys.stdin.buffer
    out = sys.stdout.buffer
    while True:
        kind = _read(inp, 1)
        if kind == b"Q":
            break
        now = int.from_bytes(_read(inp, 4), "big")
        clock[0] = now
        for p in ports:
            n = int.from_bytes(_read(inp, 2), "big")
            if n:
                p.rx += _read(inp, n)
        board.tick(now)
        a = gc.mem_alloc()
        if a > peak:
            peak = a
        reply = bytearray()
        for p in ports:
            reply.extend(len(p.tx).to_bytes(2, "big"))
            reply.extend(p.tx)
            p.tx = bytearray()
        out.write(reply)
        out.flush()
    st = board.stats
    tx = rx = 0
    for name in board.node.links:
        s = board.node.links[name].stats
        tx += s.get("tx_frames", 0)
        rx += s.get("rx_frames", 0)
    print('{"peak": %d, "after_build": %d, "code": %d, "oom": %d, "errors": %d, "tx_frames": %d, "rx_frames": %d, "relayed": %d}'
          % (peak, base, code, st["oom"], st["errors"], tx, rx, board.transport.stats["relayed"]))


main(sys.argv[1], sys.argv[2])
