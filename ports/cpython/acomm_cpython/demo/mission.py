# The demo mission: a surface buoy (the gateway, where the topside team
# sits), a diver with a tablet and a companion AUV, all with SeaTrac beacons
# (the buoy and the AUV X150 USBL, the diver an X110 modem) on one simulated
# acoustic channel. Every node is a real acomm Node with the real SeaTrac
# driver talking to an emulated beacon; only the water is simulated.
#
# The plan (seconds of simulated time; see Mission.plan):
#     0  boot; node discovery by adverts, under the TDMA schedule
#    60  the CADDY interrogation cycle (seed 003 section 6) for 3 minutes;
#        the TDMA schedule is off while the cycle orders the channel
#   240  TDMA again; telemetry: diver status (acknowledged), AUV state and
#        the diver's position from the buoy (one-way)
#   300  the diver's tablet queues its dive log (low priority, acknowledged)
#   390  the diver raises an alarm: it overtakes the log; the buoy answers
#   600  the buoy pilot teleoperates the AUV for 5 minutes; at 720 the AUV
#        drives into an acoustic shadow for 75 s and its failsafe trips
#   960  a ship passes overhead: 2 minutes in which nobody hears anything;
#        telemetry waits in the queues and flows afterwards
#  1200  end
# The buoy also has its Iridium 9603 (demo.uplink): it relays the alarm to
# a shore node by SBD and the gateway's DirectIP, and the shore's command
# comes back as an MT message.
from acomm.catalog import caddy, teleop
from acomm.events import AVAIL_NAMES, EV_AVAILABILITY, EV_RECEIVED, EV_STATUS, FAILED, EXPIRED
from acomm.drivers.mac import Aloha, Tdma
from acomm_sim.caddy import CaddyCycle
from acomm_sim.channel import Channel
from acomm_sim.world import World

from .apps import CADDY, DiveLog, Periodic, Pilot, Timetable, Vehicle, dive_log_lines
from .places import ADDR, AUV, BUOY, DIVER, LOSS_CURVE, START
from .traffic import Traffic
from .uplink import SAT, Uplink

LINK = "acoustic"
PARTS = {BUOY: "X150 USBL", DIVER: "X110 modem", AUV: "X150 USBL"}

# The TDMA cycle (owner, ms, guard ms): the diver has most of the time (its
# acknowledged status and log lines need about 4 s each with the reply);
# the buoy sends short one-way messages and acknowledged answers, the AUV
# short one-way messages. TX_MS: the longest transmission each may start,
# the wait for the beacon's automatic reply included.
GUARD_MS = 300
SLOTS = ((BUOY, 7000, GUARD_MS), (DIVER, 10000, GUARD_MS), (AUV, 3000, GUARD_MS))
TX_MS = {BUOY: 4200, DIVER: 5100, AUV: 1200}
# While the buoy pilots the AUV the plan switches every node to a schedule
# with two short buoy slots per cycle, so that a thrust command waits for
# at most about 7 s instead of 20; the buoy then sends only one-way frames.
TELEOP_SLOTS = ((BUOY, 3000, GUARD_MS), (AUV, 2000, GUARD_MS), (BUOY, 3000, GUARD_MS), (DIVER, 6000, GUARD_MS))
TELEOP_TX_MS = {BUOY: 1200, DIVER: 5100, AUV: 1200}

MACS = ("tdma", "aloha", "none")

# traffic classes: (priority, lifespan s); lower priority numbers go first
CLASSES = {
    "alarm": (1, 600),
    "teleop": (2, 20),
    "answer": (3, 300),
    "status": (4, 300),
    "auv_state": (5, 60),
    "position": (5, 60),
    "log": (12, 1500),
}


def _fmt(ms):
    s = ms / 1000
    return "%2d:%04.1f" % (int(s // 60), s % 60)


class Mission:
    def __init__(self, seed=1, minutes=20, say=None, caddy_phase=True, usbl_noise=None, mac="tdma", uplink=True,
                 scenario=None):
        # usbl_noise: (range m, bearing degrees), the largest error of the
        # X150s' fixes (uniform); None: exact fixes, as the figures assume.
        # mac: the channel access wherever the plan sets a schedule: "tdma"
        # (the plan's slots), "aloha" (random access) or "none" (acomm sweep)
        # uplink: the buoy's Iridium link and the shore node (False: the
        # water alone, as acomm sweep compares the acoustic MACs)
        if mac not in MACS:
            raise ValueError("mac is %s, not %r" % (", ".join(MACS), mac))
        self.mac = mac
        self.seed = seed
        self.end_ms = int(minutes * 60000)
        self.timeline = []  # (ms, tag, text)
        self._say = say
        # scenario: an acomm_sim.site.Scenario (acomm demo --site FILE): its
        # physics channel instead of the loss curve, its nodes' modem models
        self.channel = _channel(scenario, seed)
        self.world = w = World(seed=seed, channel=self.channel)
        self.traffic = Traffic(LINK)
        self.nodes = {}
        for name in (BUOY, DIVER, AUV):
            emu = {"part": 843 if name == DIVER else 795, "seed": seed * 10 + ADDR[name]}
            if usbl_noise is not None and name != DIVER:
                emu["range_noise_m"], emu["bearing_noise_deg"] = usbl_noise
            self.nodes[name] = w.add(
                name,
                ADDR[name],
                "seatrac",
                position=START[name],
                mac=Tdma(SLOTS, name, 0, TX_MS[name]),
                emu_opts=emu,
                link_opts={"advert_period_ms": 30000, "queue_capacity": 64, "max_retries": 100},
                listener=self._listener(name),
            )
        self.discovered = {}  # (who, whom) -> ms
        self.caddy = None
        self.caddy_phase = caddy_phase
        self.spans = []  # (start ms, end ms, name) of the plan's phases, for the plots
        self.vehicle = Vehicle(self.channel, ADDR[AUV], START[AUV], timeout_ms=35000, say=self.say)
        self.pilot = Pilot(self.traffic, self.nodes[BUOY], AUV, 30000, 10000, CLASSES["teleop"][1],
                           CLASSES["teleop"][0], self.say)
        self.log = DiveLog(self.traffic, self.nodes[DIVER], BUOY, dive_log_lines(16), *CLASSES["log"])
        self.streams = self._streams()
        self.alarm = None
        self.answer = None
        self.outage = None
        self._log_shown = 0
        # on_other(now, node name, src, data): what reaches a node that the
        # mission did not send (an operator's console, acomm demo --web)
        self.on_other = None
        self.plan = Timetable()
        self._plan()
        for task in [self.plan, self.vehicle, self.pilot] + self.streams:
            w.add_task(task)
        self.uplink = Uplink(self) if uplink else None

    # -- output ----------------------------------------------------------------
    def say(self, now, tag, text):
        self.timeline.append((now, tag, text))
        if self._say is not None:
            self._say("%s  %-9s %s" % (_fmt(now), tag, text))

    # -- traffic ---------------------------------------------------------------
    def _streams(self):
        n = self.nodes
        ch = self.channel

        def status(now):
            k = now // 20000
            return CADDY.pack([(caddy.DIVER_STATUS, {"heart_rate": 80 + k % 25, "breathing_rate": 14 + k % 5,
                                                     "body_temp": 36.5 + (k % 4) / 10})])

        def auv_state(now):
            p = ch.position(ADDR[AUV])
            return CADDY.pack([(caddy.BUDDY_PING, {"depth": p[2], "course": (now // 1000) % 360, "speed": 0.2})])

        def position(now):
            # the diver's offset to INIT as the buoy's USBL sees it
            p = ch.position(ADDR[DIVER])
            return CADDY.pack([(caddy.DIVER_POSITION, {"diver": {"x": _clip(p[0]), "y": _clip(p[1])}})])

        def stream(src, dst, cls, period, make, ack, offset):
            prio, life = CLASSES[cls]
            return Periodic(self.traffic, n[src], dst, cls, period, make, life, prio, ack, offset)

        return [
            stream(DIVER, BUOY, "status", 20000, status, True, 0),
            stream(AUV, BUOY, "auv_state", 20000, auv_state, False, 5000),
            stream(BUOY, DIVER, "position", 30000, position, False, 10000),
        ]

    # -- the plan ----------------------------------------------------------------
    def _plan(self):
        p = self.plan
        p.at(0, self._boot)
        p.at(0, lambda now: self._macs(SLOTS, TX_MS, now))
        p.at(60, self._caddy_start)
        p.at(240, self._caddy_stop)
        p.at(240, self._telemetry_start)
        p.at(300, self._log_queue)
        p.at(390, self._alarm)
        p.at(600, self._teleop_start)
        p.at(720, self._shadow)
        p.at(900, self._teleop_stop)
        p.at(960, self._ship)

    def _boot(self, now):
        for name in (BUOY, DIVER, AUV):
            pos = START[name]
            self.say(now, "boot", "%-5s SeaTrac %s, beacon %d, at %.0f m E %.0f m N, %.0f m deep"
                     % (name, PARTS[name], ADDR[name], pos[0], pos[1], pos[2]))
        self.say(now, "mac", "TDMA %s, guard %d ms (cycle %.1f s)"
                 % (" / ".join("%s %.0f s" % (s[0], s[1] / 1000) for s in SLOTS), GUARD_MS,
                    sum(s[1] for s in SLOTS) / 1000))

    def _macs(self, slots, tx_ms, now=0):
        # every node switches at the same planned instant; the new cycle
        # starts there (slots=None: no schedule). Without TDMA (self.mac)
        # the schedule's times are Aloha's or nobody's
        for name, sn in self.nodes.items():
            if slots is None or self.mac == "none":
                sn.link.driver.mac = None
            elif self.mac == "aloha":
                sn.link.driver.mac = Aloha(10000, seed=self.seed * 100 + sn.node.node_id)
            else:
                sn.link.driver.mac = Tdma(slots, name, now, tx_ms[name])

    def _caddy_start(self, now):
        if not self.caddy_phase:
            return
        self._macs(None, None)
        self.caddy = CaddyCycle(self.world, pladypos=BUOY, buddy=AUV, diver=DIVER)
        self.caddy.start(now)
        self._caddy_from = now
        self.say(now, "caddy", "TDMA off: the CADDY interrogation cycle orders the channel "
                 "(buoy = PlaDyPos, auv = Buddy, diver)")

    def _caddy_stop(self, now):
        if self.caddy is None:
            return
        self.caddy.stop()
        self.spans.append((self._caddy_from, now, "caddy"))
        t = sorted(self.caddy.cycle_times_ms)
        med = t[len(t) // 2] / 1000 if t else None
        self.say(now, "caddy", "%d cycles, median %s s per cycle (seed 003 budget 7.24 s, 7.64 s with sonar)"
                 % (self.caddy.cycles, "-" if med is None else "%.2f" % med))
        self._macs(SLOTS, TX_MS, now)
        self.say(now, "mac", "TDMA schedule back on")

    def _telemetry_start(self, now):
        for s in self.streams:
            s.start(now)
        self.say(now, "telemetry", "diver status every 20 s (acknowledged), auv state every 20 s, "
                 "diver position from the buoy every 30 s")

    def _log_queue(self, now):
        size = self.log.queue(now)
        self.say(now, "log", "diver queues its dive log: %d lines, %d B, priority %d (lowest)"
                 % (len(self.log.lines), size, CLASSES["log"][0]))

    def _alarm(self, now):
        prio, life = CLASSES["alarm"]
        data = CADDY.pack([(caddy.ALARM, {"alarm": "low_air"})])
        self.alarm = self.traffic.send(self.nodes[DIVER], BUOY, data, "alarm", life, prio, True, now)
        got, total, _, _ = self.log.progress()
        self.say(now, "alarm", "diver raises ALARM low_air (priority %d) with %d log lines still queued"
                 % (prio, total - got))

    def _teleop_start(self, now):
        self._macs(TELEOP_SLOTS, TELEOP_TX_MS, now)
        self.say(now, "mac", "teleop TDMA: %s (cycle %.1f s)" % (
            " / ".join("%s %.0f s" % (s[0], s[1] / 1000) for s in TELEOP_SLOTS), sum(s[1] for s in TELEOP_SLOTS) / 1000))
        self.pilot.start(now)
        self._teleop_from = now
        self.say(now, "teleop", "buoy pilot takes the auv: event-triggered thrust, heartbeat every 10 s, "
                 "auv failsafe after 35 s of silence")

    def _shadow(self, now):
        self.channel.noise_burst(now, 75000, receiver=ADDR[AUV])
        self.spans.append((now, now + 75000, "shadow"))
        self.say(now, "shadow", "auv enters an acoustic shadow for 75 s: it hears nothing")

    def _teleop_stop(self, now):
        self.pilot.stop(now)
        self.spans.append((self._teleop_from, now, "teleop"))
        self.say(now, "teleop", "pilot releases the auv (neutral); %d commands, %d heartbeats sent, "
                 "auv travelled %.0f m" % (self.pilot.commands, self.pilot.heartbeats, self.vehicle.travelled))
        self.plan.at(now / 1000 + 30, self._teleop_over)

    def _teleop_over(self, now):
        # the plan's teleop window is over: the AUV leaves remote control
        # (its failsafe stops watching) and the normal schedule returns
        self.vehicle.active = False
        self._macs(SLOTS, TX_MS, now)
        self.say(now, "mac", "TDMA schedule back on; the auv is back on its own mission")

    def _ship(self, now):
        self.outage = (now, now + 120000)
        self.channel.noise_burst(now, 120000)
        self.spans.append((now, now + 120000, "outage"))
        self.say(now, "outage", "a ship passes overhead: nobody hears anything for 2 minutes")
        self.plan.at(now / 1000 + 120, lambda t: self.say(t, "outage", "the water is quiet again"))

    # -- events from the nodes ---------------------------------------------------
    def _listener(self, me):
        def on_event(ev):
            now = self.world.now()
            code = ev[0]
            if ev[1].name == SAT:  # the buoy's Iridium link (demo.uplink)
                self.uplink.buoy_event(now, ev)
                return
            if code == EV_RECEIVED:
                self._received(now, me, ev[2], ev[3], ev[4])
            elif code == EV_STATUS:
                e = self.traffic.status(me, ev[2], ev[3], now)
                if e is not None and ev[3] in (FAILED, EXPIRED) and e[2] in ("alarm", "answer", "log", "status"):
                    self.say(now, "status", "%s: a %s message %s %s" % (me, e[2], e[3], ev[4]))
            elif code == EV_AVAILABILITY:
                key = (me, ev[2])
                state = AVAIL_NAMES[ev[3]]
                if state == "available" and key not in self.discovered:
                    self.discovered[key] = now
                    self.say(now, "discover", "%s discovers %s" % (me, ev[2]))
                else:
                    self.say(now, "link", "%s: %s is %s" % (me, ev[2], state))
        return on_event

    def _received(self, now, me, src, dst, data):
        if dst != me:
            return  # overheard (the CADDY cycle listens passively): not a delivery
        e = self.traffic.received(src, dst, data, now)
        if me == AUV and src == BUOY:
            msgs = self.vehicle.on_message(now, data)
            if msgs and msgs[0][0] is teleop.THRUST and e is not None:
                self.say(now, "teleop", "auv <- thrust #%d after %.1f s" % (msgs[0][1]["seq"], (now - self.traffic.log.rows[e[0]][6]) / 1000))
            return
        if e is None:
            if self.on_other is not None:
                self.on_other(now, me, src, data)
            return
        cls = e[2]
        lat = (now - self.traffic.log.rows[e[0]][6]) / 1000
        if cls == "alarm":
            got, total, _, _ = self.log.progress()
            self.say(now, "alarm", "buoy <- diver ALARM low_air after %.1f s (%d log lines still waiting behind it)"
                     % (lat, total - got))
            prio, life = CLASSES["answer"]
            text = "ascend slowly, auv is coming"
            self.answer = self.traffic.send(self.nodes[BUOY], DIVER, CADDY.pack([(caddy.CHAT, {"text": text})]),
                                            "answer", life, prio, True, now)
            self.say(now, "chat", "buoy -> diver %r (priority %d, acknowledged)" % (text, prio))
            if self.uplink is not None:
                self.uplink.relay(now, b"buoy: diver ALARM low_air, %.0f s into the mission" % (now / 1000))
        elif cls == "answer":
            self.say(now, "chat", "diver <- buoy: answer on the tablet after %.1f s" % lat)
        elif cls == "log":
            self._log_progress(now)

    def _log_progress(self, now):
        got, total, b, size = self.log.progress()
        step = max(1, total // 6)
        if got == total or got - self._log_shown >= step:
            self._log_shown = got
            bar = "#" * (20 * got // total) + "-" * (20 - 20 * got // total)
            self.say(now, "log", "[%s] %2d/%d lines, %d/%d B" % (bar, got, total, b, size))
            if got == total:
                self.log.done_at = now
                self.say(now, "log", "dive log complete at the buoy, %.0f s after it was queued"
                         % ((now - self.log.queued_at) / 1000))

    # -- running -----------------------------------------------------------------
    def run(self, runner=None):
        # runner(world, end ms): how the World gets there (acomm demo
        # --web paces it); by default as fast as it can
        if runner is None:
            self.world.run(self.end_ms)
        else:
            runner(self.world, self.end_ms)
        self.say(self.world.now(), "end", "mission over")
        return self


def _clip(v):
    return max(-51.1, min(51.2, v))


def _channel(scenario, seed):
    # the plan's loss curve without a scenario (or with a "curve" one); else
    # the scenario's physics channel for the demo's three nodes: its site, and
    # the physics modem model of each node it names (the node's places stay the plan's)
    if scenario is None or scenario.channel == "curve":
        return Channel(seed=seed, loss_curve=LOSS_CURVE)
    from acomm_sim.physchannel import PhysicsChannel

    ch = PhysicsChannel(scenario.site, seed=seed)
    for n in scenario.nodes:
        if n.get("model") and n["name"] in ADDR:
            ch.set_modem(ADDR[n["name"]], n["model"])
    return ch
