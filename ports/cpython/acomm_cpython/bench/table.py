# The benchmarks' table and runner (`acomm bench <name> --json`, its front
# end acomm_cpython.cli.bench): runs a benchmark workload on CPython in this
# process and, for the figures that depend on the runtime, again as a script
# under the MicroPython unix port; prints one JSON object per line:
# {"name": ..., "value": ..., "unit": ...}. Figures measured in the same run
# are comparable; across machines only ratios are.

import importlib
import sys

from .runtime import find_micropython, run_micropython

# name -> workload module (in acomm_cpython.bench.workloads). A workload has
# run(emit, quick=False): emit(name, value, unit) for each figure; quick, its
# code path with small sizes (tests/cpython/test_bench_all.py runs every
# benchmark here that way, so a new one must take it and stay quick: a few
# seconds). PER_RUNTIME: the figures that depend on the runtime; the module
# then runs as a script under MicroPython too (--quick: quick_argv() in
# timer) and imports only acomm and its own folder (test_port_layers).
BENCHES = {
    "core": "core_workload",
    "queue": "queue_workload",
    "discovery": "discovery_workload",
    "codec": "codec_workload",
    # encode + decode of the teleop command and the CADDY diver status, per
    # runtime, where the time goes, and against cbor2 and ltcodecs
    "encode": "encode_workload",
    "fec": "fec_workload",
    "sim": "sim_workload",
    "teleop": "teleop_workload",
    "transfer": "transfer_workload",
    "store": "store_workload",
    "footprint": "footprint_workload",
    # acomm beside IMC, rmw_desert's CBOR and ltcodecs (BENCHMARKS.md); it
    # runs transfer and footprint again, so `all` leaves it out
    "compare": "compare_workload",
    # 24 simulated hours with faults: minutes of wall time, so not in `all`
    "soak": "soak_workload",
    # an attacker without the key in the demo's ocean (--open: open mode)
    "attack": "attack_workload",
    # the operator console: the page's size and its MicroPython heap
    "web": "web_workload",
    # a sweep in one process and on 2 Dask workers (needs the sweep extra)
    "sweep": "sweep_workload",
    # the buoy flashed onto an emulated RP2040, relaying a diver's report to
    # Iridium through a reset: minutes of wall time, so not in `all`
    "board": "board_workload",
    # a topside node's idle CPU and how soon a frame's bytes reach its
    # driver: the event loop against the 5 ms polling loop before it
    "node": "node_workload",
    # seed 004's teleoperation through `acomm bridge mavlink`: a GCS's stick
    # to an autopilot over the seed's modems (simulated) and emulated SeaTracs
    "mavlink": "mavlink_workload",
    # multi-hop routing in the simulated ocean, learned against flooding and an
    # oracle, 4 scenarios x 5 seeds: many minutes of wall time, so not in `all`
    "routing": "routing_workload",
    # a buoy's packets to a shore server with no modem and commands back,
    # through the emulated Iridium gateway's DirectIP and RockBLOCK services
    "surface": "surface_workload",
    # the physics channel (issue 39): absorption, noise, each modem's range,
    # seed 004's trials, capture, and its cost against the curve model
    "channel": "channel_workload",
}
NOT_IN_ALL = ("compare", "soak", "attack", "sweep", "board", "routing")


def workload(name):
    """The workload module of benchmark `name` (imported now)."""
    return importlib.import_module("acomm_cpython.bench.workloads." + BENCHES[name])


def run(names, emit, only=None, open_mode=False, quick=False, micropython=True):
    """Runs the benchmarks `names`, each figure through emit(name, value, unit).

    A workload runs in this process, then, when it has figures that depend
    on the runtime (PER_RUNTIME), again as a script under MicroPython
    (unless micropython=False), those figures named ..._cpython and
    ..._micropython. quick: each workload's own code path with small sizes
    and short timings (its figures mean nothing; tests/cpython/test_bench_all.py).
    only, open_mode: the footprint's and the attack's options."""
    mp = find_micropython() if micropython else None
    for name in names:
        mod = workload(name)
        per_runtime = getattr(mod, "PER_RUNTIME", ())

        def cp_emit(n, v, u):
            emit(n + "_cpython" if n in per_runtime else n, v, u)

        kw = {}
        if only:
            kw["only"] = only
        if open_mode:
            kw["open_mode"] = True
        if quick:
            kw["quick"] = True
        mod.run(cp_emit, **kw)
        if not per_runtime or not micropython:
            continue
        if mp is None:
            print("note: no micropython command found; MicroPython figures skipped", file=sys.stderr)
            continue
        for rec in run_micropython(BENCHES[name], mp, quick):
            if rec["name"] in per_runtime:
                emit(rec["name"] + "_micropython", rec["value"], rec["unit"])
