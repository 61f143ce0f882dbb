# The Channel's shortcut for stations out of reach (beyond where its loss
# curve becomes certain: no distance worked out, the same generator draws)
# changes nothing: the same transmissions give the same deliveries, the
# same counters and the same generator state as on a Channel that works
# out every distance. Stationary nodes on a grid and scattered, nodes
# without a position, a node that moves, AUVs crossing scattered nodes (the
# stations that stay put kept, the movers placed at each transmission), a
# loss curve replaced; with and without a fixed loss.
from acomm.prng import Prng
from acomm_sim.channel import Channel, Track


class Ear:
    # folds each delivery (time, source, receiver, distance in mm) into the run's [count, digest]:
    # a list of every delivery of the 90-station runs, twice, outgrew the unix port's 2 MB heap
    # once other tests had fragmented it
    def __init__(self, log, me):
        self.log = log
        self.me = me

    def receive(self, t, src, packet, distance):
        d = self.log
        d[0] += 1
        h = d[1]
        for v in (t, src, self.me, int(distance * 1000)):
            h = (h * 1000003 + v) & 0xFFFFFFF
        d[1] = h


class EveryDistance(Channel):
    def _near_of(self, src):
        return None  # the Medium's way: every station's distance


def _run(cls, seed, layout, loss, n=24):
    rng = Prng(seed)
    ch = cls(seed=seed, loss=loss, loss_curve=((0.0, 0.0), (300.0, 0.5), (500.0, 1.0)))
    log = [0, 0]
    for a in range(1, n + 1):
        ch.attach(a, Ear(log, a))
        if layout == "grid":
            ch.set_position(a, 250.0 * (a % 5), 250.0 * (a // 5), 5.0)
        elif layout == "scattered" and a % 9:
            ch.set_position(a, rng.below(3000) - 1500.0, rng.below(3000) - 1500.0, rng.below(50))
    if layout == "moving":
        for a in range(1, n + 1):
            ch.set_position(a, 200.0 * a, 0.0, 0.0)
        ch.set_track(3, Track((0.0, 0.0, 0.0), 0, velocity=(2.0, 0.0, 0.0)))
    if layout == "auvs":
        # scattered nodes that stay put, and two AUVs crossing them fast
        for a in range(1, n + 1):
            ch.set_position(a, rng.below(3000) - 1500.0, rng.below(3000) - 1500.0, rng.below(50))
        ch.set_track(7, Track((-1500.0, -1500.0, 10.0), 0, waypoints=[(1500.0, 1500.0, 10.0)], speed=60.0))
        ch.set_track(n - 1, Track((1500.0, -1500.0, 10.0), 0, velocity=(-50.0, 40.0, 0.0)))
    t = 0
    for k in range(120):
        t += rng.below(400)
        src = 1 + rng.below(n)
        ch.transmit(t, src, b"%d" % k, 100 + rng.below(300))
        ch.poll(t)
        if k == 60 and layout == "grid":
            ch.set_position(5, 10.0, 10.0, 0.0)  # a node moved: reach again
        if k == 80 and layout == "grid":
            # a station leaves and comes back: it is last in the stations' order now
            ch.detach(2)
            ch.attach(2, Ear(log, 2))
        if k == 100 and layout == "grid":
            # a new loss curve, shorter: the reach kept for the old one is stale
            ch.loss_curve = ((0.0, 0.0), (200.0, 0.5), (260.0, 1.0))
    ch.poll(t + 100000)
    return log, [getattr(ch, c) for c in ("sent", "delivered", "lost", "range_lost", "collided", "deaf")], ch.rng.next32()


def test_stations_out_of_reach_take_the_same_draws():
    for layout in ("grid", "scattered", "moving", "auvs"):
        for seed, loss in ((1, 0.0), (2, 0.1)):
            fast = _run(Channel, seed, layout, loss)
            slow = _run(EveryDistance, seed, layout, loss)
            assert fast == slow, (layout, seed, loss)
            assert fast[1][1] > 0 and fast[1][3] > 0  # some arrive, some are out of reach


def test_a_large_network_skips_the_same_draws():
    # 90 stations over 3 km: most transmissions owe dozens of draws to
    # stations out of reach, which the Channel skips in one step (prngskip)
    for layout in ("grid", "scattered", "auvs"):
        fast = _run(Channel, 4, layout, 0.0, n=90)
        slow = _run(EveryDistance, 4, layout, 0.0, n=90)
        assert fast == slow, layout
        assert fast[1][1] > 0 and fast[1][3] > 1000
