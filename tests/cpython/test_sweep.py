# acomm sweep: the CSV of a sweep run in this process is the same, byte for
# byte, as the one run on a Dask LocalCluster of 2 worker processes on
# loopback; a crashing run is recorded with its seed and traceback and the
# sweep goes on; --resume runs only what the CSV lacks; plots are written.
import os

import pytest

from acomm_cpython.demo import sweep

# a tiny grid: 4 nodes, 1 simulated minute per run (a fraction of a second each)
GRID = ["loss=0,0.3", "mac=tdma,aloha"]


def _grid(items=GRID):
    return sweep.parse_grid("grid", items + ["nodes=4"])


def _csv(out):
    with open(os.path.join(out, "sweep.csv"), "rb") as f:
        return f.read()


def test_local_and_dask_local_cluster_write_the_same_csv(tmp_path):
    distributed = pytest.importorskip("distributed")
    a, b = str(tmp_path / "local"), str(tmp_path / "dask")
    rows, paths = sweep.sweep("grid", _grid(), 2, 1, a, workers=1, quiet=True)
    assert len(rows) == 8 and all(r["status"] == "ok" for r in rows)
    assert {r["mac"] for r in rows} == {"tdma", "aloha"} and {r["seed"] for r in rows} == {"1", "2"}
    # the runs measure something: frames were sent and most arrived without extra loss
    assert all(int(r["sent"]) > 0 for r in rows)
    assert sum(float(r["pdr"]) for r in rows if r["loss"] == "0.0") > sum(float(r["pdr"]) for r in rows if r["loss"] == "0.3")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        sweep.sweep("grid", _grid(), 2, 1, b, scheduler=cluster.scheduler_address, quiet=True, plots=False)
    assert _csv(a) == _csv(b)
    if paths:  # matplotlib installed (dev): one plot per swept parameter (nodes has one value)
        assert sorted(os.path.basename(p) for p in paths) == ["sweep_loss.png", "sweep_mac.png", "sweep_nodes.png"]
        assert all(os.path.getsize(p) > 1000 for p in paths)


def test_a_crash_is_recorded_with_its_seed_and_the_sweep_goes_on(tmp_path):
    grid = sweep.parse_grid("grid", ["nodes=1,3"])  # one node: the scenario refuses it
    rows, _ = sweep.sweep("grid", grid, 2, 0.5, str(tmp_path), workers=1, quiet=True, plots=False)
    bad = [r for r in rows if r["status"] == "crash"]
    good = [r for r in rows if r["status"] == "ok"]
    assert [r["seed"] for r in bad] == ["1", "2"] and all(r["nodes"] == "1" for r in bad)
    assert all("Traceback" in r["error"] and "ValueError: grid: nodes is 2..254" in r["error"] for r in bad)
    assert len(good) == 2 and all(r["error"] == "" and int(r["sent"]) > 0 for r in good)


def test_resume_runs_only_what_the_csv_lacks(tmp_path, capsys):
    out = str(tmp_path / "resumed")
    grid = _grid(["loss=0,0.3"])
    sweep.sweep("grid", grid, 1, 0.5, out, workers=1, quiet=True, plots=False)
    sweep.sweep("grid", grid, 2, 0.5, out, workers=1, resume=True, plots=False)
    assert "2 runs (2 already in" in capsys.readouterr().err
    fresh = str(tmp_path / "fresh")
    sweep.sweep("grid", grid, 2, 0.5, fresh, workers=1, quiet=True, plots=False)
    assert _csv(out) == _csv(fresh)


def test_grid_arguments_are_checked():
    assert sweep.parse_grid("demo", ["loss=0,0.1", "mac=tdma"]) == [("loss", [0.0, 0.1]), ("mac", ["tdma"])]
    for bad in (["range=100"], ["loss"], ["loss=0", "loss=1"]):
        with pytest.raises(ValueError):
            sweep.parse_grid("demo", bad)
    assert sweep.parse_grid("grid", ["nodes=4,9"]) == [("nodes", [4, 9])]
    assert len(sweep.plan("grid", sweep.parse_grid("grid", ["nodes=4,9", "mac=tdma,aloha,none"]), 3, 1)) == 18


def test_progress_says_runs_done_and_time_left():
    import io

    s = io.StringIO()
    p = sweep.Progress(4, stream=s)
    assert "0/4 runs, ? left" in p.line()
    p.step({"status": "ok"})
    p.step({"status": "crash"})
    assert "2/4 runs, 1 crashed, 0:00:0" in s.getvalue().split("\r")[-1]
