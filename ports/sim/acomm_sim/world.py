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
# Time advances in steps of step_ms; in each step every node that has work
# runs once (link timers, queue, driver), bytes cross the serial lines, the
# emulators run and the channel delivers what has arrived. A node with
# nothing to do (Link.idle, driver ready, no bytes waiting, and either an
# empty queue or a MAC that says "not your turn yet") is stepped only when
# its turn comes, bytes arrive, or max_quiet_ms has passed (its driver's own
# slow timers, such as keepalives, may run that much late). When every node
# sleeps and nothing is on the channel or the lines, the clock jumps to the
# earliest wake-up. Runs stay deterministic. Modems (MODEMS below) are
# looked up by name so that any emulated modem can be used; `mac` wraps the
# node's driver (acomm.drivers.mac) to give it a TDMA slot or ALOHA backoff.
#
# Applications (traffic generators, a teleop pilot, the CADDY cycle) join
# with w.add_task(task): task.poll(now) runs at the start of every step it
# is due and returns when it next wants to run (a ticks value), or None for
# "the next step". The clock never jumps past a task's wake-up.
#
# A node may have more interfaces: w.add_link("buoy", "satellite", "iridium")
# gives the buoy an Iridium modem beside its SeaTrac (surface modems keep
# their network on the channel and stay off the acoustic medium).
# Portable Python (the core tests run it on MicroPython too).

import heapq

from acomm_sim.clock import ManualClock
from acomm.compat import ticks_add, ticks_diff
from acomm_sim.fakeuart import uart_pair
from acomm.drivers.transparent import TransparentDriver
from acomm.drivers.mac import MacDriver
from acomm.drivers.registry import driver_class
from acomm.node import Node
from acomm.link.names import NameTable

from . import idlesteps
from .channel import Channel


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


def _load(mod, cls):
    # imported on first use: a World with SeaTrac beacons loads no other modem
    return getattr(__import__(mod, None, None, [cls]), cls)


def _emulator(mod, cls):
    return lambda ch, addr, now, opts: _load(mod, cls)(ch, addr, now=now, **opts)


def _driver(name):
    # the core's driver of that name (acomm.drivers.registry), as a board has it
    return lambda addr, opts: driver_class(name)(addr, **opts)


# modem name -> (driver factory(address, opts), emulator factory(channel,
# address, now, opts)). The drivers are the registry's (acomm.drivers.registry);
# bpsk and fhss are packet modems on its transparent driver.
MODEMS = {
    "seatrac": (_driver("seatrac"), _emulator("acomm_sim.seatrac", "SeatracEmulator")),
    "bpsk": (_packet_driver("bpsk"), _packet_emu("bpsk")),
    "fhss": (_packet_driver("fhss"), _packet_emu("fhss")),
    "evologics": (_driver("evologics"), _emulator("acomm_sim.evologics", "EvologicsEmulator")),
    "micromodem": (_driver("micromodem"), _emulator("acomm_sim.micromodem", "MicroModemEmulator")),
    "benthos": (_driver("benthos"), _emulator("acomm_sim.benthos", "BenthosEmulator")),
    # surface links: the emulators share a gateway / SMS centre kept on the channel
    "iridium": (_driver("iridium"), _emulator("acomm_sim.iridium", "IridiumEmulator")),
    "sms": (lambda addr, opts: _load("acomm_sim.gsm", "sms_driver")(addr, opts), _emulator("acomm_sim.gsm", "GsmEmulator")),
}
MODEMS["gsm"] = MODEMS["sms"]  # the name the simulator used before the registry


def _modem_in(now, emu, dev):
    # what the host wrote reaches the modem; the modem's timers run
    if dev.any():
        emu.feed(now, dev.read())
    emu.poll(now)


def _modem_out(emu, dev):
    out = emu.take_output()
    if out:
        dev.write(out)


def _catch_up(sn, now):
    # The steps the World skipped for sn (idlesteps) each asked its ALOHA
    # MAC whether it may send, through MacDriver.ready(): ask now, at their
    # times, before anything at `now`, so that the backoffs drawn again
    # when the old one ran out, and the driver's `held` count, come out as
    # they would have. Between two draws the answers follow from the
    # backoff's end alone (acomm.drivers.mac.Aloha.may_start): counted, not asked.
    s, q, d = sn.replay
    sn.replay = None
    mac = d.mac
    b = mac.max_backoff_ms
    t = ticks_add(s, q)
    while ticks_diff(now, t) > 0:
        u = mac.until
        if u is None or ticks_diff(t, u) > b:
            if not mac.may_start(t):  # a draw
                d.held += 1
            t = ticks_add(t, q)
            continue
        a = ticks_diff(u, t)
        # the steps t + j*q, j < k, that draw nothing and come before now
        k = min((b + a) // q + 1, (ticks_diff(now, t) + q - 1) // q)
        if a > 0:
            d.held += min(k, (a + q - 1) // q)  # "not yet": before u
        t = ticks_add(t, k * q)


def _index(sn):
    return sn.index


def _join_active(active, sn):
    # sn into the active list, which is in World._order, at its place: a
    # node or two wake at a time, and sorting the whole list for them
    # (a key call per node) cost more the larger the network
    i = sn.index
    hi = len(active)
    if not hi or active[hi - 1].index < i:
        active.append(sn)
        return
    lo = 0
    while lo < hi:
        mid = (lo + hi) >> 1
        if active[mid].index < i:
            lo = mid + 1
        else:
            hi = mid
    active.insert(lo, sn)


def _node_quiet(now, sn):
    if not _modem_quiet(now, sn.emu, sn.host_end, sn.modem_end):
        return False
    for x in sn.extra:
        if not _modem_quiet(now, x[2], x[3], x[4]):
            return False
    return True


def _sleep_until(now, sn):
    # When a node that may sleep (World._join) must be visited again: its
    # own wake-up, or earlier when one of its modems is busy and says until
    # when its poll has nothing to do (busy_until). None: it may not sleep.
    w = sn.wake
    if w is None:
        return None
    ends = [(sn.emu, sn.host_end, sn.modem_end)]
    for x in sn.extra:
        ends.append((x[2], x[3], x[4]))
    for emu, host, dev in ends:
        if host.any() or host.in_flight() or dev.any() or dev.in_flight():
            return None
        if emu.idle(now):
            continue
        t = emu.busy_until(now)
        if t is None:
            return None
        if ticks_diff(t, w) < 0:
            w = t
    return w


def _modem_quiet(now, emu, host, dev):
    # nothing can come of this modem and its line before something else does
    idle = getattr(emu, "idle", None)
    if idle is None or not idle(now):
        return False
    for end in (host, dev):
        if end.any() or end.in_flight():
            return False
    return True


def _sleeps(emu):
    # an emulator that, once idle, does nothing until bytes come from its
    # host or the medium delivers a packet to it: its node may sleep
    return getattr(emu, "quiet_until_heard", False)


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
        self.wake = None  # next step due (None: at the next world step)
        # more links of this node (World.add_link): [link, driver, emulator,
        # host end, modem end] each; the first link is the fields above
        self.extra = []
        # one round of the node's work; a board's Board.tick (World.adopt)
        self.step = node.step if node is not None else None
        self.index = 0  # place in World._order
        self.asleep = False  # in World._sleeping, not stepped
        self.sleep_key = None
        self.sleep_wake = None  # when it joins the active list again
        self.can_sleep = False
        # (time, period, MacDriver) of steps skipped whose MAC question is
        # still to be asked (idlesteps, World._catch_up), or None
        self.replay = None
        # the node's transport reads wall seconds = World ticks // this
        # (idlesteps then knows when its packets expire and skips their
        # empty steps), or None when its wall clock is its own
        self.wall_unit_ms = None

    @property
    def link(self):
        for k in self.node.links:
            return self.node.links[k]


class World:
    def __init__(self, seed=1, channel=None, start=0, step_ms=10, max_quiet_ms=100, share_names=True, fast=True):
        self.clock = ManualClock(start)
        # fast: nodes sleep and the clock jumps whenever that changes nothing
        # (the figures are the same; False visits every node at every step
        # it would have been visited before, for tests that check just that)
        self.fast = fast
        # every node is told every other's name (False: none, for networks
        # larger than a node's name table, which then learns from adverts)
        self.share_names = share_names
        self.channel = channel if channel is not None else Channel(seed=seed, now=start)
        self.seed = seed
        self.step_ms = step_ms
        self.nodes = {}
        self._order = []
        self.max_quiet_ms = max_quiet_ms
        self.steps = 0
        self.node_steps = 0
        self.node_skips = 0
        self.jumped_ms = 0
        self._tasks = []  # [task, wake]
        self._loose = []  # [emulator, host end, modem end] no node owns
        # Nodes whose modems are idle and that wait for a wake-up sleep in a
        # heap of (ms after _base, index, node) and are not visited by the
        # steps; a packet the channel delivers to their modem, a task, the
        # wake-up or run() wakes them. The others are _active, in _order.
        self._active = []
        self._sorted = True
        self._sleeping = []
        self._base = start
        self._by_station = {}  # id(emulator) -> SimNode
        self.channel.receivers = []

    # each node's name table holds this many (with share_names, every node's name is in every table)
    names_capacity = 64

    def now(self):
        return self.clock()

    def add(self, name, node_id, modem, address=None, position=None, track=None, mac=None, link="acoustic",
            driver_opts=None, emu_opts=None, link_opts=None, listener=None):
        """A node with its real driver on an emulated modem at position (x, y, depth) -> SimNode (.node, .events)."""
        addr = node_id if address is None else address
        driver = MODEMS[modem][0](addr, dict(driver_opts or {}))
        emu, host, dev = self.modem_ends(modem, addr, emu_opts, position)
        sn = SimNode(name, None, None, None, host, dev, addr)
        node = Node(name, node_id, self.clock, names=NameTable(self.names_capacity), listener=listener or sn.events.append)
        for other in self._order if self.share_names else ():
            node.names.add(other.name, other.node.node_id)
            other.node.names.add(name, node_id)
        if track is not None:
            self.channel.set_track(addr, track)
        lo = {"advert_period_ms": 60000}
        lo.update(link_opts or {})
        node.add_link(link, MacDriver(driver, mac) if mac is not None else driver, host, **lo)
        sn.node, sn.driver, sn.emu = node, driver, emu
        sn.step = node.step
        self._join(name, sn)
        return sn

    def _join(self, name, sn):
        sn.index = len(self._order)
        self.nodes[name] = sn
        self._order.append(sn)
        self._by_station[id(sn.emu)] = sn
        sn.can_sleep = self.fast and _sleeps(sn.emu)
        self._active.append(sn)

    def add_link(self, name, link, modem, address=None, driver_opts=None, emu_opts=None, link_opts=None):
        # a second (third...) interface for node `name`: e.g. a buoy with a
        # SeaTrac on the acoustic channel and an Iridium modem. The modem's
        # emulator shares the World's channel (surface modems keep their
        # network there and stay off the acoustic medium).
        sn = self.nodes[name]
        addr = sn.node.node_id if address is None else address
        driver = MODEMS[modem][0](addr, dict(driver_opts or {}))
        emu, host, dev = self.modem_ends(modem, addr, emu_opts)
        lo = {"advert_period_ms": 60000}
        lo.update(link_opts or {})
        lk = sn.node.add_link(link, driver, host, **lo)
        sn.extra.append([lk, driver, emu, host, dev])
        self._by_station[id(emu)] = sn
        sn.can_sleep = sn.can_sleep and _sleeps(emu)
        self.wake(sn)
        return lk

    def modem_ends(self, modem, address, emu_opts=None, position=None):
        # a modem in the water and its line: -> [emulator, host end, modem
        # end]. Its host end is for a node: add_link, adopt (a node built
        # elsewhere, e.g. a board's by acomm_mp.assemble), or add_loose.
        host, dev = uart_pair(rxbuf=4096, clock=self.clock)
        emu = MODEMS[modem][1](self.channel, address, self.clock(), dict(emu_opts or {}))
        if position is not None:
            self.channel.set_position(address, position[0], position[1], position[2])
        return [emu, host, dev]

    def add_loose(self, ends):
        # modem_ends() whose host end no node of the World reads: a node in
        # another process (acomm bench footprint) exchanges its bytes in a
        # task; the World runs the modem as it does a node's
        self._loose.append(ends)
        return ends

    def adopt(self, name, node, ends, step=None, events=None):
        # a node built elsewhere joins the World: ends[i] = modem_ends() of
        # its i-th link (in node.links order); step(now) replaces node.step;
        # events: the list its listener fills, if the caller keeps one
        names = list(node.links)
        emu, host, dev = ends[0]
        sn = SimNode(name, node, node.links[names[0]].driver, emu, host, dev, None)
        for k in range(1, len(ends)):
            lk = node.links[names[k]]
            e = ends[k]
            sn.extra.append([lk, lk.driver, e[0], e[1], e[2]])
        if step is not None:
            sn.step = step
        for other in self._order:
            if node.names.id_of(other.name) is None:
                node.names.add(other.name, other.node.node_id)
            if other.node.names.id_of(name) is None:
                other.node.names.add(name, node.node_id)
        if events is not None:
            sn.events = events
        self._join(name, sn)
        for x in sn.extra:
            self._by_station[id(x[2])] = sn
            sn.can_sleep = sn.can_sleep and _sleeps(x[2])
        return sn

    def add_task(self, task):
        self._tasks.append([task, None])
        return task

    def remove_task(self, task):
        self._tasks = [t for t in self._tasks if t[0] is not task]

    def _run_tasks(self, now):
        ran = False
        for t in self._tasks:
            w = t[1]
            if w is None or ticks_diff(now, w) >= 0:
                t[1] = t[0].poll(now)
                ran = True
        if ran:
            # a task may have given any node work: wake them all this step
            self._wake_all()

    def wake(self, sn):
        """Steps node `sn` at the next step (after its state was changed from outside)."""
        sn.wake = None
        if sn.asleep:
            self._activate(sn)

    def _activate(self, sn):
        # a sleeping node back on the active list: at its place when the
        # list is in order, else at its end until the next sort
        sn.asleep = False
        if self._sorted:
            _join_active(self._active, sn)
        else:
            self._active.append(sn)

    def _wake_all(self):
        for sn in self._order:
            sn.wake = None
        if self._sleeping:
            self._active = list(self._order)
            self._sorted = True
            for sn in self._active:
                sn.asleep = False
            self._sleeping = []

    def _sleep(self, sn, now, until):
        # off the active list until `until` (or a packet, a task, run())
        if not self._sleeping:
            self._base = now
        sn.asleep = True
        sn.sleep_wake = until
        sn.sleep_key = ticks_diff(until, self._base)
        heapq.heappush(self._sleeping, (sn.sleep_key, sn.index, sn))

    def _first_sleeper(self):
        # the sleeping node that wakes first (stale heap entries dropped)
        h = self._sleeping
        while h:
            k, _, sn = h[0]
            if sn.asleep and sn.sleep_key == k:
                return sn
            heapq.heappop(h)
        return None

    def _wake_due(self, now):
        # sleeping nodes whose wake-up has come join the active list
        while True:
            sn = self._first_sleeper()
            if sn is None or ticks_diff(now, sn.sleep_wake) < 0:
                return
            heapq.heappop(self._sleeping)
            self._activate(sn)

    def _extra_bytes(self, sn):
        for x in sn.extra:
            if x[3].any():
                return True
        return False

    def _quiet_until(self, sn, now):
        # when this node next needs a step; None means at the next one
        if sn.host_end.any():
            return None
        for lk, d, _, host, _ in sn.extra:
            if host.any() or not lk.idle(now) or len(lk.queue) or not d.ready(now):
                return None
        link = sn.link
        if not link.idle(now):
            return idlesteps.busy_wake(sn, link, now, self.step_ms) if self.fast else None
        d = link.driver
        queued = len(link.queue)
        cap = ticks_add(now, self.max_quiet_ms)
        if isinstance(d, MacDriver) and d.mac is not None:
            if not d.driver.ready(now):
                return None
            if not queued:
                return idlesteps.idle_wake(sn, link, now, self.max_quiet_ms) if self.fast else cap
            if d.mac.may_start(now):
                return None
            wake = d.mac.next_start(now)
            if wake is not None and ticks_diff(wake, cap) < 0:
                return wake
            if wake is not None and self.fast and isinstance(d.mac, idlesteps.MACS):
                w = idlesteps.slot_wake(sn, link, now, wake, self.max_quiet_ms)
                if w is not None:
                    return w
            return cap
        if queued or not d.ready(now):
            return None
        if d.__class__ is MacDriver:
            d = d.driver
        return idlesteps.idle_wake(sn, link, now, self.max_quiet_ms) if self.fast and isinstance(d, TransparentDriver) else cap

    def step(self):
        now = self.clock()
        ch = self.channel
        if self._tasks:
            self._run_tasks(now)
        if self._sleeping:
            self._wake_due(now)
        if not self._sorted:
            self._active.sort(key=_index)
            self._sorted = True
        active = self._active
        for sn in active:
            w = sn.wake
            if w is None or ticks_diff(now, w) >= 0 or sn.host_end.any() or self._extra_bytes(sn):
                if sn.replay is not None:
                    _catch_up(sn, now)
                sn.step(now)
                sn.wake = self._quiet_until(sn, now)
                self.node_steps += 1
            else:
                self.node_skips += 1
            _modem_in(now, sn.emu, sn.modem_end)
            for x in sn.extra:
                _modem_in(now, x[2], x[4])
        for e in self._loose:
            _modem_in(now, e[0], e[2])
        ch.poll(now)
        heard = ch.receivers
        if heard:
            # a packet reached a sleeping node's modem: its output goes out now
            for emu in heard:
                sn = self._by_station.get(id(emu))
                if sn is not None and sn.asleep:
                    self._activate(sn)
            del heard[:]
            if not self._sorted:
                active.sort(key=_index)
                self._sorted = True
        for sn in active:
            _modem_out(sn.emu, sn.modem_end)
            for x in sn.extra:
                _modem_out(x[2], x[4])
        for e in self._loose:
            _modem_out(e[0], e[2])
        self.clock.advance(self.step_ms)
        self.steps += 1
        # nodes with a wake-up and quiet modems go to sleep
        now = self.clock()
        keep = None
        for i in range(len(active)):
            sn = active[i]
            until = _sleep_until(now, sn) if sn.can_sleep else None
            if until is not None:
                if keep is None:
                    keep = active[:i]
                self._sleep(sn, now, until)
            elif keep is not None:
                keep.append(sn)
        if keep is not None:
            self._active = keep

    def _all_quiet_until(self, now, flights=False):
        # When every node sleeps, nothing is on the lines, every emulator
        # says it is idle and (unless `flights`) nothing is on the channel,
        # nothing can happen before the earliest wake-up (or arrival): the
        # clock may jump there. None when it cannot.
        if self.channel.in_flight() and not flights:
            return None
        first = None
        for t in self._tasks:
            w = t[1]
            if w is None:
                return None
            if first is None or ticks_diff(w, first) < 0:
                first = w
        for sn in self._active:
            w = sn.wake
            if w is None:
                return None
            if not _node_quiet(now, sn):
                return None
            if first is None or ticks_diff(w, first) < 0:
                first = w
        for e in self._loose:
            if not _modem_quiet(now, e[0], e[1], e[2]):
                return None
        sn = self._first_sleeper()
        if sn is not None and (first is None or ticks_diff(sn.sleep_wake, first) < 0):
            first = sn.sleep_wake
        if flights and self.channel.in_flight():
            a = self.channel.next_arrival()
            if first is None or ticks_diff(a, first) < 0:
                first = a
        return first

    def run(self, ms, until=None):
        """Runs `ms` of simulated time, or until until() is true (-> True)."""
        end = ticks_add(self.clock(), ms)
        self._wake_all()  # the caller may have given them work
        for t in self._tasks:
            t[1] = None
        clk = self.clock
        ch = self.channel
        # Without until(), the clock may also jump while packets are on
        # their way (until() may look at the time of each step)
        flights = until is None and self.fast
        while ticks_diff(end, clk()) > 0:
            self.step()
            if until is not None and until():
                self._catch_up_all()
                return True
            now = clk()
            w = self._all_quiet_until(now, flights)
            if w is not None:
                if ticks_diff(w, end) > 0:
                    w = end
                # stay on the grid of steps
                k = ticks_diff(w, now) // self.step_ms
                if k > 0:
                    if ch.in_flight():
                        # the steps skipped would each have polled the
                        # channel with nothing arriving: the last one counts
                        ch.poll(ticks_add(now, (k - 1) * self.step_ms))
                    clk.advance(k * self.step_ms)
                    self.jumped_ms += k * self.step_ms
        self._catch_up_all()
        return until is None

    def _catch_up_all(self):
        # at the end of a run, the MAC questions of the steps skipped before it
        now = self.clock()
        for sn in self._order:
            if sn.replay is not None:
                _catch_up(sn, now)
