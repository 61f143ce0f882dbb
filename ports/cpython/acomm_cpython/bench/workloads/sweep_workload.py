# `acomm bench sweep`: how much faster a sweep runs on 2 Dask workers than
# in one process. The sweep: the demo mission (SeaTrac beacons, about a
# second of wall time per run) over loss 0/0.1/0.2 and mac tdma/aloha, 2
# seeds, 20 simulated minutes (12 runs), in this process and on a Dask
# LocalCluster of 2 worker processes on loopback (started, and its workers
# warmed up with one short run each, before the clock starts, and closed
# after; its start is reported on its own; this process is warmed up the
# same way), the two alternating ROUNDS times, each figure the fastest of
# its rounds. All CSVs must be identical, or the bench fails.
#   sweep_local_1_core_s       wall seconds in this process
#   sweep_dask_2_workers_s     wall seconds on the 2 workers
#   sweep_speedup_2_workers    their ratio (at most 2 on this 2-core machine)
#   sweep_cluster_start_s      starting the LocalCluster
#   sweep_load_1min            the 1-minute load average when the timed runs
#                              end: the runs use both cores, so other work on
#                              the machine shows as a load above 2 and takes
#                              from the workers, not from the single process
#                              (at a load of 2.4, 1.16x; quiet, 1.98x)
# Needs dask[distributed] (pip install 'acomm[sweep]'). CPython only.
import os
import shutil
import tempfile
import time

from acomm_cpython.demo import sweep

PER_RUNTIME = ()
GRID = ["loss=0,0.1,0.2", "mac=tdma,aloha"]
SEEDS = 2
MINUTES = 20
SCENARIO = "demo"
ROUNDS = 2


def _least(best, t):
    return t if best is None else min(best, t)


def run(emit, quick=False):
    if quick:
        # the local sweep alone, two 12-second runs: no Dask cluster
        d = tempfile.mkdtemp(prefix="acomm-sweep-bench-")
        try:
            t0 = time.perf_counter()
            sweep.sweep(SCENARIO, sweep.parse_grid(SCENARIO, ["mac=tdma,aloha"]), 1, 0.2, d, workers=1, quiet=True,
                        plots=False)
            emit("sweep_local_1_core_s", time.perf_counter() - t0, "s")
        finally:
            shutil.rmtree(d, ignore_errors=True)
        return
    try:
        from distributed import LocalCluster
    except ImportError:
        raise RuntimeError("the sweep bench needs Dask: pip install 'acomm[sweep]'")
    grid = sweep.parse_grid(SCENARIO, GRID)
    d = tempfile.mkdtemp(prefix="acomm-sweep-bench-")
    try:
        warm = sweep.parse_grid(SCENARIO, ["loss=0"])
        sweep.sweep(SCENARIO, warm, 1, 0.2, os.path.join(d, "warm"), workers=1, quiet=True, plots=False)
        local = dask = start = None
        csvs = []
        for k in range(ROUNDS):
            # the local run with no cluster up (its idle processes would take a little from it)
            a, b = os.path.join(d, "local%d" % k), os.path.join(d, "dask%d" % k)
            t0 = time.perf_counter()
            sweep.sweep(SCENARIO, grid, SEEDS, MINUTES, a, workers=1, quiet=True, plots=False)
            local = _least(local, time.perf_counter() - t0)
            t0 = time.perf_counter()
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                              dashboard_address=None) as cluster:
                start = _least(start, time.perf_counter() - t0)
                sweep.sweep(SCENARIO, warm, 2, 0.2, os.path.join(d, "warm%d" % k),
                            scheduler=cluster.scheduler_address, quiet=True, plots=False)
                t0 = time.perf_counter()
                sweep.sweep(SCENARIO, grid, SEEDS, MINUTES, b, scheduler=cluster.scheduler_address, quiet=True,
                            plots=False)
                dask = _least(dask, time.perf_counter() - t0)
            csvs += [a, b]
        load = os.getloadavg()[0]
        texts = set()
        for c in csvs:
            with open(os.path.join(c, "sweep.csv"), "rb") as f:
                texts.add(f.read())
        if len(texts) != 1:
            raise RuntimeError("the CSVs of the local and the Dask sweeps differ")
    finally:
        shutil.rmtree(d, ignore_errors=True)
    emit("sweep_local_1_core_s", local, "s")
    emit("sweep_dask_2_workers_s", dask, "s")
    emit("sweep_speedup_2_workers", local / dask, "x")
    emit("sweep_cluster_start_s", start, "s")
    emit("sweep_load_1min", load, "load")
