# Core throughput figures, portable: runs in-process on CPython and as a
# script on the MicroPython unix port (or a board: `mpremote run`).
try:
    from acomm_cpython.bench.workloads.timer import emit_json, quick_argv, rate, set_quick
except ImportError:  # MicroPython: the runner puts this folder on the path
    from timer import emit_json, quick_argv, rate, set_quick

from acomm import frame
from acomm.codec.crc import crc16, crc16_pure

PER_RUNTIME = ("crc16_mbps", "crc16_pure_mbps", "frame_roundtrips_per_s")


def run(emit, quick=False):
    set_quick(quick)
    data = bytes(range(256)) * 4

    def crc_block():
        crc16(data)
        return len(data)

    emit("crc16_mbps", rate(crc_block) * 8 / 1e6, "Mbit/s")

    def crc_pure_block():
        crc16_pure(data)
        return len(data)

    # the table-driven bytecode version, for boards without the viper emitter
    emit("crc16_pure_mbps", rate(crc_pure_block) * 8 / 1e6, "Mbit/s")

    buf = bytearray(64)
    payload = bytes(range(32))
    mv = memoryview(buf)

    def roundtrip():
        for _ in range(20):
            n = frame.encode_raw_into(buf, frame.DATA, 3, 7, 21, payload, frame.F_ACK_REQ)
            f = frame.decode_raw(mv[:n])
        assert f.seq == 21
        return 20

    emit("frame_roundtrips_per_s", rate(roundtrip), "1/s")


if __name__ == "__main__":
    run(emit_json, quick_argv())
