# Figures for the store-and-forward transport's payload: how much the
# acomm compressor saves on a 2 KiB dive log (with zlib level 9 for
# reference, CPython only) and how fast compression and Reed-Solomon run.
# Portable: runs in-process on CPython and as a script on the MicroPython
# unix port.
#
#   run(emit) calls emit(name, value, unit) for:
#     compress_ratio_divelog  compressed / original bytes, acomm.codec.compress,
#                             on divelog.divelog() (2048 bytes)
#     zlib9_ratio_divelog     the same with zlib.compress(level 9) (CPython)
#     compress_kbps           input kbit/s through compress (per runtime)
#     decompress_kbps         output kbit/s through decompress (per runtime)
#     rs_encode_kbps          message kbit/s through ReedSolomon(16).encode
#                             of 239-byte messages (255-byte codewords)
#     rs_decode_kbps          message kbit/s through decode of those
#                             codewords with 8 (= nsym/2) damaged bytes
#                             each (per runtime)

try:
    from acomm_cpython.bench.workloads.divelog import divelog
    from acomm_cpython.bench.workloads.timer import emit_json, quick_argv, rate, set_quick
except ImportError:  # MicroPython: the runner puts this folder on the path
    from divelog import divelog
    from timer import emit_json, quick_argv, rate, set_quick

from acomm.codec.compress import compress, decompress
from acomm.codec.fec import ReedSolomon
from acomm.prng import Prng

PER_RUNTIME = ("compress_kbps", "decompress_kbps", "rs_encode_kbps", "rs_decode_kbps")

RS_NSYM = 16


def _damaged(rng, cw, nerr):
    bad = bytearray(cw)
    hit = bytearray(len(cw))
    while nerr:
        p = rng.below(len(cw))
        if not hit[p]:
            hit[p] = 1
            bad[p] ^= rng.range(1, 255)
            nerr -= 1
    return bytes(bad)


def run(emit, quick=False):
    set_quick(quick)
    log = divelog()
    packed = compress(log)
    assert decompress(packed, len(log)) == log
    emit("compress_ratio_divelog", round(len(packed) / len(log), 4), "ratio")
    try:
        import zlib

        emit("zlib9_ratio_divelog", round(len(zlib.compress(log, 9)) / len(log), 4), "ratio")
    except (ImportError, TypeError):  # MicroPython: no zlib, or no level
        pass

    def comp():
        compress(log)
        return len(log)

    emit("compress_kbps", rate(comp) * 8 / 1000, "kbit/s")

    def decomp():
        decompress(packed, len(log))
        return len(log)

    emit("decompress_kbps", rate(decomp) * 8 / 1000, "kbit/s")

    rs = ReedSolomon(RS_NSYM)
    rng = Prng(16)
    msg = rng.bytes(255 - RS_NSYM)
    cw = rs.encode(msg)

    def enc():
        rs.encode(msg)
        return len(msg)

    emit("rs_encode_kbps", rate(enc) * 8 / 1000, "kbit/s")

    bad = _damaged(rng, cw, RS_NSYM // 2)
    assert rs.decode_count(bad) == (msg, RS_NSYM // 2)

    def dec():
        rs.decode(bad)
        return len(msg)

    emit("rs_decode_kbps", rate(dec) * 8 / 1000, "kbit/s")


if __name__ == "__main__":
    run(emit_json, quick_argv())
