# Shared harness for the modem driver tests (SeaTrac, EvoLogics, Micro-Modem,
# Benthos): Nodes whose Links drive a modem driver over FakeUART lines whose
# other ends the test pumps into emulated modems on one acoustic medium, and
# the checks every modem's fault tests make. Runs on CPython and MicroPython.
# What is particular to one modem (its faults, its reasons, its timings)
# stays in that modem's test file, which passes it in.
from acomm_sim.clock import ManualClock
from acomm.events import DELIVERED, EV_DRIVER_DOWN, EV_DRIVER_UP, EV_RECEIVED, FAILED, TRANSMITTED, TRANSMITTING
from acomm_sim.fakeuart import uart_pair
from acomm.link import BROADCAST
from acomm.link.names import AddressMap
from acomm.node import Node
from acomm_sim.medium import Medium
from linkcheck import Recorder, check_exactly_one_final

BUOY, DIVER = ("buoy", 10, 1), ("diver", 20, 2)
GHOST = ("ghost", 30, 5)  # a name every node knows, with no modem behind it


class Net:
    # driver(addr, **drv_opts) and emulator(medium, addr, now=..., **emu_opts)
    # make one node's driver and its emulated modem. stations are
    # (name, node id, modem address); ghost is one more known name. With
    # broadcast set, the links map node ids to modem addresses through an
    # AddressMap whose broadcast address it is; with broadcast None they use
    # the link's default (node id = modem address). emu_ids gives a modem
    # another address than its driver wants.
    def __init__(
        self,
        driver,
        emulator,
        stations=(BUOY, DIVER),
        start=0,
        distance=100.0,
        emu_opts=None,
        link_opts=None,
        drv_opts=None,
        emu_ids=None,
        broadcast=0,
        ghost=GHOST,
        uart_opts=None,
    ):
        self.clk = ManualClock(start)
        self.medium = Medium(default_distance=distance)
        self.nodes = {}
        self.emus = {}
        self.drivers = {}
        self.ends = {}
        known = tuple(stations) + (ghost,)
        for name, nid, addr in stations:
            a, b = uart_pair(clock=self.clk, **(uart_opts or {}))
            node = Node(name, nid, self.clk, listener=Recorder())
            opts = {"advert_period_ms": 600000}
            amap = None if broadcast is None else AddressMap(False, broadcast)
            for other, oid, oaddr in known:
                node.names.add(other, oid)
                if amap is not None:
                    amap.set(oid, oaddr)
            if amap is not None:
                opts["addr_map"] = amap
            drv = driver(addr, **(drv_opts or {}))
            opts.update(link_opts or {})
            node.add_link("acoustic", drv, a, **opts)
            self.nodes[name] = node
            self.drivers[name] = drv
            eid = (emu_ids or {}).get(name, addr)
            self.emus[name] = emulator(self.medium, eid, now=start, **(emu_opts or {}))
            self.ends[name] = b

    def run(self, ms, step=20, until=None):
        clk = self.clk
        for _ in range(ms // step):
            now = clk()
            for name, node in self.nodes.items():
                node.step(now)
                e = self.emus[name]
                end = self.ends[name]
                data = end.read()
                if data:
                    e.feed(now, data)
                e.poll(now)
                out = e.take_output()
                if out:
                    end.write(out)
            clk.advance(step)
            if until is not None and until():
                return True
        return until is None

    def up(self, ms=6000):
        return self.run(ms, until=lambda: all(d.ready(self.clk()) for d in self.drivers.values()))

    def send(self, src, dst, data, ack=False, life=60):
        return self.nodes[src].send("acoustic", dst, data, life, 2, ack)

    def rec(self, name):
        return self.nodes[name].listeners[0]

    def received(self, name):
        return [(e[2], e[3], bytes(e[4])) for e in self.rec(name).of(EV_RECEIVED)]

    def done(self, name, rid):
        return lambda: self.rec(name).final(rid) is not None


def spy_events(drv):
    # Every event the driver hands its link from now on, in a list.
    seen = []
    orig = drv.take_events

    def spy():
        ev = orig()
        seen.extend(ev)
        return ev

    drv.take_events = spy
    return seen


def faulted(net, fault, what, where="buoy", within_ms=40000, **kw):
    # One acknowledged request from buoy to diver on a started net, with
    # `fault` (an emulator method) armed for `what` on `where`'s modem;
    # returns the request id once it has ended and the dust has settled.
    getattr(net.emus[where], fault)(what, **kw)
    r = net.send("buoy", "diver", b"through faults", ack=True)
    assert net.run(within_ms, until=net.done("buoy", r))
    net.run(3000)
    return r


def check_recovered(net, r, reason=None, within_ms=12000):
    # Request r (b"through faults", buoy to diver) got there despite the
    # fault, for `reason` if given, and the next request goes through.
    rec = net.rec("buoy")
    assert rec.final(r) == DELIVERED, rec.reasons(r)
    if reason is not None:
        assert any(reason in x for x in rec.reasons(r)), rec.reasons(r)
    # delivered to the application once, even when the modem sent it twice
    assert net.received("diver") == [("buoy", "diver", b"through faults")]
    r2 = net.send("buoy", "diver", b"and after", ack=True)
    assert net.run(within_ms, until=net.done("buoy", r2))
    assert rec.final(r2) == DELIVERED
    check_exactly_one_final(rec, [r, r2])


def reboot_mid_transfer(net, after_ms):
    # An acknowledged request from buoy to diver on a started net; the buoy's
    # modem restarts after_ms later. Returns the request id once it ended.
    r = net.send("buoy", "diver", b"through faults", ack=True)
    net.run(after_ms)
    net.emus["buoy"].reboot(net.clk())
    assert net.run(40000, until=net.done("buoy", r))
    net.run(2000)
    return r


def check_down_and_up(net, down_ms, up_ms, within_ms=12000):
    # The buoy's modem stops answering six commands: the driver says so,
    # the request fails, the driver comes back up and the next request is
    # delivered. Returns the failed request's id.
    seen = spy_events(net.drivers["buoy"])
    net.emus["buoy"].swallow_next(None, count=6)
    r = net.send("buoy", "diver", b"one", ack=True)
    assert net.run(down_ms, until=lambda: (EV_DRIVER_DOWN, "modem not answering") in seen)
    assert net.run(up_ms, until=lambda: seen[-1] == (EV_DRIVER_UP,))
    assert net.rec("buoy").final(r) == FAILED
    r2 = net.send("buoy", "diver", b"two", ack=True)
    assert net.run(within_ms, until=net.done("buoy", r2))
    assert net.rec("buoy").final(r2) == DELIVERED
    return r


def mixed_faults(net, rounds, gap_ms, reboot_at, life=(5, 40), payload=None):
    # A soak on a started net: `rounds` requests either way, some broadcast,
    # most acknowledged, with faults and noise armed at random on both
    # modems and the diver's restarting once. Checks that every request
    # ended exactly once and no link holds one any more; returns how many
    # ended with each final status. payload(rng, i) makes request i's bytes.
    from acomm.prng import Prng

    rng = Prng(5)
    ids = {"buoy": [], "diver": []}
    faults = ("corrupt_next", "truncate_next", "swallow_next")
    for i in range(rounds):
        src = "buoy" if rng.chance(0.5) else "diver"
        dst = BROADCAST if rng.chance(0.2) else ("diver" if src == "buoy" else "buoy")
        data = b"m%d" % i if payload is None else payload(rng, i)
        ids[src].append(net.send(src, dst, data, ack=rng.chance(0.7), life=rng.range(life[0], life[1])))
        emu = net.emus["buoy" if rng.chance(0.5) else "diver"]
        if rng.chance(0.3):
            getattr(emu, faults[rng.below(3)])(None)
        if rng.chance(0.2):
            emu.inject_noise(rng.bytes(rng.range(1, 40)))
        if i == reboot_at:
            net.emus["diver"].reboot(net.clk())
        net.run(gap_ms)  # below capacity: the outcomes come from the faults
    net.run(60000)
    finals = {}
    for name in ("buoy", "diver"):
        rec = net.rec(name)
        check_exactly_one_final(rec, ids[name])
        for rid in ids[name]:
            finals[rec.final(rid)] = finals.get(rec.final(rid), 0) + 1
    assert finals.get(DELIVERED) and finals.get(TRANSMITTED), finals
    return finals


def check_still_works(net, within_ms=15000):
    r = net.send("diver", "buoy", b"still here", ack=True)
    assert net.run(within_ms, until=net.done("diver", r))
    assert net.rec("diver").final(r) == DELIVERED


def run_emulators(emus, t0, t1, step=10):
    # Polls emulators with no host from t0 to t1; what each one said.
    out = [bytearray() for _ in emus]
    t = t0
    while t <= t1:
        for i, e in enumerate(emus):
            e.poll(t)
            out[i] += e.take_output()
        t += step
    return [bytes(o) for o in out]


def check_mtu(net, mtu, within_ms=12000):
    # On a started net, the buoy's link refuses a frame one byte over the
    # MTU at once, and delivers the largest that fits. Returns that request.
    assert not net.nodes["buoy"].links["acoustic"].request(net.clk(), 9, "diver", bytes(mtu + 1), 60)
    assert net.rec("buoy").statuses(9) == [FAILED] and "MTU" in net.rec("buoy").reasons(9)[0]
    r = net.send("buoy", "diver", bytes(range(mtu)), ack=True)  # the largest that fits
    assert net.run(within_ms, until=net.done("buoy", r))
    assert net.rec("buoy").final(r) == DELIVERED
    return r


def check_absent(net, reason):
    # On a started net whose links retry once, an acknowledged request to a
    # name with no modem behind it fails for `reason` after two tries.
    r = net.send("buoy", "ghost", b"anyone?", ack=True)
    assert net.run(30000, until=net.done("buoy", r))
    rec = net.rec("buoy")
    assert rec.final(r) == FAILED and rec.reasons(r)[-1] == reason
    assert rec.statuses(r).count(TRANSMITTING) == 2  # retried once
    return r
