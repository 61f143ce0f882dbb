# Fading per arrival (issue 39): block fading, one draw per copy of a packet,
# Rician with a K factor from the site's geometry. The image model
# (acomm_sim.multipath) gives, besides the direct path, the echoes a receiver
# cannot tell apart from it (those within its tolerance: guard, symbol or
# equaliser span). With a rough, moving surface their phases against the
# direct path are random, so the sum that reaches the demodulator is
#
#     h = sqrt(K / (K + 1)) + sqrt(1 / (K + 1)) * w,   w complex Gaussian, E|w|^2 = 1
#
# with K = (direct power) / (summed power of those echoes); |h|^2 is the
# power gain of that copy, mean 1, the same over the whole packet (block
# fading), applied to the mean power of the sum (direct plus those echoes).
# K -> infinity is no fading, K = 0 Rayleigh. Echoes later than
# the tolerance are not in K: they stay inter-symbol interference at their
# mean power (multipath.py). docs/simulator.md ("Fading") gives the sources.
#
# The draw: w = sqrt(E) * exp(i phi), E exponential of mean 1, phi uniform
# (the polar form of a complex Gaussian), from two 32-bit draws of the
# simulator's generator (acomm.prng.Prng). Portable Python: math only.

import math

MODES = ("rician", "rayleigh", "none")

_INV32 = 1.0 / 4294967296.0
_TWO_PI = 2.0 * math.pi


def check_mode(mode):
    """mode if it is one of MODES, else ValueError."""
    if mode not in MODES:
        raise ValueError("fading is one of %s, not %r" % (", ".join(MODES), mode))
    return mode


def params(mode, echo_ratio):
    """How an arrival whose unresolved echoes carry echo_ratio times the
    direct path's power (linear) fades -> (K, scale): its Rician K, or None
    for no fading, and the mean power of the faded sum over the direct
    path's (1 + echo_ratio: the echoes' power adds, on average, to the
    direct path's). 'none' never fades and keeps the direct path alone,
    (None, 1.0), as the model without fading did; 'rayleigh' is K = 0
    whatever the geometry; 'rician' is K = 1 / echo_ratio, and no fading
    when no echo falls within the tolerance (nothing to fade with)."""
    if mode == "none":
        return None, 1.0
    if mode == "rayleigh":
        return 0.0, 1.0 + echo_ratio
    if echo_ratio <= 0:
        return None, 1.0
    return 1.0 / echo_ratio, 1.0 + echo_ratio


def gain(rng, k):
    """One power gain |h|^2 (mean 1) of a Rician channel of factor k (0:
    Rayleigh), from two draws of rng (an acomm.prng.Prng)."""
    u1 = (rng.next32() + 1) * _INV32  # (0, 1]: log defined
    u2 = rng.next32() * _INV32
    e = -math.log(u1)  # |w|^2, exponential of mean 1
    if k <= 0:
        return e
    s2 = 1.0 / (k + 1)
    a = math.sqrt(k * s2)
    r = math.sqrt(e * s2)
    phi = _TWO_PI * u2
    x = a + r * math.cos(phi)
    y = r * math.sin(phi)
    return x * x + y * y


K_MAX = 400.0  # above this K the gain stays within about +-0.5 dB: taken as this K


def cdf(k, x):
    """P(g <= x) for the power gain g (mean 1) of a Rician channel of
    factor k (0: Rayleigh, 1 - exp(-x)): the non-central chi-square law of
    two degrees of freedom, as its Poisson mixture of gamma laws,
    sum over n of exp(-k) k^n / n! * P(n + 1, (k + 1) x), P the regularised
    lower incomplete gamma function (a sum of Poisson terms itself)."""
    if x <= 0:
        return 0.0
    k = K_MAX if k > K_MAX else k
    y = (k + 1) * x
    w = math.exp(-k)  # Poisson weight of n
    t = math.exp(-y)  # exp(-y) y^j / j!
    below = t  # sum over j <= n of t: 1 - P(n + 1, y)
    total = 0.0
    n = 0
    left = 1.0  # Poisson mass not yet taken
    while True:
        total += w * (1 - below)
        left -= w
        n += 1
        if left < 1e-12 or (n > k and w < 1e-16):
            break
        w = w * k / n
        t = t * y / n
        below += t
    return 0.0 if total < 0 else (1.0 if total > 1 else total)


# the grid on which average() takes the gain's law: 0.25 dB steps from
# -50 dB to +20 dB (a step-like f of the SNR changes little within one)
_DB_LO = -50.0
_DB_HI = 20.0
_DB_STEP = 0.25
_tables = {}


def _table(k):
    # (the midpoints of the grid's cells, in linear gain; each cell's
    # probability), the cells below the grid and above it included; kept
    # per K to 3 significant figures
    key = float("%.3g" % k)
    tab = _tables.get(key)
    if tab is not None:
        return tab
    if len(_tables) > 64:
        _tables.clear()
    n = int((_DB_HI - _DB_LO) / _DB_STEP + 0.5)
    mids = [0.5 * 10 ** (_DB_LO / 10)]
    probs = []
    prev = cdf(key, 10 ** (_DB_LO / 10))
    probs.append(prev)
    for i in range(n):
        lo = _DB_LO + i * _DB_STEP
        mids.append(10 ** ((lo + _DB_STEP / 2) / 10))
        c = cdf(key, 10 ** ((lo + _DB_STEP) / 10))
        probs.append(c - prev)
        prev = c
    mids.append(10 ** (_DB_HI / 10))
    probs.append(1 - prev)
    tab = _tables[key] = (mids, probs)
    return tab


def average(f, k):
    """E[f(g)] over the power gain g of a Rician channel of factor k (None:
    f(1.0), no fading), for f that changes little within 0.25 dB of g: the
    law of g (cdf) on a grid of 0.25 dB cells from -50 to +20 dB, f at each
    cell's middle; cells whose probability is below 1e-12 are skipped."""
    if k is None:
        return f(1.0)
    mids, probs = _table(k)
    total = 0.0
    for i in range(len(mids)):
        p = probs[i]
        if p > 1e-12:
            total += p * f(mids[i])
    return total
