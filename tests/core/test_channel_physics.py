# The physics channel (acomm_sim.acoustics, detection, multipath, linkbudget,
# site, physchannel): absorption and noise against their formulas' known
# values, BER against textbook points, the image paths of a shallow channel,
# link budgets that fall with range, wind and depth, and on a channel: a near
# packet that survives a far one (capture) where the curve model loses both,
# damaged bytes for modems that hand them up, drops for those with a CRC.
# Pure arithmetic: runs on CPython and on the MicroPython unix port.
import math

from acomm_sim import acoustics as ac
from acomm_sim import detection as det
from acomm_sim import linkbudget as lb
from acomm_sim.channel import Channel
from acomm_sim.linktrial import capture_trial, link_trial, listen, run
from acomm_sim.multipath import echo_ratios, images
from acomm_sim.physchannel import PhysicsChannel
from acomm_sim.site import Site, parse


def close(a, b, tol):
    return abs(a - b) <= tol


def test_thorp_at_the_bench_frequencies():
    # Thorp's formula in dB/km, evaluated by hand (docs/simulator.md's table)
    assert close(ac.thorp_db_per_km(10), 1.187, 0.005)
    assert close(ac.thorp_db_per_km(25), 6.105, 0.005)
    assert close(ac.thorp_db_per_km(50), 17.467, 0.005)


def test_francois_garrison_follows_the_water():
    # their formula at 10 deg C, 35 psu, pH 8, at the surface (docs' table)
    fg = ac.francois_garrison_db_per_km
    assert close(fg(10, 10, 35, 0, 8), 0.963, 0.005)
    assert close(fg(25, 10, 35, 0, 8), 4.998, 0.005)
    assert close(fg(50, 10, 35, 0, 8), 15.392, 0.01)
    # fresh water absorbs far less (no boric acid or MgSO4 relaxation)
    assert fg(25, 15, 0.3, 1, 7) < 0.2 * fg(25, 15, 35, 1, 8)
    # pressure lowers the MgSO4 term
    assert fg(25, 4, 35, 3000, 8) < fg(25, 4, 35, 0, 8)


def test_spreading_and_absorption():
    assert close(ac.transmission_loss_db(1000, 0, 1.5), 45.0, 1e-9)
    assert close(ac.transmission_loss_db(1000, 6.0, 2), 66.0, 1e-9)
    assert ac.transmission_loss_db(0.2, 5.0) < 0.01  # no spreading inside 1 m


def test_noise_rises_with_wind_and_shipping_and_band():
    assert ac.noise_psd_db(25, 10) > ac.noise_psd_db(25, 0) + 10
    assert ac.noise_psd_db(0.1, 0, 1.0) > ac.noise_psd_db(0.1, 0, 0.0) + 15  # ships are loud low down
    # 16 kHz of band hold about 3 dB more noise than 8 kHz around the same centre
    wide = ac.noise_band_db(20, 36, 5)
    narrow = ac.noise_band_db(24, 32, 5)
    assert 2.0 < wide - narrow < 4.0
    # the integral of a flat-ish PSD: level + 10 log10(bandwidth in Hz)
    assert close(narrow, ac.noise_psd_db(28, 5) + 10 * math.log10(8000), 1.0)


def test_erfc_and_its_portable_fallback():
    for x in (-2.0, -0.5, 0.0, 0.3, 1.0, 2.5, 4.0):
        assert close(det.erfc_approx(x), det.erfc(x), 2e-7 * max(1.0, det.erfc(x)))
    assert close(det.q(0), 0.5, 1e-9)
    assert close(det.q_inv(1e-4), 3.719, 0.001)


def test_bit_error_rates_at_textbook_points():
    # BPSK: 1e-5 at Eb/N0 = 9.6 dB; non-coherent BFSK: 1e-5 at 13.4 dB
    assert close(math.log10(det.ber("psk", ac.lin(9.6))), -5, 0.1)
    assert close(math.log10(det.ber("fsk", ac.lin(13.4))), -5, 0.1)
    assert det.ber("dpsk", ac.lin(10)) < det.ber("fsk", ac.lin(10))
    assert det.ber("psk", 0) == 0.5
    assert close(det.frame_ok(1e-3, 1000), math.exp(1000 * math.log(1 - 1e-3)), 1e-12)
    # more coding gain, more Eb/N0
    assert close(det.ebn0(1.0, 8000, 100, 3.0) / det.ebn0(1.0, 8000, 100), ac.lin(3.0), 1e-9)


def test_images_of_a_shallow_channel():
    p = images(100, 2, 3, 10, 2)
    assert p[0] == (1, 0, 0)  # direct
    assert (5, 1, 0) in p  # surface: zs + zr
    assert (15, 0, 1) in p  # bottom: 2H - zs - zr
    assert (21, 1, 1) in p and (19, 1, 1) in p  # bottom-surface, surface-bottom
    assert all(ns + nb <= 2 for _, ns, nb in p)
    assert len(images(100, 2, 3, 10, 6)) > len(p)
    site = Site(depth_m=2, bottom_loss_db=1, surface_loss_db=0.5, max_bounces=30)
    late, _, spread = echo_ratios(85, 1, 1, site, 0.0, 0.8)
    assert spread > 5 and late > 0.1
    # a modem that absorbs the whole spread sees no late echo
    assert echo_ratios(85, 1, 1, site, 0.0, spread + 1)[0] == 0.0


def test_link_pdr_falls_with_range_wind_and_echoes():
    site = Site(depth_m=1000)
    r = lb.range_at(site, "seatrac_x150")
    assert 1000 < r < 100000
    assert lb.link_pdr(site, "seatrac_x150", r * 0.8) > 0.9 > lb.link_pdr(site, "seatrac_x150", r * 1.2)
    assert lb.range_at(site.with_(wind_mps=15), "seatrac_x150") < r
    # a reflective shallow channel costs the one-symbol BPSK modem, not the
    # hopping FSK one (its late echoes, without fading; test_fading has both)
    river = Site(depth_m=1.75, node_depth_m=1.0, bottom_loss_db=0.5, surface_loss_db=0.5, max_bounces=40,
                 fading="none")
    assert lb.link_pdr(river, "bpsk", 85, 14) < 0.1
    assert lb.link_pdr(river, "fhss", 85, 14) > 0.9
    assert lb.link_pdr(river.with_(fading="rician"), "fhss", 85, 14) > 0.9


def test_capture_near_packet_survives_far_one():
    site = Site(depth_m=200)
    phys = PhysicsChannel(site, modems={1: "seatrac_x150", 2: "seatrac_x150", 3: "seatrac_x150"}, seed=3)
    near, far = capture_trial(phys, 100.0, 3000.0, 40)
    assert near >= 0.95 and far < 0.1  # the near one is captured, the far one lost
    assert phys.interfered >= 36
    curve = Channel(seed=3, loss_curve=((0, 0.0), (5000, 0.0)))
    assert capture_trial(curve, 100.0, 3000.0, 40) == (0.0, 0.0)  # the curve model: both lost
    assert curve.collided == 80


def test_bytes_damaged_for_byte_modems_dropped_for_crc_modems():
    # at a range where frames have bit errors but preambles are heard
    site = Site(depth_m=1000)
    d = lb.range_at(site, "bpsk", 0.3, 40)
    for name, crc in (("bpsk", False), ("whoi_mm_fsk", True)):
        ch = PhysicsChannel(site, modems={1: name, 2: name}, seed=5)
        pdr = link_trial(ch, lb.range_at(site, name, 0.3, 40), 30, b"x" * 40, (10.0, 10.0))
        assert 0 < pdr < 0.9, (name, pdr)
        if crc:
            assert ch.damaged == 0 and ch.range_lost > 0
        else:
            assert ch.damaged > 0
    assert d > 100


def test_moving_a_node_recomputes_its_pairs():
    ch = PhysicsChannel(Site(), seed=1)
    listen(ch, {1: (0.0, 0.0, 10.0), 2: (500.0, 0.0, 10.0)})
    near = ch.snr_db(1, 2)
    ch.set_position(2, 5000.0, 0.0, 10.0)
    assert ch.snr_db(1, 2) < near - 15


def test_site_and_scenario_files():
    s = parse({"site": {"depth_m": 30, "wind_mps": 10, "absorption": "fg"},
               "nodes": [{"name": "buoy", "id": 1, "modem": "seatrac", "position": [0, 0, 1]}]})
    assert s.site.depth_m == 30.0 and s.channel == "physics" and s.nodes[0]["name"] == "buoy"
    assert s.site.with_(wind_mps=0).wind_mps == 0.0 and s.site.wind_mps == 10.0
    for bad in ({"site": {"depht_m": 3}}, {"sight": {}}, {"channel": "ray"}, {"nodes": [{"name": "x"}]}):
        try:
            parse(bad)
        except ValueError:
            continue
        raise AssertionError(bad)


def test_a_world_runs_on_it_and_range_decides():
    # two BPSK nodes heard at 1 km, a third not at 20 km (its bytes come up
    # damaged or not at all, and its link drops them)
    from acomm.events import EV_RECEIVED
    from acomm_sim.world import World

    ch = PhysicsChannel(Site(depth_m=200), seed=2)
    w = World(seed=2, channel=ch)
    w.add("a", 1, "bpsk", position=(0.0, 0.0, 10.0))
    w.add("b", 2, "bpsk", position=(1000.0, 0.0, 10.0))
    w.add("c", 3, "bpsk", position=(20000.0, 0.0, 10.0))
    w.run(1000)
    w.nodes["a"].node.send("acoustic", "*", b"hello", 60, 5)
    w.run(20000)
    got = {n: [e for e in sn.events if e[0] == EV_RECEIVED] for n, sn in w.nodes.items()}
    assert got["b"] and not got["c"]
    assert ch.model_name(1) == "bpsk" and ch.snr_db(1, 3) < 0 < ch.snr_db(1, 2)


def test_a_station_that_leaves_takes_nothing_with_it():
    ch = PhysicsChannel(Site(), seed=1)
    ears = listen(ch, {1: (0.0, 0.0, 10.0), 2: (300.0, 0.0, 10.0)})
    ch.transmit(0, 1, b"bye", 500)
    ch.detach(2)
    run(ch, 0, 2000)
    assert not ears[2].got and not ch._rx and ch.in_flight() == 0


def test_a_transmission_loss_model_replaces_spreading():
    # PhysicsChannel(tl=...) (Bellhop's, where installed) decides the received
    # power: the source level less tl's loss, asked once per pair at the
    # sender's band centre (test_channel_site's Bellhop test only checks ch.tl)
    from acomm_sim.modems_db import MODELS

    asked = []

    def tl(metres, zs, zr, f_khz):
        asked.append((metres, zs, zr, f_khz))
        return 60.0

    m = MODELS["seatrac_x150"]
    ch = PhysicsChannel(Site(depth_m=1000), modems={1: "seatrac_x150", 2: "seatrac_x150"}, seed=1, tl=tl)
    listen(ch, {1: (0.0, 0.0, 10.0), 2: (3000.0, 0.0, 10.0)})
    power = ch.budget(1, 2)[0]
    ch.budget(1, 2)
    assert close(ac.db(power), m["sl_db"] - 60.0 - m.get("impl_loss_db", 0.0), 1e-6)
    assert len(asked) == 1 and close(asked[0][0], 3000.0, 1e-6) and asked[0][1:] == (10.0, 10.0, lb.centre_khz(m))
