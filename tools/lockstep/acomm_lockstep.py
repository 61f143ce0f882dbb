# A board's node alone in a MicroPython process, stepped in lock with a
# simulated ocean that runs elsewhere (acomm_cpython.bench.workloads.footprint_
# minute): the heap holds only what the board holds (node, links,
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
# Protocol on stdin/stdout, binary, one exchange per simulated step (a
# board's UART passes one byte at a time under QEMU, so quiet steps are one
# byte each way):
#   out, once the node is built: b"LOCK" (what comes before is not the
#        protocol: mem_info with info=True, or a traceback)
#   in:  b"T" now(4, big-endian) then per link: length(2) bytes
#        0x80 | dt: a quiet step, the clock moves on dt ms (< 128), no bytes
#        b"Q": stop; the process prints one JSON line of figures
#   out: 0 (no UART wrote) or 1 then per link: length(2) bytes the board
#        wrote to that UART
#
# Nothing is allocated per step: the harness is measured with the buoy.
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
_ONE = bytearray(1)
_HDR = bytearray(4)
_INP = None


def _read_into(buf, n):
    # n bytes from the ocean into buf[0:n]; no allocation (a short read is
    # finished one byte at a time)
    got = _INP.readinto(buf, n) or 0
    while got < n:
        if not _INP.readinto(_ONE, 1):
            raise SystemExit(3)
        buf[got] = _ONE[0]
        got += 1


class _Uart:
    # machine.UART as a board has it, behind the port's own UartStream: the
    # receive ring acomm_mp.start asks for (the link's rxbuf) and the
    # RP2040 port's default 256-byte transmit buffer, both on the heap
    # as on the board and allocated once. Nothing here allocates per step
    # but the bytes each read() returns, as machine.UART.read allocates them
    # too: no slices, no memoryviews made per call otherwise (bytes are
    # copied one by one, a few per step). Bytes beyond a full ring are lost, as in an overrun;
    # a full transmit buffer takes part of a write (the node keeps the rest).
    def __init__(self, rxbuf=1024, txbuf=256):
        self.rx = bytearray(rxbuf)
        self.rmv = memoryview(self.rx)  # read() slices it: no copy but the bytes
        self.head = 0
        self.count = 0
        self.tx = bytearray(txbuf)
        self.tn = 0
        self.overruns = 0

    def any(self):
        return self.count

    def read(self, n):
        # timeout=0, as acomm_mp.start opens it: what is waiting, up to n,
        # in one new bytes object (two pieces when it wraps the ring)
        n = min(n, self.count)
        if not n:
            return None
        rx = self.rmv
        size = len(rx)
        h = self.head
        if h + n <= size:
            out = bytes(rx[h : h + n])
        else:
            out = bytes(rx[h:size]) + bytes(rx[: n - (size - h)])
        self.head = (h + n) % size
        self.count -= n
        return out

    def write(self, data):
        tx = self.tx
        t = self.tn
        n = min(len(data), len(tx) - t)
        for i in range(n):
            tx[t + i] = data[i]
        self.tn = t + n
        return n

    def fill(self, n):
        # n bytes from the ocean process into the ring
        rx = self.rx
        size = len(rx)
        while n:
            _read_into(_ONE, 1)
            if self.count < size:
                rx[(self.head + self.count) % size] = _ONE[0]
                self.count += 1
            else:
                self.overruns += 1
            n -= 1


def _store(path):
    from acomm.transport.store import Store

    def open_store(st):
        # the board's store on a real file, as on its flash
        return Store(path, capacity_bytes=st["capacity"], max_record=st["max_record"])

    return open_store


def _mem_info(label):
    import micropython

    print("== %s: gc.mem_alloc() = %d, gc.mem_free() = %d" % (label, gc.mem_alloc(), gc.mem_free()))
    micropython.mem_info()


def main(path, store_path, rom=None, info=False):
    """Runs the board of config file `path` in lock with the ocean on stdin/stdout until b"Q"."""
    global _ROM, _INP
    if rom:
        _ROM = _mount_rom(rom)
    try:
        # on a board's UART the byte 0x03 would be a Ctrl-C
        import micropython

        micropython.kbd_intr(-1)
    except (ImportError, AttributeError):
        pass
    from acomm_mp.assemble import build

    # the config as start("config") loads it: by module name, released once
    # checked, so only the checked copy stays on the heap
    folder, slash, fname = path.rpartition("/")
    sys.path.insert(0, folder or slash or ".")
    from acomm_mp.boot import load_config

    cfg = load_config(fname[:-3] if fname.endswith(".py") else fname)
    load_config = None
    sys.path.pop(0)
    # every module the board runs, loaded before the node exists: what is
    # allocated then is mostly bytecode, which a ROMFS partition or firmware
    # with the modules frozen in (ports/micropython/manifest.py) keeps in
    # flash instead
    from acomm.drivers.registry import driver_class

    for lk in cfg["links"]:
        driver_class(lk["modem"])
    driver_class = None
    import acomm.transport.store  # noqa: F401
    import acomm_mp.runloop  # noqa: F401
    import acomm_mp.start  # noqa: F401 - the board's entry point stays loaded while it runs

    gc.collect()
    code = gc.mem_alloc()
    if info:
        _mem_info("after imports")
    from acomm_mp.uartstream import UartStream

    ports = []

    def open_uart(lk):
        u = _Uart(lk["rxbuf"])
        ports.append(u)
        return UartStream(u)

    clock = [0]
    board = build(cfg, open_uart, lambda: clock[0], lambda: 1000000 + clock[0] // 1000, _store(store_path),
                  listener=lambda ev: None, say=lambda s: None)
    cfg = build = None
    # as acomm_mp.start does once the node is built
    from acomm_mp import release, release_builder

    release_builder()
    release("acomm_mp.boot")
    release = release_builder = None
    gc.collect()
    base = gc.mem_alloc()
    if info:
        _mem_info("after build")
    peak = base
    _INP = inp = sys.stdin.buffer
    out = sys.stdout.buffer
    flush = getattr(out, "flush", None)  # bare-metal stdout has none
    hdr = _HDR
    # the ocean starts stepping once it reads this: whatever came before
    # (an error while importing or building) is not the protocol
    out.write(b"LOCK")
    if flush:
        flush()
    now = 0
    if info:
        _trace_oom(board.node)
    while True:
        _read_into(hdr, 1)
        c = hdr[0]
        if c == 81:  # b"Q"
            break
        if c & 0x80:
            # a quiet step: the clock moves on, no bytes for any UART
            now += c & 0x7F
        else:
            _read_into(hdr, 4)
            now = (hdr[0] << 24) | (hdr[1] << 16) | (hdr[2] << 8) | hdr[3]
            for u in ports:
                _read_into(hdr, 2)
                u.fill((hdr[0] << 8) | hdr[1])
        clock[0] = now
        board.tick(now)
        a = gc.mem_alloc()
        if a > peak:
            peak = a
        quiet = 0
        for u in ports:
            quiet |= u.tn
        hdr[0] = 1 if quiet else 0
        out.write(hdr, 0, 1)
        if quiet:
            for u in ports:
                hdr[0] = u.tn >> 8
                hdr[1] = u.tn & 0xFF
                out.write(hdr, 0, 2)
                if u.tn:
                    out.write(u.tx, 0, u.tn)
                u.tn = 0
        if flush:
            flush()
    # the figures as plain ints first (small ints take no heap), then the board is let go: the
    # closing line is the harness's, not the buoy's, and formatting it once failed for want of
    # 184 bytes in the heap the minute had left fragmented (at 49,152, when 48,896 passed)
    st = board.stats
    oom, errors = st["oom"], st["errors"]
    tx = rx = 0
    for name in board.node.links:
        s = board.node.links[name].stats
        tx += s.get("tx_frames", 0)
        rx += s.get("rx_frames", 0)
    tr = board.transport
    relayed, stored = tr.stats["relayed"], _stored(tr)
    overruns = 0
    for u in ports:
        overruns += u.overruns
    # a board that routes: route requests its finder heard (rebroadcast,
    # answered or duplicates), routes in its table, control frames it sent
    rt = tr.router.routing
    if rt is None:
        rq = nr = cs = -1
    else:
        fs = rt.stats
        rq, nr, cs = fs["rebroadcasts"] + fs["replies"] + fs["duplicates"], len(rt.routes), fs["control_sent"]
    board = tr = rt = st = s = fs = ports = None
    gc.collect()
    print('{"peak": %d, "after_build": %d, "code": %d, "oom": %d, "errors": %d, "tx_frames": %d, "rx_frames": %d, "relayed": %d, "rom": %d, "overruns": %d, "stored": %d, "route_requests": %d, "routes": %d, "control_sent": %d}'
          % (peak, base, code, oom, errors, tx, rx, relayed, len(_ROM) if _ROM else 0, overruns, stored, rq, nr, cs))
    if info:
        if _OOM:
            # where the heap ran out first (the board counts and carries on)
            print("== first MemoryError at %d ms, gc.mem_alloc() = %d, gc.mem_free() = %d" % _OOM[1])
            sys.print_exception(_OOM[0])
        _mem_info("at the end")
    try:
        micropython.kbd_intr(3)
    except (NameError, AttributeError):
        pass


_OOM = []


def _trace_oom(node):
    # info only: keeps the first MemoryError of a step and the heap then,
    # printed at the end (the protocol owns stdout while the minute runs)
    step = node.step

    def traced(now):
        try:
            return step(now)
        except MemoryError as e:
            if not _OOM:
                _OOM.append(e)
                _OOM.append((now, gc.mem_alloc(), gc.mem_free()))
            raise

    node.step = traced


def _stored(tr):
    # packets in the buoy's custody at the end (in its store)
    try:
        return len(tr._out)
    except AttributeError:
        return -1


if __name__ == "__main__":
    main(*sys.argv[1:4])
