# Prints what the simulator computed for fixed seeds, with every wall-clock
# figure left out, so that a change meant to make the simulator faster can be
# checked to change nothing else: run it before and after and diff the two
# outputs (they must be byte-identical).
#
#   .venv/bin/python tools/sim_fingerprint.py > before.txt
#   ... change the simulator ...
#   .venv/bin/python tools/sim_fingerprint.py > after.txt && diff before.txt after.txt
#
# It covers the demo (its --json summary without wall_s and speedup, a hash
# of its per-packet CSV and of its timeline), a soak at raised fault rates
# (figures of soak_workload, no tracemalloc), the sim bench's TDMA and ALOHA
# runs (collisions, PDR and a hash of every node's events) and one hour of
# the 64-node scale run. --full adds the 24-hour soak of `acomm bench soak`
# (minutes of wall time).
import hashlib
import json
import os
import sys
import tempfile


def _h(obj):
    return hashlib.sha256(repr(obj).encode()).hexdigest()[:16]


def _plain(ev):
    # an event with its objects (the Link) by type, so the hash has no addresses
    return tuple(x if isinstance(x, (int, float, str, bytes, type(None))) else type(x).__name__ for x in ev)


def _timed_worlds():
    # every World records its nodes' events with the simulated time at which
    # they came (appended last, so e[0] is still the event's code)
    from acomm_sim import world

    class TimedWorld(world.World):
        def add(self, name, node_id, modem, **kw):
            if kw.get("listener") is None:
                box = []
                kw["listener"] = lambda ev: box.append(_plain(ev) + (self.clock(),))
                sn = world.World.add(self, name, node_id, modem, **kw)
                sn.events = box
                return sn
            return world.World.add(self, name, node_id, modem, **kw)

    return TimedWorld


def demo(seed=1, minutes=20):
    from acomm_cpython.demo import report
    from acomm_cpython.demo.mission import Mission

    m = Mission(seed=seed, minutes=minutes).run()
    s = report.summary(m, 1.0)
    del s["wall_s"], s["speedup"]
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "packets.csv")
        m.traffic.log.write_csv(p)
        with open(p, "rb") as f:
            csv = hashlib.sha256(f.read()).hexdigest()[:16]
    return {"summary": s, "csv": csv, "timeline": _h(m.timeline),
            "events": {n: _h(sn.events) for n, sn in sorted(m.world.nodes.items())}}


def soak(hours, rate_scale, seed):
    from acomm_cpython.bench.workloads.soak_workload import soak as run

    f, _, _ = run(seed=seed, hours=hours, rate_scale=rate_scale, trace=False)
    return f


def sim_bench():
    from acomm.events import EV_RECEIVED
    from acomm_cpython.bench.workloads import sim_workload as sw

    sw.World = _timed_worlds()
    out = {}
    for kind in ("tdma", "aloha"):
        w, _, pdr = sw.run_once(kind)
        out[kind] = {"collided": w.channel.collided, "delivered": w.channel.delivered, "deaf": w.channel.deaf,
                     "pdr": pdr, "now": w.now(),
                     "events": _h([(n, sn.events) for n, sn in sorted(w.nodes.items())]),
                     "received": sum(1 for sn in w.nodes.values() for e in sn.events if e[0] == EV_RECEIVED)}
    return out


def scale(nodes, sim_s):
    from acomm_cpython.bench.workloads import sim_workload as sw

    if not hasattr(sw, "run_scale"):
        return None
    sw.World = _timed_worlds()
    w, _, pdr = sw.run_scale(nodes, sim_s)
    return {"nodes": nodes, "pdr": pdr, "collided": w.channel.collided, "delivered": w.channel.delivered,
            "events": _h([(n, sn.events) for n, sn in sorted(w.nodes.items())])}


def main(argv):
    print("demo", json.dumps(demo(), sort_keys=True))
    print("soak_short", json.dumps(soak(1.5, 12, 3), sort_keys=True))
    print("sim_bench", json.dumps(sim_bench(), sort_keys=True))
    print("scale_64", json.dumps(scale(64, 600), sort_keys=True))
    if "--full" in argv:
        print("soak_24h", json.dumps(soak(24.0, 1.0, 1), sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
