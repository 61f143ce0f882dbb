# The MicroPython side of the benchmarks: where the unix port's command is,
# and a workload run under it as a script. A leaf of the bench group, so
# that workloads which run others under MicroPython (compare, footprint,
# web) need not import the bench's table, which imports them.

import importlib
import json
import os
import shutil
import subprocess
import sys

import acomm

WORKLOADS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "workloads")


def find_micropython():
    """The micropython command beside this Python (a venv's), else on PATH; None when there is none."""
    here = os.path.join(os.path.dirname(sys.executable), "micropython")
    if os.path.exists(here):
        return here
    return shutil.which("micropython")


def workload_file(modname):
    """The script of workload `modname` (a module of acomm_cpython.bench.workloads)."""
    return os.path.join(WORKLOADS, modname + ".py")


def run_micropython(modname, mp, quick=False):
    """Runs workload `modname` as a script under the MicroPython command mp -> its JSON lines, as dicts.

    acomm and the workloads folder go on MICROPYPATH (.frozen keeps the
    built-in asyncio importable), nothing else: a portable workload imports
    only acomm and its own folder (tests/cpython/test_port_layers.py).
    quick: the script gets --quick (small sizes, short timings).
    RuntimeError with its output when it fails."""
    core_root = os.path.dirname(os.path.dirname(os.path.abspath(acomm.__file__)))
    env = dict(os.environ)
    env["MICROPYPATH"] = ".frozen:%s:%s" % (core_root, WORKLOADS)
    # a workload may ask for its own heap (MICROPYTHON_HEAP): timings of
    # code that allocates depend on it, through the collector's sweeps
    heap = getattr(importlib.import_module("acomm_cpython.bench.workloads." + modname), "MICROPYTHON_HEAP", "8M")
    proc = subprocess.run(
        [mp, "-X", "heapsize=" + heap, workload_file(modname)] + (["--quick"] if quick else []),
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
