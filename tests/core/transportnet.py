# Simulated networks for the transport tests: SeaTrac nodes in a World,
# each with a Transport, and optionally a second, costly link between two
# of them (a serial radio standing in for a satellite link: it is slow to
# start and costs money per byte) for link choice and fail-over.
from acomm.drivers.transparent import TransparentDriver
from acomm.events import EV_PACKET, EV_PACKET_STATUS
from acomm_sim.fakeuart import uart_pair
from acomm.transport import Transport
from acomm_sim.channel import Channel
from acomm_sim.world import World

QUIET = {"advert_period_ms": 600000}


def wall_of(w):
    return lambda: w.now() // 1000


def net(loss=0.0, relay=False, seed=1, stores=None):
    # diver -> buoy, straight (150 m) or through the auv when relay (the
    # buoy is 300 m away, beyond the acoustic range of 200 m)
    curve = ((0.0, 0.0), (200.0, 0.0), (201.0, 1.0)) if relay else None
    w = World(seed=seed, channel=Channel(seed=seed, loss=loss, loss_curve=curve))
    a = w.add("diver", 2, "seatrac", position=(0, 0, 10), link_opts=QUIET)
    b = w.add("buoy", 1, "seatrac", position=(300 if relay else 150, 0, 0), link_opts=QUIET)
    c = w.add("auv", 3, "seatrac", position=(150, 0, 5), link_opts=QUIET) if relay else None
    stores = stores or {}
    ta = Transport.of(a.node, store=stores.get("diver"), routes={"buoy": "auv"} if relay else None, wall=wall_of(w))
    Transport.of(b.node, store=stores.get("buoy"), routes={"diver": "auv"} if relay else None, wall=wall_of(w))
    if c is not None:
        Transport.of(c.node, store=stores.get("auv"), wall=wall_of(w))
    w.run(15000)
    return w, a, b, c, ta


def add_satellite(w, a, b, cost=0.05, latency_ms=20000):
    # a costly, slow-to-start second link between sim nodes a and b
    ea, eb = uart_pair(rxbuf=4096, clock=w.clock)
    links = []
    for sn, end in ((a, ea), (b, eb)):
        d = TransparentDriver(baud=19200, mtu=120, model="satellite stand-in")
        d.caps.cost_tx = cost
        d.caps.latency_ms = latency_ms
        links.append(sn.node.add_link("sat", d, end, medium="satellite", **QUIET))
    return links


def packets(sn):
    return [e for e in sn.events if e[0] == EV_PACKET]


def statuses(sn, pid):
    return [e[2] for e in sn.events if e[0] == EV_PACKET_STATUS and e[1] == pid]
