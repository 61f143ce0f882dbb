# The World's shortcuts (nodes that sleep until their turn, their airtime's
# end or a packet, and clock jumps over packets in flight) change nothing:
# the same network run with World(fast=False), which visits every node at
# every step it visited before the shortcuts, gives the same events at the
# same simulated times, the same channel counters and the same MAC state
# (ALOHA's backoffs and generator). TDMA, ALOHA and no MAC, one-way and
# acknowledged traffic, frames that expire in the queue.
from acomm.drivers.mac import Aloha, Tdma
from acomm_sim.channel import Channel
from acomm_sim.world import World

AIR = ((12 + 1 + 5 + 12) * 8000 + 399) // 400  # a 12-byte payload on BPSK


def _plain(ev):
    return tuple(x if isinstance(x, (int, float, str, bytes, type(None))) else "obj" for x in ev)


def network(mac_kind, fast, n=4, rounds=2):
    ch = Channel(seed=7, loss=0.1, loss_curve=((0.0, 0.0), (150.0, 0.2), (400.0, 1.0)))
    w = World(seed=7, channel=ch, fast=fast)
    sched = [(i + 1, AIR + 400, 150) for i in range(n)]
    for i in range(n):
        mac = None
        if mac_kind == "tdma":
            mac = Tdma(sched, i + 1, tx_ms=AIR)
        elif mac_kind == "aloha":
            mac = Aloha(4 * AIR, seed=3 + i)
        box = []
        w.add("n%d" % (i + 1), i + 1, "bpsk", position=(i * 60.0, 0.0, 5.0), mac=mac,
              link_opts={"advert_period_ms": 40000, "queue_capacity": 4},
              listener=lambda ev, box=box: box.append(_plain(ev) + (w.now(),)))
        w.nodes["n%d" % (i + 1)].events = box
    for k in range(rounds):
        for sn in w.nodes.values():
            i = sn.node.node_id
            # a broadcast, an acknowledged frame to a neighbour, and one
            # whose lifespan (1 s) ends before a TDMA slot comes
            sn.node.send("acoustic", "*", b"status %02d %03d" % (i, k), 60, 5)
            sn.node.send("acoustic", "n%d" % (i % n + 1), b"ack me %d" % k, 30, 4, True)
            sn.node.send("acoustic", "*", b"short-lived", 1, 9)
        w.run(20000)
    w.run(60000)  # quiet: adverts and losses fall due
    return w


def _same(mac_kind):
    a = network(mac_kind, True)
    b = network(mac_kind, False)
    for name in a.nodes:
        assert a.nodes[name].events == b.nodes[name].events, (mac_kind, name)
    for k in ("sent", "delivered", "collided", "deaf", "lost", "range_lost"):
        assert getattr(a.channel, k) == getattr(b.channel, k), (mac_kind, k)
    assert a.now() == b.now()
    # the MACs were asked the same questions at the same times: same
    # answers held back, same ALOHA backoffs and generator state
    for name in a.nodes:
        da, db = a.nodes[name].link.driver, b.nodes[name].link.driver
        if getattr(da, "mac", None) is None:
            continue
        if hasattr(da.mac, "rng"):  # ALOHA (TDMA's held counts the polls, fewer when skipped)
            assert da.held == db.held, (mac_kind, name, da.held, db.held)
            assert da.mac.backoffs == db.mac.backoffs and da.mac.until == db.mac.until, (mac_kind, name)
            assert da.mac.rng.next32() == db.mac.rng.next32(), (mac_kind, name)
    # and the shortcuts were taken: fewer node steps
    assert a.node_steps < b.node_steps, (a.node_steps, b.node_steps)
    return a


def test_tdma_runs_the_same_with_and_without_the_shortcuts():
    w = _same("tdma")
    assert w.channel.delivered > 0


def test_aloha_runs_the_same_with_and_without_the_shortcuts():
    _same("aloha")


def test_no_mac_runs_the_same_with_and_without_the_shortcuts():
    _same(None)
