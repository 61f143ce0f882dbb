# The simulated acoustic channel (acomm_sim.channel): propagation delay from
# positions that move, collisions at one receiver but not at another,
# half-duplex, loss that grows with range, and noise bursts. Deterministic.
from acomm.compat import TICKS_MAX, ticks_add, ticks_diff
from acomm_sim.channel import Channel, Track, interpolate


class Ear:
    def __init__(self):
        self.got = []

    def receive(self, t, src, packet, distance):
        self.got.append((t, src, packet, round(distance, 3)))


def net(n=3, **kw):
    ch = Channel(**kw)
    ears = []
    for a in range(1, n + 1):
        e = Ear()
        ch.attach(a, e)
        ears.append(e)
    return ch, ears


def run(ch, t0, t1, step=10):
    t = t0
    while ticks_diff(t1, t) >= 0:
        ch.poll(t)
        t = ticks_add(t, step)


def test_delay_follows_positions_and_tracks():
    ch, (a, b, c) = net()
    ch.set_position(1, 0.0, 0.0, 0.0)
    ch.set_position(2, 300.0, 400.0, 0.0)  # 500 m: 333 ms at 1500 m/s
    ch.set_position(3, 0.0, 0.0, 1500.0)
    end = ch.transmit(1000, 1, b"p", 200)
    assert end == 1200
    run(ch, 1000, 3000, 1)
    assert b.got == [(1533, 1, b"p", 500.0)] and c.got == [(2200, 1, b"p", 1500.0)]
    # node 2 swims to 1000 m east at 2 m/s, starting at t=0
    ch.set_track(2, Track((0.0, 0.0, 0.0), 0, waypoints=((1000.0, 0.0, 0.0),), speed=2.0))
    assert ch.position(2, 250000) == (500.0, 0.0, 0.0)
    assert ch.position(2, 900000) == (1000.0, 0.0, 0.0)  # and stays there
    ch.transmit(250000, 1, b"q", 100)
    run(ch, 250000, 251000, 1)
    assert b.got[-1] == (250000 + 100 + 333, 1, b"q", 500.0)
    # drifting: 0.5 m/s north
    d = Track((0.0, 0.0, 10.0), 1000, velocity=(0.0, 0.5, 0.0))
    assert d.at(0) == (0.0, 0.0, 10.0) and d.at(21000) == (0.0, 10.0, 10.0)


def test_collision_at_one_receiver_not_at_another():
    # 1 and 2, 1 km apart, transmit 50 ms apart; 3 sits half-way (arrivals
    # overlap), 4 is 1 km beyond 2 (1's packet arrives 667 ms after 2's
    # ended there)
    ch, ears = net(4)
    for addr, x in ((1, 0.0), (2, 1000.0), (3, 500.0), (4, 2000.0)):
        ch.set_position(addr, x, 0.0, 0.0)
    start = TICKS_MAX - 100  # across the tick wrap
    ch.transmit(start, 1, b"from1", 500)
    ch.transmit(ticks_add(start, 50), 2, b"from2", 500)
    run(ch, start, ticks_add(start, 5000))
    assert ears[2].got == []  # 3 heard two packets at once: both lost
    assert [g[2] for g in ears[3].got] == [b"from2", b"from1"]
    assert ch.collided == 2
    # 1 and 2 had finished by the time the other's packet reached them
    assert [g[2] for g in ears[0].got] == [b"from2"] and [g[2] for g in ears[1].got] == [b"from1"]
    assert ch.deaf == 0
    # 5 sits next to 1 and transmits while 2's packet arrives: it is deaf to it
    e5 = Ear()
    ch.attach(5, e5)
    ch.set_position(5, 1.0, 0.0, 0.0)
    t = ticks_add(start, 10000)
    ch.transmit(t, 2, b"late", 500)
    ch.transmit(ticks_add(t, 700), 5, b"mine", 500)
    run(ch, t, ticks_add(t, 5000))
    assert e5.got == [] and ch.deaf == 1
    # without the collision model both are heard
    ch2, ears2 = net(4, collisions=False)
    for addr, x in ((1, 0.0), (2, 1000.0), (3, 500.0), (4, 2000.0)):
        ch2.set_position(addr, x, 0.0, 0.0)
    ch2.transmit(0, 1, b"from1", 500)
    ch2.transmit(50, 2, b"from2", 500)
    run(ch2, 0, 5000)
    assert len(ears2[2].got) == 2


def test_back_to_back_packets_do_not_collide():
    ch, (a, b, c) = net()
    ch.transmit(0, 1, b"one", 500)
    ch.transmit(500, 1, b"two", 500)  # starts as the first ends
    ch.transmit(1000, 3, b"three", 400)
    run(ch, 0, 3000)
    assert [g[2] for g in b.got] == [b"one", b"two", b"three"] and ch.collided == 0


def test_loss_grows_with_range():
    assert interpolate(((100, 0.0), (1000, 0.5), (2000, 1.0)), 550) == 0.25
    assert interpolate(((100, 0.1),), 0) == 0.1 and interpolate(((100, 0.1), (200, 0.3)), 900) == 0.3
    curve = ((0, 0.0), (500, 0.1), (1500, 0.9))
    ch, (a, b, c) = net(seed=7, loss_curve=curve)
    ch.set_distance(1, 2, 100.0)  # about 2 % loss
    ch.set_distance(1, 3, 1400.0)  # about 82 %
    t = 0
    for i in range(400):
        ch.transmit(t, 1, b"x", 100)
        t += 2000
        run(ch, t - 2000, t, 500)
    near, far = len(b.got), len(c.got)
    assert 380 <= near <= 400 and 40 <= far <= 110, (near, far)
    assert ch.range_lost == 800 - near - far
    assert abs(ch.loss_at(1000) - 0.5) < 1e-9


def test_noise_burst_everywhere_or_at_one_receiver():
    ch, (a, b, c) = net()
    ch.noise_burst(1000, 2000)  # everyone, 1.0 .. 3.0 s
    ch.noise_burst(5000, 1000, receiver=3)
    for t in (0, 1500, 4000, 5200):
        ch.transmit(t, 1, b"t%d" % t, 300)
    run(ch, 0, 8000)
    assert [g[2] for g in b.got] == [b"t0", b"t4000", b"t5200"]
    assert [g[2] for g in c.got] == [b"t0", b"t4000"]
    assert ch.noise_lost == 3


def test_a_cancelled_packet_neither_arrives_nor_collides():
    # a sender that stops mid-packet: its copies leave the channel's flight
    # (and its per-receiver list), so a later packet to the same receiver is
    # heard, and the first bit of what is still coming is known
    ch, (a, b, c) = net()
    ch.set_position(1, 0.0, 0.0, 0.0)
    ch.set_position(2, 150.0, 0.0, 0.0)  # 100 ms
    ch.set_position(3, 300.0, 0.0, 0.0)  # 200 ms from 1, 100 ms from 2
    ch.transmit(0, 1, b"cut", 500)
    assert ch.arriving(3, 1) == 200
    ch.cancel(1, 100)
    assert ch.arriving(3, 1) is None and ch.in_flight() == 0
    ch.transmit(150, 2, b"ok", 300)
    assert ch.arriving(3, 2) == 250
    run(ch, 0, 1500)
    assert [g[2] for g in c.got] == [b"ok"] and ch.collided == 0
