# Every benchmark of the table (acomm_cpython.bench.table.BENCHES, whatever it
# holds when this runs) through the real command line in quick mode:
# `acomm bench NAME --quick --json` runs the workload's own code path with
# small sizes and short timings (the MicroPython run of its per-runtime
# figures included, with --quick too), exits 0 and prints figures as JSON
# lines {"name", "value", "unit"} with a number for a value. The heavy ones
# run a real but cheap part: footprint the buoy's minute once on the unix
# port's roomy heap, board the flash of the run's two boards staged for the
# Pico, web the unix port's heap from source, sweep the local sweep.
#
# The benchmarks run two at a time (this machine's cores; their figures mean
# nothing here), all started by one fixture, each checked by its own test.
import json
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

from acomm_cpython.bench.table import BENCHES

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TIMEOUT_S = 300


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [os.path.join(ROOT, "ports", p)
                                                  for p in ("cpython", "sim", "micropython", "web")])
    return env


def _bench(name):
    t0 = time.monotonic()
    p = subprocess.run([sys.executable, "-m", "acomm_cpython.cli", "bench", name, "--quick", "--json"],
                       capture_output=True, text=True, env=_env(), timeout=TIMEOUT_S, cwd=ROOT)
    return p.returncode, p.stdout, p.stderr, time.monotonic() - t0


@pytest.fixture(scope="module")
def runs():
    # the slowest first, so that the two lanes end together
    names = sorted(BENCHES, key=lambda n: n not in ("web", "compare", "soak", "sim"))
    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(zip(names, pool.map(_bench, names)))


@pytest.mark.parametrize("name", sorted(BENCHES))
def test_the_benchmark_runs_quick_and_prints_figures(runs, name):
    rc, out, err, secs = runs[name]
    assert rc == 0, "acomm bench %s --quick exited %d after %.1f s:\n%s" % (name, rc, secs, err[-3000:])
    figures = []
    for line in out.splitlines():
        r = json.loads(line)  # --json: nothing but JSON lines on stdout
        assert set(r) == {"name", "value", "unit"}, line
        assert isinstance(r["name"], str) and r["name"] and isinstance(r["unit"], str), line
        assert isinstance(r["value"], (int, float)) and not isinstance(r["value"], bool), line
        figures.append(r["name"])
    assert figures, "acomm bench %s --quick printed no figure:\n%s" % (name, err[-3000:])
    assert len(set(figures)) == len(figures), "a figure printed twice: %s" % figures


def test_a_portable_benchmark_runs_on_both_runtimes_in_quick_mode(runs):
    # the queue's MicroPython run once failed on a simulator import
    from acomm_cpython.bench.runtime import find_micropython

    if find_micropython() is None:
        pytest.skip("no micropython command")
    names = [json.loads(ln)["name"] for ln in runs["queue"][1].splitlines()]
    assert "queue_ops_per_s_cpython" in names and "queue_ops_per_s_micropython" in names, names
