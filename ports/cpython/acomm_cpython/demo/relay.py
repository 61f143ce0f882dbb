# `acomm demo --mission relay`: the diver swims out of the buoy's range and
# keeps reporting to it through the companion AUV, with routes nobody typed
# (docs/routing.md). The real stack on emulated SeaTrac beacons, every node
# with a Transport made with routing on; the water is the routing bench's:
# a beacon hears another within RANGE_M, never beyond.
#
# The plan (minutes): 0-3 the diver works beside the buoy (heard directly);
# 3-9 it swims 330 m out, past the buoy's range but within the AUV's, which
# holds station between them; its reports wait for a route, and one is
# found through the AUV; at minute 13 the AUV runs a survey leg out of
# everyone's range: the route breaks and is given up; at minute 15 the diver
# turns back and the route is found again, directly, once the buoy hears it.
# The diver sends a 20-byte report every 30 s. The timeline prints each
# change of the diver's route to the buoy as the nodes themselves hold it,
# and every report's arrival with its delay.

import json

from acomm.events import EV_PACKET
from acomm.transport import Transport
from acomm_sim.channel import Channel, Track
from acomm_sim.world import World

RANGE_M = 200.0
LOSS = ((0.0, 0.02), (RANGE_M, 0.05), (RANGE_M + 1.0, 1.0))
BUOY, DIVER, AUV = "buoy", "diver", "auv"
ADDR = {BUOY: 1, DIVER: 2, AUV: 3}
REPORT_MS = 30000
EPOCH_MS = 1000  # the simulator's clock at its start


class RelayMission:
    def __init__(self, seed=1, minutes=20, say=None):
        self.seed = seed
        self.minutes = minutes
        self.say = say
        self.w = World(seed=seed, channel=Channel(seed=seed, loss_curve=LOSS))
        m = 60000
        tracks = {
            BUOY: Track((0.0, 0.0, 0.5)),
            # the diver: beside the buoy until minute 3, 330 m east by 9, there until 15, back by 20
            DIVER: _legs((60.0, 0.0, 12.0), [(3 * m, (60.0, 0.0, 12.0)), (9 * m, (330.0, 0.0, 12.0)),
                                              (15 * m, (330.0, 0.0, 12.0)), (20 * m, (60.0, 0.0, 12.0))]),
            # the AUV: on station between them, then 580 m north from minute 13 at 2 m/s
            AUV: Track((165.0, 20.0, 8.0), t0=EPOCH_MS + 13 * m, waypoints=[(165.0, 600.0, 8.0)], speed=2.0),
        }
        self.sn = {}
        for name in (BUOY, DIVER, AUV):
            sn = self.w.add(name, ADDR[name], "seatrac", position=tracks[name].at(0),
                            link_opts={"advert_period_ms": 60000})
            self.w.channel.set_track(ADDR[name], tracks[name])
            sn.t = Transport.of(sn.node, wall=lambda: self.w.now() // 1000, routing={"seed": seed})
            self.sn[name] = sn
        self.timeline = []
        self.sent = {}  # seq -> time sent
        self.got = {}  # seq -> delay ms
        self._route = "none"
        self._next = None  # the diver's next report (run() sets it)
        self.route_changes = []  # (time ms, "direct", "via auv" or "none")

    def _log(self, now, text):
        line = "%6.1f s  %s" % (now / 1000.0, text)
        self.timeline.append(line)
        if self.say:
            self.say(line)

    def poll(self, now):
        """A world task: the diver's reports, and its route to the buoy as it holds it."""
        if now >= self._next:
            self._next = now + REPORT_MS
            seq = len(self.sent) + 1
            self.sent[seq] = now
            body = b"diver ok %04d depth12" % seq
            self.sn[DIVER].t.send(now, BUOY, body, 600, 8)
        rt = self.sn[DIVER].t.router.routing
        r = rt.table.lookup(now, ADDR[BUOY])
        link = self.sn[DIVER].node.link("acoustic")
        if link.discovery.state(ADDR[BUOY]) == 1 and (r is None or r[0] == ADDR[BUOY]):
            route = "direct"
        elif r is not None:
            route = "via %s" % self.sn[DIVER].node.names.name_of(r[0])
        else:
            route = "none"
        if route != self._route:
            self._route = route
            self.route_changes.append((now, route))
            self._log(now, {"direct": "diver -> buoy: heard directly",
                            "none": "diver -> buoy: no route (searching while reports wait)"}.get(
                                route, "diver -> buoy: route found %s (cost %d)" % (route, r[2] if r else 0)))
        return now + 1000

    def _listener(self):
        def on_event(ev):
            if ev[0] == EV_PACKET and ev[1] == DIVER:
                seq = int(ev[3][9:13])
                if seq in self.sent and seq not in self.got:
                    self.got[seq] = self.w.now() - self.sent[seq]
                    self._log(self.w.now(), "buoy got report %d after %.1f s" % (seq, self.got[seq] / 1000.0))
        return on_event

    def run(self):
        """The whole plan -> self."""
        w = self.w
        self.sn[BUOY].node.listen(self._listener())
        w.run(65000)  # the beacons hear each other's adverts
        self._next = w.now()
        w.add_task(self)
        for at, what in ((3, "the diver swims out, past the buoy's range"), (13, "the AUV runs a survey leg away"),
                         (15, "the diver turns back")):
            if at < self.minutes:
                w.run(max(0, EPOCH_MS + at * 60000 - w.now()))
                self._log(w.now(), what)
        w.run(max(0, EPOCH_MS + int(self.minutes * 60000) - w.now()))
        return self

    def summary(self):
        relays = self.sn[AUV].t.stats["relayed"]
        lat = sorted(self.got.values())
        found = [r for _, r in self.route_changes]
        return {"mission": "relay", "seed": self.seed, "minutes": self.minutes, "reports_sent": len(self.sent),
                "reports_delivered": len(self.got), "relayed_by_auv": relays,
                "route_changes": found, "route_requests": self.sn[DIVER].t.router.routing.finder.stats["requests"],
                "delay_p50_s": round(lat[len(lat) // 2] / 1000.0, 1) if lat else None}


def _legs(start, points):
    # a Track through (time ms, place) points, holding each place until the next time: waypoints
    # at the speed that takes exactly each leg's time
    tr = Track(start, t0=EPOCH_MS)
    t = 0
    here = start
    for at, place in points:
        tr.legs.append((t, at, here, place))
        t, here = at, place
    return tr


def main(args, say):
    """`acomm demo --mission relay`: runs it, prints the timeline (unless --json) and the summary."""
    m = RelayMission(seed=args.seed, minutes=args.minutes, say=say).run()
    s = m.summary()
    if say:
        print()
        for k in sorted(s):
            print("%-18s %s" % (k, s[k]))
    else:
        print(json.dumps(s))
    return 0
