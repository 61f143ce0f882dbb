# `acomm bench encode`: acomm's encode + decode speed on both runtimes for
# the two messages a link carries most often: seed 004's teleop thrust
# command and the CADDY diver status (heart rate, breathing, body
# temperature; acomm.catalog.caddy), and for the CADDY diver reply of
# BENCHMARKS.md. One round trip is what compare_speed times: the catalog
# message packed into an elided link frame, and back. Portable: runs
# in-process on CPython and as a script on the MicroPython unix port.
#
#   encode_decode_per_s_<item>        round trips per second (per runtime;
#                                     the median of 9 windows of 0.1 s)
#   encode_stage_ns_<item>_<stage>    where a round trip's time goes, per
#                                     runtime (MicroPython has no profiler;
#                                     it runs with a 256 KB heap, see below):
#                                     pack (catalog -> bits), frame (the
#                                     link frame's encode), unframe (its
#                                     decode), unpack (bits -> values)
#   encode_decode_<peer>_over_acomm_<item>   on CPython, a peer's rate over
#                                     acomm's (cbor2 as rmw_desert sends it,
#                                     ltcodecs as ros_acomms does; median of
#                                     rounds interleaved in this process)

try:
    from acomm_cpython.bench.workloads import compare_speed as cs
    from acomm_cpython.bench.workloads.timer import emit_json, quick_argv, rate, set_quick
except ImportError:  # MicroPython: the runner puts this folder on the path
    import compare_speed as cs
    from timer import emit_json, quick_argv, rate, set_quick

from acomm import frame
from acomm.catalog import caddy

ITEMS = ("teleop", "diver_status", "diver_reply")
STAGES = ("pack", "frame", "unframe", "unpack")
PER_RUNTIME = tuple("encode_decode_per_s_" + i for i in ITEMS) + tuple(
    "encode_stage_ns_%s_%s" % (i, s) for i in ITEMS for s in STAGES)

# MicroPython runs this with a board-sized heap: under the runner's usual 8
# MB, the collector's sweeps of the whole heap made a stage timed alone
# (pack, say) take 5 times as long as the round trip that contains it
MICROPYTHON_HEAP = "256K"

# the demo's diver status (acomm_cpython.demo.mission), on the catalog's grid
DIVER_STATUS_VALUES = {"heart_rate": 84, "breathing_rate": 15, "body_temp": 36.7}


def items():
    # -> {name: (catalog, message, values)}
    from_compare = cs.ci.message_items()
    return {
        "teleop": from_compare["teleop"],
        "diver_status": (caddy.CATALOG, caddy.DIVER_STATUS, cs.ci._grid(caddy.CATALOG, caddy.DIVER_STATUS,
                                                                          DIVER_STATUS_VALUES)),
        "diver_reply": from_compare["diver"],
    }


def coders():
    return {name: cs.MessageCoder(item) for name, item in items().items()}


def stages(c):
    # -> {stage: ns per call}, each stage timed alone (steady_rate)
    pair = c._pair
    cat = c.cat
    body = cat.pack(pair)
    wire = frame.encode_elided(frame.Frame(frame.DATA, 2, 1, 0, body))

    def pack():
        for _ in range(20):
            cat.pack(pair)
        return 20

    def frame_():
        for _ in range(20):
            frame.encode_elided(frame.Frame(frame.DATA, 2, 1, 0, body))
        return 20

    def unframe():
        for _ in range(20):
            frame.decode_elided(wire, 2, 1)
        return 20

    def unpack():
        for _ in range(20):
            cat.unpack(body)
        return 20

    fns = {"pack": pack, "frame": frame_, "unframe": unframe, "unpack": unpack}
    return {s: 1e9 / steady_rate(fns[s]) for s in STAGES}


def steady_rate(fn, windows=9, min_us=100000):
    # the median rate of several short windows: a machine shared with
    # other work slows some windows down, not the median
    rs = sorted(rate(fn, min_us) for _ in range(windows))
    return rs[windows // 2]


def run(emit, quick=False):
    set_quick(quick)
    cs_ = coders()
    for name in ITEMS:
        c = cs_[name]
        got = c.decode(c.encode())
        assert got[0][1] == c.values, (name, got)

        def rounds():
            for _ in range(20):
                c.decode(c.encode())
            return 20

        emit("encode_decode_per_s_" + name, int(steady_rate(rounds)), "1/s")
        st = stages(c)
        for s in STAGES:
            emit("encode_stage_ns_%s_%s" % (name, s), int(st[s]), "ns")
    try:
        from acomm_cpython.bench.workloads.encode_peers import peer_ratios
    except ImportError:  # MicroPython
        return
    for rec in peer_ratios(items(), cs_, *((2, 10) if quick else ())):
        emit(*rec)


if __name__ == "__main__":
    run(emit_json, quick_argv())
