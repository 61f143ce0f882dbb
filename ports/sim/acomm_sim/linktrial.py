# Small trials on a bare channel (no nodes, no modems' protocols): stations
# that only listen, packets put on the channel by hand. What the channel
# bench and the channel tests measure: the PDR of one link, and a near
# sender against a far interferer (capture). Portable Python.

from acomm.compat import ticks_add, ticks_diff


class Ear:
    """A station that keeps what it hears: [(t, src, packet)]."""

    def __init__(self):
        self.got = []

    def receive(self, t, src, packet, distance):
        self.got.append((t, src, packet))


def listen(ch, places):
    """Attach an Ear at each {addr: (east, north, depth)} -> {addr: Ear}."""
    ears = {}
    for a in places:
        ears[a] = Ear()
        ch.attach(a, ears[a])
        p = places[a]
        ch.set_position(a, p[0], p[1], p[2])
    return ears


def run(ch, t0, t1, step=10):
    """Poll the channel from t0 to t1 (ms) every step ms."""
    t = t0
    while ticks_diff(t1, t) >= 0:
        ch.poll(t)
        t = ticks_add(t, step)


def link_trial(ch, metres, n, payload=b"0123456789abcd", depth=(1.0, 1.0), airtime_ms=1000):
    """n packets from 1 to 2, metres apart at depths `depth`, one every
    airtime + 2 s -> the share that arrived intact (a damaged one counts as
    lost, as the trial's receiving stack dropped it)."""
    ears = listen(ch, {1: (0.0, 0.0, depth[0]), 2: (metres, 0.0, depth[1])})
    period = airtime_ms + 2000 + int(metres * 1000 / ch.sound_speed)
    t = 0
    for _ in range(n):
        ch.transmit(t, 1, payload, airtime_ms)
        run(ch, t, t + period - 1, 100)
        t += period
    return sum(1 for _, _, p in ears[2].got if p == payload) / n


def capture_trial(ch, near_m, far_m, rounds, airtime_ms=1000):
    """Each round, 2 (far_m from the receiver 3) sends a packet whose
    arrival overlaps that of one from 1 (near_m away) -> (share of the near
    packets that arrived, share of the far ones)."""
    ears = listen(ch, {1: (near_m, 0.0, 10.0), 2: (-far_m, 0.0, 10.0), 3: (0.0, 0.0, 10.0)})
    lag = int((far_m - near_m) * 1000 / ch.sound_speed)  # the far one leaves this much earlier
    t = 0
    for i in range(rounds):
        ch.transmit(t, 2, b"far-%d" % i, airtime_ms)
        ch.transmit(t + lag + airtime_ms // 4, 1, b"near-%d" % i, airtime_ms)
        run(ch, t, t + 10000 + lag, 50)
        t += 10000 + lag + 1000
    got = ears[3].got
    return (sum(1 for _, s, _ in got if s == 1) / rounds, sum(1 for _, s, _ in got if s == 2) / rounds)
