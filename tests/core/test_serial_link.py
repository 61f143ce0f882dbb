# Nodes over the transparent serial link on FakeUART lines: raw frames, link
# acks, noise, discovery among three nodes, and the final-status rule under
# loss, corruption and cancellation.
from acomm import frame as fr
from acomm.frame import slip
from acomm_sim.clock import ManualClock
from acomm.compat import TICKS_MAX
from acomm.drivers.transparent import TransparentDriver
from acomm.events import (
    AVAILABLE,
    DELIVERED,
    EV_AVAILABILITY,
    EV_RECEIVED,
    EV_STATUS,
    TRANSMITTED,
    UNAVAILABLE,
    is_final,
)
from acomm_sim.fakeuart import uart_bus, uart_pair
from acomm.link import BROADCAST
from acomm.node import Node
from acomm.prng import Prng
from linkcheck import Recorder, check_exactly_one_final

NAMES = (("buoy", 1), ("diver", 2), ("auv", 3))


def make_nodes(uarts, clk, **opts):
    nodes = []
    for (name, nid), u in zip(NAMES, uarts):
        n = Node(name, nid, clk, listener=Recorder())
        for other, oid in NAMES:
            n.names.add(other, oid)
        opts.setdefault("advert_period_ms", 20000)
        n.add_link("radio", TransparentDriver(9600), u, **opts)
        nodes.append(n)
    return nodes


def run(nodes, clk, ms, step=5, skip=()):
    for _ in range(ms // step):
        for n in nodes:
            if n not in skip:
                n.step()
        clk.advance(step)


def test_unicast_with_link_ack_and_broadcast():
    clk = ManualClock(TICKS_MAX - 2000)  # the exchange crosses the tick wrap
    a, b = uart_pair(clock=clk)
    buoy, diver = make_nodes((a, b), clk)
    r1 = diver.send("radio", "buoy", b"depth 12.5 m", 30, priority=2, ack=True)
    r2 = buoy.send("radio", BROADCAST, b"surface in 5 min", 30, priority=2)
    run((buoy, diver), clk, 3000)
    assert diver.listeners[0].final(r1) == DELIVERED
    assert buoy.listeners[0].final(r2) == TRANSMITTED
    got_b = [(e[2], e[3], bytes(e[4])) for e in buoy.listeners[0].of(EV_RECEIVED)]
    got_d = [(e[2], e[3], bytes(e[4])) for e in diver.listeners[0].of(EV_RECEIVED)]
    assert got_b == [("diver", "buoy", b"depth 12.5 m")]
    assert got_d == [("buoy", BROADCAST, b"surface in 5 min")]


def test_noise_between_frames_is_counted_and_link_keeps_going():
    clk = ManualClock()
    a, b = uart_pair(clock=clk)
    buoy, diver = make_nodes((a, b), clk)
    b.inject(b"\x00\xffNOISE\xc0garbage\xc0\xdb\x01")
    r1 = buoy.send("radio", "diver", b"one", 30, ack=True)
    run((buoy, diver), clk, 1000)
    b.inject(slip.encode(b"\x40\x01\x21bad crc!!"))
    r2 = buoy.send("radio", "diver", b"two", 30, ack=True)
    run((buoy, diver), clk, 1000)
    assert buoy.listeners[0].final(r1) == DELIVERED
    assert buoy.listeners[0].final(r2) == DELIVERED
    link = diver.links["radio"]
    assert link.stats["rx_bad"] >= 2
    assert [bytes(e[4]) for e in diver.listeners[0].of(EV_RECEIVED)] == [b"one", b"two"]


def test_frames_for_other_nodes_are_counted_not_delivered():
    clk = ManualClock()
    nodes = make_nodes(uart_bus(3, clock=clk), clk)
    buoy, diver, auv = nodes
    rid = buoy.send("radio", "diver", b"for the diver", 30, ack=True)
    run(nodes, clk, 2000)
    assert buoy.listeners[0].final(rid) == DELIVERED
    assert auv.listeners[0].of(EV_RECEIVED) == []
    assert auv.links["radio"].stats["rx_not_for_us"] >= 1


def test_three_nodes_discover_each_other_and_notice_loss():
    clk = ManualClock()
    nodes = make_nodes(uart_bus(3, clock=clk), clk, advert_period_ms=4000, lost_after=3)
    run(nodes, clk, 200, skip=nodes[1:])  # the buoy powers on first
    run(nodes, clk, 9000)
    for n in nodes:
        seen = set(e[2] for e in n.listeners[0].of(EV_AVAILABILITY) if e[3] == AVAILABLE)
        assert seen == set(nm for nm, _ in NAMES) - {n.name}, (n.name, seen)
    # the AUV falls silent (dives out of range): the others notice
    buoy, diver, auv = nodes
    run(nodes, clk, 3 * 4000 + 4000, skip=(auv,))
    for n in (buoy, diver):
        assert n.links["radio"].availability("auv") == UNAVAILABLE
        assert n.links["radio"].availability("buoy" if n is diver else "diver") == AVAILABLE


def test_every_request_gets_exactly_one_final_status_under_faults():
    clk = ManualClock(TICKS_MAX - 30000)
    a, b = uart_pair(clock=clk)
    a.set_faults(drop=0.15, flip=0.1, split=6, delay_ms=3, seed=4)
    b.set_faults(drop=0.15, flip=0.1, split=6, delay_ms=3, seed=5)
    buoy, diver = make_nodes((a, b), clk, queue_capacity=12, max_retries=2, ack_timeout_ms=300)
    rng = Prng(77)
    ids = {buoy: [], diver: []}
    sent_payloads = {}
    for step in range(3000):
        if rng.chance(0.05):
            src = buoy if rng.chance(0.5) else diver
            dst = BROADCAST if rng.chance(0.2) else ("diver" if src is buoy else "buoy")
            payload = b"m%d" % step
            rid = src.send(
                "radio", dst, payload, rng.range(1, 20) / 4, priority=rng.range(1, 16), ack=rng.chance(0.6)
            )
            ids[src].append(rid)
            sent_payloads[payload] = 0
        if rng.chance(0.01):
            src = buoy if rng.chance(0.5) else diver
            if ids[src]:
                src.links["radio"].cancel(clk(), ids[src][rng.below(len(ids[src]))], "test")
        for n in (buoy, diver):
            n.step()
        clk.advance(5)
    run((buoy, diver), clk, 10000)  # let every lifespan run out
    for n in (buoy, diver):
        check_exactly_one_final(n.listeners[0], ids[n])
        # a frame is delivered to the application at most once
        for e in n.listeners[0].of(EV_RECEIVED):
            p = bytes(e[4])
            sent_payloads[p] += 1
            assert sent_payloads[p] == 1, p
    finals = {}
    for n in (buoy, diver):
        for e in n.listeners[0].of(EV_STATUS):
            if is_final(e[3]):
                finals[e[3]] = finals.get(e[3], 0) + 1
    assert len(finals) >= 4  # the faults really produced a mix of outcomes
    assert diver.links["radio"].stats["rx_bad"] + buoy.links["radio"].stats["rx_bad"] > 0


def test_raw_frames_on_the_line_are_compact():
    clk = ManualClock()
    a, b = uart_pair(clock=clk)
    buoy, diver = make_nodes((a, b), clk, advert_period_ms=600000)
    seen = []
    orig = a.write

    def tap(data):
        seen.append(bytes(data))
        return orig(data)

    a.write = tap
    buoy.send("radio", "diver", b"0123456789", 30)
    run((buoy, diver), clk, 100)
    # the first write is the advert of a node that has never sent
    frames = []
    for w in seen:
        slip.SlipDecoder(64).feed(w, frames)
    data = [fr.decode_raw(f) for f in frames]
    d = [f for f in data if f.ftype == fr.DATA][0]
    raw = [f for f in frames if fr.decode_raw(f).ftype == fr.DATA][0]
    assert len(raw) == 10 + fr.RAW_OVERHEAD_SHORT and d.src == 1 and d.dst == 2


class ShortWriter:
    # A UART whose write() takes at most 3 bytes at a time, or None (timeout)
    # every third call, as machine.UART may.
    def __init__(self, uart):
        self.uart = uart
        self.calls = 0

    def read(self, n=-1):
        return self.uart.read(n)

    def write(self, data):
        self.calls += 1
        if self.calls % 3 == 0:
            return None
        return self.uart.write(bytes(data[:3]))


def test_short_writes_lose_nothing():
    clk = ManualClock()
    a, b = uart_pair(clock=clk)
    buoy, diver = make_nodes((ShortWriter(a), b), clk, advert_period_ms=600000)
    rid = buoy.send("radio", "diver", b"a longer message than three bytes", 30, ack=True)
    run((buoy, diver), clk, 3000)
    assert buoy.listeners[0].final(rid) == DELIVERED
    assert [bytes(e[4]) for e in diver.listeners[0].of(EV_RECEIVED)] == [b"a longer message than three bytes"]


def test_own_frames_heard_back_are_not_received():
    clk = ManualClock()
    a, b = uart_pair(clock=clk)
    buoy, diver = make_nodes((a, b), clk)
    b.peers.append(b)  # the diver's radio hears itself
    diver.send("radio", BROADCAST, b"echo", 30)
    run((buoy, diver), clk, 1000)
    assert diver.listeners[0].of(EV_RECEIVED) == []
    assert diver.links["radio"].stats["rx_own"] >= 1
    assert [bytes(e[4]) for e in buoy.listeners[0].of(EV_RECEIVED)] == [b"echo"]


def test_a_link_without_a_stream_keeps_running():
    # nobody drains the driver's output: the driver refuses, the link counts
    clk = ManualClock()
    n = Node("lonely", 7, clk, listener=Recorder())
    n.add_link("radio", TransparentDriver(9600), None, advert_period_ms=100)
    for _ in range(3000):
        n.step()
        clk.advance(10)
    assert n.links["radio"].stats["tx_refused"] > 0


class _Unplugged:
    # a stream whose device went away for a while: read and write raise
    def __init__(self, end):
        self.end = end
        self.out = False

    def read(self, n=-1):
        if self.out:
            self.end.read()
            raise OSError(5, "unplugged")
        return self.end.read(n)

    def write(self, data):
        if self.out:
            raise OSError(5, "unplugged")
        return self.end.write(data)


def test_a_stream_that_raises_does_not_stop_the_node():
    # pyserial raises when a USB adapter is pulled: the node must keep
    # stepping (its timers, its statuses) and use the line when it is back
    clk = ManualClock()
    a, b = uart_pair(clock=clk)
    cable = _Unplugged(b)
    buoy, diver = make_nodes((a, cable), clk)
    cable.out = True
    r1 = diver.send("radio", "buoy", b"while unplugged", 5, priority=2, ack=True)
    run((buoy, diver), clk, 8000)  # raises out of step() without the fix
    assert diver.stream_errors > 0
    assert diver.listeners[0].final(r1) is not None  # it still got its final status
    cable.out = False
    r2 = diver.send("radio", "buoy", b"plugged back", 30, priority=2, ack=True)
    run((buoy, diver), clk, 5000)
    assert diver.listeners[0].final(r2) == DELIVERED
    assert [bytes(e[4]) for e in buoy.listeners[0].of(EV_RECEIVED)] == [b"plugged back"]
