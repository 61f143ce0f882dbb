# `acomm bench transfer`: 4 KiB of random (incompressible) bytes from a
# diver's tablet to the buoy, 150 m apart, on SeaTrac beacons
# in the simulated ocean, at 0, 10 and 20 % frame loss, two ways:
#
#   acomm   the transport: fragments to the MTU, one bitmap SACK per round
#           of up to 65 fragments, only the missing ones again;
#   saw     stop-and-wait, the baseline: one acknowledged link frame at a
#           time (the modem's own acknowledgement), retried until it gets
#           through.
#
# goodput_ratio_<modem>_<loss %> = delivered payload bits per second divided
# by the ideal for that modem: the modem's MTU filled with payload, frame
# after frame, no acknowledgements, minus the loss:
#     ideal = MTU * 8 / airtime(MTU) * (1 - loss)
# The ideal counts acomm's 2 bytes per fragment (the link header, whose
# sequence field carries the fragment's flags, and the fragment's index
# byte) as overhead: on a 30-byte SeaTrac frame they cap the ratio at
# 28/30 = 0.93 before any acknowledgement is paid for.
from acomm.events import DELIVERED, EV_PACKET, EV_PACKET_STATUS, EV_STATUS
from acomm.prng import Prng
from acomm.transport import Transport
from acomm_sim.channel import Channel
from acomm_sim.world import World

PER_RUNTIME = ()
SIZE = 4096
LOSSES = (0.0, 0.1, 0.2)
MODEMS = ("seatrac", "evologics")
DISTANCE = 150.0


def _world(modem, loss, seed):
    w = World(seed=seed, channel=Channel(seed=seed, loss=loss))
    lo = {"advert_period_ms": 3600000, "max_retries": 1000, "queue_capacity": 64}
    a = w.add("diver", 2, modem, position=(0.0, 0.0, 10.0), link_opts=lo)
    b = w.add("buoy", 1, modem, position=(DISTANCE, 0.0, 0.0), link_opts=lo)
    w.run(15000)
    return w, a, b


def ideal_bps(driver, loss):
    # the driver's own airtime model of its largest frame: SeaTrac 500 ms +
    # 80 ms a byte; EvoLogics a burst (1024 bytes at its burst bit rate
    # after the packet's fixed part), not an instant message
    mtu = driver.caps.mtu_tx
    burst = getattr(driver, "burst_mtu", 0)
    air = driver.airtime_ms(mtu, True) if burst and mtu == burst else driver.airtime_ms(mtu)
    return mtu * 8 * 1000 / air * (1 - loss)


def run_acomm(modem, loss, seed=1, size=None):
    w, a, b = _world(modem, loss, seed)
    wall = lambda: w.now() // 1000  # noqa: E731
    ta = Transport.of(a.node, wall=wall, compress=False)
    Transport.of(b.node, wall=wall, compress=False)
    data = Prng(seed).bytes(SIZE if size is None else size)
    t0 = w.now()
    pid = ta.send(t0, "buoy", data, 36000, 5)
    ok = w.run(36000000, until=lambda: any(e[0] == EV_PACKET_STATUS and e[1] == pid and e[2] == DELIVERED
                                            for e in a.events))
    got = [e for e in b.events if e[0] == EV_PACKET]
    assert ok and got and got[0][3] == data, "transfer did not complete"
    return (w.now() - t0) / 1000, a.driver


def run_stop_and_wait(modem, loss, seed=1, size=None):
    w, a, b = _world(modem, loss, seed)
    link = a.link
    mtu = link.mtu_for(1)
    size = SIZE if size is None else size
    data = Prng(seed).bytes(size)
    t0 = w.now()
    for k in range(0, size, mtu):
        rid = a.node.send("acoustic", "buoy", data[k : k + mtu], 36000, 5, True)
        ok = w.run(36000000, until=lambda: any(e[0] == EV_STATUS and e[2] == rid and e[3] == DELIVERED for e in a.events))
        assert ok, "stop-and-wait frame never delivered"
    return (w.now() - t0) / 1000, a.driver


def run(emit, quick=False):
    size = 256 if quick else SIZE
    for modem in MODEMS:
        for loss in LOSSES:
            pct = int(loss * 100)
            t, d = run_acomm(modem, loss, size=size)
            ideal = ideal_bps(d, loss)
            emit("goodput_ratio_%s_%d" % (modem, pct), size * 8 / t / ideal, "ratio")
            emit("transfer_time_%s_%d" % (modem, pct), t, "s")
            ts, _ = run_stop_and_wait(modem, loss, size=size)
            emit("goodput_ratio_stopwait_%s_%d" % (modem, pct), size * 8 / ts / ideal, "ratio")
