# `acomm sweep` on the routed networks of `acomm bench routing`
# (acomm_sim.routednet), through the real command line: the chain learned
# against the oracle, the grid with routing, the random network with its
# AUVs; each run writes its row, with the routing overhead, to sweep.csv.
import csv
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _sweep(tmp_path, *args):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [os.path.join(ROOT, "ports", p) for p in ("cpython", "sim")])
    out = str(tmp_path / "out")
    p = subprocess.run([sys.executable, "-m", "acomm_cpython.cli", "sweep", "--workers", "1", "--no-plots",
                        "--quiet", "--out", out] + list(args), capture_output=True, text=True, env=env, cwd=ROOT,
                       timeout=300)
    assert p.returncode == 0, p.stderr[-3000:]
    with open(os.path.join(out, "sweep.csv")) as f:
        return list(csv.DictReader(f))


def test_the_chain_learned_and_by_the_oracle(tmp_path):
    rows = _sweep(tmp_path, "--scenario", "chain", "--grid", "routing=learned,oracle", "--seeds", "1",
                  "--minutes", "10")
    assert [r["routing"] for r in rows] == ["learned", "oracle"] and all(r["status"] == "ok" for r in rows), rows
    learned, oracle = rows
    assert int(learned["sent"]) > 0 and float(learned["pdr"]) > 0
    assert float(learned["overhead"]) > 0 and float(oracle["overhead"]) == 0  # the oracle sends no route control


def test_the_grid_with_routing_and_the_random_network(tmp_path):
    rows = _sweep(tmp_path / "g", "--scenario", "grid", "--grid", "routing=learned", "--grid", "nodes=16",
                  "--seeds", "1", "--minutes", "8")
    assert rows[0]["status"] == "ok" and int(rows[0]["sent"]) > 0, rows
    rows = _sweep(tmp_path / "r", "--scenario", "random", "--grid", "routing=flooding", "--seeds", "1",
                  "--minutes", "4")
    assert rows[0]["status"] == "ok" and int(rows[0]["sent"]) > 0 and float(rows[0]["overhead"]) > 0, rows
