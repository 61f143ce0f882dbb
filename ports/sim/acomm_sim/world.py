# The simulated ocean: real acomm Nodes, each with its real driver talking
# over a FakeUART line to an emulated modem, and all emulated modems on one
# acoustic Channel, on one virtual clock. Deterministic for a given seed.
#
#   w = World(seed=1)
#   buoy = w.add("buoy", 1, "seatrac", position=(0, 0, 0))
#   diver = w.add("diver", 2, "seatrac", position=(80, 60, 12))
#   w.run(60000)                         # one simulated minute
#   buoy.node.send("acoustic", "diver", b"hi", 60, 2, True)
#
# Time advances in steps of step_ms; in each step every node runs once
# (link timers, queue, driver), bytes cross the serial lines, the emulators
# run and the channel delivers what has arrived. Modems (MODEMS below) are
# looked up by name so that any emulated modem can be used; `mac` wraps the
# node's driver (acomm.mac) to give it a TDMA slot or ALOHA backoff.
# Portable Python (the core tests run it on MicroPython too).

from acomm.clock import ManualClock
from acomm.compat import ticks_add, ticks_diff
from acomm.fakeuart import uart_pair
from acomm.mac import MacDriver
from acomm.node import Node

from .channel import Channel


def _seatrac(addr, opts):
    from acomm.drivers.seatrac import SeatracDriver

    return SeatracDriver(addr, **opts)


def _seatrac_emu(ch, addr, now, opts):
    from .seatrac import SeatracEmulator

    return SeatracEmulator(ch, addr, now=now, **opts)


def _packet_driver(profile):
    def make(addr, opts):
        from acomm.drivers.transparent import TransparentDriver

        from .packetmodem import PROFILES

        bitrate, overhead, fixed = PROFILES[profile]
        o = {"baud": 9600, "mtu": 64, "turnaround_ms": fixed, "model": profile.upper(), "air_bitrate": bitrate,
             "air_overhead": overhead}
        o.update(opts)
        return TransparentDriver(**o)

    return make


def _packet_emu(profile):
    def make(ch, addr, now, opts):
        from .packetmodem import PacketModemEmulator

        return PacketModemEmulator(ch, addr, now=now, profile=profile, **opts)

    return make


def _by_path(mod, cls):
    def make(*args):
        m = __import__(mod, None, None, [cls])
        opts = args[-1]
        if len(args) == 2:
            return getattr(m, cls)(args[0], **opts)
        return getattr(m, cls)(args[0], args[1], now=args[2], **opts)

    return make


# modem name -> (driver factory(address, opts), emulator factory(channel, address, now, opts))
MODEMS = {
    "seatrac": (_seatrac, _seatrac_emu),
    "bpsk": (_packet_driver("bpsk"), _packet_emu("bpsk")),
    "fhss": (_packet_driver("fhss"), _packet_emu("fhss")),
    "evologics": (_by_path("acomm.drivers.evologics", "EvologicsDriver"),
                  _by_path("acomm_sim.evologics", "EvologicsEmulator")),
    "micromodem": (_by_path("acomm.drivers.micromodem", "MicroModemDriver"),
                   _by_path("acomm_sim.micromodem", "MicroModemEmulator")),
    "benthos": (_by_path("acomm.drivers.benthos", "BenthosDriver"),
                _by_path("acomm_sim.benthos", "BenthosEmulator")),
}


class SimNode:
    def __init__(self, name, node, driver, emu, host_end, modem_end, address):
        self.name = name
        self.node = node
        self.driver = driver
        self.emu = emu
        self.host_end = host_end
        self.modem_end = modem_end
        self.address = address
        self.events = []

    @property
    def link(self):
        for k in self.node.links:
            return self.node.links[k]


class World:
    def __init__(self, seed=1, channel=None, start=0, step_ms=10):
        self.clock = ManualClock(start)
        self.channel = channel if channel is not None else Channel(seed=seed, now=start)
        self.seed = seed
        self.step_ms = step_ms
        self.nodes = {}
        self._order = []
        self.steps = 0

    def now(self):
        return self.clock()

    def add(self, name, node_id, modem, address=None, position=None, track=None, mac=None, link="acoustic",
            driver_opts=None, emu_opts=None, link_opts=None, listener=None):
        make_driver, make_emu = MODEMS[modem]
        addr = node_id if address is None else address
        now = self.clock()
        host, dev = uart_pair(rxbuf=4096, clock=self.clock)
        sn = SimNode(name, None, None, None, host, dev, addr)
        node = Node(name, node_id, self.clock, listener=listener or sn.events.append)
        for other in self._order:
            node.names.add(other.name, other.node.node_id)
            other.node.names.add(name, node_id)
        driver = make_driver(addr, dict(driver_opts or {}))
        emu = make_emu(self.channel, addr, now, dict(emu_opts or {}))
        if position is not None:
            self.channel.set_position(addr, position[0], position[1], position[2])
        if track is not None:
            self.channel.set_track(addr, track)
        lo = {"advert_period_ms": 60000}
        lo.update(link_opts or {})
        node.add_link(link, MacDriver(driver, mac) if mac is not None else driver, host, **lo)
        sn.node, sn.driver, sn.emu = node, driver, emu
        self.nodes[name] = sn
        self._order.append(sn)
        return sn

    def step(self):
        now = self.clock()
        ch = self.channel
        for sn in self._order:
            sn.node.step(now)
            dev = sn.modem_end
            if dev.any():
                sn.emu.feed(now, dev.read())
            sn.emu.poll(now)
        ch.poll(now)
        for sn in self._order:
            out = sn.emu.take_output()
            if out:
                sn.modem_end.write(out)
        self.clock.advance(self.step_ms)
        self.steps += 1

    def run(self, ms, until=None):
        # Runs `ms` of simulated time, or until until() is true (-> True).
        end = ticks_add(self.clock(), ms)
        while ticks_diff(end, self.clock()) > 0:
            self.step()
            if until is not None and until():
                return True
        return until is None
