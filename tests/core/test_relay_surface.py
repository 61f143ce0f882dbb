# Seed 003 section 4.3 end to end: the diver's tablet cannot reach shore,
# the buoy can. A packet from the diver goes acoustically to the buoy (its
# static route), which takes custody, stores it and forwards it to shore
# over Iridium: the buoy's acoustic link does not reach shore, so its polls
# go unanswered, the link stalls and the transport fails over to the
# satellite link. Real SeaTrac and Iridium drivers against their emulators.
from acomm.events import EV_PACKET, TRANSMITTED
from acomm.prng import Prng
from acomm.transport import Transport
from acomm_sim.world import World
from transportnet import QUIET, statuses, wall_of

SAT_DRIVER = {"retry_first_ms": 5000, "retry_max_ms": 20000, "give_up_ms": 600000, "mo_mtu": 270}
SAT_LINK = {"advert_period_ms": 3600000, "ack_timeout_ms": 60000, "medium": "satellite"}
SAT_EMU = {"session_ms": 2000}


def test_the_buoy_forwards_acoustic_packets_to_shore_over_iridium():
    w = World(seed=8)
    diver = w.add("diver", 2, "seatrac", position=(0, 0, 12), link_opts=QUIET)
    buoy = w.add("buoy", 1, "seatrac", position=(120, 0, 0), link_opts=QUIET)
    shore = w.add("shore", 3, "iridium", link="satellite", driver_opts=SAT_DRIVER, emu_opts=SAT_EMU,
                  link_opts=SAT_LINK)
    w.add_link("buoy", "satellite", "iridium", driver_opts=SAT_DRIVER, emu_opts=SAT_EMU, link_opts=SAT_LINK)
    wall = wall_of(w)
    td = Transport.of(diver.node, routes={"shore": "buoy"}, wall=wall)
    tb = Transport.of(buoy.node, wall=wall)
    Transport.of(shore.node, wall=wall)
    w.run(15000)
    log = Prng(21).bytes(400)  # a dive log that does not compress
    pid = td.send(w.now(), "shore", log, 7200, 6)
    assert w.run(3600000, until=lambda: any(e[0] == EV_PACKET for e in shore.events))
    got = [e for e in shore.events if e[0] == EV_PACKET]
    assert len(got) == 1 and got[0][1:] == ("diver", "shore", log)  # the origin, not the buoy
    assert statuses(diver, pid)[-1] == TRANSMITTED  # the buoy took custody
    assert tb.stats["relayed"] == 1 and tb.stats["failovers"] == 1
    sat = buoy.node.links["satellite"].stats["tx_frames"]
    assert sat >= 2  # 400 bytes in 270-byte SBD messages
    w.run(300000)
    assert tb.pending() == [] and len(tb.store.keys()) <= 1  # delivered, out of the store
