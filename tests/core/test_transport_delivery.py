# The transport's implicit acknowledgement (acomm.transport.delivery): on a
# link whose modem reports delivery by itself (an EvoLogics S2C, burst data),
# DELIVERED acknowledges a fragment; the peer's SACK stays the authority.
import sys

from acomm.events import DELIVERED, QUEUED
from acomm.prng import Prng
from acomm.transport import Transport
from acomm.transport import segment as sg
from acomm.transport.arq import Outgoing
from acomm.transport.delivery import ReportedOutgoing
from acomm_sim.channel import Channel
from acomm_sim.world import World
from transportnet import QUIET, net, packets, statuses, wall_of


def test_reported_fragments_are_equal_and_the_report_acknowledges_them():
    # 4100 bytes at 1022 per fragment: five of 820, not four full and a runt
    o = ReportedOutgoing(bytes(4100), 1022, 0, 0, 7)
    assert (o.count, o.fragsize) == (5, 820) and Outgoing(bytes(4100), 1022, 0, 0, 7).count == 5
    o.new_round()
    sizes = [len(o.next_fragment()[2]) for _ in range(5)]
    assert sizes == [821] * 5 and o.next_fragment() is None
    # the poll's fragment and those of half the MTU or less are not reported
    assert o.report_min == 512 and o.report_wanted(821, False) and o.report_wanted(512, False)
    assert not o.report_wanted(821, True) and not o.report_wanted(511, False)
    o.reported(1)
    o.reported(1)  # twice: no matter
    assert o.base == 0 and o.acked[1]
    o.reported(0)
    o.reported(2)
    o.reported(3)
    assert o.base == 4 and not o.complete
    o.reported(9)  # no such fragment: ignored
    # the peer's SACK is the authority: it says it lacks 2 and 3 (its
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


def test_an_evologics_transfer_sends_a_train_and_takes_the_reports():
    w = World(seed=3, channel=Channel(seed=3, loss=0.1))
    a = w.add("diver", 2, "evologics", position=(0, 0, 10), link_opts=QUIET)
    b = w.add("buoy", 1, "evologics", position=(150, 0, 0), link_opts=QUIET)
    ta = Transport.of(a.node, wall=wall_of(w), compress=False)
    Transport.of(b.node, wall=wall_of(w), compress=False)
    w.run(15000)
    data = Prng(4).bytes(3000)  # three bursts of 1002 bytes (header included)
    pid = ta.send(w.now(), "buoy", data, 3600, 5)
    most = [0]
    reports = []
    plain = ReportedOutgoing.reported

    def reported(o, index):
        reports.append(index)
        plain(o, index)

    def done():
        # bursts the modem sent whose report is still to come
        most[0] = max(most[0], len(a.driver.awaiting))
        return DELIVERED in statuses(a, pid)

    ReportedOutgoing.reported = reported
    try:
        assert w.run(600000, until=done)
    finally:
        ReportedOutgoing.reported = plain
    got = packets(b)
    assert len(got) == 1 and got[0][1:] == ("diver", "buoy", data)
    assert statuses(a, pid) == [QUEUED, DELIVERED]
    # the three bursts went one behind the other, in one train, before any
    # report came; the two that do not carry the poll were acknowledged by
    # the modem's DELIVERED
    assert most[0] == 3 and not a.driver.awaiting
    assert sorted(set(reports)) == [0, 1], reports
