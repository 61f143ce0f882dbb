# acomm's encode + decode of compare_items' workload, per item: what goes
# on the wire (catalog message in an elided link frame; the log through the
# compressor and the transport's packet header) and back. Portable: runs
# in-process on CPython and as a script on the MicroPython unix port, so
# the same figure exists for both runtimes.
#
#   run(emit) calls emit(name, value, unit) for:
#     roundtrips_per_s_<item>   encode + decode of one item, per second
#
# compare_workload also uses coders() to interleave acomm with the peers in
# one process on CPython.

try:
    from acomm_cpython.bench.workloads import compare_items as ci
    from acomm_cpython.bench.workloads.timer import emit_json, quick_argv, rate, set_quick
except ImportError:  # MicroPython: the runner puts this folder on the path
    import compare_items as ci
    from timer import emit_json, quick_argv, rate, set_quick

from acomm.codec import compress
from acomm import frame
from acomm.transport import segment

PER_RUNTIME = ("roundtrips_per_s_teleop", "roundtrips_per_s_diver", "roundtrips_per_s_pladypos",
               "roundtrips_per_s_vstate", "roundtrips_per_s_chat", "roundtrips_per_s_log")


class MessageCoder:
    def __init__(self, item):
        self.cat, self.msg, self.values = item
        self._pair = [(self.msg, self.values)]

    def encode(self):
        f = frame.Frame(frame.DATA, 2, 1, 0, self.cat.pack(self._pair))
        return frame.encode_elided(f)

    def decode(self, data):
        f = frame.decode_elided(data, 2, 1)
        return self.cat.unpack(f.payload)


class LogCoder:
    # the fragments' own bytes are slices of this blob: not counted
    def __init__(self, data):
        self.data = data

    def encode(self):
        return ci.log_packet(self.data)

    def decode(self, blob):
        h = segment.decode_packet_header(blob)
        body = blob[h.size:h.size + h.length]
        # 65536: the transport's default largest packet
        return compress.decompress(body, 65536) if h.compressed else body


def coders():
    items = ci.message_items()
    out = {}
    for name in ci.MESSAGE_ITEMS:
        out[name] = MessageCoder(items[name])
    out["log"] = LogCoder(ci.log_text())
    return out


def check(name, coder):
    # one round trip gives the item back (the timing below is of real work)
    got = coder.decode(coder.encode())
    if name == "log":
        assert got == coder.data
    else:
        assert got[0][1] == coder.values


def run(emit, quick=False):
    set_quick(quick)
    cs = coders()
    for name in ci.ITEMS:
        c = cs[name]
        check(name, c)
        k = 1 if name == "log" else 20

        def rounds():
            for _ in range(k):
                c.decode(c.encode())
            return k

        emit("roundtrips_per_s_" + name, int(rate(rounds)), "1/s")


if __name__ == "__main__":
    run(emit_json, quick_argv())
