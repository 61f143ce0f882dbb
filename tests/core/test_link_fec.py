# Reed-Solomon FEC on a link (acomm.link.framing, fec=N): on a channel that
# damages bytes, frames that would fail their CRC are repaired; without
# FEC the same channel loses a third of them. Both ends on the seed 004
# BPSK packet modem, which hands up damaged packets as they are.
from acomm.events import DELIVERED, EV_RECEIVED
from acomm.prng import Prng
from acomm.transport import Transport
from acomm_sim.channel import Channel
from acomm_sim.world import World
from transportnet import QUIET, packets, statuses, wall_of


def _pair(fec, seed=3):
    w = World(seed=seed, channel=Channel(seed=seed, byte_errors=0.01))
    lo = dict(QUIET)
    lo["fec"] = fec
    a = w.add("diver", 2, "bpsk", position=(0, 0, 10), link_opts=lo)
    b = w.add("buoy", 1, "bpsk", position=(200, 0, 0), link_opts=lo)
    w.run(5000)
    return w, a, b


def _frames_through(fec, n=60):
    w, a, b = _pair(fec)
    payload = Prng(1).bytes(a.link.mtu_for(1))
    for k in range(n):
        a.node.send("acoustic", "buoy", payload, 600, 5)
        w.run(3000)
    got = [e for e in b.events if e[0] == EV_RECEIVED]
    assert all(e[4] == payload for e in got)  # whatever arrives is right
    return len(got), w.channel.damaged, b.link.framing.corrected


def test_fec_repairs_damaged_bytes_that_would_cost_the_frame():
    plain, damaged0, _ = _frames_through(0)
    fixed, damaged8, corrected = _frames_through(8)
    assert damaged0 > 0 and damaged8 > 0
    assert plain <= 50  # about 0.99^61 = 54 % of the frames come through
    assert fixed >= 58 and corrected >= damaged8 * 0.9


def test_the_mtu_leaves_room_for_the_parity():
    w, a, b = _pair(8)
    w0, a0, b0 = _pair(0)
    assert a.link.mtu_for(1) == a0.link.mtu_for(1) - 8
    assert a.link.caps.mtu_tx == a0.link.caps.mtu_tx - 8


def test_the_transport_runs_over_a_link_with_fec():
    w, a, b = _pair(8)
    wall = wall_of(w)
    ta = Transport.of(a.node, wall=wall)
    Transport.of(b.node, wall=wall)
    data = Prng(6).bytes(500)
    pid = ta.send(w.now(), "buoy", data, 3600, 5)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    assert packets(b)[0][3] == data and b.link.framing.corrected > 0
