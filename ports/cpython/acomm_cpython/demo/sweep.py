# `acomm sweep`: a parameter study of the simulated ocean. A grid over the
# parameters of a scenario (acomm_cpython.demo.sweep_scenarios) times a number of
# seeds; each run is deterministic from its seed and parameters, so the
# runs go anywhere: in this process (--workers 1), on local processes (all
# cores by default), or on a Dask cluster (--scheduler tcp://HOST:8786 from
# `dask scheduler` and `dask worker`; --scheduler local starts a Dask
# LocalCluster of --workers processes on loopback).
#
#   acomm sweep --grid loss=0,0.1,0.2 --grid mac=tdma,aloha --seeds 10 --minutes 20 --out results/
#
# Writes out/sweep.csv, one row per run (its parameters, seed, minutes,
# status ok or crash, the measures, and a crash's traceback), sorted by grid
# point and seed, so the same sweep gives the same file wherever it ran;
# out/sweep.parquet too when pyarrow is installed; and with matplotlib one
# plot per swept parameter (out/sweep_<param>.png): PDR and median latency
# against its values, mean over the seeds with a bootstrap 95 % interval,
# one line per combination of the other parameters. A run that raises is
# recorded with its seed and traceback and the sweep goes on. Rows are
# appended as runs finish, so an interrupted sweep keeps them: --resume
# skips the runs already in the CSV.
import csv
import itertools
import os
import sys
import time
import traceback

from . import sweep_scenarios as sc

KEY = ("scenario", "seed", "minutes")
TAIL = ("status",) + sc.MEASURES + ("error",)


def parse_grid(scenario, items, site=False):
    """['loss=0,0.1', 'mac=tdma'] -> [(name, [values])] in the order given
    (site: a scenario file is given, so its site parameters may be swept too)."""
    out = []
    for item in items:
        name, eq, vals = item.partition("=")
        name = name.strip()
        if not eq or not vals:
            raise ValueError("--grid %r: write NAME=V1,V2,..." % item)
        if name not in sc.SCENARIOS[scenario] and not (site and name in sc.SITE_PARAMS):
            raise ValueError("--grid %s: %s has the parameters %s" % (name, scenario, ", ".join(sc.SCENARIOS[scenario])))
        if any(n == name for n, _ in out):
            raise ValueError("--grid %s given twice" % name)
        out.append((name, [sc.parse_value(name, v.strip(), scenario) for v in vals.split(",")]))
    return out


def plan(scenario, grid, seeds, minutes, base=None):
    """Every run of the sweep: [(scenario, {param: value}, seed, minutes)], in
    CSV order (base: parameters every run has, not swept: the site file)."""
    names = [n for n, _ in grid]
    minutes = float(minutes)
    runs = []
    for combo in itertools.product(*[v for _, v in grid]):
        params = dict(base or {})
        params.update(zip(names, combo))
        for seed in range(1, seeds + 1):
            runs.append((scenario, params, seed, minutes))
    return runs


def one_run(scenario, params, seed, minutes):
    """Runs one point (in any process) -> its CSV row as a dict; never raises."""
    row = {"scenario": scenario, "seed": seed, "minutes": minutes}
    row.update((k, v) for k, v in params.items() if k != "site")  # the site file is not a column
    try:
        row.update(sc.run(scenario, params, seed, minutes))
        row["status"] = "ok"
    except Exception:  # a crash is a result: recorded with its seed, the sweep goes on
        row["status"] = "crash"
        row["error"] = traceback.format_exc()
    return row


def _fmt(v):
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(round(v, 6))
    return str(v)


def _key(scenario, params, seed, minutes, names):
    return tuple([scenario, _fmt(seed), _fmt(float(minutes))] + [_fmt(params[n]) for n in names])


class CsvRows:
    # the sweep's CSV: rows appended as runs end, sorted into plan order at the end
    def __init__(self, path, names):
        self.path = path
        self.names = names
        self.columns = list(KEY) + list(names) + list(TAIL)

    def existing(self):
        # {key: row} of the rows already written (--resume)
        if not os.path.exists(self.path):
            return {}
        with open(self.path, newline="") as f:
            r = csv.DictReader(f)
            if r.fieldnames != self.columns:
                raise ValueError("%s has other columns (%s); --resume needs the same grid" % (self.path, r.fieldnames))
            return {tuple([row[k] for k in KEY] + [row[n] for n in self.names]): row for row in r}

    def start(self, keep):
        with open(self.path, "w", newline="") as f:
            w = csv.DictWriter(f, self.columns)
            w.writeheader()
            for row in keep:
                w.writerow(row)

    def append(self, row):
        with open(self.path, "a", newline="") as f:
            csv.DictWriter(f, self.columns).writerow({k: _fmt(row.get(k)) for k in self.columns})

    def finish(self, order):
        # rewrite in plan order: the file does not depend on which run ended first
        rows = self.existing()
        with open(self.path, "w", newline="") as f:
            w = csv.DictWriter(f, self.columns)
            w.writeheader()
            for k in order:
                if k in rows:
                    w.writerow(rows[k])
        return [rows[k] for k in order if k in rows]


class Progress:
    # runs done out of total and the time left, on one line of stderr
    def __init__(self, total, quiet=False, stream=None):
        self.total = total
        self.done = 0
        self.crashed = 0
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.t0 = time.monotonic()

    def line(self):
        el = time.monotonic() - self.t0
        left = el / self.done * (self.total - self.done) if self.done else None
        bar = "#" * (30 * self.done // max(1, self.total))
        return "[%-30s] %d/%d runs%s, %s left" % (bar, self.done, self.total,
                                                  ", %d crashed" % self.crashed if self.crashed else "",
                                                  "?" if left is None else _hms(left))

    def step(self, row):
        self.done += 1
        if row.get("status") != "ok":
            self.crashed += 1
        if not self.quiet:
            self.stream.write("\r" + self.line())
            if self.done == self.total:
                self.stream.write("\n")
            self.stream.flush()


def _hms(s):
    s = int(s + 0.5)
    return "%d:%02d:%02d" % (s // 3600, s // 60 % 60, s % 60)


def execute(runs, on_row, workers=0, scheduler=None):
    """Runs every (scenario, params, seed, minutes); on_row(row) as each ends, in any order."""
    if scheduler:
        return _on_dask(runs, on_row, scheduler, workers)
    if workers == 1 or len(runs) <= 1:
        for r in runs:
            on_row(one_run(*r))
        return
    from concurrent.futures import ProcessPoolExecutor, as_completed

    with ProcessPoolExecutor(max_workers=workers or os.cpu_count()) as ex:
        futs = [ex.submit(one_run, *r) for r in runs]
        for f in as_completed(futs):
            on_row(f.result())


def _on_dask(runs, on_row, scheduler, workers):
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise RuntimeError("--scheduler needs Dask: pip install 'acomm[sweep]'")
    cluster = None
    if scheduler == "local":
        cluster = LocalCluster(n_workers=workers or os.cpu_count(), threads_per_worker=1, processes=True,
                               host="127.0.0.1", dashboard_address=None)
        scheduler = cluster.scheduler_address
    try:
        with Client(scheduler) as client:
            futs = [client.submit(one_run, *r, pure=False) for r in runs]
            for f in as_completed(futs):
                on_row(f.result())
    finally:
        if cluster is not None:
            cluster.close()


def sweep(scenario, grid, seeds, minutes, out, workers=0, scheduler=None, resume=False, plots=True, quiet=False,
          site=None):
    """The whole sweep -> (rows in plan order, plot paths). site: a scenario
    file's decoded content (acomm_sim.site.parse), for every run."""
    names = [n for n, _ in grid]
    runs = plan(scenario, grid, seeds, minutes, None if site is None else {"site": site})
    order = [_key(s, p, seed, m, names) for s, p, seed, m in runs]
    os.makedirs(out, exist_ok=True)
    table = CsvRows(os.path.join(out, "sweep.csv"), names)
    have = table.existing() if resume else {}
    todo = [r for r, k in zip(runs, order) if k not in have]
    table.start(list(have.values()))
    bar = Progress(len(todo), quiet)
    if not quiet:
        sys.stderr.write("acomm sweep: %d runs (%d already in %s)\n" % (len(todo), len(runs) - len(todo), table.path))

    def on_row(row):
        table.append(row)
        bar.step(row)

    execute(todo, on_row, workers, scheduler)
    rows = table.finish(order)
    _parquet(rows, os.path.join(out, "sweep.parquet"))
    paths = []
    if plots:
        from .sweep_plot import plot_all

        paths = plot_all(rows, grid, out)
    return rows, paths


def _parquet(rows, path):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return None
    pq.write_table(pa.Table.from_pylist(rows), path)
    return path
