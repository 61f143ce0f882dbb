# BENCHMARKS.md from the JSON lines of `acomm bench compare --json`: the
# tables, the machine, and per row what the numbers mean and where acomm
# loses. The figures are also kept verbatim at the end of the file, so
# tests/cpython/test_benchmarks_md.py can check that the text is what this
# module renders from them, and that the figures that do not depend on
# timing (bytes, limits, airtime) are what the code gives today.
import json

from acomm_cpython.bench.workloads import compare_items as ci
from acomm_cpython.bench.workloads import compare_peers as cp

COMMAND = ".venv/bin/python tools/mkbenchmarks.py"
BENCH = "acomm bench compare --json"
FIGURES = "## The figures (JSON lines)"
ITEM_TITLES = {
    "teleop": "teleop command (6 axes + seq)",
    "diver": "CADDY diver reply",
    "pladypos": "CADDY PlaDyPos reply",
    "vstate": "Seaware vehicle state",
    "chat": "20-character chat line",
    "log": "2 KiB text log",
}
ENC_TITLES = {
    "acomm_payload": "acomm payload",
    "acomm_elided": "acomm elided",
    "acomm_raw": "acomm raw",
    "imc": "IMC (imcpy)",
    "cbor": "CBOR + 6 (rmw_desert)",
    "ltcodecs": "ltcodecs + 1 (ros_acomms)",
}
PEER_ENCS = cp.PEERS
# static: recomputed by the test; the rest depends on timing or simulation
STATIC_PREFIXES = ("bytes_", "ratio_", "limit_bits_", "limit_id_bits_", "frames_", "airtime_", "latency_")


def is_static(name):
    return name.startswith(STATIC_PREFIXES)


def parse(lines):
    # JSON lines -> ordered list of (name, value, unit)
    out = []
    for line in lines:
        line = line.strip()
        if line.startswith("{"):
            d = json.loads(line)
            out.append((d["name"], d["value"], d["unit"]))
    return out


def dumps(rec):
    # one record as the bench prints it (bench.main's format)
    return json.dumps({"name": rec[0], "value": rec[1], "unit": rec[2]})


def _fmt(v):
    if isinstance(v, float):
        if abs(v) >= 100:
            return "%d" % v if v == int(v) else "%.1f" % v
        return ("%.3f" % v).rstrip("0").rstrip(".")
    return str(v)


class _Figures:
    def __init__(self, records):
        self.d = {r[0]: r[1] for r in records}

    def get(self, name):
        return self.d.get(name)

    def s(self, name, missing="-"):
        v = self.d.get(name)
        return missing if v is None else _fmt(v)


def _bytes_table(f, peers):
    encs = ("acomm_payload", "acomm_elided", "acomm_raw") + peers
    head = "| item | limit (bits) | " + " | ".join(ENC_TITLES[e] for e in encs) + " |"
    out = [head, "|" + "---|" * (len(encs) + 2)]
    for it in ci.ITEMS:
        cells = []
        for e in encs:
            b = f.get("bytes_%s_%s" % (it, e))
            cells.append("-" if b is None else "%d (%sx)" % (b, f.s("ratio_%s_%s" % (it, e))))
        lim = f.s("limit_bits_" + it)
        if it == "log":
            lim += " (zlib -9)"
        out.append("| %s | %s | %s |" % (ITEM_TITLES[it], lim, " | ".join(cells)))
    return out


def _checks(f, peers):
    # per item: acomm elided against the best peer and against the limit
    out = ["| item | acomm elided | best peer | limit, whole bytes | limit with the message id, whole bytes | "
           "at or below every peer | within 1 byte of the limit |", "|---|---|---|---|---|---|---|"]
    for it in ci.ITEMS:
        ours = f.get("bytes_%s_acomm_elided" % it)
        theirs = [(f.get("bytes_%s_%s" % (it, p)), p) for p in peers if f.get("bytes_%s_%s" % (it, p)) is not None]
        best = min(theirs) if theirs else None
        lim = -(-f.get("limit_bits_" + it) // 8)
        lim_id = -(-f.get("limit_id_bits_" + it) // 8)
        frames = f.get("frames_log_acomm") if it == "log" else 1
        out.append("| %s | %d | %s | %d | %d | %s | %s |" % (
            ITEM_TITLES[it], ours, "-" if best is None else "%d (%s)" % best, lim, lim_id,
            "-" if best is None else ("yes" if ours <= best[0] else "**no**"),
            "yes" if ours <= lim + frames else ("with the id" if ours <= lim_id + frames else "**no**")))
    return out


def _airtime_table(f, peers):
    encs = ("acomm_elided", "acomm_raw") + peers
    out = ["| profile | " + " | ".join(ENC_TITLES[e] for e in encs) + " |", "|" + "---|" * (len(encs) + 1)]
    for prof in ("bpsk", "fhss"):
        cells = []
        for e in encs:
            a = f.get("airtime_%s_teleop_%s" % (prof, e))
            cells.append("-" if a is None else "%s B: %s / %s ms" % (
                f.s("bytes_teleop_" + e), _fmt(a), f.s("latency_%s_teleop_%s" % (prof, e))))
        out.append("| %s | %s |" % (prof.upper(), " | ".join(cells)))
    return out


def _speed_table(f, peers):
    out = ["| item | acomm CPython (1/s) | acomm MicroPython (1/s) | " + " | ".join(
        "%s / acomm" % ENC_TITLES[p] for p in peers) + " |", "|" + "---|" * (len(peers) + 3)]
    for it in ci.ITEMS:
        out.append("| %s | %s | %s | %s |" % (
            ITEM_TITLES[it], f.s("roundtrips_per_s_%s_cpython" % it), f.s("roundtrips_per_s_%s_micropython" % it),
            " | ".join(f.s("speed_%s_%s" % (it, p)) for p in peers)))
    return out


def _transfer_table(f):
    out = ["| modem | loss | acomm goodput / ideal | stop-and-wait goodput / ideal | acomm / stop-and-wait |",
           "|---|---|---|---|---|"]
    for modem in ("seatrac", "evologics"):
        for pct in (0, 10, 20):
            out.append("| %s | %d %% | %s | %s | %s |" % (
                modem, pct, f.s("transfer_goodput_ratio_%s_%d" % (modem, pct)),
                f.s("transfer_goodput_ratio_stopwait_%s_%d" % (modem, pct)),
                f.s("transfer_arq_over_saw_%s_%d" % (modem, pct))))
    return out


def _footprint_table(records):
    out = ["| figure | value |", "|---|---|"]
    for n, v, u in records:
        if n.startswith("footprint_"):
            out.append("| %s | %s %s |" % (n[len("footprint_"):], _fmt(v), u))
    return out


def render(records, machine):
    # -> the text of BENCHMARKS.md; machine: one line saying where it ran
    f = _Figures(records)
    peers = tuple(p for p in PEER_ENCS if f.get("bytes_teleop_" + p) is not None)
    gone = [p for p in PEER_ENCS if p not in peers]
    L = []
    a = L.append
    a("# Benchmarks: acomm beside IMC, ROS 2 over rmw_desert, ros_acomms' codecs and stop-and-wait")
    a("")
    a("Generated by `%s`, which runs `%s` (peers from `pip install .[bench]`) and writes this file "
      "from its JSON lines; the lines are kept at the end. `tests/cpython/test_benchmarks_md.py` checks "
      "that this text is what the generator renders from them and that the bytes, limits and airtime "
      "are what the code gives today (not the timings)." % (COMMAND, BENCH))
    a("")
    a("Machine: %s" % machine)
    if gone:
        a("")
        a("Peers missing in this run, their columns left out: %s." % ", ".join(
            "%s (`%s`)" % (p, cp.MODULES[p]) for p in gone))
    a("")
    a("## 1. Bytes on the wire")
    a("")
    a("Each item encoded once by each system; in brackets, the bytes' bits over the limit (the sum over "
      "fields of log2 of their number of distinct values; for the log, its zlib -9 size). The values are "
      "on acomm's quantization grid, and every peer gets them in the form that costs it least "
      "(`ports/cpython/acomm_cpython/bench/workloads/compare_peers.py` says how for each).")
    a("")
    L.extend(_bytes_table(f, peers))
    a("")
    a("- **acomm payload** is the catalog message alone (id + body, to a whole byte); **acomm elided** "
      "adds the 1-byte frame header of links whose modem carries addresses and a CRC (Micro-Modem, "
      "SeaTrac, EvoLogics); **acomm raw** the 3-byte header and 2-byte CRC of links that carry neither "
      "(UDP, a transparent modem such as seed 004's). The log is one transport packet (%s bytes: the "
      "5-byte packet header and acomm's compressor's output) in %s fragments of a 256-byte Micro-Modem "
      "frame, each with its frame header and fragment index." % (
          f.s("bytes_log_acomm_payload"), f.s("frames_log_acomm")))
    a("- **IMC** is one imcpy packet per IMC message (20-byte header, 2-byte CRC), as DUNE sends it. "
      "IMC has no diver, PlaDyPos or hull-state message: the closest are EstimatedState for a "
      "system's navigation (PlaDyPos's reply adds a UsblPosition for the diver), Temperature + FuelLevel + "
      "Voltage for the vehicle state, DesiredControl for the thrust, TextMessage for chat and log. "
      "Its fields are fp32/fp64 whatever their range, so IMC costs %s-%s times the limit on the small "
      "items." % (_fmt(min(f.get("ratio_%s_imc" % i) or 0 for i in ci.MESSAGE_ITEMS)),
                  _fmt(max(f.get("ratio_%s_imc" % i) or 0 for i in ci.MESSAGE_ITEMS))) if "imc" in peers else
      "- IMC: not measured in this run.")
    a("- **CBOR + 6** is the fields as one CBOR array of integers (cbor2) behind rmw_desert's 6-byte "
      "header (seed 004); the thrust command comes to %s bytes, within the seed's 13-14 (it carries the "
      "sequence number as a seventh integer). The log is given to CBOR already zlib -9 compressed, "
      "because the seed says rmw_desert compresses without saying how." % f.s("bytes_teleop_cbor"))
    a("- **ltcodecs + 1** is WHOI's field codecs with each field's exact range and number of values, so "
      "the body has the same bits as acomm's; + 1 is the message codec id byte ros_acomms puts in front. "
      "ros_acomms itself is not on PyPI: any framing it adds beyond that byte is not counted, in its favour.")
    a("")
    a("### acomm against the peers and the limit")
    a("")
    a("Elided form, on the links that carry their own addressing and CRC. \"Within 1 byte\": acomm's "
      "bytes are at most the limit in whole bytes plus one byte per frame; \"with the id\" when that "
      "holds only once the limit counts which message of its catalog it is (log2 of the catalog's size).")
    a("")
    L.extend(_checks(f, peers))
    a("")
    a("Where acomm loses, and why:")
    a("")
    a("- **PlaDyPos reply and vehicle state, against ltcodecs by one byte.** Their bodies are whole bytes "
      "(56 and 24 bits). acomm adds a message id inside the payload (CADDY's 4 bits, seed 003; "
      "Seaware's 8-bit tag, seed 002's Table I) and then its 1-byte frame header (frame type and a "
      "4-bit sequence number for duplicate filtering and acknowledgements): the 4-bit id pushes the "
      "PlaDyPos reply to %s payload bytes, and the tag is a whole byte. ltcodecs + 1 carries the id byte "
      "and nothing else: no sequence number, no frame type. Against the bare body limit both are 2 bytes "
      "over; counting which message it is (log2 of 13 messages, 3.7 bits) they are within 1 byte." %
      f.s("bytes_pladypos_acomm_payload"))
    a("- **Chat line, 2 bytes over the limit.** CADDY's 6-bit alphabet has 42 symbols in 64 codes "
      "(0.6 bit a character lost) and a line shorter than 40 characters ends with a 6-bit END; "
      "docs/codec.md says so. It still beats ltcodecs' 7-bit ASCII (%s bytes)." % f.s("bytes_chat_ltcodecs"))
    a("- **The 2 KiB log, %s bytes over zlib -9 and behind CBOR + zlib (%s bytes).** acomm's compressor "
      "(acomm/codec/compress.py) is an LZ77 with Elias-gamma codes and no entropy stage, sized for a buoy "
      "(2.5 KiB of tables; MicroPython's deflate only decompresses on most boards); zlib adds "
      "Huffman coding, which acomm's compressor does not have. The CBOR row is also one unfragmented message, which no acoustic "
      "modem carries in one frame; acomm pays %s bytes of fragmenting on 256-byte frames." % (
          _fmt(f.get("bytes_log_acomm_elided") - int(f.get("limit_bits_log")) // 8),
          f.s("bytes_log_cbor"), f.get("bytes_log_acomm_elided") - f.get("bytes_log_acomm_payload")))
    a("- acomm's codecs and wire format were not changed for this table.")
    a("")
    a("## 2. Airtime and latency of the teleop command (seed 004's profiles)")
    a("")
    a("Bytes: airtime / latency over 85 m, from the simulator's packet modem model "
      "(`acomm_sim.packetmodem`: the bytes plus the modem's framing, 12 bytes at 400 bit/s for BPSK, "
      "10 bytes at 192 bit/s for FHSS; latency adds 85 m of sound at 1500 m/s).")
    a("")
    L.extend(_airtime_table(f, peers))
    a("")
    a("The seed's modem is transparent (no addresses, no CRC of its own in the simulator), so acomm runs "
      "raw there (`acomm bench teleop`); the elided column is for a modem that does carry them. The modem's "
      "framing dominates small packets: acomm raw saves %s ms over rmw_desert's CBOR on BPSK and %s ms on "
      "FHSS, per command. The seed measured about 2.0 s (BPSK) and 2.7 s (FHSS), of which about 1.4 s is "
      "its ROS 2 / DESERT stack: no encoding changes that part. ltcodecs + 1 ties acomm elided here and has "
      "no CRC of its own on a transparent modem." % (
          _diff(f, "airtime_bpsk_teleop_cbor", "airtime_bpsk_teleop_acomm_raw"),
          _diff(f, "airtime_fhss_teleop_cbor", "airtime_fhss_teleop_acomm_raw")))
    a("")
    a("## 3. Encode + decode speed")
    a("")
    a("acomm's round trips per second (one item encoded into its wire form and decoded back) on both "
      "runtimes, and each peer's rate over acomm's on CPython: the coders run interleaved in one process, "
      "in an order that rotates every round, and each figure is the median of 41 rounds. Above 1 the peer "
      "is faster.")
    a("")
    L.extend(_speed_table(f, peers))
    a("")
    a("acomm is pure Python (it must run unchanged on MicroPython); a message whose fields are all "
      "scalars or optional scalars is packed into one integer and unpacked from one (acomm/codec/flat.py), "
      "other messages field by field. imcpy and cbor2 "
      "are C extensions, so they are several times faster on CPython, and far faster on the log, where "
      "acomm's compressor is Python against zlib's C. ltcodecs is pure Python over the bitstring package "
      "and is slower than acomm on the messages (its lzma, in C, is faster on the log). A teleop command "
      "is on the air for 0.4-1 s (section 2), so every rate here is far above what one link needs; the "
      "MicroPython column is what a buoy or tablet has to spare.")
    a("")
    a("## 4. Bulk transfer: selective ARQ against stop-and-wait")
    a("")
    a("From `acomm bench transfer` (4 KiB of random bytes over 150 m in the simulated ocean): goodput over "
      "the modem's ideal, for acomm's transport (bitmap SACKs, only missing fragments again) and for one "
      "acknowledged frame at a time, and their ratio.")
    a("")
    L.extend(_transfer_table(f))
    a("")
    a("On SeaTrac, whose 30-byte frames each cost a round trip under stop-and-wait, the selective ARQ "
      "moves %s times as much as stop-and-wait without loss and %s times at 20 %% loss. On EvoLogics the "
      "transport hands the modem its bursts one behind the other, the modem sends them as one train and "
      "its own DELIVERED and FAILED are the acknowledgement (no SACK per round; docs/transport.md), while "
      "stop-and-wait waits for each "
      "burst's acknowledgement: %s times as much at 0 %%, %s at 10 %% and %s at 20 %% loss, where "
      "every lost burst costs stop-and-wait the modem's full acknowledgement timeout." % (
          f.s("transfer_arq_over_saw_seatrac_0"), f.s("transfer_arq_over_saw_seatrac_20"),
          f.s("transfer_arq_over_saw_evologics_0"), f.s("transfer_arq_over_saw_evologics_10"),
          f.s("transfer_arq_over_saw_evologics_20")))
    a("")
    a("## 5. Footprint on a microcontroller")
    a("")
    a("From `acomm bench footprint` (the buoy board's program on 32-bit builds: MicroPython's qemu "
      "Cortex-M3 firmware, the unix port built for i386 and the Raspberry Pi Pico's own firmware in the "
      "rp2040js emulator, where the `.mpy` buoy's free heap is what its ready line reports at boot; "
      "the `*_unix64_estimate_*` figures come from "
      "the 64-bit unix port and understate a board; docs/micropython-port.md explains each figure), "
      "passed through as it comes. The peers have no "
      "MicroPython port to compare with: imcpy and cbor2's fast path are C extensions for CPython, "
      "ltcodecs needs bitstring, msgpack and PyYAML.")
    a("")
    L.extend(_footprint_table(records))
    a("")
    if f.get("sim_speedup_16_nodes") is not None:
        _simulator_section(f, a)
    a(FIGURES)
    a("")
    a("```")
    for r in records:
        a(dumps(r))
    a("```")
    a("")
    return "\n".join(L)


def _simulator_section(f, a):
    a("## 6. The simulated ocean: speed, scale and sweeps")
    a("")
    a("From `acomm bench sim` and `acomm bench sweep` (docs/simulator.md says what each run is). The "
      "speed-up is simulated seconds per wall second of 16 BPSK nodes on TDMA for one simulated hour; the "
      "scale runs put 16, 64 and 256 nodes on a 400 m grid, each hearing at most its 8 nearest, each "
      "sending one frame a minute under ALOHA, for ten simulated minutes, and give the process's CPU time per "
      "simulated second (the fastest of three runs; wall time moved by a factor of 2 with the other work "
      "on this shared machine; a cost ratio of 4 for 4 times the nodes is linear); the memory is tracemalloc's peak while the 256-node world is "
      "built and runs a minute. The sweep runs the demo mission 12 times (3 losses, 2 MACs, 2 seeds, 20 "
      "simulated minutes) in one process and on a Dask LocalCluster of 2 worker processes, alternating "
      "twice, the fastest of each (identical CSVs); sweep_load_1min is the machine's 1-minute load average "
      "as its runs end.")
    a("")
    a("| figure | value |")
    a("|---|---|")
    rows = [("sim_speedup_16_nodes", "x"), ("sim_cost_16_nodes", "ms/s"), ("sim_cost_64_nodes", "ms/s"),
            ("sim_cost_256_nodes", "ms/s"), ("sim_cost_ratio_64_vs_16", ""), ("sim_cost_ratio_256_vs_64", ""),
            ("sim_memory_256_nodes", "B"), ("sweep_local_1_core_s", "s"), ("sweep_dask_2_workers_s", "s"),
            ("sweep_speedup_2_workers", "x"), ("sweep_load_1min", "")]
    for name, unit in rows:
        if f.get(name) is not None:
            a("| %s | %s%s |" % (name, f.s(name), " " + unit if unit else ""))
    a("")
    a("The simulator steps the real stack byte by byte; what made it faster is that nodes with nothing to "
      "do are no longer visited: a node whose modem is idle sleeps until its next wake-up or a packet, and "
      "a node on a transparent modem also sleeps through its TDMA wait, its airtime and its idle timers "
      "(the steps skipped are those that did nothing; tests/core/test_world_fast.py checks that the events "
      "are the same). The channel's cost per transmission no longer grows with the whole network: the "
      "generator draws owed by stations out of reach are skipped in one step (acomm_sim.prngskip: the "
      "same state as drawing them), and the collision check reads only the copies on their way to the "
      "one receiver (docs/simulator.md has the profile). The sweep's speed-up depends on what else runs "
      "on the machine's 2 cores: at a load above 2 the workers share them with that work.")
    a("")


def _diff(f, a, b):
    x, y = f.get(a), f.get(b)
    return "-" if x is None or y is None else _fmt(x - y)


def figures_of(text):
    # the records kept in a BENCHMARKS.md, and its machine line
    lines = text.split("\n")
    i = lines.index(FIGURES)
    start = lines.index("```", i) + 1
    end = lines.index("```", start)
    machine = next(l[len("Machine: "):] for l in lines if l.startswith("Machine: "))
    return parse(lines[start:end]), machine
