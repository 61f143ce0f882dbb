# The physics channel (acomm_sim.physchannel, issue 39) against what is
# known of the sea and of the modems (docs/simulator.md, "Physics channel"):
#
#   channel_absorption_db_per_km_<f>kHz        Thorp at 10, 25, 50 kHz
#   channel_absorption_fg_db_per_km_<f>kHz     Francois-Garrison at FG_WATER
#   channel_absorption_fg_arlpy_check_db_per_km  FG at arlpy's documented
#        example (50 kHz, 27 deg C, 35 psu, 10 m, pH 8.1), beside its value
#        (..._published: 10.71 dB/km, arlpy.uwa.absorption's doctest)
#   channel_noise_db_<f>kHz_wind<w>            ambient noise PSD (dB re 1 uPa^2/Hz)
#   channel_range_pdr90_<modem>_m              range at which a packet of the
#        model's default size arrives whole 9 times in 10, in the "datasheet"
#        site (Site.preset), averaged over its fading (acomm_sim.fading),
#        beside channel_range_datasheet_<modem>_m where the datasheet states
#        one, and channel_margin_to_datasheet_<modem>_db: the extra loss that
#        would bring the two together
#   channel_range_pdr50_<modem>_m              the same where it falls to 0.5
#        (with pdr90: how wide the slope is)
#   channel_nofading_range_pdr90_<modem>_m     pdr90 with Site(fading="none"):
#        the model before fading (a cliff: its pdr50 is a few % further)
#   channel_fading_k_<modem>                   the Rician K at the pdr90 range
#   channel_sim_pdr_at_range90_seatrac_x150    the same link on the simulated
#        channel (packets and fades drawn one by one): about 0.9; and
#        channel_sim_pdr_at_range50_seatrac_x150: about 0.5
#   channel_seed004_<place>_<profile>_pdr      seed 004's trial geometry on
#        the "piovego" site (river, 85 m) and in the lab (0.6 m), 14-byte
#        commands, beside the seed's two trials (..._seed004_t1/t2);
#        channel_seed004_<place>_<profile>_link_pdr the link budget's
#        average for the same (no draws); channel_seed004_nofading_<...>_pdr
#        the simulated trial with Site(fading="none")
#   channel_capture_near_pdr_<physics|curve>   a sender 100 m from the
#        receiver under an interferer 2 km away whose packet overlaps it;
#        channel_capture_far_pdr_<...> the interferer's own
#   sim_speedup_16_nodes_curve, _physics and sim_speedup_ratio_physics_vs_curve:
#        sim bench's 16-node TDMA hour on the default curve-less Channel and
#        on a PhysicsChannel, alternating, the fastest of each counting
import time

from acomm.drivers.mac import Tdma
from acomm.events import EV_RECEIVED
from acomm_sim import acoustics as ac
from acomm_sim import fading
from acomm_sim import linkbudget as lb
from acomm_sim.channel import Channel
from acomm_sim.linktrial import capture_trial, link_trial
from acomm_sim.modems_db import MODELS
from acomm_sim.physchannel import PhysicsChannel
from acomm_sim.site import Site
from acomm_sim.world import World

from . import sim_workload as sw

PER_RUNTIME = ()

FREQS_KHZ = (10, 25, 50)
FG_WATER = {"temperature_c": 10.0, "salinity_psu": 35.0, "depth_m": 50.0, "ph": 8.0}
ARLPY_EXAMPLE = ((50.0, 27.0, 35.0, 10.0, 8.1), 10.71)
# seed 004 Table II, reliability setup: PDR % (trial 1, trial 2)
SEED004 = {("river", "bpsk"): (94.0, 91.4), ("river", "fhss"): (85.2, 92.6),
           ("lab", "bpsk"): (100.0, 99.7), ("lab", "fhss"): (100.0, 99.1)}
PLACES = {"river": 85.0, "lab": 0.6}
COMMAND = b"0123456789abcd"  # the seed's 14-byte command


def _absorption(emit):
    for f in FREQS_KHZ:
        emit("channel_absorption_db_per_km_%dkHz" % f, ac.thorp_db_per_km(f), "dB/km")
    w = FG_WATER
    for f in FREQS_KHZ:
        emit("channel_absorption_fg_db_per_km_%dkHz" % f,
             ac.francois_garrison_db_per_km(f, w["temperature_c"], w["salinity_psu"], w["depth_m"], w["ph"]), "dB/km")
    args, published = ARLPY_EXAMPLE
    emit("channel_absorption_fg_arlpy_check_db_per_km", ac.francois_garrison_db_per_km(*args), "dB/km")
    emit("channel_absorption_fg_arlpy_check_published_db_per_km", published, "dB/km")
    for wind in (0, 5, 10):
        emit("channel_noise_db_25kHz_wind%d" % wind, ac.noise_psd_db(25.0, wind, 0.5), "dB re 1uPa^2/Hz")


def _ranges(emit, quick):
    site = Site.preset("datasheet")
    flat = Site.preset("datasheet", fading="none")
    for name in sorted(MODELS):
        m = MODELS[name]
        r = lb.range_at(site, name)
        emit("channel_range_pdr90_%s_m" % name, r, "m")
        emit("channel_range_pdr50_%s_m" % name, lb.range_at(site, name, 0.5), "m")
        emit("channel_nofading_range_pdr90_%s_m" % name, lb.range_at(flat, name), "m")
        near = lb.arrival(site, m, m, r, site.node_depth_m, site.node_depth_m)[2]
        k = fading.params(site.fading, near)[0]
        emit("channel_fading_k_%s" % name, -1.0 if k is None else k, "ratio")
        if m["range_m"]:
            emit("channel_range_datasheet_%s_m" % name, m["range_m"], "m")
            alpha = lb.absorption(site, lb.centre_khz(m))
            emit("channel_margin_to_datasheet_%s_db" % name, ac.transmission_loss_db(r, alpha, site.spreading_k)
                 - ac.transmission_loss_db(m["range_m"], alpha, site.spreading_k), "dB")
    n = 50 if quick else 400
    for p in (90, 50):
        r = lb.range_at(site, "seatrac_x150", p / 100)
        ch = PhysicsChannel(site, modems={1: "seatrac_x150", 2: "seatrac_x150"}, seed=1)
        emit("channel_sim_pdr_at_range%d_seatrac_x150" % p,
             link_trial(ch, r, n, b"x" * MODELS["seatrac_x150"]["default_bytes"], (10.0, 10.0)), "ratio")


def _seed004(emit, quick):
    n = 40 if quick else 500
    for (place, profile), trials in sorted(SEED004.items()):
        site = Site.preset("piovego")
        air = ((len(COMMAND) + MODELS[profile]["overhead_bytes"]) * 8000) // int(MODELS[profile]["bitrate"])
        for tag, s in (("", site), ("nofading_", site.with_(fading="none"))):
            ch = PhysicsChannel(s, modems={1: profile, 2: profile}, seed=4)
            pdr = link_trial(ch, PLACES[place], n, COMMAND, (1.0, 1.0), air)
            emit("channel_seed004_%s%s_%s_pdr" % (tag, place, profile), 100 * pdr, "%")
        emit("channel_seed004_%s_%s_link_pdr" % (place, profile),
             100 * lb.link_pdr(site, profile, PLACES[place], len(COMMAND), 1.0, 1.0), "%")
        for i, t in enumerate(trials):
            emit("channel_seed004_%s_%s_seed004_t%d_pdr" % (place, profile, i + 1), t, "%")


def _capture(emit, quick):
    rounds = 20 if quick else 200
    model = "seatrac_x150"
    phys = PhysicsChannel(Site.preset("datasheet"), modems={1: model, 2: model, 3: model}, seed=2)
    curve = Channel(seed=2, loss_curve=((0.0, 0.0), (3000.0, 0.1), (6000.0, 1.0)))
    for tag, ch in (("physics", phys), ("curve", curve)):
        near, far = capture_trial(ch, 100.0, 2000.0, rounds)
        emit("channel_capture_near_pdr_%s" % tag, near, "ratio")
        emit("channel_capture_far_pdr_%s" % tag, far, "ratio")


def _world(channel, sim_s):
    # sim_workload.run_once's TDMA network on the given channel -> (speed-up, PDR)
    air = sw.airtime_ms()
    sched = [(i + 1, air + 500 + 400, 200) for i in range(sw.NODES)]
    w = World(seed=1, channel=channel)
    for i in range(sw.NODES):
        w.add("n%d" % (i + 1), i + 1, "bpsk", position=(50.0 * i, 0.0, 10.0), mac=Tdma(sched, i + 1, tx_ms=air),
              link_opts={"advert_period_ms": 600000, "queue_capacity": 8})
    t0 = time.perf_counter()
    sent = sw._broadcast_each_minute(w, sim_s)
    wall = time.perf_counter() - t0
    rx = sum(1 for sn in w.nodes.values() for e in sn.events if e[0] == EV_RECEIVED)
    return sim_s / wall, rx / (sent * (sw.NODES - 1))


def _speed(emit, quick):
    sim_s = 120 if quick else sw.SIM_S
    best = {"curve": 0.0, "physics": 0.0}
    pdr = {}
    for _ in range(1 if quick else 3):
        for tag in ("curve", "physics"):
            ch = Channel(seed=1) if tag == "curve" else PhysicsChannel(Site(depth_m=50.0), seed=1)
            speed, pdr[tag] = _world(ch, sim_s)
            best[tag] = max(best[tag], speed)
    for tag in ("curve", "physics"):
        emit("sim_speedup_16_nodes_%s" % tag, best[tag], "x")
        emit("sim_pdr_16_nodes_%s" % tag, pdr[tag], "ratio")
    emit("sim_speedup_ratio_physics_vs_curve", best["physics"] / best["curve"], "ratio")


def run(emit, quick=False):
    _absorption(emit)
    _ranges(emit, quick)
    _seed004(emit, quick)
    _capture(emit, quick)
    _speed(emit, quick)
