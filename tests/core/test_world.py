# The simulated ocean (acomm_sim.world): real Nodes, drivers and emulated
# modems on one Channel and one virtual clock. Deterministic: the same seed
# gives the same run, TDMA keeps a busy network free of collisions where
# unscheduled senders collide, and delay follows distance.
from acomm.events import DELIVERED, EV_RECEIVED, EV_STATUS, TRANSMITTED, is_final
from acomm.drivers.mac import Aloha, Tdma
from acomm_sim.world import World

AIR = ((12 + 1 + 5 + 12) * 8000 + 399) // 400  # a 12-byte payload on BPSK


def busy_network(mac_kind, seed=1, n=4, rounds=3):
    w = World(seed=seed)
    sched = [(i + 1, AIR + 400, 150) for i in range(n)]
    for i in range(n):
        mac = None
        if mac_kind == "tdma":
            mac = Tdma(sched, i + 1, tx_ms=AIR)
        elif mac_kind == "aloha":
            mac = Aloha(4 * AIR, seed=seed + i)
        w.add("n%d" % (i + 1), i + 1, "bpsk", position=(i * 40.0, 0.0, 5.0), mac=mac,
              link_opts={"advert_period_ms": 600000})
    for k in range(rounds):
        for sn in w.nodes.values():
            sn.node.send("acoustic", "*", b"status %02d %03d" % (sn.node.node_id, k), 60, 5)
        w.run(15000)
    rx = sum(1 for sn in w.nodes.values() for e in sn.events if e[0] == EV_RECEIVED)
    return w, rx


def test_tdma_avoids_the_collisions_of_unscheduled_senders():
    w, rx = busy_network("tdma")
    assert w.channel.collided == 0 and rx == 4 * 3 * 3
    w2, rx2 = busy_network(None)  # everyone at once: every copy collides
    assert w2.channel.collided > 0 and rx2 < rx
    w3, rx3 = busy_network("aloha")
    assert rx2 <= rx3 <= rx


def test_same_seed_same_run():
    a = busy_network("aloha", seed=4)
    b = busy_network("aloha", seed=4)
    assert a[1] == b[1] and a[0].channel.collided == b[0].channel.collided
    ea = [e[:2] + e[3:] for e in a[0].nodes["n1"].events]
    eb = [e[:2] + e[3:] for e in b[0].nodes["n1"].events]
    assert [e[0] for e in ea] == [e[0] for e in eb]


def test_unicast_latency_follows_airtime_and_distance():
    w = World(seed=2)
    w.add("buoy", 1, "bpsk", position=(0.0, 0.0, 0.0), link_opts={"advert_period_ms": 600000})
    w.add("rov", 2, "bpsk", position=(1500.0, 0.0, 0.0), link_opts={"advert_period_ms": 600000})
    w.run(3000)  # the start-up adverts go by
    t0 = w.now()
    rid = w.nodes["buoy"].node.send("acoustic", "rov", b"thrust", 30, 1, True)
    assert w.run(20000, until=lambda: any(e[0] == EV_RECEIVED for e in w.nodes["rov"].events))
    got = [w.now()]
    # raw frame: 6 bytes + 5 header/CRC, SLIP-framed to the modem; 12 bytes of
    # modem framing at 400 bit/s = 460 ms on the air, 1000 ms of propagation
    lat = got[0] - t0
    assert 1460 <= lat <= 1460 + 60, lat
    w.run(10000)
    finals = [e[3] for e in w.nodes["buoy"].events if e[0] == EV_STATUS and e[2] == rid]
    assert finals[-1] == DELIVERED and TRANSMITTED not in finals


def test_every_emulated_modem_runs_in_the_world():
    # each modem of world.MODEMS: driver and emulator found by name, up,
    # and an acknowledged unicast delivered over the channel
    for modem in ("seatrac", "evologics", "micromodem", "benthos", "bpsk", "fhss"):
        w = World(seed=3)
        opts = {"advert_period_ms": 600000}
        a = w.add("buoy", 1, modem, position=(0.0, 0.0, 1.0), link_opts=opts)
        w.add("diver", 2, modem, position=(120.0, 0.0, 10.0), link_opts=opts)
        assert w.run(30000, until=lambda: all(sn.driver.ready(w.now()) for sn in w.nodes.values())), modem
        rid = a.node.send("acoustic", "diver", b"hello " + modem.encode(), 60, 2, True)

        def final():
            s = [e[3] for e in a.events if e[0] == EV_STATUS and e[2] == rid]
            return s and is_final(s[-1])

        assert w.run(60000, until=final), modem
        assert [e[3] for e in a.events if e[0] == EV_STATUS and e[2] == rid][-1] == DELIVERED, modem
        got = [bytes(e[4]) for e in w.nodes["diver"].events if e[0] == EV_RECEIVED]
        assert got == [b"hello " + modem.encode()], (modem, got)


def test_frames_to_one_node_are_not_taken_for_copies_when_others_get_frames_in_between():
    # A link numbers frames per destination: with one shared 4-bit counter,
    # b saw every fourth number and took the 17th frame (seq 0 again within
    # the minute its duplicate filter remembers) for a copy of the 1st.
    from acomm.events import EV_RECEIVED

    w = World(seed=2)
    a = w.add("a", 1, "seatrac", position=(0, 0, 5))
    b = w.add("b", 2, "seatrac", position=(60, 0, 5))
    w.add("c", 3, "seatrac", position=(0, 60, 5))
    w.run(15000)
    sent = []
    for k in range(24):
        dst = "b" if k % 4 == 0 else "c"
        a.node.send("acoustic", dst, b"frame %02d" % k, 300, 5, False)
        if dst == "b":
            sent.append(b"frame %02d" % k)
    w.run(120000)
    got = [bytes(e[4]) for e in b.events if e[0] == EV_RECEIVED]
    assert got == sent and b.link.stats["rx_duplicates"] == 0
