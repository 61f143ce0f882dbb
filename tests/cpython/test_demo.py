# The main job: `acomm demo`'s mission, run once (about 2 s of wall time)
# and checked for what its timeline claims: discovery, the CADDY phase, an
# alarm overtaking the dive log, the teleop failsafe tripping in the
# acoustic shadow and recovering, traffic waiting through the outage; the
# buoy's alarm reaching the shore node over Iridium SBD and DirectIP and the
# shore's command coming back as an MT message, all in virtual time; and
# the command line's JSON summary, CSV and determinism.
import csv
import json

from acomm_cpython.cli import main as cli
from acomm_cpython.demo import report
from acomm_cpython.demo.mission import Mission

_RUN = {}


def mission():
    if "m" not in _RUN:
        m = Mission(seed=1, minutes=20).run()
        _RUN["m"] = m
        _RUN["s"] = report.summary(m, 1.0)
    return _RUN["m"], _RUN["s"]


def test_every_node_discovers_the_others_in_the_first_minutes():
    m, s = mission()
    assert len(m.discovered) == 6
    assert s["discovery_s"] < 90


def test_caddy_phase_runs_its_cycles():
    m, s = mission()
    c = s["caddy"]
    assert c["cycles"] >= 10
    assert 7.0 < c["cycle_median_s"] < 15.0


def test_the_alarm_overtakes_the_dive_log():
    m, s = mission()
    a = s["alarm"]
    # raised at 390 s with most of the log still queued; one TDMA cycle is 20 s
    assert a["latency_s"] is not None and a["latency_s"] < 45
    assert a["log_lines_delivered_after_it"] >= 5
    assert a["answer_latency_s"] is not None
    log = s["log"]
    assert log["received"] == log["lines"] and log["complete_s"] > 390 + a["latency_s"]


def test_teleop_failsafe_trips_in_the_shadow_and_recovers():
    m, s = mission()
    t = s["teleop"]
    trips = [x for x in t["failsafe_trips"] if x[1] == "timeout"]
    # the shadow covers 720..795 s; the failsafe waits 35 s of silence
    assert trips and 720 < trips[0][0] < 795
    assert any(trips[0][0] < r < 900 for r in t["failsafe_recoveries_s"])
    rows = m.traffic.log.rows.values()
    shadow = [r for r in rows if r[1] == "teleop" and 722000 <= r[6] <= 780000]
    assert shadow and all(r[7] is None or r[7] > 795000 for r in shadow)
    assert t["auv_travelled_m"] > 5


def test_traffic_waits_through_the_outage_and_flows_after():
    m, s = mission()
    o = s["outage"]
    assert o["queued_during"] > 0 and o["received_during"] == 0
    assert o["delivered_after"] > 0
    # the acknowledged diver status waited rather than being lost
    rows = m.traffic.log.rows.values()
    status = [r for r in rows if r[1] == "status" and 960000 <= r[6] < 1080000]
    assert status and all(r[7] is not None and r[7] >= 1080000 for r in status)


def test_the_alarm_reaches_shore_by_directip_and_the_command_comes_back_as_mt():
    from acomm_cpython.demo.uplink import COMMAND
    from acomm_cpython.shore import directip as dip

    m, s = mission()
    u, r = m.uplink, s["uplink"]
    # every MO message reached the shore node as DirectIP bytes, parsed by its Reader and confirmed,
    # in MOMSN order; the alarm is in one of them (inside the buoy's acomm frame)
    assert r["mo_by_directip"] >= 2 and r["mo_momsn"] == list(range(1, r["mo_by_directip"] + 1))
    assert all(taken == 1 for _, _, _, taken in u.port.mo) and r["refused"] == {}
    payloads = [dip.decode_mo(dip.Reader(dip.MO_IES).feed(msg))["payload"] for _, _, msg, _ in u.port.mo]
    assert any(b"ALARM low_air" in p for p in payloads)
    assert u.driver.stats["mo_delivered"] == r["mo_by_directip"]
    # the shore got it, and the buoy got the shore's ACK back as an MT message
    alarm_at = 390 + s["alarm"]["latency_s"]
    assert r["report_to_shore_s"] is not None and r["report_acked_s"] > r["report_to_shore_s"]
    # the command: handed to the gateway by DirectIP (queued: a place >= 1), collected by the buoy
    # in a session, and the buoy's ACK came back to shore by DirectIP
    assert r["mt_by_directip"] >= 2 and all(st >= 1 for st in r["mt_statuses"])
    assert r["command_to_buoy_s"] is not None and r["command_session"].startswith("AT+SBDIX")
    assert r["command_acked_s"] > r["command_to_buoy_s"]
    said = [t for ms, tag, t in m.timeline if tag == "uplink" and ms / 1000 > alarm_at]
    assert any("buoy <- shore %r" % COMMAND.decode() in t for t in said), said
    # the acoustic mission saw none of it: the shore is not one of its nodes
    assert len(m.discovered) == 6


def test_summary_rows_cover_every_class_with_sane_figures():
    m, s = mission()
    classes = set(r["class"] for r in s["traffic"])
    assert classes == {"alarm", "teleop", "answer", "status", "auv_state", "position", "log"}
    for r in s["traffic"]:
        assert 0 <= r["pdr"] <= 1 and r["received"] <= r["sent"]
        if r["received"]:
            lo, hi = r["latency_median_ci95_s"] if r["received"] > 1 else (r["latency_median_s"],) * 2
            assert lo <= r["latency_median_s"] <= hi


def test_command_line_json_csv_and_the_same_run_for_the_same_seed(tmp_path, capsys):
    out = str(tmp_path)
    args = ["demo", "--seed", "3", "--minutes", "4", "--json", "--no-plots", "--out", out]
    assert cli(args) == 0
    first = json.loads(capsys.readouterr().out)
    assert cli(args) == 0
    second = json.loads(capsys.readouterr().out)
    for k in ("wall_s", "speedup"):
        first.pop(k)
        second.pop(k)
    assert first == second
    with open(first["csv"]) as f:
        rows = list(csv.reader(f))
    assert rows[0][0] == "id" and len(rows) - 1 == sum(r["sent"] for r in first["traffic"])
    assert cli(["demo", "--minutes", "0"]) == 2
