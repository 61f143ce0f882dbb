# The World's shortcuts on routed networks (acomm_sim.idlesteps with a
# transport: its timers, ALOHA waits and acknowledgement waits skipped)
# change nothing: RoutedNet(fast=False), which steps every node every time
# it did before them, gives the same packets on the water at the same
# times, the same deliveries and the same counters and MAC state.
from acomm_sim.routednet import RoutedNet


def _run(fast, scenario, mode, nodes, minutes):
    net = RoutedNet(scenario, mode, 3, nodes=nodes, fast=fast)
    air = []
    inner = net.ch.transmit

    def transmit(now, src, packet, airtime_ms):
        air.append((now, src, bytes(packet)))
        return inner(now, src, packet, airtime_ms)

    net.ch.transmit = transmit
    m = net.run(minutes, drain_minutes=2)
    per = []
    for name in net.names:
        sn = net.w.nodes[name]
        d = sn.link.driver
        per.append((name, sorted(sn.link.stats.items()), sorted(sn.t.stats.items()), d.held, d.mac.backoffs,
                    d.mac.until, d.mac.rng.next32()))
    return net, air, m, per


def _same(scenario, mode, nodes, minutes):
    a, air_a, m_a, per_a = _run(True, scenario, mode, nodes, minutes)
    b, air_b, m_b, per_b = _run(False, scenario, mode, nodes, minutes)
    assert air_a == air_b
    assert m_a == m_b
    assert per_a == per_b
    for k in ("sent", "delivered", "collided", "deaf", "lost", "range_lost"):
        assert getattr(a.ch, k) == getattr(b.ch, k), k
    assert a.w.now() == b.w.now()
    assert a.w.node_steps * 3 < b.w.node_steps, (a.w.node_steps, b.w.node_steps)
    return a


def test_learned_routes_run_the_same_with_and_without_the_shortcuts():
    net = _same("large", "learned", 24, 4)
    assert net.got  # packets crossed the network


def test_flooding_runs_the_same_with_and_without_the_shortcuts():
    _same("chain", "flooding", None, 4)


def test_static_routes_run_the_same_with_and_without_the_shortcuts():
    net = _same("chain", "oracle", None, 4)
    assert net.got
