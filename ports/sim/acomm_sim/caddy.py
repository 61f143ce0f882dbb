# The CADDY interrogation cycle (seed 003 section 6) on the real stack in a
# simulated World: three agents, PlaDyPos (surface vehicle, USBL), Buddy
# (AUV, USBL) and the diver (modem), each a World node on SeaTrac beacons,
# run the four interrogation pairs in order, again and again:
#
#   step  asks        request (AT odd)                     reply (AT even)
#   0     PlaDyPos -> diver    empty                       DIVER_REPLY
#   1     Buddy -> PlaDyPos    BUDDY_PING(_DIVER)          PLADYPOS_REPLY
#   2     Buddy -> diver       BUDDY_TO_DIVER(_EXT)        DIVER_REPLY
#   3     PlaDyPos -> Buddy    empty                       DIVER_POSITION
#
# How it maps to SeaTrac: a request is an acked link frame (DAT_SEND with
# MSG_REQU, elided one-byte header); every agent always answers with the
# same message, so it keeps its next reply queued in its beacon
# (Link.set_reply -> DAT_QUEUE_SET) and refreshes it whenever it has been
# asked; the beacon sends it in its automatic reply. The third agent hears
# both by passive listening (beacons with hear_all, links with overhear).
# Each agent runs an acomm.apps.interrogation.Interrogation over the four steps;
# a step's timeout is what its longest request and reply take on the air
# plus the beacons' full reply window and a margin, so a lost reply costs
# one timeout and the cycle goes on.
#
# Interface (a World task; the demo uses it too):
#
#   cyc = CaddyCycle(world, pladypos="buoy", buddy="auv", diver="diver")
#   cyc.start(now)        # joins the world's tasks, queues the replies
#   world.run(...)
#   cyc.stop()            # leaves the tasks, takes its listeners off the nodes
#   cyc.cycles            # complete cycles (PlaDyPos starting step 0 again)
#   cyc.cycle_times_ms    # the time of each, start to start
#   cyc.counters[k]       # step k: asked, delivered, failed, replies,
#                         # overheard (reply heard by the third agent),
#                         # timeouts (agents that left the step on its timeout)
#   cyc.log               # (time, step, "request" | "reply", src, dst, message name)
#   cyc.estimates[role]   # what each agent believes: {"diver": (x, y), ...}
#
# State comes from the simulation: positions, course and speed from the
# channel's tracks, diver positions from the USBL fixes of the drivers
# (driver.last_fix after a delivered interrogation), the diver offset seen
# by Buddy's sonar when the diver is within sonar_range_m (then Buddy sends
# the seed's longer "(45)"/"(65)" messages). Offsets are to INIT = `init`
# (east, north) and are clamped to the catalog's +-51 m.

from math import atan2, degrees, sqrt

from acomm.catalog import caddy as C
from acomm.compat import ticks_add, ticks_diff
from acomm.errors import DecodeError
from acomm.events import DELIVERED, EV_RECEIVED, EV_STATUS, is_final
from acomm.apps.interrogation import Interrogation

ROLES = ("pladypos", "buddy", "diver")
STEPS = (("pladypos", "diver"), ("buddy", "pladypos"), ("buddy", "diver"), ("pladypos", "buddy"))
REPLY = {"diver": C.DIVER_REPLY, "pladypos": C.PLADYPOS_REPLY, "buddy": C.DIVER_POSITION}
SEED_BUDGET_S = (7.24, 7.64)  # seed 003 section 6.1: diver unseen / seen by Buddy


def _bytes(bits):
    return (C.ID_BITS + bits + 7) // 8


def _clamp(v, lo, hi):
    return lo if v < lo else (hi if v > hi else v)


def _xy(x, y):
    return {"x": _clamp(round(x, 1), -51.1, 51.2), "y": _clamp(round(y, 1), -51.1, 51.2)}


def request_bytes(step, sees_diver):
    # payload bytes of the request of a step (the link adds its 1-byte header)
    if step == 1:
        return _bytes((C.BUDDY_PING_DIVER if sees_diver else C.BUDDY_PING).max_bits)
    if step == 2:
        return _bytes((C.BUDDY_TO_DIVER_EXT if sees_diver else C.BUDDY_TO_DIVER).max_bits)
    return 0


def reply_bytes(step):
    return _bytes(REPLY[STEPS[step][1]].max_bits)


def budget_s(sees_diver=False, header=1, turn_s=1.3, byte_s=0.08):
    # seed 003 6.1's own formula for acomm's byte counts: 1.3 s per pair
    # and 80 ms per byte of request and reply, link header included
    n = 0
    for k in range(len(STEPS)):
        n += request_bytes(k, sees_diver) + reply_bytes(k) + 2 * header
    return len(STEPS) * turn_s + byte_s * n


class _Agent:
    def __init__(self, role, sn, link_name, steps):
        self.role = role
        self.sn = sn
        self.link = sn.node.links[link_name]
        self.schedule = Interrogation(sn.name, steps)
        self.inbox = []
        self.rid = None  # our request under way
        self.listener = None  # ours on the node, while the cycle runs
        self.overheard = False  # the link's own overhear setting, given back at stop


class CaddyCycle:
    def __init__(self, world, pladypos, buddy, diver, link="acoustic", sonar_range_m=15.0, init=(0.0, 0.0),
                 margin_ms=500, priority=2):
        self.world = world
        self.names = {"pladypos": pladypos, "buddy": buddy, "diver": diver}
        self.role_of = {pladypos: "pladypos", buddy: "buddy", diver: "diver"}
        self.link_name = link
        self.sonar_range_m = sonar_range_m
        self.init = init
        self.priority = priority
        self.steps = [(self.names[a], self.names[r], self._timeout(k, margin_ms)) for k, (a, r) in enumerate(STEPS)]
        self.agents = {}
        self.cycles = 0
        self.cycle_times_ms = []
        self.counters = [dict(asked=0, delivered=0, failed=0, replies=0, overheard=0, timeouts=0) for _ in STEPS]
        self.log = []
        self.estimates = {r: {} for r in ROLES}
        self._cycle_start = None
        self._running = False

    def _timeout(self, k, margin_ms):
        # longest request and reply on the air, the beacon's turnaround and
        # the whole range window (what the asking beacon waits before it
        # gives up), and a margin for the serial lines and steps
        d = self.world.nodes[self.names[STEPS[k][0]]].driver
        air = d.airtime_ms(request_bytes(k, True) + 1) + d.airtime_ms(reply_bytes(k) + 1)
        return air + 2 * d.range_tmo_m * 1000 // d.vos + d.turnaround_ms + d.resp_time_ms + margin_ms

    # -- life ----------------------------------------------------------------
    def start(self, now):
        for role in ROLES:
            sn = self.world.nodes[self.names[role]]
            a = _Agent(role, sn, self.link_name, self.steps)
            a.overheard = a.link.overhear
            a.link.overhear = True
            a.listener = self._listener(a)
            sn.node.listen(a.listener)
            a.schedule.start(now)
            self.agents[role] = a
            self._queue_reply(a, now)
        if not self._running:
            self.world.add_task(self)
            self._running = True
        return self

    def stop(self):
        for a in self.agents.values():
            a.sn.node.unlisten(a.listener)
            a.link.overhear = a.overheard
            a.schedule.stop()
        if self._running:
            self.world.remove_task(self)
            self._running = False

    def _listener(self, a):
        def on_event(ev):
            a.inbox.append(ev)

        return on_event

    # -- the World task -------------------------------------------------------
    def poll(self, now):
        # what everyone observed first, then whose turn it is
        for role in ROLES:
            a = self.agents[role]
            events, a.inbox = a.inbox, []
            for ev in events:
                if ev[0] == EV_STATUS and ev[2] == a.rid and is_final(ev[3]):
                    self._finished(a, now, ev[3] == DELIVERED)
                elif ev[0] == EV_RECEIVED:
                    self._received(a, now, ev[2], ev[3], ev[4])
        for role in ROLES:
            a = self.agents[role]
            s = a.schedule
            before = s.timeouts[s.step]
            k = s.step
            s.poll(now)
            if s.timeouts[k] != before:
                self.counters[k]["timeouts"] += 1
            dst = s.turn(now)
            if dst is not None:
                self._ask(a, now, s.step, dst)
        return None  # every step: events must be answered at once

    def _ask(self, a, now, k, dst):
        if k == 0:
            if self._cycle_start is not None:
                self.cycle_times_ms.append(ticks_diff(now, self._cycle_start))
                self.cycles += 1
            self._cycle_start = now
        msg, data = self._request(a.role, k)
        self.counters[k]["asked"] += 1
        self.log.append((now, k, "request", a.sn.name, dst, msg.name if msg else ""))
        a.rid = a.sn.node.next_req_id()
        life_s = self.steps[k][2] / 1000
        # no link retry: a repeat would fall into the next step's time
        a.link.request(now, a.rid, dst, data, life_s, self.priority, True, 0)

    def _finished(self, a, now, ok):
        k = a.schedule.asked
        a.rid = None
        if k is not None:
            self.counters[k]["delivered" if ok else "failed"] += 1
            if ok:
                fix = a.sn.driver.last_fix
                if fix is not None and "easting" in fix:
                    who = self.role_of.get(self.names[STEPS[k][1]])
                    p = self._pos(a.role)
                    self.estimates[a.role][who] = (p[0] + fix["easting"] - self.init[0],
                                                   p[1] + fix["northing"] - self.init[1])
        a.schedule.done(now, ok)

    def _received(self, a, now, src, dst, data):
        s = a.schedule
        k = s.heard(now, src, dst)
        try:
            msgs = C.CATALOG.unpack(data) if data else []
        except DecodeError:
            msgs = []
        if k is None:
            return
        reply = (src, dst) == (self.steps[k][1], self.steps[k][0])
        if reply:
            name = msgs[0][0].name if msgs else ""
            if dst == a.sn.name:
                self.counters[k]["replies"] += 1
                self.log.append((now, k, "reply", src, dst, name))
            else:
                self.counters[k]["overheard"] += 1
        elif dst == a.sn.name:
            self._queue_reply(a, now)  # asked: our beacon just sent the queued one
        for m, v in msgs:
            self._learn(a.role, self.role_of.get(src), m, v)

    def _learn(self, role, src_role, m, v):
        # what an agent takes from a message it heard (as seed 003 section 6
        # says each one uses it): positions to INIT
        est = self.estimates[role]
        if m is C.PLADYPOS_REPLY:
            est["pladypos"] = (v["pladypos"]["x"], v["pladypos"]["y"])
            est.setdefault("diver", (v["diver"]["x"], v["diver"]["y"]))
        elif m is C.DIVER_POSITION and role != "buddy":
            est["diver"] = (v["diver"]["x"], v["diver"]["y"])
        elif m is C.BUDDY_TO_DIVER or m is C.BUDDY_TO_DIVER_EXT:
            est["buddy"] = (v["buddy"]["x"], v["buddy"]["y"])

    # -- messages from the simulated state ------------------------------------
    def _addr(self, role):
        return self.world.nodes[self.names[role]].address

    def _pos(self, role, t=None):
        p = self.world.channel.position(self._addr(role), t)
        return p if p is not None else (0.0, 0.0, 0.0)

    def _motion(self, role):
        # course (degrees from north) and speed (m/s) over the last second
        now = self.world.now()
        p1 = self._pos(role, now)
        p0 = self._pos(role, ticks_add(now, -1000))
        dx, dy = p1[0] - p0[0], p1[1] - p0[1]
        course = degrees(atan2(dx, dy)) % 360.0 if (dx or dy) else 0.0
        return course, _clamp(sqrt(dx * dx + dy * dy), 0.0, 1.0)

    def _off(self, role):
        p = self._pos(role)
        return _xy(p[0] - self.init[0], p[1] - self.init[1])

    def sees_diver(self):
        b, d = self._pos("buddy"), self._pos("diver")
        return sqrt((b[0] - d[0]) ** 2 + (b[1] - d[1]) ** 2 + (b[2] - d[2]) ** 2) <= self.sonar_range_m

    def _diver_estimate(self, role):
        # a USBL fix of ours first, then what we heard
        e = self.estimates[role].get("diver")
        if e is None:
            return _xy(0.0, 0.0)
        return _xy(e[0], e[1])

    def _request(self, role, k):
        if k in (0, 3):
            return None, b""  # an empty interrogation: the reply is what matters
        course, speed = self._motion("buddy")
        v = {"depth": self._pos("buddy")[2], "course": course, "speed": speed}
        seen = self.sees_diver()
        if seen:
            b, d = self._pos("buddy"), self._pos("diver")
            # the diver to Buddy (step 1) or to INIT (step 2), from the sonar
            v["diver"] = _xy(d[0] - b[0], d[1] - b[1]) if k == 1 else self._off("diver")
        if k == 1:
            m = C.BUDDY_PING_DIVER if seen else C.BUDDY_PING
        else:
            v["buddy"] = self._off("buddy")
            m = C.BUDDY_TO_DIVER_EXT if seen else C.BUDDY_TO_DIVER
        return m, C.CATALOG.pack([(m, v)])

    def _reply(self, role):
        m = REPLY[role]
        if role == "diver":
            course, _ = self._motion("diver")
            v = {"heading": course, "depth": self._pos("diver")[2]}
        elif role == "pladypos":
            course, speed = self._motion("pladypos")
            v = {"quant": 0, "pladypos": self._off("pladypos"), "course": course, "speed": speed,
                 "diver": self._diver_estimate("pladypos")}
        else:
            if self.sees_diver():
                o = self._off("diver")
                self.estimates["buddy"]["diver"] = (o["x"], o["y"])
            v = {"diver": self._diver_estimate("buddy")}
        return m, C.CATALOG.pack([(m, v)])

    def _queue_reply(self, a, now):
        a.link.set_reply(now, self._reply(a.role)[1])
