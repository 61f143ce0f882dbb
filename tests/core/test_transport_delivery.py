# The transport's implicit acknowledgement (acomm.transport.delivery): on a
# link whose modem reports delivery by itself (an EvoLogics S2C, burst data),
# DELIVERED acknowledges a fragment; the peer's SACK stays the authority.
import sys

from acomm.events import DELIVERED, QUEUED, TRANSMITTED
from acomm.prng import Prng
from acomm.transport import Transport
from acomm.transport import segment as sg
from acomm.transport.arq import Outgoing
from acomm.transport.delivery import REPORT_COMPLETE, REPORT_NEW_ROUND, REPORT_REPOLL, ReportedOutgoing
from acomm_sim.channel import Channel
from acomm_sim.world import World
from transportnet import QUIET, net, packets, statuses, wall_of


def _round(o):
    # the fragments of a round: (index, poll flag, size)
    out = []
    nf = o.next_fragment()
    while nf is not None:
        out.append((nf[0], sg.is_poll(nf[1]), len(nf[2])))
        nf = o.next_fragment()
    return out


def test_reported_fragments_are_equal_and_to_the_destination_the_reports_acknowledge_them():
    # 4100 bytes at 1022 per fragment: five of 820, not four full and a runt
    o = ReportedOutgoing(bytes(4100), 1022, 0, 0, 7, True)
    assert (o.count, o.fragsize) == (5, 820) and Outgoing(bytes(4100), 1022, 0, 0, 7).count == 5
    o.new_round()
    # no fragment asks for a SACK: the modem reports each of them
    assert _round(o) == [(i, False, 821) for i in range(5)]
    assert o.report_min == 512 and o.report_wanted(821, False) and o.report_wanted(512, False)
    assert not o.report_wanted(511, False)
    # a report is not the round's end while others are to come
    assert [o.reported(i, i != 2, True) for i in (0, 1, 2, 3)] == [0, 0, 0, 0]
    assert o.base == 2 and not o.complete
    # the last report is in: DELIVERED ones were heard, so 2 is missing
    assert o.reported(4, True, False) == REPORT_NEW_ROUND
    assert o.base == 2 and list(o.acked) == [1, 1, 0, 1, 1]


def test_the_reports_of_a_round_decide_the_next_one():
    o = ReportedOutgoing(bytes(3000), 1022, 0, 0, 7, True)
    o.new_round()
    assert len(_round(o)) == 3
    assert [o.reported(0, True, True), o.reported(1, False, True), o.reported(2, True, False)] == [0, 0,
                                                                                             REPORT_NEW_ROUND]
    assert o.new_round() == [1] and _round(o) == [(1, False, 1001)]
    # the last one FAILED, and nothing else in the round was heard: the
    # modem's acknowledgement may be what was lost, a bare poll asks
    assert o.reported(1, False, False) == REPORT_REPOLL
    assert o.repoll()[0] == 1 and sg.is_poll(o.repoll()[1])
    o.new_round()
    # a report while the round is still being sent is not its end
    assert o.reported(1, False, False) == 0
    _round(o)
    assert o.reported(1, True, False) == REPORT_COMPLETE and o.complete and o.base == 3
    # a packet of one short fragment is not reported: it asks for a SACK
    o = ReportedOutgoing(bytes(300), 1022, 0, 0, 7, True)
    o.new_round()
    assert _round(o) == [(0, True, 301)] and not o.report_wanted(301, True)


def test_to_a_relay_the_poll_is_not_reported_and_the_sack_completes():
    o = ReportedOutgoing(bytes(4100), 1022, 0, 0, 7, False)
    o.new_round()
    # the poll goes last, as on any link; the relay's SACK says whether
    # it took custody (it may be full)
    assert [f[1] for f in _round(o)] == [False] * 4 + [True]
    assert o.report_wanted(821, False) and not o.report_wanted(821, True)
    o.reported(1, True, True)
    assert o.reported(1, True, True) == 0  # twice: no matter
    assert o.base == 0 and o.acked[1]
    o.reported(0, True, True)
    o.reported(2, True, True)
    o.reported(3, False, True)
    assert o.base == 3 and not o.acked[3]
    # to a relay, reports never end a round or the transfer
    assert o.reported(3, True, False) == 0 and o.base == 4 and not o.complete
    o.reported(9, True, False)  # no such fragment: ignored
    # the SACK is the authority: it says the relay lacks 2 and 3 (its
    # reassembly was dropped) though the modem reported them: they go again
    s = sg.decode(*sg.sack(0, 0, 2, b"\x02"))
    assert o.on_sack(s) and o.base == 2
    assert o.new_round() == [2, 3]
    # only a completion SACK completes the transfer
    assert o.on_sack(sg.decode(*sg.sack_complete(0, 0, 5, 7))) and o.complete


def test_a_link_without_reports_never_loads_the_delivery_module():
    mod = sys.modules.pop("acomm.transport.delivery")
    try:
        w, a, b, _, ta = net()  # SeaTrac: the modem acknowledges only when asked
        pid = ta.send(w.now(), "buoy", Prng(2).bytes(70), 3600, 5)
        assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
        assert "acomm.transport.delivery" not in sys.modules
    finally:
        sys.modules["acomm.transport.delivery"] = mod


def _evologics_pair(loss=0.0, seed=3):
    w = World(seed=seed, channel=Channel(seed=seed, loss=loss))
    a = w.add("diver", 2, "evologics", position=(0, 0, 10), link_opts=QUIET)
    b = w.add("buoy", 1, "evologics", position=(150, 0, 0), link_opts=QUIET)
    ta = Transport.of(a.node, wall=wall_of(w), compress=False)
    Transport.of(b.node, wall=wall_of(w), compress=False)
    w.run(15000)
    return w, a, b, ta


def test_an_evologics_transfer_sends_a_train_and_the_reports_complete_it():
    w, a, b, ta = _evologics_pair(0.1)
    data = Prng(4).bytes(3000)  # three bursts of 1002 bytes (header included)
    pid = ta.send(w.now(), "buoy", data, 3600, 5)
    most = [0]

    def done():
        # bursts the modem sent whose report is still to come
        most[0] = max(most[0], len(a.driver.awaiting))
        return DELIVERED in statuses(a, pid)

    assert w.run(600000, until=done)
    got = packets(b)
    assert len(got) == 1 and got[0][1:] == ("diver", "buoy", data)
    assert statuses(a, pid) == [QUEUED, DELIVERED]
    # the three bursts went one behind the other, in one train, before any
    # report came, and the modem's DELIVERED acknowledged them: the buoy
    # sent no SACK
    assert most[0] == 3 and not a.driver.awaiting
    assert ta.stats["fragments"] == 3 and ta.stats["sacks"] == 0


def test_a_burst_lost_in_the_train_goes_again_alone_when_the_reports_come():
    w, a, b, ta = _evologics_pair()
    data = Prng(5).bytes(3000)
    t0 = w.now()
    # noise at the buoy in the middle of the second burst (1,753 ms each)
    w.channel.noise_burst(t0 + 2700, 200, receiver=1)
    pid = ta.send(t0, "buoy", data, 3600, 5)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    assert [p[3] for p in packets(b)] == [data]
    # the modem said FAILED for that one only; it went again at once, with
    # no SACK asked for or sent
    assert ta.stats["fragments"] == 4 and ta.stats["sacks"] == 0 and ta.stats["resent"] == 0
    assert w.channel.noise_lost == 1


def test_a_lost_acknowledgement_is_settled_by_a_bare_poll():
    w, a, b, ta = _evologics_pair()
    data = Prng(6).bytes(3000)
    t0 = w.now()
    pid = ta.send(t0, "buoy", data, 3600, 5)
    # noise at the diver when the buoy's modem acknowledges the train
    # (three bursts and 100 ms each way: about 5.4 s)
    w.channel.noise_burst(t0 + 5300, 600, receiver=2)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    assert [p[3] for p in packets(b)] == [data]
    # every burst FAILED: the sender asked with a bare poll, whose SACK
    # said the buoy had them all; nothing went twice
    assert w.channel.noise_lost == 1
    assert ta.stats["fragments"] == 4 and ta.stats["resent"] == 1 and ta.stats["sacks"] == 1


def test_to_a_relay_the_sack_completes_the_transfer():
    curve = ((0.0, 0.0), (200.0, 0.0), (201.0, 1.0))
    w = World(seed=3, channel=Channel(seed=3, loss_curve=curve))
    a = w.add("diver", 2, "evologics", position=(0, 0, 10), link_opts=QUIET)
    b = w.add("buoy", 1, "evologics", position=(300, 0, 0), link_opts=QUIET)
    c = w.add("auv", 3, "evologics", position=(150, 0, 5), link_opts=QUIET)
    ta = Transport.of(a.node, routes={"buoy": "auv"}, wall=wall_of(w), compress=False)
    Transport.of(b.node, routes={"diver": "auv"}, wall=wall_of(w), compress=False)
    tc = Transport.of(c.node, wall=wall_of(w), compress=False)
    w.run(15000)
    data = Prng(7).bytes(3000)
    pid = ta.send(w.now(), "buoy", data, 3600, 5)
    assert w.run(600000, until=lambda: len(packets(b)) == 1)
    assert packets(b)[0][1:] == ("diver", "buoy", data)
    # the auv's modem acknowledged the bursts, but only its SACK says it
    # took custody: the diver got one, and so did the auv from the buoy
    assert ta.stats["sacks"] >= 1 and tc.stats["relayed"] == 1
    assert statuses(a, pid)[-1] == TRANSMITTED
