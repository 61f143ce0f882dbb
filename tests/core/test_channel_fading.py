# Fading per arrival (acomm_sim.fading, issue 39): the Rician law of the
# gain (its draws against its distribution function, that against the
# Rayleigh closed form), K from the site's geometry, PDR against range as a
# slope with fading and as the old cliff without, on the link budget and on
# the simulated channel, and runs that repeat per seed.
# Pure arithmetic: runs on CPython and on the MicroPython unix port.
import math

from acomm.prng import Prng
from acomm_sim import fading
from acomm_sim import linkbudget as lb
from acomm_sim.linktrial import link_trial
from acomm_sim.modems_db import model
from acomm_sim.physchannel import PhysicsChannel
from acomm_sim.site import Site


def close(a, b, tol):
    return abs(a - b) <= tol


def test_rayleigh_law_is_the_closed_form():
    for x in (0.001, 0.1, 0.5, 1.0, 3.0):
        assert close(fading.cdf(0.0, x), 1 - math.exp(-x), 1e-9)
    # a strong direct path: deep fades rare, the gain near 1
    assert fading.cdf(10.0, 0.1) < 0.002 < fading.cdf(1.0, 0.1)
    assert fading.cdf(100.0, 0.5) < 1e-4 and fading.cdf(100.0, 2.0) > 0.9999
    # the average over the law: mean gain 1, P(g < 0.1) as cdf says
    for k in (0.0, 1.26, 10.0):
        assert close(fading.average(lambda g: g, k), 1.0, 0.002)
        assert close(fading.average(lambda g: 1.0 if g < 0.1 else 0.0, k), fading.cdf(k, 0.1), 0.01)
    assert fading.average(lambda g: g * 7, None) == 7.0  # no fading: f(1)


def test_draws_follow_the_law():
    rng = Prng(11)
    n = 4000
    for k, x in ((0.0, 0.1), (1.26, 0.3), (10.0, 0.5)):
        total = 0.0
        below = 0
        for _ in range(n):
            g = fading.gain(rng, k)
            total += g
            below += g < x
        assert close(total / n, 1.0, 0.06), k
        assert close(below / n, fading.cdf(k, x), 0.02), (k, below / n, fading.cdf(k, x))
    # two draws per gain, whatever K
    a, b = Prng(3), Prng(3)
    fading.gain(a, 0.0)
    b.next32()
    b.next32()
    assert a.next32() == b.next32()


def test_k_factor_from_the_geometry():
    assert fading.params("none", 0.8) == (None, 1.0)
    assert fading.params("rayleigh", 0.8) == (0.0, 1.8)
    assert fading.params("rician", 0.0) == (None, 1.0)
    k, scale = fading.params("rician", 0.25)
    assert close(k, 4.0, 1e-12) and close(scale, 1.25, 1e-12)
    m = model("seatrac_x150")
    deep = Site(depth_m=1000)
    shallow = Site(depth_m=30)
    # nodes far from surface and bottom in deep water: every echo is late
    # (interference), none fades the direct path
    near = lb.arrival(deep, m, m, 2000, 300, 300)[2]
    assert fading.params("rician", near)[0] is None
    # a long link in shallow water: its echoes fall within the tolerance and
    # carry more than the direct path (K < 1, near Rayleigh)
    near = lb.arrival(shallow, m, m, 3000, 5, 25)[2]
    assert fading.params("rician", near)[0] < 1
    # a lossier surface and bottom: a stronger direct path
    lossy = shallow.with_(surface_loss_db=6, bottom_loss_db=12)
    assert fading.params("rician", lb.arrival(lossy, m, m, 3000, 5, 25)[2])[0] > 2


def test_site_fading_option():
    assert Site().fading == "rician"
    assert Site(fading="none").fading == "none"
    try:
        Site(fading="nakagami")
    except ValueError:
        return
    raise AssertionError("an unknown fading mode was taken")


def test_without_fading_the_budget_is_the_one_before():
    # the datasheet site's PDR-90 range of the SeaTrac model before fading
    # (docs/simulator.md, 7079 m): "none" is the old model
    r = lb.range_at(Site.preset("datasheet", fading="none"), "seatrac_x150")
    assert close(r, 7079, 1.0), r


def test_pdr_falls_over_a_span_with_fading_and_a_step_without():
    faded = Site.preset("datasheet")
    flat = Site.preset("datasheet", fading="none")
    name = "seatrac_x150"
    r90, r50, r10 = (lb.range_at(faded, name, p) for p in (0.9, 0.5, 0.1))
    f90, f10 = lb.range_at(flat, name, 0.9), lb.range_at(flat, name, 0.1)
    # with fading PDR takes over 20 % of the range to fall from 0.9 to 0.1,
    # without it 5 % (the cliff: the SNR alone decides)
    assert (r10 - r90) / r90 > 0.2, (r90, r10)
    assert (f10 - f90) / f90 < 0.06, (f90, f10)
    assert r90 < f90 < r10 and r90 < r50 < r10
    # the same on the simulated channel, packet by packet: three ranges where
    # the faded link delivers about 0.9, 0.5, 0.1 of its packets, where the
    # link without fading delivers all, few and none
    got = {}
    for tag, site in (("faded", faded), ("flat", flat)):
        got[tag] = []
        for i, r in enumerate((r90, r50, r10)):
            ch = PhysicsChannel(site, modems={1: name, 2: name}, seed=20 + i)
            got[tag].append(link_trial(ch, r, 60, b"x" * 16, (10.0, 10.0)))
    p90, p50, p10 = got["faded"]
    assert p90 > 0.75 and 0.25 < p50 < 0.75 and p10 < 0.3, got
    assert got["flat"][0] == 1.0 and got["flat"][1] < 0.3 and got["flat"][2] == 0.0, got


def test_runs_repeat_per_seed():
    site = Site.preset("datasheet")
    r = lb.range_at(site, "seatrac_x150", 0.5)
    runs = []
    for seed in (5, 5, 6):
        ch = PhysicsChannel(site, modems={1: "seatrac_x150", 2: "seatrac_x150"}, seed=seed)
        ears_pdr = link_trial(ch, r, 40, b"x" * 16, (10.0, 10.0))
        runs.append((ears_pdr, ch.range_lost, ch.undetected))
    assert runs[0] == runs[1]
    assert runs[0] != runs[2]


def test_seed004_fhss_fades_against_its_own_echoes():
    # seed 004's river (Site.preset("piovego"), 85 m, 14-byte commands): the
    # FHSS profile's SNR is about 70 dB, so the noise never matters; what a
    # deep fade does is sink the copy under its own late echoes (kept at their
    # mean power): a few copies in a thousand, where no fading loses none
    river = Site.preset("piovego")
    assert lb.link_pdr(river.with_(fading="none"), "fhss", 85, 14) > 0.99999
    p = lb.link_pdr(river, "fhss", 85, 14)
    assert 0.98 < p < 0.999, p
