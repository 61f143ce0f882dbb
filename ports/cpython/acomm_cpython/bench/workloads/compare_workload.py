# `acomm bench compare`: acomm side by side with what users would pick
# instead, on compare_items' fixed workload. BENCHMARKS.md is
# written from these lines by tools/mkbenchmarks.py.
#
#   bytes       bytes_<item>_<encoding>: acomm_payload (catalog bytes, no
#               frame), acomm_elided, acomm_raw, imc, cbor, ltcodecs;
#               limit_bits_<item> (log: 8 x its zlib -9 size) and
#               limit_id_bits_<item> (the limit + which message it is);
#               ratio_<item>_<encoding> = bytes * 8 / limit_bits;
#               frames_log_acomm: the log's fragments
#   airtime     airtime_<profile>_teleop_<encoding> and
#               latency_<profile>_teleop_<encoding> (85 m, seed 004's river):
#               the simulator's packet modem model (acomm_sim.packetmodem)
#   speed       speed_<item>_<peer>: the peer's encode + decode rate over
#               acomm's, interleaved in this process (median of ROUNDS);
#               roundtrips_per_s_<item>_{cpython,micropython}: acomm's own
#   transfer    transfer_*: acomm_cpython.bench.workloads.transfer_workload's lines,
#               and transfer_arq_over_saw_<modem>_<loss %>
#   footprint   footprint_*: footprint_workload's lines, passed through
#
# Peers that do not import are named on stderr and their rows skipped.
import sys

from acomm_sim.medium import Medium
from acomm_sim.packetmodem import PROFILES, PacketModemEmulator
from acomm_cpython.bench.workloads import compare_items as ci
from acomm_cpython.bench.workloads import compare_peers as cp
from acomm_cpython.bench.workloads import compare_speed as cs
from acomm_cpython.bench.workloads.timer import elapsed_us, now_us

PER_RUNTIME = ()  # acomm's MicroPython figures come from compare_speed (run())
ACOMM_FORMS = ("acomm_payload", "acomm_elided", "acomm_raw")
ENCODINGS = ACOMM_FORMS + cp.PEERS
RIVER_M = 85.0  # seed 004's river distance
SOUND_MS = 1.5  # metres per millisecond (1500 m/s)
ROUNDS = 41
BATCH_US = 2000  # each timed batch lasts about this long


def static_records(peers):
    # The figures that do not depend on timing: bytes, limits, ratios,
    # airtime and latency; a list of (name, value, unit). BENCHMARKS.md's
    # test recomputes these.
    out = []
    items = ci.message_items()
    ours = ci.acomm_bytes()
    theirs = {p: cp.peer_bytes(peers[p]) for p in peers}
    log = ci.log_text()
    for name in ci.ITEMS:
        row = {"acomm_payload": ours[name]["payload"], "acomm_elided": ours[name]["elided"],
               "acomm_raw": ours[name]["raw"]}
        for p in theirs:
            row[p] = theirs[p][name]
        if name == "log":
            limit = 8.0 * cp.log_reference(log)
            limit_id = limit
        else:
            limit = ci.limit_bits(name, items[name])
            limit_id = ci.limit_with_id_bits(name, items[name])
        out.append(("limit_bits_" + name, round(limit, 2), "bit"))
        out.append(("limit_id_bits_" + name, round(limit_id, 2), "bit"))
        for enc in ENCODINGS:
            if enc in row:
                out.append(("bytes_%s_%s" % (name, enc), row[enc], "bytes"))
                out.append(("ratio_%s_%s" % (name, enc), round(row[enc] * 8 / limit, 3), "x limit"))
    out.append(("frames_log_acomm", ours["log"]["frames"], "frames"))
    out.extend(airtime_records(ours["teleop"], {p: theirs[p]["teleop"] for p in theirs}))
    return out


def airtime_records(ours, theirs):
    # seed 004's profiles as the simulator models them: the packet's bytes
    # plus the modem's framing at the profile's bit rate; latency adds the
    # sound's travel over the river distance (the seed's own latencies also
    # hold about 1.4 s of its ROS 2 stack, which no encoding changes)
    out = []
    sizes = {"acomm_elided": ours["elided"], "acomm_raw": ours["raw"]}
    sizes.update(theirs)
    for prof in sorted(PROFILES):
        modem = PacketModemEmulator(Medium(), 1, profile=prof)
        for enc in ENCODINGS:
            if enc in sizes:
                air = modem.airtime_ms(sizes[enc])
                out.append(("airtime_%s_teleop_%s" % (prof, enc), air, "ms"))
                out.append(("latency_%s_teleop_%s" % (prof, enc), round(air + RIVER_M / SOUND_MS, 1), "ms"))
    return out


def _median(xs):
    s = sorted(xs)
    n = len(s)
    return s[n // 2] if n % 2 else (s[n // 2 - 1] + s[n // 2]) / 2


class _PeerCoder:
    # a peer's encode + decode of one item, in compare_speed's shape
    def __init__(self, peer, name, value):
        self.peer, self.name, self.value = peer, name, value

    def encode(self):
        return self.peer.encode(self.name, self.value)

    def decode(self, data):
        return self.peer.decode(self.name, data)


def _batch(coder):
    # how many round trips make about BATCH_US
    k = 1
    while True:
        t0 = now_us()
        for _ in range(k):
            coder.decode(coder.encode())
        if elapsed_us(t0) >= BATCH_US or k >= 4096:
            return k
        k *= 2


def time_rounds(coders, rounds):
    """{name: [microseconds per encode + decode, one per round]}: each coder's batch timed in turn,
    the order rotating every round, so a slow moment of the machine falls on every coder alike."""
    order = list(coders)
    sizes = {c: _batch(coders[c]) for c in order}
    per = {c: [] for c in order}
    for r in range(rounds):
        k = r % len(order)
        for c in order[k:] + order[:k]:
            coder, n = coders[c], sizes[c]
            t0 = now_us()
            for _ in range(n):
                coder.decode(coder.encode())
            per[c].append(elapsed_us(t0) / n)
    return per


def speed_records(peers, rounds=ROUNDS):
    # Per item, acomm and every peer time one batch each per round, in an
    # order that rotates every round (no coder always runs first, after the
    # same neighbour, or on a warmer cache); the figure is each coder's
    # median microseconds per round trip, reported as acomm's over the peer's
    # (how many times acomm's rate the peer reaches).
    out = []
    ours = cs.coders()
    vals = cp.item_values()
    for name in ci.ITEMS:
        coders = {"acomm": ours[name]}
        for p in peers:
            coders[p] = _PeerCoder(peers[p], name, peers[p].prepare(name, vals[name]))
        cs.check(name, ours[name])
        per = time_rounds(coders, rounds)
        base = _median(per["acomm"])
        for p in peers:
            out.append(("speed_%s_%s" % (name, p), round(base / _median(per[p]), 3), "x acomm"))
    return out


def run(emit, speed=True, slow=True, quick=False):
    # quick: every part, each in its own quick mode (2 timed rounds)
    gone = cp.missing()
    if gone:
        print("note: peers not installed, their rows skipped: %s (pip install .[bench])"
              % ", ".join("%s (%s)" % (p, cp.MODULES[p]) for p in gone), file=sys.stderr)
    peers = cp.peers()
    for rec in static_records(peers):
        emit(*rec)
    if speed:
        for rec in speed_records(peers, 2 if quick else ROUNDS):
            emit(*rec)
        cs.run(lambda n, v, u: emit(n + "_cpython", v, u), quick)
        _micropython_speed(emit, quick)
    if slow:
        _transfer(emit, quick)
        _footprint(emit, quick)
        _simulator(emit, quick)


def _micropython_speed(emit, quick=False):
    from acomm_cpython.bench.runtime import find_micropython, run_micropython

    mp = find_micropython()
    if mp is None:
        print("note: no micropython command found; MicroPython figures skipped", file=sys.stderr)
        return
    for rec in run_micropython("compare_speed", mp, quick):
        emit(rec["name"] + "_micropython", rec["value"], rec["unit"])


def _transfer(emit, quick=False):
    from acomm_cpython.bench.workloads import transfer_workload

    seen = {}

    def tr(name, value, unit):
        seen[name] = value
        emit("transfer_" + name, value, unit)

    transfer_workload.run(tr, quick)
    for modem in transfer_workload.MODEMS:
        for loss in transfer_workload.LOSSES:
            pct = int(loss * 100)
            a = seen["goodput_ratio_%s_%d" % (modem, pct)]
            s = seen["goodput_ratio_stopwait_%s_%d" % (modem, pct)]
            emit("transfer_arq_over_saw_%s_%d" % (modem, pct), round(a / s, 3), "ratio")


def _simulator(emit, quick=False):
    # the simulator's speed and scale (sim_workload) and a sweep's speed-up
    # on 2 Dask workers (sweep_workload, when Dask is installed)
    from acomm_cpython.bench.workloads import sim_workload as sw
    from acomm_cpython.bench.workloads import sweep_workload

    sim_s = 120 if quick else sw.SIM_S
    _, wall, _ = sw.run_once("tdma", sim_s=sim_s)
    emit("sim_speedup_16_nodes", round(sim_s / wall, 1), "x")
    sw.run_scales(lambda n, v, u: emit(n, round(v, 4) if isinstance(v, float) else v, u),
                  *((1, sw.PERIOD_S) if quick else ()))
    try:
        sweep_workload.run(lambda n, v, u: emit(n, round(v, 3), u), quick)
    except RuntimeError as e:
        print("note: %s" % e, file=sys.stderr)


def _footprint(emit, quick=False):
    # passed through as it comes: the footprint bench is its owner's to change
    from acomm_cpython.bench.workloads import footprint_workload

    footprint_workload.run(lambda n, v, u: emit("footprint_" + n, v, u), quick=quick)
