# Shallow-water multipath, simply: the image arrivals of an isovelocity
# channel of the site's depth (flat surface and bottom, constant sound
# speed), each weaker than the direct path by its longer way (spreading and
# absorption) and by what each reflection loses. Echoes that arrive within
# the receiving modem's tolerance (its guard or symbol or equaliser span)
# are absorbed (they make the direct path fade: acomm_sim.fading); later
# ones are interference, as power added to the noise.
# Not a ray tracer (no refraction, no rough-surface scatter): a documented
# first order model (docs/simulator.md, "Multipath"). Portable Python.

import math


def images(horizontal_m, zs, zr, depth, max_bounces):
    """The image paths between a source at depth zs and a receiver at zr,
    horizontal_m apart, in water `depth` deep, with at most max_bounces
    reflections -> [(vertical separation m, surface hits, bottom hits)],
    the direct path first. (Four families per order m: Urick/Jensen's
    method of images for a waveguide with two flat boundaries.)"""
    zs = min(max(zs, 0.0), depth)
    zr = min(max(zr, 0.0), depth)
    out = [(abs(zr - zs), 0, 0)]
    m = 0
    while True:
        fam = []
        if m >= 1:
            fam.append((2 * m * depth + zr - zs, m, m))
            fam.append((2 * m * depth - zr + zs, m, m))
        fam.append((2 * m * depth + zr + zs, m + 1, m))
        fam.append((2 * (m + 1) * depth - zr - zs, m, m + 1))
        added = False
        for z, ns, nb in fam:
            if ns + nb <= max_bounces:
                out.append((abs(z), ns, nb))
                added = True
        if not added:
            return out
        m += 1


def echo_ratios(horizontal_m, zs, zr, site, alpha_db_per_km, tolerance_ms):
    """The echoes of the site's channel against the direct path, for a
    receiver that absorbs tolerance_ms of delay spread -> (late, near,
    spread_ms): the power of the echoes later than tolerance_ms over the
    direct path's (linear; inter-symbol interference), the same for those
    within it (what the direct path fades with: acomm_sim.fading's K is
    1 / near), and the delay spread of all of them."""
    paths = images(horizontal_m, zs, zr, site.depth_m, site.max_bounces)
    h2 = horizontal_m * horizontal_m
    r0 = math.sqrt(h2 + paths[0][0] ** 2)
    r0 = r0 if r0 > 1.0 else 1.0
    k10 = site.spreading_k * 10
    late = 0.0
    near = 0.0
    spread = 0.0
    c = site.sound_speed
    for z, ns, nb in paths[1:]:
        r = math.sqrt(h2 + z * z)
        delay_ms = (r - r0) / c * 1000
        if delay_ms > spread:
            spread = delay_ms
        loss_db = k10 * math.log10(r / r0) + alpha_db_per_km * (r - r0) / 1000 \
            + ns * site.surface_loss_db + nb * site.bottom_loss_db
        if delay_ms <= tolerance_ms:
            near += 10 ** (-loss_db / 10)
        else:
            late += 10 ** (-loss_db / 10)
    return late, near, spread

