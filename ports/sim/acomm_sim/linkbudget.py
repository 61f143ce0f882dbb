# The link budget of one arrival, as functions of the site, the two modems'
# models and the geometry: what acomm_sim.physchannel does per copy of a
# packet, and what a planner asks without running a network ("will my buoy
# hear the diver at 800 m?": link_pdr). Portable Python.

from . import acoustics as ac
from . import detection as det
from . import fading
from .modems_db import model
from .multipath import echo_ratios


def absorption(site, f_khz):
    """Absorption in the site's water at f_khz -> dB/km: Thorp, or
    Francois-Garrison at the site's temperature, salinity, pH and half its
    depth (site.absorption == 'fg')."""
    if site.absorption == "fg":
        return ac.francois_garrison_db_per_km(f_khz, site.temperature_c, site.salinity_psu, site.depth_m / 2, site.ph)
    return ac.thorp_db_per_km(f_khz)


def centre_khz(m):
    """The centre of modem model m's band (kHz): where its absorption is taken."""
    return (m["band_khz"][0] + m["band_khz"][1]) / 2


def noise_power(site, m):
    """Ambient noise in modem model m's band at the site (uPa^2, linear)."""
    lo, hi = m["band_khz"]
    return ac.lin(ac.noise_band_db(lo, hi, site.wind_mps, site.shipping))


def arrival(site, ms, mr, metres, zs, zr, alpha=None, tl=None):
    """(power uPa^2, late echo ratio, near echo ratio) of a packet from a
    modem of model ms at depth zs to one of model mr at depth zr, metres
    apart (straight line): the source level less spreading and absorption
    at the sender's centre frequency (or less tl(metres, zs, zr, f_khz) dB
    when a transmission loss model is given: Bellhop's), less the
    receiver's implementation loss (impl_loss_db, 0 unless set), times the
    share of the sender's band the receiver listens to (0 when the bands do
    not meet); the echoes as multipath.echo_ratios says (late: inter-symbol
    interference; near: within the receiver's tolerance, what it fades
    with)."""
    lo = max(ms["band_khz"][0], mr["band_khz"][0])
    hi = min(ms["band_khz"][1], mr["band_khz"][1])
    if hi <= lo:
        return 0.0, 0.0, 0.0
    share = (hi - lo) / (ms["band_khz"][1] - ms["band_khz"][0])
    fc = centre_khz(ms)
    if alpha is None:
        alpha = absorption(site, fc)
    loss = ac.transmission_loss_db(metres, alpha, site.spreading_k) if tl is None else tl(metres, zs, zr, fc)
    power = ac.lin(ms["sl_db"] - loss - mr.get("impl_loss_db", 0.0)) * share
    dz = zr - zs
    h = (metres * metres - dz * dz) ** 0.5 if metres * metres > dz * dz else 0.0
    late, near, _ = echo_ratios(h, zs, zr, site, alpha, mr["tolerance_ms"])
    return power, late, near


def chances(m, power, noise, inter_pre=0.0, inter=0.0, frac=0.0, nbits=None, thr=None):
    """What receiver model m makes of a packet of `power` over `noise` (both
    uPa^2; noise includes the late echoes), with interference inter_pre
    during its preamble and `inter` (overlap-weighted) over the share `frac`
    of it that others overlap -> (P detected, P no bit wrong given detected,
    mean bit error rate). nbits: the frame's bits on the air (default: the
    model's default packet plus its framing); thr: det.q_inv(m['pfa'])."""
    bw = (m["band_khz"][1] - m["band_khz"][0]) * 1000
    if thr is None:
        thr = det.q_inv(m["pfa"])
    if nbits is None:
        nbits = (m["default_bytes"] + m["overhead_bytes"]) * 8
    pd = det.detection_probability(power / (noise + inter_pre), bw, m["preamble_s"], thr)
    ber_clean = det.ber(m["modulation"], det.ebn0(power / noise, bw, m["bitrate"], m["coding_gain_db"]))
    ber_hit = ber_clean
    if frac > 0:
        ber_hit = det.ber(m["modulation"], det.ebn0(power / (noise + inter / frac), bw, m["bitrate"],
                                                     m["coding_gain_db"]))
    ok = det.frame_ok(ber_clean, nbits * (1 - frac)) * det.frame_ok(ber_hit, nbits * frac)
    return pd, ok, ber_clean * (1 - frac) + ber_hit * frac


_THR = {}  # false alarm probability -> detector threshold


def threshold(pfa):
    """det.q_inv(pfa), kept (a bisection: worth keeping)."""
    t = _THR.get(pfa)
    if t is None:
        t = _THR[pfa] = det.q_inv(pfa)
    return t


def link_pdr(site, name, metres, nbytes=None, zs=None, zr=None):
    """Chance that a packet of nbytes (default: the model's) sent over
    `metres` between two modems of model `name` at depths zs, zr (default:
    the site's node depth) arrives whole, with no other traffic: averaged
    over the site's fading (acomm_sim.fading: the mean power of the direct
    path and its unresolved echoes times the gain g; the late echoes at
    their mean)."""
    m = model(name)
    zs = site.node_depth_m if zs is None else zs
    zr = site.node_depth_m if zr is None else zr
    power, late, near = arrival(site, m, m, metres, zs, zr)
    nbits = (m["default_bytes"] if nbytes is None else nbytes) * 8 + m["overhead_bytes"] * 8
    noise = noise_power(site, m) + power * late
    thr = threshold(m["pfa"])

    k, scale = fading.params(site.fading, near)
    mean = power * scale

    def ok(g):
        pd, whole, _ = chances(m, mean * g, noise, nbits=nbits, thr=thr)
        return pd * whole

    return fading.average(ok, k)


def range_at(site, name, pdr=0.9, nbytes=None, lo=1.0, hi=100000.0):
    """The range (m) at which link_pdr falls to `pdr` (bisection on a
    falling curve; hi if it never does within hi, lo if it starts below)."""
    if link_pdr(site, name, lo, nbytes) < pdr:
        return lo
    if link_pdr(site, name, hi, nbytes) >= pdr:
        return hi
    for _ in range(40):
        mid = (lo + hi) / 2
        if link_pdr(site, name, mid, nbytes) >= pdr:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2
