# Scenario files through the real command line (issue 39): `acomm demo
# --site FILE` runs the mission on the file's physics channel, `acomm sweep
# --site FILE --grid wind=...` sweeps the site's wind and the delivery falls
# with it, a TOML file reads as its JSON twin (Python 3.11+), and a bad file
# is refused with a message; Bellhop's transmission loss where arlpy and
# its binary are installed (skipped, with one line, where they are not).
import csv
import json
import math
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
COASTAL = os.path.join(ROOT, "docs", "sites", "coastal.json")


def _acomm(*args):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [os.path.join(ROOT, "ports", p) for p in ("cpython", "sim")])
    return subprocess.run([sys.executable, "-m", "acomm_cpython.cli"] + list(args), capture_output=True, text=True,
                          env=env, cwd=ROOT, timeout=300)


def test_demo_runs_on_a_site_file(tmp_path):
    p = _acomm("demo", "--site", COASTAL, "--json", "--no-plots", "--minutes", "5", "--out", str(tmp_path))
    assert p.returncode == 0, p.stderr[-3000:]
    s = json.loads(p.stdout)
    assert s["simulated_s"] == 300.0 and any(t["received"] for t in s["traffic"]), s


def test_sweep_over_the_wind_of_a_site(tmp_path):
    out = str(tmp_path / "out")
    p = _acomm("sweep", "--scenario", "grid", "--site", COASTAL, "--grid", "wind=0,20", "--grid", "range=5500",
               "--grid", "nodes=4", "--seeds", "1", "--minutes", "3", "--workers", "1", "--no-plots", "--quiet",
               "--out", out)
    assert p.returncode == 0, p.stderr[-3000:]
    with open(os.path.join(out, "sweep.csv")) as f:
        rows = list(csv.DictReader(f))
    assert [r["wind"] for r in rows] == ["0.0", "20.0"] and all(r["status"] == "ok" for r in rows), rows
    calm, storm = (float(r["pdr"]) for r in rows)
    assert calm > 0.9 and storm < calm - 0.5  # 5.5 km carries in calm water, not in a gale


def test_a_toml_site_reads_as_its_json_twin(tmp_path):
    pytest.importorskip("tomllib")
    from acomm_sim.site import load

    path = tmp_path / "site.toml"
    path.write_text('channel = "physics"\n[site]\ndepth_m = 40\nwind_mps = 6\nabsorption = "fg"\n')
    sc = load(str(path))
    assert sc.site.depth_m == 40.0 and sc.site.wind_mps == 6.0 and sc.site.absorption == "fg"


def test_a_bad_site_file_is_refused(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"site": {"depht_m": 10}}))
    p = _acomm("demo", "--site", str(bad), "--json")
    assert p.returncode == 2 and "depht_m" in p.stdout, p.stdout + p.stderr
    p = _acomm("sweep", "--site", str(bad), "--grid", "wind=1")
    assert p.returncode == 2 and "depht_m" in p.stderr, p.stdout + p.stderr
    p = _acomm("sweep", "--grid", "wind=1")  # without a site, wind is no parameter
    assert p.returncode == 2
    p = _acomm("sweep", "--scenario", "chain", "--site", COASTAL)  # the routed networks have their own channel
    assert p.returncode == 2 and "demo and grid" in p.stderr, p.stderr


def test_bellhop_transmission_loss_where_installed():
    from acomm_cpython import bellhop

    ok, why = bellhop.available()
    if not ok:
        pytest.skip("optional Bellhop path skipped: " + why)
    from acomm_sim import acoustics as ac
    from acomm_sim.physchannel import PhysicsChannel
    from acomm_sim.site import Site

    site = Site(depth_m=100)
    tl = bellhop.transmission_loss(site)
    ray = tl(1000, 10, 20, 25.0)
    # within the bounds of cylindrical and spherical spreading, absorption aside
    assert 10 * math.log10(1000) - 10 < ray < 20 * math.log10(1000) + ac.thorp_db_per_km(25) + 10
    ch = PhysicsChannel(site, tl=tl)
    assert ch.tl is tl
