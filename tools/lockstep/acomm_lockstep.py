# A board's node alone in a MicroPython process, stepped in lock with a
# simulated ocean that runs elsewhere (acomm_cpython.workloads.footprint_
# workload): the heap holds only what the board holds (node, links,
# drivers, transport, store), not the emulators or the other nodes, so
# `-X heapsize=` finds the board's own smallest heap.
#
#   micropython -X heapsize=24wk tools/lockstep/acomm_lockstep.py /path/config.py /tmp/store [rom.img]
#
# With rom.img (a ROMFS image of the board's lib/, `mpremote romfs build`)
# the modules are imported from a VfsRom mounted at /rom, so their bytecode
# runs in place as it does from a board's ROMFS partition or frozen into
# firmware. The unix port has no ROM partition: the image is read into one
# bytearray first thing, and the caller subtracts its size from the heap.
#
# Protocol on stdin/stdout, binary, one exchange per simulated step:
#   in:  b"T" now(4, big-endian) then per link: length(2) bytes
#        b"Q": stop; the process prints one JSON line of figures
#   out: per link: length(2) bytes the board wrote to that UART
import gc
import sys


def _mount_rom(path):
    # one allocation the size of the image, made before anything else so it
    # sits whole at the start of the heap, as a flash partition would
    import os
    import vfs

    img = bytearray(os.stat(path)[6])
    with open(path, "rb") as f:
        f.readinto(img)
    vfs.mount(vfs.VfsRom(img), "/rom")
    sys.path.insert(0, "/rom")
    return img


_ROM = None


class _Uart:
    # machine.UART as a board has it, behind the port's own UartStream: the
    # receive ring acomm_mp.start asks for (the link's rxbuf) and the
    # RP2040 port's default 256-byte transmit buffer, both on the heap
    # as on the board and allocated once, so the harness allocates nothing
    # per step but the bytes each read returns (machine.UART.read allocates
    # them too). Bytes beyond a full ring are lost, as in an overrun; a full
    # transmit buffer takes part of a write (the node keeps the rest).
    def __init__(self, rxbuf=1024, txbuf=256):
        self.rx = bytearray(rxbuf)
        self.rmv = memoryview(self.rx)
        self.head = 0
        self.count = 0
        self.tx = bytearray(txbuf)
        self.tmv = memoryview(self.tx)
        self.tn = 0
        self.overruns = 0

    def any(self):
        return self.count

    def read(self, n):
        # timeout=0, as acomm_mp.start opens it: what is waiting, up to n,
        # in one new bytes object, as machine.UART.read allocates it
        n = min(n, self.count)
        if not n:
            return None
        size = len(self.rx)
        h = self.head
        if h + n <= size:
            out = bytes(self.rmv[h : h + n])
        else:
            out = bytes(self.rmv[h:size]) + bytes(self.rmv[: n - (size - h)])
        self.head = (h + n) % size
        self.count -= n
        return out

    def write(self, data):
        n = min(len(data), len(self.tx) - self.tn)
        self.tmv[self.tn : self.tn + n] = memoryview(data)[:n]
        self.tn += n
        return n

    def fill(self, inp, n):
        # n bytes from the ocean process into the ring
        size = len(self.rx)
        while n:
            tail = (self.head + self.count) % size
            k = min(n, size - self.count, size - tail)
            if k:
                _read_into(inp, self.rmv[tail : tail + k])
                self.count += k
            else:
                k = min(n, len(_SCRATCH))
                _read_into(inp, memoryview(_SCRATCH)[:k])
                self.overruns += k
            n -= k


_SCRATCH = bytearray(64)
# a bare-metal port's stdout has no flush(): what it writes goes straight out
_FLUSH = hasattr(sys.stdout.buffer, "flush")
_HDR = bytearray(5)


def _read_into(inp, mv):
    got = 0
    while got < len(mv):
        k = inp.readinto(mv[got:])
        if not k:
            raise SystemExit(3)
        got += k


def _store(path):
    from acomm.store import Store

    def open_store(st):
        # the board's store on a real file, as on its flash
        return Store(path, capacity_bytes=st["capacity"], max_record=st["max_record"])

    return open_store


def main(path, store_path, rom=None):
    """Runs the board of config file `path` in lock with the ocean on stdin/stdout until b"Q"."""
    global _ROM
    if rom:
        _ROM = _mount_rom(rom)
    from acomm_mp.assemble import build

    # the config as start("config") loads it: by module name, released once
    # checked, so only the checked copy stays on the heap
    folder, slash, fname = path.rpartition("/")
    sys.path.insert(0, folder or slash or ".")
    from acomm_mp.start import load_config

    cfg = load_config(fname[:-3] if fname.endswith(".py") else fname)
    sys.path.pop(0)
    # every module the board runs, loaded before the node exists: what is
    # allocated then is mostly bytecode, which a ROMFS partition or firmware
    # with the modules frozen in (ports/micropython/manifest.py) keeps in
    # flash instead
    from acomm_mp.modems import driver_class

    for lk in cfg["links"]:
        driver_class(lk["modem"])
    import acomm.store  # noqa: F401
    import acomm_mp.runloop  # noqa: F401

    gc.collect()
    code = gc.mem_alloc()
    from acomm_mp.uartstream import UartStream

    ports = []

    def open_uart(lk):
        u = _Uart(lk["rxbuf"])
        ports.append(u)
        return UartStream(u)

    clock = [0]
    board = build(cfg, open_uart, lambda: clock[0], lambda: 1000000 + clock[0] // 1000, _store(store_path),
                  listener=lambda ev: None, say=lambda s: None)
    gc.collect()
    base = gc.mem_alloc()
    peak = base
    inp = sys.stdin.buffer
    out = sys.stdout.buffer
    hdr = memoryview(_HDR)
    while True:
        _read_into(inp, hdr[:1])
        if _HDR[0] == ord("Q"):
            break
        _read_into(inp, hdr[:4])
        now = int.from_bytes(_HDR[:4], "big")
        clock[0] = now
        for u in ports:
            _read_into(inp, hdr[:2])
            u.fill(inp, (_HDR[0] << 8) | _HDR[1])
        board.tick(now)
        a = gc.mem_alloc()
        if a > peak:
            peak = a
        for u in ports:
            _HDR[0] = u.tn >> 8
            _HDR[1] = u.tn & 0xFF
            out.write(hdr[:2])
            out.write(u.tmv[: u.tn])
            u.tn = 0
        if _FLUSH:
            out.flush()
    st = board.stats
    tx = rx = 0
    for name in board.node.links:
        s = board.node.links[name].stats
        tx += s.get("tx_frames", 0)
        rx += s.get("rx_frames", 0)
    print('{"peak": %d, "after_build": %d, "code": %d, "oom": %d, "errors": %d, "tx_frames": %d, "rx_frames": %d, "relayed": %d, "rom": %d, "overruns": %d}'
          % (peak, base, code, st["oom"], st["errors"], tx, rx, board.transport.stats["relayed"], len(_ROM) if _ROM else 0,
             sum(u.overruns for u in ports)))


if __name__ == "__main__":
    main(*sys.argv[1:4])
