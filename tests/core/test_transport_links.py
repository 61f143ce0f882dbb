# The transport's link choice (acomm.transport.route): acoustic before a costly
# satellite link while both reach, fail-over when the acoustic path goes,
# a medium that pins a packet to one link, and "all" that sends a copy on
# every link and delivers once. Then bad input at the transport: forged
# and corrupted fragments, acknowledgements for unknown packets, fragments
# that overrun the size they declared.
from acomm.transport import segment as sg
from acomm.errors import AcommError
from acomm.events import DELIVERED, EXPIRED, QUEUED
from acomm.prng import Prng
from checks import raises
from transportnet import add_satellite, net, packets, statuses


def _sat_net():
    w, a, b, _, ta = net()
    add_satellite(w, a, b)
    w.run(2000)
    return w, a, b, ta


def _frames(sn):
    return dict((n, sn.node.links[n].stats["tx_frames"]) for n in sn.node.links)


def test_acoustic_is_chosen_while_it_reaches_and_satellite_when_it_is_gone():
    w, a, b, ta = _sat_net()
    pid = ta.send(w.now(), "buoy", Prng(1).bytes(200), 3600, 10)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    f = _frames(a)
    assert f["acoustic"] >= 8 and f["sat"] == 0  # free beats cheap
    w.channel.loss = 1.0  # the diver swims into an acoustic shadow
    pid = ta.send(w.now(), "buoy", Prng(2).bytes(200), 3600, 10)
    assert w.run(1200000, until=lambda: DELIVERED in statuses(a, pid))
    assert ta.stats["failovers"] == 1 and _frames(a)["sat"] > 0
    assert [e[3] for e in packets(b)][1] == Prng(2).bytes(200)
    # the acoustic path stays marked as stalled: the next packet goes by satellite at once
    n = _frames(a)["acoustic"]
    pid = ta.send(w.now(), "buoy", b"surfacing in 5 min", 3600, 10)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    assert _frames(a)["acoustic"] == n


def test_an_urgent_packet_takes_the_faster_link_even_when_it_costs():
    w, a, b, _, ta = net()
    sat = add_satellite(w, a, b, cost=0.05, latency_ms=100)  # a fast radio this time
    w.run(2000)
    pid = ta.send(w.now(), "buoy", b"low air!", 600, 1)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    assert sat[0].stats["tx_frames"] >= 1 and _frames(a)["acoustic"] == 0
    pid = ta.send(w.now(), "buoy", b"routine status", 600, 10)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    assert _frames(a)["acoustic"] >= 1  # not urgent: the free link


def test_a_pinned_medium_does_not_fail_over():
    w, a, b, ta = _sat_net()
    w.channel.loss = 1.0
    pid = ta.send(w.now(), "buoy", b"acoustic only", 120, 10, medium="acoustic")
    assert w.run(300000, until=lambda: EXPIRED in statuses(a, pid))
    assert _frames(a)["sat"] == 0 and not packets(b)
    raises(AcommError, ta.send, w.now(), "buoy", b"x", 60, 10, "carrier pigeon")


def test_medium_all_sends_a_copy_on_every_link_and_delivers_once():
    w, a, b, ta = _sat_net()
    pid = ta.send(w.now(), "buoy", b"mission abort acknowledged", 3600, 3, medium="all")
    assert ta.pending() == [pid]
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    w.run(60000)
    assert statuses(a, pid) == [QUEUED, DELIVERED]
    assert len(packets(b)) == 1 and ta.pending() == []
    f = _frames(a)
    assert f["acoustic"] >= 1 and f["sat"] >= 1


def test_bad_input_at_the_transport_is_counted_and_harmless():
    w, a, b, _, ta = net()
    tb = b.node.transport
    link = b.node.links["acoustic"]
    rng = Prng(3)
    for _ in range(300):  # forged and corrupted segments
        tb.on_segment(w.now(), link, 2, 1, rng.below(16), rng.bytes(rng.below(40)))
    tb.on_segment(w.now(), link, 2, 1, *sg.sack(0, 1, 3, b"\xff"))  # a SACK for nothing we sent
    tb.on_segment(w.now(), link, 2, 1, *sg.sack_complete(1, 0, 4, 999))
    bad = tb.stats["rx_bad"]
    assert bad >= 2 and not packets(b)
    # a fragment 0 that declares 2 MB: refused at once, with a reason for the sender
    head = sg.packet_header(77, 2000000)
    h, first = sg.frag_header(True, 0, 0, 0)
    w.run(120000)  # the SACKs owed to the forger leave the link's queue first (see below)
    assert not len(link.queue)
    tb.on_segment(w.now(), link, 2, 1, h, first + head + b"x" * 10)
    refusal = sg.sack_refused(0, 0, sg.REFUSE_TOO_BIG)[1]
    assert tb.stats["rx_bad"] == bad + 1 and [r.data for r in link.queue] == [refusal]
    # only a marker stays, which answers a poll with the refusal again
    tb.on_segment(w.now(), link, 2, 1, h, first)
    assert [r.data for r in link.queue] == [refusal, refusal]
    # fragments beyond the count the first one declared
    h, first = sg.frag_header(False, 1, 0, 0)
    tb.on_segment(w.now(), link, 2, 1, h, first + sg.packet_header(78, 30) + b"y" * 20)
    h, first = sg.frag_header(True, 1, 0, 9)
    tb.on_segment(w.now(), link, 2, 1, h, first + b"z" * 24)
    assert tb.stats["rx_bad"] == bad + 2
    # the node still works, once the SACKs it owed the forger (sent to the
    # diver, whose id the forgeries used) have left its queue: a refusal
    # among them would otherwise meet the diver's real transfer
    w.run(120000)
    pid = ta.send(w.now(), "buoy", b"still here", 600, 5)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    assert packets(b)[-1][3] == b"still here"
