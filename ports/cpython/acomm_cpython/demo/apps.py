# The applications of the demo mission, each a World task (poll(now) -> the
# next time it wants to run). They use only the public API of the node
# (Node.send through demo.traffic) and the message catalogs, as an
# application on a real buoy, tablet or vehicle would.
from acomm.catalog import caddy, teleop
from acomm.compat import ticks_add

CADDY = caddy.CATALOG
TELEOP = teleop.CATALOG


class Periodic:
    # One telemetry stream: make(now) -> payload bytes, every period_ms while
    # running.
    def __init__(self, traffic, sn, dst, cls, period_ms, make, lifespan_s, priority, ack, offset_ms=0):
        self.traffic = traffic
        self.sn = sn
        self.dst = dst
        self.cls = cls
        self.period_ms = period_ms
        self.make = make
        self.lifespan_s = lifespan_s
        self.priority = priority
        self.ack = ack
        self.offset_ms = offset_ms
        self.running = False
        self.sent = 0
        self._next = None

    def start(self, now):
        self.running = True
        self._next = ticks_add(now, self.offset_ms)

    def stop(self):
        self.running = False

    def poll(self, now):
        if not self.running:
            return ticks_add(now, 1000)
        if now >= self._next:
            self.traffic.send(self.sn, self.dst, self.make(now), self.cls, self.lifespan_s, self.priority, self.ack, now)
            self.sent += 1
            self._next = ticks_add(self._next, self.period_ms)
        return self._next


class DiveLog:
    # The diver's log, one CADDY chat message per line, queued all at once
    # at low priority and acknowledged line by line. progress() says how far
    # the buoy has got.
    def __init__(self, traffic, sn, dst, lines, priority=12, lifespan_s=1500):
        self.traffic = traffic
        self.sn = sn
        self.dst = dst
        self.lines = lines
        self.priority = priority
        self.lifespan_s = lifespan_s
        self.entries = []
        self.queued_at = None
        self.done_at = None

    def payloads(self):
        return [CADDY.pack([(caddy.CHAT, {"text": line})]) for line in self.lines]

    def queue(self, now):
        self.queued_at = now
        payloads = self.payloads()
        for p in payloads:
            self.entries.append(self.traffic.send(self.sn, self.dst, p, "log", self.lifespan_s, self.priority, True, now))
        return sum(len(p) for p in payloads)

    def progress(self):
        # (lines received, lines, bytes received, bytes)
        got = [e for e in self.entries if e[4] is not None]
        size = self.traffic.log.rows
        return (len(got), len(self.entries), sum(size[e[0]][5] for e in got), sum(size[e[0]][5] for e in self.entries))


def dive_log_lines(n):
    # What a dive computer writes: time, depth, air, heart rate; lower case
    # because the CADDY chat alphabet has no capitals.
    out = []
    for k in range(n):
        out.append("t%02d.%02d depth %4.1fm air %3d hr %3d" % (2 + k // 2, (k % 2) * 30, 8.0 + 0.4 * k, 200 - 3 * k, 82 + k % 7))
    return out


# Seed 004's joystick sequence (8 steps), here with surge and sway for a
# vehicle that drives about on the surface of a plane.
SEQUENCE = (
    ("neutral", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("forward", (0.6, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("neutral", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("right", (0.0, 0.6, 0.0, 0.0, 0.0, 0.0)),
    ("neutral", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("back", (-0.6, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("neutral", (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)),
    ("left", (0.0, -0.6, 0.0, 0.0, 0.0, 0.0)),
)


class Pilot:
    # The operator at the buoy: samples the joystick every poll_ms (seed 004:
    # 0.1 s), sends event-triggered thrust commands and keep-alive heartbeats
    # (acomm.catalog.teleop.TeleopSender), one-way, never retransmitted: a
    # repeated old command is worse than a new one.
    def __init__(self, traffic, sn, dst, step_ms, heartbeat_ms, lifespan_s, priority, say, poll_ms=100):
        self.traffic = traffic
        self.sn = sn
        self.dst = dst
        self.step_ms = step_ms
        self.lifespan_s = lifespan_s
        self.priority = priority
        self.say = say
        self.poll_ms = poll_ms
        self.sender = teleop.TeleopSender(threshold=0.2, heartbeat_ms=heartbeat_ms)
        self.running = False
        self.started = None
        self.step_name = None
        self.commands = 0
        self.heartbeats = 0

    def start(self, now):
        self.running = True
        self.started = now

    def stop(self, now):
        # the last word is neutral
        self._send(now, self.sender.update(now, teleop.NEUTRAL))
        self.running = False

    def _send(self, now, msg):
        if msg is None:
            return
        name, values = msg
        m = teleop.THRUST if name == "thrust" else teleop.HEARTBEAT
        self.traffic.send(self.sn, self.dst, TELEOP.pack([(m, values)]), "teleop", self.lifespan_s, self.priority, False, now)
        if name == "thrust":
            self.commands += 1
        else:
            self.heartbeats += 1

    def poll(self, now):
        if not self.running:
            return ticks_add(now, 1000)
        k = ((now - self.started) // self.step_ms) % len(SEQUENCE)
        name, vector = SEQUENCE[k]
        msg = self.sender.update(now, vector)
        if msg is not None:
            self.say(now, "teleop", "buoy pilot: %s, thrust command #%d queued" % (name, msg[1]["seq"]))
        self._send(now, msg or self.sender.poll(now))
        return ticks_add(now, self.poll_ms)


class Vehicle:
    # The companion AUV under teleoperation: applies the failsafe's thrust
    # (acomm.catalog.teleop.Failsafe: neutral when nothing valid came for
    # timeout_ms or a command was missed) and moves the modem on the
    # simulated channel accordingly, at up to speed_ms m/s per unit thrust.
    def __init__(self, channel, addr, start, timeout_ms, say, speed=0.5, period_ms=1000):
        self.channel = channel
        self.addr = addr
        self.pos = list(start)
        self.failsafe = teleop.Failsafe(timeout_ms)
        self.say = say
        self.speed = speed
        self.period_ms = period_ms
        self.trips = []  # (time, reason)
        self.recoveries = []
        self.travelled = 0.0
        self.active = True  # under remote control; False: the failsafe rests

    def on_message(self, now, payload):
        try:
            msgs = TELEOP.unpack(payload)
        except Exception:
            return None
        for m, values in msgs:
            self.failsafe.on_message(now, m.name, values)
        return msgs

    def poll(self, now):
        if not self.active:
            return ticks_add(now, 10000)
        v = self.failsafe.poll(now)
        for ev in self.failsafe.pop_events():
            if ev == "tripped":
                self.trips.append((now, self.failsafe.reason))
                self.say(now, "failsafe", "auv FAILSAFE (%s): neutral thrust, holding position" % self.failsafe.reason)
            else:
                self.recoveries.append(now)
                self.say(now, "failsafe", "auv recovered: a new thrust command arrived")
        dt = self.period_ms / 1000
        de, dn = v[1] * self.speed * dt, v[0] * self.speed * dt  # sway east, surge north
        if de or dn:
            self.pos[0] += de
            self.pos[1] += dn
            self.travelled += (de * de + dn * dn) ** 0.5
            self.channel.set_position(self.addr, self.pos[0], self.pos[1], self.pos[2])
        return ticks_add(now, self.period_ms)


class Timetable:
    # The mission plan: (time ms, action(now)) in time order.
    def __init__(self, t0=0):
        self.t0 = t0
        self.items = []

    def at(self, s, action):
        self.items.append((self.t0 + int(s * 1000), action))
        self.items.sort(key=lambda it: it[0])

    def poll(self, now):
        while self.items and self.items[0][0] <= now:
            self.items.pop(0)[1](now)
        return self.items[0][0] if self.items else ticks_add(now, 60000)
