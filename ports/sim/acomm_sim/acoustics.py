# The link budget of an acoustic arrival, from textbook physics: how much of
# a source's level is left at a receiver (spreading and absorption), how
# loud the sea is in the modem's band (ambient noise), and the signal to
# noise ratio that follows. Frequencies are in kHz, distances in metres,
# levels in dB re 1 uPa (at 1 m for source levels), as the sources use them.
#
# Sources (docs/simulator.md, "Physics channel", gives the equations):
#   Thorp, W. H. (1967), "Analytic description of the low-frequency
#     attenuation coefficient", JASA 42(1), 270; the form in dB/km used by
#     Stojanovic (2007) and Urick's "Principles of Underwater Sound";
#   Francois, R. E. and Garrison, G. R. (1982), "Sound absorption based on
#     ocean measurements. Part II: Boric acid contribution and equation for
#     total absorption", JASA 72(6), 1879-1890;
#   Coates, R. (1990), "Underwater Acoustic Systems", and Stojanovic, M.
#     (2007), "On the relationship between capacity and distance in an
#     underwater acoustic communication channel", ACM MC2R 11(4), 34-43:
#     the four empirical components (turbulence, shipping, wind, thermal)
#     that approximate Wenz's (1962) curves.
# Portable Python: math only (runs on the MicroPython unix port).

import math


def thorp_db_per_km(f_khz):
    """Thorp's absorption in sea water at f_khz kHz -> dB/km (valid above a
    few hundred Hz; Stojanovic 2007, eq. 3)."""
    f2 = f_khz * f_khz
    return 0.11 * f2 / (1 + f2) + 44 * f2 / (4100 + f2) + 2.75e-4 * f2 + 0.003


def francois_garrison_db_per_km(f_khz, temperature_c=10.0, salinity_psu=35.0, depth_m=0.0, ph=8.0):
    """Francois and Garrison's (1982) absorption -> dB/km: boric acid,
    magnesium sulphate and pure water relaxations at temperature (deg C),
    salinity (psu), depth (m) and pH. Valid about -2..22 deg C, 30..35 psu,
    0.2..1000 kHz (outside that it extrapolates)."""
    t = temperature_c
    s = salinity_psu
    d = depth_m
    f2 = f_khz * f_khz
    tk = t + 273.0
    c = 1412.0 + 3.21 * t + 1.19 * s + 0.0167 * d  # their sound speed, m/s
    # boric acid
    a1 = 8.86 / c * 10 ** (0.78 * ph - 5)
    f1 = 2.8 * math.sqrt(s / 35) * 10 ** (4 - 1245 / tk)
    boric = a1 * f1 * f2 / (f1 * f1 + f2)
    # magnesium sulphate
    a2 = 21.44 * s / c * (1 + 0.025 * t)
    p2 = 1 - 1.37e-4 * d + 6.2e-9 * d * d
    f2r = 8.17 * 10 ** (8 - 1990 / tk) / (1 + 0.0018 * (s - 35))
    mgso4 = a2 * p2 * f2r * f2 / (f2r * f2r + f2)
    # pure water (two fits, either side of 20 deg C)
    if t <= 20:
        a3 = 4.937e-4 - 2.59e-5 * t + 9.11e-7 * t * t - 1.50e-8 * t * t * t
    else:
        a3 = 3.964e-4 - 1.146e-5 * t + 1.45e-7 * t * t - 6.5e-10 * t * t * t
    p3 = 1 - 3.83e-5 * d + 4.9e-10 * d * d
    return boric + mgso4 + a3 * p3 * f2


def transmission_loss_db(metres, alpha_db_per_km, k=1.5):
    """Spreading (k * 10 log10 r: 1 cylindrical, 2 spherical, 1.5 the usual
    'practical' mix) plus absorption, re 1 m -> dB. Below 1 m: no spreading
    loss (the source level is defined at 1 m)."""
    r = metres if metres > 1.0 else 1.0
    return k * 10 * math.log10(r) + alpha_db_per_km * r / 1000


def noise_psd_db(f_khz, wind_mps=0.0, shipping=0.5):
    """Ambient noise power spectral density at f_khz -> dB re 1 uPa^2/Hz:
    the sum of Coates' turbulence, shipping (activity 0..1), wind (m/s) and
    thermal components (Stojanovic 2007, eqs. 7)."""
    lf = math.log10(f_khz)
    turb = 17 - 30 * lf
    ship = 40 + 20 * (shipping - 0.5) + 26 * lf - 60 * math.log10(f_khz + 0.03)
    wind = 50 + 7.5 * math.sqrt(wind_mps) + 20 * lf - 40 * math.log10(f_khz + 0.4)
    thermal = -15 + 20 * lf
    return 10 * math.log10(10 ** (turb / 10) + 10 ** (ship / 10) + 10 ** (wind / 10) + 10 ** (thermal / 10))


def noise_band_db(f_lo_khz, f_hi_khz, wind_mps=0.0, shipping=0.5, steps=16):
    """Ambient noise level in the band f_lo..f_hi kHz -> dB re 1 uPa^2: the
    PSD integrated over the band (midpoint rule in `steps` slices; the PSD
    is smooth, 16 slices are within 0.01 dB of a fine integral)."""
    w = (f_hi_khz - f_lo_khz) / steps
    total = 0.0
    for i in range(steps):
        total += 10 ** (noise_psd_db(f_lo_khz + (i + 0.5) * w, wind_mps, shipping) / 10)
    return 10 * math.log10(total * w * 1000)


def db(x):
    """Linear power ratio -> dB (-300 for nothing)."""
    return 10 * math.log10(x) if x > 0 else -300.0


def lin(x_db):
    """dB -> linear power ratio."""
    return 10 ** (x_db / 10)
