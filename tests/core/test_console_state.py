# The operator console's state (acomm.apps.console) on a simulated ocean: a
# buoy with an X150 USBL and a diver with an X110 modem, real nodes and
# SeaTrac drivers against emulated beacons. The console listens to the
# buoy's events; its views and its commands are checked as the web server
# (acomm_web) would use them, without any web library; with a network key
# what the console sends arrives sealed.
from acomm.apps.console import ALARM_SIZE, BUCKETS, LOG_SIZE, ConsoleState
from acomm.catalog import caddy
from acomm.events import DELIVERED, EV_RECEIVED, EV_STATUS, QUEUED
from acomm_sim.world import World

C = caddy.CATALOG


def ocean():
    w = World(seed=3)
    got = {"diver": [], "buoy": []}
    buoy = w.add("buoy", 1, "seatrac", position=(0.0, 0.0, 0.5), emu_opts={"part": 795, "seed": 11},
                 link_opts={"advert_period_ms": 20000}, listener=got["buoy"].append)
    diver = w.add("diver", 2, "seatrac", position=(30.0, 40.0, 10.0), emu_opts={"part": 843, "seed": 12},
                  link_opts={"advert_period_ms": 20000}, listener=got["diver"].append)
    con = ConsoleState(buoy.node)
    buoy.node.listen(con.on_event)
    w.add_task(Poller(con))
    return w, buoy, diver, con, got


class Poller:
    def __init__(self, con):
        self.con = con

    def poll(self, now):
        self.con.poll(now)
        return now + 500


def received(events):
    return [C.unpack(ev[4]) for ev in events if ev[0] == EV_RECEIVED]


def test_nodes_chat_range_alarm():
    w, buoy, diver, con, got = ocean()
    w.run(60000)
    nodes = con.view("nodes", w.now())["nodes"]
    names = sorted(n["name"] for n in nodes)
    assert names == ["buoy", "diver"], names
    d = [n for n in nodes if n["name"] == "diver"][0]
    assert d["id"] == 2 and d["links"][0]["state"] == "available", d
    assert d["links"][0]["period_s"] == 20 and d["links"][0]["heard_s"] is not None
    info = con.view("info", w.now())
    assert info["name"] == "buoy" and "ranging" in info["links"][0]["caps"], info

    # chat: queued (202), delivered, the diver gets the CADDY chat line
    v = con.versions()["log"]
    code, ans = con.command(w.now(), {"op": "chat", "dst": "diver", "text": "come up slowly"}, "alice")
    assert code == 202, (code, ans)
    assert con.versions()["log"] != v
    w.run(30000)
    e = [x for x in con.view("log", w.now())["entries"] if x["req"] == ans["req"]][0]
    assert e["by"] == "alice" and e["cls"] == "chat" and e["status"] == "delivered", e
    assert [s for _, s in e["timeline"]][0] == "queued" and e["timeline"][-1][1] == "delivered", e
    assert [[(m.name, v) for m, v in r] for r in received(got["diver"])] == [[("chat", {"text": "come up slowly"})]]

    # the acknowledged DAT brought a USBL fix: the diver within a metre and
    # two degrees of bearing of where it is (50 m away, 10 m deep)
    pos = con.view("positions", w.now())
    f = pos["fixes"]["diver"]
    assert abs(f["east"] - 30.0) < 3 and abs(f["north"] - 40.0) < 3, f
    assert pos["ranges"]["diver"]["metres"] > 49, pos

    # range: a ping, EV_RANGE_RECEIVED, a fresh range
    code, ans = con.command(w.now(), {"op": "range", "dst": "diver"}, "alice")
    assert code == 202, (code, ans)
    w.run(20000)
    r = con.view("positions", w.now())["ranges"]["diver"]
    assert 49 < r["metres"] < 53 and r["age_s"] < 20, r

    # the diver's alarm shows until acknowledged
    diver.node.send("acoustic", "buoy", C.pack([(caddy.ALARM, {"alarm": "low_air"})]), 60, 1, True)
    w.run(20000)
    al = con.view("alarms", w.now())
    assert al["unacked"] == 1 and al["alarms"][0]["from"] == "diver" and "low_air" in al["alarms"][0]["text"], al
    code, ans = con.command(w.now(), {"op": "ack", "alarm": al["alarms"][0]["id"]}, "bob")
    assert code == 200 and ans["acked_by"] == "bob", (code, ans)
    al = con.view("alarms", w.now())
    assert al["unacked"] == 0 and al["alarms"][0]["acked_by"] == "bob"
    assert con.view("log", w.now())["entries"][-1]["by"] == "bob"

    # link quality: acknowledged requests delivered in this minute
    q = con.view("quality", w.now())["buckets"]
    assert sum(b["acked"] for b in q) >= 1 and q[-1]["pdr"] is not None, q


def test_queue_and_cancel():
    w, buoy, diver, con, got = ocean()
    w.run(1000)
    code, ans = con.command(w.now(), {"op": "command", "dst": "diver", "catalog": "caddy", "name": "come_here"})
    assert code == 202, (code, ans)
    code2, ans2 = con.command(w.now(), {"op": "command", "dst": "diver", "catalog": "seaware", "name": "stop_mission"})
    assert code2 == 202, (code2, ans2)
    q = con.view("queue", w.now())["links"][0]
    reqs = [i["req"] for i in q["items"]]
    assert ans2["req"] in reqs, q
    item = [i for i in q["items"] if i["req"] == ans2["req"]][0]
    assert item["cls"] == "command" and 0 < item["expires_s"] <= 120 and item["dst"] == "diver", item
    code, c = con.command(w.now(), {"op": "cancel", "req": ans2["req"]}, "carol")
    assert code == 200 and c["canceled"] == ans2["req"], (code, c)
    e = [x for x in con.view("log", w.now())["entries"] if x["req"] == ans2["req"]][0]
    assert e["status"] == "canceled", e
    code, c = con.command(w.now(), {"op": "cancel", "req": ans2["req"]})
    assert code == 404, (code, c)


def test_bad_commands_get_4xx_with_a_reason():
    w, buoy, diver, con, got = ocean()
    now = w.now()
    cases = [
        ("not a dict", 400),
        ({}, 400),
        ({"op": "launch"}, 400),
        ({"op": "chat", "dst": "nemo", "text": "hi"}, 404),
        ({"op": "chat", "dst": "diver"}, 400),
        ({"op": "chat", "dst": "diver", "text": "CAPITALS"}, 400),
        ({"op": "chat", "dst": "diver", "text": "x" * 500}, 400),
        ({"op": "chat", "dst": "buoy", "text": "me"}, 400),
        ({"op": "chat", "dst": "diver", "text": "hi", "link": "radio"}, 404),
        ({"op": "command", "dst": "diver", "catalog": "caddy", "name": "fly"}, 400),
        ({"op": "command", "dst": "diver", "catalog": "imc", "name": "x"}, 400),
        ({"op": "cancel", "req": "one"}, 400),
        ({"op": "cancel", "req": 999}, 404),
        ({"op": "range", "dst": 7}, 400),
        ({"op": "ack", "alarm": 5}, 404),
    ]
    for cmd, want in cases:
        code, ans = con.command(now, cmd)
        assert code == want and ans["error"], (cmd, code, ans)
    assert con.rejected == len(cases) and con.commands == 0
    # the node goes on
    w.run(5000)
    assert con.command(w.now(), {"op": "chat", "dst": "diver", "text": "still here"})[0] == 202


def test_bounded():
    w, buoy, diver, con, got = ocean()
    node = buoy.node
    link = node.links["acoustic"]
    for k in range(3 * LOG_SIZE):
        ev = (EV_RECEIVED, link, "diver", "buoy", C.pack([(caddy.ALARM, {"alarm": "cold"})]))
        con.on_event(ev, k * 1000)
    assert len(con.log) == LOG_SIZE and con.held()["requests"] <= LOG_SIZE
    assert len(con.alarms) == ALARM_SIZE and con.alarms[-1]["id"] == 3 * LOG_SIZE
    # an acknowledged alarm leaves first
    con.command(200000, {"op": "ack", "alarm": con.alarms[3]["id"]})
    kept = con.alarms[3]["id"]
    con.on_event((EV_RECEIVED, link, "diver", "buoy", C.pack([(caddy.ALARM, {"alarm": "cramp"})])), 200000)
    ids = [a["id"] for a in con.alarms]
    assert kept not in ids and len(ids) == ALARM_SIZE and con.alarms[0]["acked_by"] is None, ids
    # what no catalog parses is logged as data, in hex
    con.on_event((EV_RECEIVED, link, "diver", "buoy", b"\xff\xff\xff garbage"), 200000)
    assert con.log[-1]["cls"] == "data" and con.log[-1]["text"].startswith("ffffff"), con.log[-1]
    # statuses over more than an hour keep an hour of buckets
    for k in range(3 * BUCKETS):
        con.on_event((EV_STATUS, link, k, QUEUED, ""), k * 60000)
        con.on_event((EV_STATUS, link, k, DELIVERED, ""), k * 60000 + 100)
    assert con.held()["buckets"] == BUCKETS and con.held()["queued"] <= 64
    q = con.view("quality", 3 * BUCKETS * 60000)["buckets"]
    assert len(q) <= BUCKETS


def test_the_store_in_the_queue_view():
    from acomm.transport import Transport

    w, buoy, diver, con, got = ocean()
    wall = lambda: 1000 + w.now() // 1000  # noqa: E731
    t = Transport.of(buoy.node, wall=wall)
    Transport.of(diver.node, wall=wall)
    w.run(30000)
    pid = t.send(w.now(), "diver", bytes(range(200)), 300, 5)
    store = con.view("queue", w.now())["transport"]
    assert [p["pid"] for p in store] == [pid], store
    p = store[0]
    assert p["dst"] == "diver" and p["priority"] == 5 and p["cls"] == "p5" and 0 < p["expires_s"] <= 300, p
    w.run(200000, until=lambda: not t.pending())
    assert con.view("queue", w.now())["transport"] == [], "delivered: no longer in the store"
    assert [e for e in con.log if e["cls"] == "data" and e["peer"] == "diver"] == [], "fragments are not messages"


def test_with_a_network_key_the_console_sends_sealed():
    from acomm.apps.policy import commands
    from acomm.frame.auth import Auth

    key = bytes(range(32))
    w, buoy, diver, con, got = ocean()
    for sn in (buoy, diver):
        sn.node.set_auth(Auth(key), commands())
    w.run(60000)
    assert con.view("info", w.now())["sealed"] is True
    code, ans = con.command(w.now(), {"op": "chat", "dst": "diver", "text": "sealed line"}, "alice")
    assert code == 202, ans
    w.run(30000)
    rx = [ev for ev in got["diver"] if ev[0] == EV_RECEIVED]
    assert len(rx) == 1 and rx[0][5] is True, rx  # its tag verified at the diver
    e = [x for x in con.log if x["req"] == ans["req"]][0]
    assert e["status"] == "delivered", e
