# From a signal to noise (plus interference) ratio to a received frame: the
# chance that the receiver detects the preamble, the bit error rate of the
# modulation, and what that means for a frame of n bits. Textbook formulas
# for an additive white Gaussian noise channel (Proakis, "Digital
# Communications", 5th ed., sections 4.3 and 4.5; Van Trees / Kay for the
# Neyman-Pearson detector); docs/simulator.md gives them with their symbols.
# Portable Python: math only.

import math

try:
    _erfc = math.erfc
except AttributeError:  # some MicroPython builds leave erf/erfc out
    _erfc = None


def erfc(x):
    """The complementary error function: math.erfc where the runtime has it,
    else a rational approximation (Numerical Recipes' erfcc, |error| < 1.2e-7
    relative, which is far below what a link budget resolves)."""
    if _erfc is not None:
        return _erfc(x)
    return erfc_approx(x)


def erfc_approx(x):
    """Numerical Recipes' Chebyshev fit of erfc (used where math has none)."""
    z = abs(x)
    t = 1 / (1 + 0.5 * z)
    r = t * math.exp(-z * z - 1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (
        -0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
    return r if x >= 0 else 2 - r


def q(x):
    """The Gaussian tail Q(x) = P(N(0,1) > x)."""
    return 0.5 * erfc(x / math.sqrt(2))


def q_inv(p):
    """The x with Q(x) = p, 0 < p < 1 (bisection: called once per detector
    set-up, not per packet)."""
    lo, hi = -40.0, 40.0
    for _ in range(100):
        mid = (lo + hi) / 2
        if q(mid) > p:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def detection_probability(snr_lin, bandwidth_hz, preamble_s, threshold):
    """Chance that a preamble of preamble_s seconds, received at snr_lin
    (linear, in the band) is detected by a matched filter whose threshold
    gives the wanted false alarm rate: Pd = Q(threshold - sqrt(2 E/N0)),
    E/N0 = SNR * B * T (the preamble's energy over the noise density);
    threshold = q_inv(P_fa)."""
    if snr_lin <= 0:
        return 0.0
    return q(threshold - math.sqrt(2 * snr_lin * bandwidth_hz * preamble_s))


def ber(modulation, ebn0_lin):
    """Bit error rate at Eb/N0 (linear) of
    'psk'  coherent BPSK (and QPSK per bit): Q(sqrt(2 Eb/N0));
    'fsk'  non-coherent binary FSK: exp(-Eb/2N0) / 2;
    'dpsk' differential BPSK: exp(-Eb/N0) / 2."""
    if ebn0_lin <= 0:
        return 0.5
    if modulation == "psk":
        return 0.5 * erfc(math.sqrt(ebn0_lin))
    if modulation == "fsk":
        return 0.5 * math.exp(-ebn0_lin / 2)
    if modulation == "dpsk":
        return 0.5 * math.exp(-ebn0_lin)
    raise ValueError("unknown modulation %r" % (modulation,))


def ebn0(snr_lin, bandwidth_hz, bitrate, coding_gain_db=0.0):
    """Eb/N0 (linear) from the in-band SNR: SNR * B / R, times the coding
    gain (the Eb/N0 an uncoded link would need for the same BER, over the
    coded link's: the datasheet's or an assumed one)."""
    return snr_lin * bandwidth_hz / bitrate * 10 ** (coding_gain_db / 10)


def frame_ok(bit_error_rate, nbits):
    """Chance that nbits independent bits all arrive right: (1 - BER)^n."""
    if bit_error_rate <= 0:
        return 1.0
    if bit_error_rate >= 0.5:
        return 0.5 ** nbits
    return math.exp(nbits * math.log(1 - bit_error_rate))
