# Workload for acomm.transport.store, portable to MicroPython and CPython.
#
#   run(emit) calls emit(name, value, unit) for:
#     store_appends_per_s        put() of a 64-byte record (76 bytes with the
#                                record's own 12), flushed before it returns
#                                (sync=False), keys cycling over 256 so that
#                                the automatic compactions are paid for in the
#                                figure (per runtime). Not like for like: on
#                                CPython flush() only hands the bytes to the
#                                kernel, while the MicroPython unix port's
#                                flush() calls fsync (as flush() commits to
#                                flash on boards), so its figure is a durable
#                                one, to compare with the fsync one below.
#     store_recover_kib_per_s    opening (recovering) a 100 KiB store of such
#                                records: every record's CRC-32 is checked
#                                (per runtime)
#     store_appends_fsync_per_s_cpython
#                                the same put() with the default sync=True:
#                                fsync after each record, what a power cut
#                                needs. CPython only: the MicroPython unix port
#                                has neither os.fsync nor os.sync.
#
# Files go to a fresh folder under /tmp, removed afterwards.
#
#   python3 ports/cpython/acomm_cpython/bench/workloads/store_workload.py
#   micropython ports/cpython/acomm_cpython/bench/workloads/store_workload.py

import gc
import os
from binascii import hexlify

try:
    from acomm_cpython.bench.workloads.timer import elapsed_us, emit_json, now_us, quick_argv, rate, set_quick
except ImportError:  # run as a script: this folder is on the path
    from timer import elapsed_us, emit_json, now_us, quick_argv, rate, set_quick

from acomm.compat import IS_MICROPYTHON
from acomm.transport.store import Store

PER_RUNTIME = ("store_appends_per_s", "store_recover_kib_per_s")


def _appends(path, sync):
    s = Store(path, capacity_bytes=1 << 20, max_record=256, sync=sync)
    data = bytes(range(64))
    k = [0]

    def block():
        for _ in range(20):
            s.put(k[0] & 255, data)
            k[0] += 1
        return 20

    r = rate(block)
    s.close()
    return r


def _recover(path, kib=100):
    s = Store(path, capacity_bytes=1 << 20, max_record=256, sync=False)
    data = bytes(range(64))
    k = 0
    while s.used_bytes < kib * 1024:
        s.put(k, data)
        k += 1
    size = s.used_bytes
    s.close()
    gc.collect()
    t0 = now_us()
    s = Store(path, capacity_bytes=1 << 20, max_record=256)
    dt = elapsed_us(t0)
    assert len(s) == k
    s.close()
    return size / 1024 * 1e6 / dt


def run(emit, quick=False):
    set_quick(quick)
    d = "/tmp/acomm-bench-store-" + hexlify(os.urandom(4)).decode()
    os.mkdir(d)
    try:
        gc.collect()
        emit("store_appends_per_s", int(_appends(d + "/a", False)), "puts/s")
        gc.collect()
        emit("store_recover_kib_per_s", _recover(d + "/b", 8 if quick else 100), "KiB/s")
        if not IS_MICROPYTHON:
            emit("store_appends_fsync_per_s_cpython", int(_appends(d + "/c", True)), "puts/s")
    finally:
        for n in os.listdir(d):
            os.remove(d + "/" + n)
        os.rmdir(d)


if __name__ == "__main__":
    run(emit_json, quick_argv())
