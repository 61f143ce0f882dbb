# The IMC gateway's protocol logic (acomm.apps.imcgateway) without
# sockets: two simulated SeaTrac nodes, a gateway on each, IMC packets fed
# in as datagrams from a made-up endpoint, and what comes out decoded.
import time

from acomm import imc
from acomm.events import EV_RECEIVED
from acomm.imc import enums as E
from acomm.apps.imcgateway import ImcGateway
from acomm_sim.world import World

TOOL = ("127.0.0.1", 6001)  # a Neptus, say
ME = 0x4444


def _net(names=None):
    w = World(seed=1)
    a = w.add("topside", 1, "seatrac", position=(0, 0, 0))
    b = w.add("auv", 2, "seatrac", position=(100, 0, 10))
    gws = []
    for sn, imc_id in ((a, 0x4001), (b, 0x4002)):
        gw = ImcGateway(sn.node, imc_id, names=names)
        sn.node.listen(gw.on_event)
        gws.append(gw)
    w.run(5000)  # past the first adverts, which would collide with the first request
    return w, gws[0], gws[1]


def _feed(w, gw, msg, dst=None, ep=TOOL):
    gw.feed(w.now(), ep, imc.encode(msg, src=ME, dst=gw.imc_id if dst is None else dst, timestamp=time.time()))


def _out(gw):
    return [(ep, imc.decode(d)) for ep, d in gw.take_output()]


def _msgs(out, abbrev):
    return [p.msg for _, p in out if p.msg["abbrev"] == abbrev]


def _treq(req_id, dst, mode=E.DMODE_TEXT, mean=E.CMEAN_ACOUSTIC, deadline=60, **kw):
    m = {"abbrev": "TransmissionRequest", "req_id": req_id, "comm_mean": mean, "destination": dst,
         "deadline": time.time() + deadline, "data_mode": mode, "txt_data": "ok"}
    m.update(kw)
    return m


def test_transmission_request_acoustic_is_delivered_with_one_final_status():
    w, a, b = _net()
    b.peers.heard(w.now(), TOOL)
    _feed(w, a, _treq(42, "auv", txt_data="surface now"))
    _feed(w, a, _treq(43, "auv", mode=E.DMODE_INLINEMSG, msg_data={"abbrev": "Abort"}))
    w.run(30000)
    st = _msgs(_out(a), "TransmissionStatus")
    for rid in (42, 43):
        mine = [m["status"] for m in st if m["req_id"] == rid]
        assert mine == [E.TSTAT_IN_PROGRESS, E.TSTAT_DELIVERED], (rid, st)
    rx = _msgs(_out(b), "UamRxFrame")
    assert sorted(m["data"] for m in rx) == sorted([b"surface now", imc.encode_inline({"abbrev": "Abort"})])


def test_refusals_each_get_one_final_status_and_nothing_is_sent():
    w, a, b = _net()
    _feed(w, a, _treq(1, "nobody"))
    _feed(w, a, _treq(2, "auv", mean=E.CMEAN_SATELLITE))  # no satellite link here
    _feed(w, a, _treq(3, "auv", mean=E.CMEAN_WIFI))
    _feed(w, a, _treq(4, "auv", deadline=-5))
    _feed(w, a, _treq(5, "auv", mode=E.DMODE_REVERSE_RANGE))
    _feed(w, a, _treq(6, "auv", txt_data="x" * 200))  # beyond the SeaTrac's MTU
    _feed(w, a, _treq(7, "topside"))  # ourselves
    _feed(w, a, {"abbrev": "UamTxFrame", "seq": 9, "sys_dst": "auv", "data": b"y" * 100})
    _feed(w, a, {"abbrev": "UamTxFrame", "seq": 10, "sys_dst": "auv", "data": b"z"}, dst=0x1111)  # not for us
    w.run(5000)
    out = _out(a)
    got = dict((m["req_id"], m["status"]) for m in _msgs(out, "TransmissionStatus"))
    assert got == {1: E.TSTAT_INV_ADDR, 2: E.TSTAT_TEMPORARY_FAILURE, 3: E.TSTAT_INPUT_FAILURE,
                   4: E.TSTAT_TEMPORARY_FAILURE, 5: E.TSTAT_INPUT_FAILURE, 6: E.TSTAT_TEMPORARY_FAILURE,
                   7: E.TSTAT_INV_ADDR}, got
    assert len(_msgs(out, "TransmissionStatus")) == 7
    assert [(m["seq"], m["value"]) for m in _msgs(out, "UamTxStatus")] == [(9, E.UTS_INV_SIZE)]
    assert a.stats["refused"] == 8 and a.stats["requests"] == 0 and a.stats["not_for_us"] == 1
    assert a.node.links["acoustic"].stats["tx_frames"] == 0


def test_ranges_come_back_as_uam_rx_range_and_range_received():
    w, a, b = _net()
    _feed(w, a, {"abbrev": "UamTxRange", "seq": 3, "sys_dst": "auv", "timeout": 20})
    _feed(w, a, _treq(11, "auv", mode=E.DMODE_RANGE))
    w.run(30000)
    out = _out(a)
    rng = _msgs(out, "UamRxRange")
    assert len(rng) == 1 and rng[0]["seq"] == 3 and rng[0]["sys"] == "auv" and 95 < rng[0]["value"] < 105, rng
    assert [m["value"] for m in _msgs(out, "UamTxStatus")] == [E.UTS_IP, E.UTS_DONE]
    ts = _msgs(out, "TransmissionStatus")
    assert [m["status"] for m in ts] == [E.TSTAT_IN_PROGRESS, E.TSTAT_RANGE_RECEIVED]
    assert 95 < ts[-1]["range"] < 105


def test_names_from_announces_and_from_the_map():
    # the far gateway calls itself "lauv-1" in IMC: the near one learns
    # from its Announce that lauv-1 is acomm node 2
    w, a, b = _net()
    b.sys_name = "lauv-1"
    a.on_discovery(w.now(), ("127.0.0.1", 30100), b.announce(["imc+udp://127.0.0.1:6003/"]))
    assert a.acomm_name("lauv-1") == "auv"
    assert ("127.0.0.1", 6003) in a.peers.subscribers(w.now())
    _feed(w, a, {"abbrev": "UamTxFrame", "seq": 1, "sys_dst": "lauv-1", "flags": E.UTF_ACK, "data": b"hi"})
    w.run(20000)
    assert [m["value"] for m in _msgs(_out(a), "UamTxStatus")][-1] == E.UTS_DELIVERED
    # our own Announce coming back is not a system
    a.on_discovery(w.now(), ("127.0.0.1", 30100), a.announce())
    assert list(a.peers.systems) == [b.imc_id] and a.peers.stats["announce_own"] == 1
    # a configured map, and the reverse on reception
    w2, a2, b2 = _net(names={"noptilus-2": "auv", "ccu-1": "topside"})
    b2.peers.heard(w2.now(), TOOL)
    _feed(w2, a2, {"abbrev": "UamTxFrame", "seq": 1, "sys_dst": "noptilus-2", "data": b"hey"})
    w2.run(20000)
    assert [m["value"] for m in _msgs(_out(a2), "UamTxStatus")] == [E.UTS_IP, E.UTS_DONE]
    rx = _msgs(_out(b2), "UamRxFrame")
    assert [(m["sys_src"], m["sys_dst"], m["data"]) for m in rx] == [("ccu-1", "noptilus-2", b"hey")]


def test_broadcast_and_overheard_frames():
    w, a, b = _net()
    b.peers.heard(w.now(), TOOL)
    _feed(w, a, {"abbrev": "UamTxFrame", "seq": 5, "sys_dst": "broadcast", "flags": E.UTF_ACK, "data": b"all"})
    w.run(10000)
    assert [m["value"] for m in _msgs(_out(a), "UamTxStatus")] == [E.UTS_IP, E.UTS_DONE]
    assert [(m["sys_dst"], m["flags"]) for m in _msgs(_out(b), "UamRxFrame")] == [("broadcast", 0)]
    b.on_event((EV_RECEIVED, b.node.links["acoustic"], "topside", "diver", b"not yours"))
    assert [m["flags"] for m in _msgs(_out(b), "UamRxFrame")] == [E.URF_PROMISCUOUS]


def test_requests_in_progress_are_capped_and_tables_are_bounded():
    w, a, b = _net()
    a.max_requests = 3
    for seq in range(5):
        _feed(w, a, {"abbrev": "UamTxFrame", "seq": seq, "sys_dst": "auv", "data": b"q"})
    st = _msgs(_out(a), "UamTxStatus")
    assert [(m["seq"], m["value"]) for m in st if m["value"] == E.UTS_BUSY] == [(3, E.UTS_BUSY), (4, E.UTS_BUSY)]
    w.run(60000)
    finals = [m["seq"] for m in _msgs(_out(a), "UamTxStatus") if m["value"] == E.UTS_DONE]
    assert sorted(finals) == [0, 1, 2]
    for i in range(100):  # a sweep of senders: the contact table keeps 32
        a.feed(w.now(), ("10.0.0.%d" % i, 6001), imc.encode({"abbrev": "Heartbeat"}, src=ME, dst=a.imc_id))
    assert len(a.peers.contacts) == 32 and a.peers.stats["contacts_dropped"] == 69  # and the first sender, TOOL
    a.max_output = 10
    for i in range(50):
        a.on_event((EV_RECEIVED, a.node.links["acoustic"], "auv", "topside", b"r"))
    assert len(a.take_output()) == 10 and a.stats["output_dropped"] > 0
