# `acomm demo --mission relay` through the real command line: the diver swims
# out of the buoy's range and its reports reach the buoy through the AUV on a
# route the nodes found themselves; when the AUV leaves, the route is lost,
# and it is found again, directly, once the diver is back in the buoy's range.
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _demo(*args):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [os.path.join(ROOT, "ports", p) for p in ("cpython", "sim")])
    return subprocess.run([sys.executable, "-m", "acomm_cpython.cli", "demo", "--mission", "relay"] + list(args),
                          capture_output=True, text=True, env=env, cwd=ROOT, timeout=300)


def test_the_diver_reports_through_the_auv_on_a_route_found_and_found_again():
    p = _demo("--json")
    assert p.returncode == 0, p.stderr[-3000:]
    s = json.loads(p.stdout)
    changes = s["route_changes"]
    assert changes[0] == "direct" and "via auv" in changes, changes
    assert changes[changes.index("via auv"):][-1] == "direct" and "none" in changes[changes.index("via auv"):]
    assert s["relayed_by_auv"] > 0 and s["route_requests"] > 0
    assert s["reports_delivered"] >= 0.9 * s["reports_sent"], s


def test_the_timeline_and_what_goes_with_the_caddy_mission_only():
    p = _demo("--minutes", "10")
    assert p.returncode == 0, p.stderr[-3000:]
    assert "route found via auv" in p.stdout and "buoy got report" in p.stdout, p.stdout[-2000:]
    for extra in (("--web", "127.0.0.1:0"), ("--site", "docs/sites/coastal.json")):
        p = _demo(*extra)
        assert p.returncode == 2 and "--web and --site go with the caddy mission" in p.stdout, (extra, p.stdout)
