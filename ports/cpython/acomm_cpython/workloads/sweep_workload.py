# `acomm bench sweep`: how much faster a sweep runs on 2 Dask workers than
# in one process. The sweep: the demo mission (SeaTrac beacons, about a
# second of wall time per run) over loss 0/0.1/0.2 and mac tdma/aloha, 2
# seeds, 20 simulated minutes (12 runs), once in this process and once on
# a Dask LocalCluster of 2
# worker processes on loopback (started, and its workers warmed up with one
# short run each, before the clock starts; its start is reported on its
# own; this process is warmed up the same way). Both CSVs must be identical, or the bench fails.
#   sweep_local_1_core_s       wall seconds in this process
#   sweep_dask_2_workers_s     wall seconds on the 2 workers
#   sweep_speedup_2_workers    their ratio (at most 2 on this 2-core machine)
#   sweep_cluster_start_s      starting the LocalCluster
# Needs dask[distributed] (pip install 'acomm[sweep]'). CPython only.
import os
import shutil
import tempfile
import time

from acomm_cpython import sweep

PER_RUNTIME = ()
GRID = ["loss=0,0.1,0.2", "mac=tdma,aloha"]
SEEDS = 2
MINUTES = 20
SCENARIO = "demo"


def run(emit):
    try:
        from distributed import LocalCluster
    except ImportError:
        raise RuntimeError("the sweep bench needs Dask: pip install 'acomm[sweep]'")
    grid = sweep.parse_grid(SCENARIO, GRID)
    d = tempfile.mkdtemp(prefix="acomm-sweep-bench-")
    try:
        a, b = os.path.join(d, "local"), os.path.join(d, "dask")
        warm = sweep.parse_grid(SCENARIO, ["loss=0"])
        sweep.sweep(SCENARIO, warm, 1, 0.2, os.path.join(d, "warm"), workers=1, quiet=True, plots=False)
        t0 = time.perf_counter()
        sweep.sweep(SCENARIO, grid, SEEDS, MINUTES, a, workers=1, quiet=True, plots=False)
        local = time.perf_counter() - t0
        t0 = time.perf_counter()
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                          dashboard_address=None) as cluster:
            start = time.perf_counter() - t0
            sweep.sweep(SCENARIO, warm, 2, 0.2, os.path.join(d, "warm2"), scheduler=cluster.scheduler_address,
                        quiet=True, plots=False)
            t0 = time.perf_counter()
            sweep.sweep(SCENARIO, grid, SEEDS, MINUTES, b, scheduler=cluster.scheduler_address, quiet=True,
                        plots=False)
            dask = time.perf_counter() - t0
        with open(os.path.join(a, "sweep.csv"), "rb") as f1, open(os.path.join(b, "sweep.csv"), "rb") as f2:
            if f1.read() != f2.read():
                raise RuntimeError("the CSVs of the local and the Dask sweep differ")
    finally:
        shutil.rmtree(d, ignore_errors=True)
    emit("sweep_local_1_core_s", local, "s")
    emit("sweep_dask_2_workers_s", dask, "s")
    emit("sweep_speedup_2_workers", local / dask, "x")
    emit("sweep_cluster_start_s", start, "s")
