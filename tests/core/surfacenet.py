# Test rig for the surface-link drivers (Iridium SBD, GSM SMS): drivers
# talking over FakeUART lines to their emulated modems, all on one clock and
# one shared network (gateway or SMS centre), without a Link, so a test sees
# every driver event and every byte. Runs on CPython and MicroPython.
from acomm_sim.clock import ManualClock
from acomm.events import DELIVERED
from acomm_sim.fakeuart import uart_pair
from acomm.prng import Prng
from linkcheck import check_exactly_one_final


class Rig:
    # drivers[i] drives emus[i]; events[i] is what drivers[i] reported, as
    # (time, event) pairs
    def __init__(self, drivers, make_emu, network):
        self.clk = ManualClock(0)
        self.net = network
        self.drivers = list(drivers)
        self.emus = [make_emu(network, i + 1) for i in range(len(self.drivers))]
        self.ends = [uart_pair(rxbuf=4096, clock=self.clk) for _ in self.drivers]
        self.events = [[] for _ in self.drivers]
        self.wire = [bytearray() for _ in self.drivers]  # what each driver wrote

    def now(self):
        return self.clk()

    def run(self, ms, step=10, until=None):
        clk = self.clk
        for _ in range(ms // step):
            now = clk()
            for i, d in enumerate(self.drivers):
                host, dev = self.ends[i]
                data = host.read()
                if data:
                    d.feed(now, data)
                d.poll(now)
                out = d.take_output()
                if out:
                    self.wire[i] += out
                    host.write(out)
                for ev in d.take_events():
                    self.events[i].append((now, ev))
                e = self.emus[i]
                data = dev.read()
                if data:
                    e.feed(now, data)
                e.poll(now)
                out = e.take_output()
                if out:
                    dev.write(out)
            clk.advance(step)
            if until is not None and until():
                return True
        return until is None

    def up(self, ms=5000):
        return self.run(ms, until=lambda: all(d.ready(self.clk()) for d in self.drivers))

    def of_all(self):
        return [[ev for _, ev in evs] for evs in self.events]

    def of(self, i, code):
        return [ev for _, ev in self.events[i] if ev[0] == code]

    def when(self, i, code):
        return [t for t, ev in self.events[i] if ev[0] == code]

    def got(self, i, code):
        return lambda: len(self.of(i, code)) > 0


class Fed:
    # one driver fed by hand, for byte-exact exchanges
    def __init__(self, driver, t=0):
        self.d = driver
        self.t = t
        self.events = []

    def poll(self, ms=0):
        self.t += ms
        self.d.poll(self.t)
        self.events += self.d.take_events()
        return self.d.take_output()

    def answer(self, data, ms=1):
        self.t += ms
        self.d.feed(self.t, data)
        self.events += self.d.take_events()
        return self.d.take_output()

    def take(self):
        ev = self.events
        self.events = []
        return ev


def soak(net, seed, rounds, gap_ms, life, payload, modem_fault, events):
    # On a started modemnet.Net of two nodes: `rounds` requests either way,
    # most acknowledged, while the emulators damage, cut and swallow lines
    # and make noise, plus modem_fault(rng, emu) (the modem's own faults)
    # and events[i](net) after round i (a restart, a lost signal). Checks
    # that every request ends exactly once, that nothing stays behind and
    # that both modems are usable after; returns the finals' counts.
    rng = Prng(seed)
    ids = {"buoy": [], "diver": []}
    faults = ("corrupt_next", "truncate_next", "swallow_next")
    for i in range(rounds):
        src = "buoy" if rng.chance(0.5) else "diver"
        dst = "diver" if src == "buoy" else "buoy"
        ids[src].append(net.send(src, dst, payload(rng, i), ack=rng.chance(0.6), life=rng.range(life[0], life[1])))
        emu = net.emus["buoy" if rng.chance(0.5) else "diver"]
        k = rng.below(6)
        if k < 3:
            getattr(emu, faults[k])(None)
        elif k == 3:
            modem_fault(rng, emu)
        elif k == 4:
            emu.inject_noise(rng.bytes(rng.range(1, 40)))
        if i in events:
            events[i](net)
        net.run(gap_ms, step=50)
    # until every request has its final status (check_exactly_one_final below: not two)
    assert net.run(900000, step=50, until=lambda: all(net.rec(n).final(r) is not None for n in ids for r in ids[n]))
    finals = {}
    for name in ids:
        rec = net.rec(name)
        check_exactly_one_final(rec, ids[name])
        for rid in ids[name]:
            finals[rec.final(rid)] = finals.get(rec.final(rid), 0) + 1
    assert finals.get(DELIVERED) and sum(finals.values()) == rounds, finals
    assert net.run(60000, step=50, until=lambda: all(d.ready(net.clk()) for d in net.drivers.values()))
    return finals
