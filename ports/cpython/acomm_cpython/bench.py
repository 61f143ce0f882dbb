# `acomm bench <name> --json`: runs a benchmark workload on CPython in this
# process and, for the figures that depend on the runtime, again as a script
# under the MicroPython unix port; prints one JSON object per line:
# {"name": ..., "value": ..., "unit": ...}. Figures measured in the same run
# are comparable; across machines only ratios are.

import importlib
import json
import os
import shutil
import subprocess
import sys

import acomm

# name -> workload module (in acomm_cpython.workloads)
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
}
NOT_IN_ALL = ("compare", "soak", "attack", "sweep", "board")


def find_micropython():
    here = os.path.join(os.path.dirname(sys.executable), "micropython")
    if os.path.exists(here):
        return here
    return shutil.which("micropython")


def _workload(name):
    return importlib.import_module("acomm_cpython.workloads." + BENCHES[name])


def run_micropython(modname, mp):
    # The workload runs as a script; acomm and the workloads folder go on
    # MICROPYPATH (.frozen keeps the built-in asyncio importable).
    core_root = os.path.dirname(os.path.dirname(os.path.abspath(acomm.__file__)))
    wl_dir = os.path.dirname(os.path.abspath(_workload_file(modname)))
    env = dict(os.environ)
    env["MICROPYPATH"] = ".frozen:%s:%s" % (core_root, wl_dir)
    # a workload may ask for its own heap (MICROPYTHON_HEAP): timings of
    # code that allocates depend on it, through the collector's sweeps
    heap = getattr(importlib.import_module("acomm_cpython.workloads." + modname), "MICROPYTHON_HEAP", "8M")
    proc = subprocess.run(
        [mp, "-X", "heapsize=" + heap, _workload_file(modname)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    if proc.returncode != 0:
        raise RuntimeError("micropython workload %s failed:\n%s%s" % (modname, proc.stdout, proc.stderr))
    out = []
    for line in proc.stdout.splitlines():
        line = line.strip()
        if line.startswith("{"):
            out.append(json.loads(line))
    return out


def _workload_file(modname):
    import acomm_cpython.workloads as w

    return os.path.join(os.path.dirname(w.__file__), modname + ".py")


def run(names, emit, only=None, open_mode=False):
    mp = find_micropython()
    for name in names:
        mod = _workload(name)
        per_runtime = getattr(mod, "PER_RUNTIME", ())

        def cp_emit(n, v, u):
            emit(n + "_cpython" if n in per_runtime else n, v, u)

        if only:
            mod.run(cp_emit, only=only)
        elif open_mode:
            mod.run(cp_emit, open_mode=True)
        else:
            mod.run(cp_emit)
        if not per_runtime:
            continue
        if mp is None:
            print("note: no micropython command found; MicroPython figures skipped", file=sys.stderr)
            continue
        for rec in run_micropython(BENCHES[name], mp):
            if rec["name"] in per_runtime:
                emit(rec["name"] + "_micropython", rec["value"], rec["unit"])
