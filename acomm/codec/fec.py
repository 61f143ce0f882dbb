# Systematic Reed-Solomon forward error correction over GF(2^8).
#
# An acoustic frame that arrives with a few damaged bytes costs a whole
# retransmission (seconds of air time) unless the receiver can repair it, so
# the store-and-forward transport may append RS parity to what it sends.
#
# Code parameters (the defaults of common RS libraries such
# as the `reedsolo` package, so acomm's codewords interoperate with them):
# field polynomial 0x11d, generator alpha = 2, first consecutive root 0
# (the generator polynomial is (x - 1)(x - 2)...(x - alpha^(nsym-1))),
# message first and the nsym parity bytes after it, codeword at most 255
# bytes (shorter messages are a shortened code: leading zeros not sent).
#
# Interface (used by the store-and-forward transport):
#
#   rs = ReedSolomon(nsym)      1 <= nsym <= 254; precomputes the generator
#   rs.encode(msg) -> bytes     msg + nsym parity bytes; EncodeError when
#                               len(msg) + nsym > 255
#   rs.decode(cw) -> bytes      the message (parity removed), corrected
#   rs.decode_count(cw) -> (msg, ncorrected)
#
# Guarantee of decode (bounded-distance decoding, t = nsym // 2):
#   * up to t damaged bytes anywhere in the codeword are corrected;
#   * a message is returned only if its codeword differs from what was
#     received in at most t bytes (checked: the corrected word's syndromes
#     are recomputed); otherwise acomm.errors.CRCError is raised (a
#     DecodeError, so generic handlers drop the frame);
#   * with more than t errors the decoder either raises or, if the damage
#     happens to land within t bytes of another codeword, returns that other
#     message. This is possible whenever e >= nsym + 1 - t (the code's
#     distance is nsym + 1): for an even nsym already at e = t + 1; an odd
#     nsym always detects t + 1 errors (one parity byte buys that). For
#     random damage its probability
#     is about sum_{i<=t} C(n, i) 255^i / 256^nsym, measured with t + 1
#     errors: nsym = 2: 10 % of 30-byte and 99.8 % of 255-byte codewords;
#     nsym = 4: 49 % at 255 bytes; nsym = 8: 3 % at 255 bytes (about 1/t!
#     for long codewords; ~1e-4 at 60 bytes); nsym = 16: ~2e-5.
#     Whatever carries RS codewords still needs its CRC; RS with nsym >= 16
#     makes a miscorrection rare, never impossible.
#   * any input: bytes, bytearray or memoryview of length nsym .. 255;
#     other lengths raise DecodeError.
#
# Erasures (known-bad positions) are not supported: the links acomm drives
# do not report which bytes were unreliable.
#
# RAM: the shared tables are 768 bytes (built once per process, at import);
# each ReedSolomon keeps nsym + 1 bytes of generator; decode allocates a few
# arrays of nsym bytes per call, none per byte.

from ..errors import CRCError, DecodeError, EncodeError

_PRIM = 0x11D


def _tables():
    # exp is doubled (510 entries + slack) so a product log[a] + log[b]
    # (at most 508) indexes it without a modulo.
    exp = bytearray(512)
    log = bytearray(256)
    x = 1
    for i in range(255):
        exp[i] = x
        log[x] = i
        x <<= 1
        if x & 0x100:
            x ^= _PRIM
    for i in range(255, 512):
        exp[i] = exp[i - 255]
    return exp, log


EXP, LOG = _tables()


def gf_mul(a, b):
    if a == 0 or b == 0:
        return 0
    return EXP[LOG[a] + LOG[b]]


def gf_div(a, b):
    # b != 0 (callers check)
    if a == 0:
        return 0
    return EXP[LOG[a] + 255 - LOG[b]]


def _poly_eval(p, x):
    # p lowest degree first (Horner from the top)
    y = 0
    if x == 0:
        return p[0] if len(p) else 0
    lx = LOG[x]
    i = len(p) - 1
    while i >= 0:
        y = (EXP[LOG[y] + lx] if y else 0) ^ p[i]
        i -= 1
    return y


class ReedSolomon:
    def __init__(self, nsym):
        if not 0 < nsym < 255:
            raise EncodeError("RS: nsym must be 1..254")
        self.nsym = nsym
        # Generator, highest degree first, monic: g[0] = 1. The encoder
        # uses the logs of the other coefficients; log 255 (no such log)
        # marks a zero coefficient, which it skips.
        g = bytearray(nsym + 1)
        g[0] = 1
        for i in range(nsym):
            # g = g * (x + alpha^i): each coefficient plus the previous one
            # times alpha^i (in GF(2^m), minus is plus)
            r = EXP[i]
            j = i + 1
            while j > 0:
                g[j] ^= gf_mul(g[j - 1], r)
                j -= 1
        self.gen = bytes(g)
        glog = bytearray(nsym)
        for j in range(nsym):
            c = g[j + 1]
            glog[j] = LOG[c] if c else 255
        self._glog = glog
        self._par = bytearray(nsym)

    def encode(self, msg):
        nsym = self.nsym
        if len(msg) + nsym > 255:
            raise EncodeError("RS: message longer than 255 - nsym")
        # Division of msg * x^nsym by g with a shift register: par holds the
        # running remainder, highest degree first.
        par = self._par
        for j in range(nsym):
            par[j] = 0
        glog = self._glog
        last = nsym - 1
        for b in msg:
            fb = b ^ par[0]
            for j in range(last):
                par[j] = par[j + 1]
            par[last] = 0
            if fb:
                lf = LOG[fb]
                for j in range(nsym):
                    lg = glog[j]
                    if lg != 255:
                        par[j] ^= EXP[lf + lg]
        return bytes(msg) + bytes(par)

    def syndromes(self, cw):
        # S_j = cw(alpha^j), j = 0 .. nsym-1; cw[0] is the highest degree
        # coefficient. Returns (bytearray, any non-zero).
        nsym = self.nsym
        s = bytearray(nsym)
        nz = 0
        for j in range(nsym):
            y = 0
            for b in cw:
                y = (EXP[LOG[y] + j] if y else 0) ^ b
            s[j] = y
            nz |= y
        return s, nz

    def decode(self, cw):
        return self.decode_count(cw)[0]

    def decode_count(self, cw):
        n = len(cw)
        nsym = self.nsym
        if n < nsym or n > 255:
            raise DecodeError("RS: codeword length out of range")
        synd, nz = self.syndromes(cw)
        k = n - nsym
        if not nz:
            return bytes(cw[:k]), 0
        lam = _berlekamp_massey(synd)
        nerr = len(lam) - 1
        if 2 * nerr > nsym:
            raise CRCError("RS: too many errors to correct")
        # Chien search: an error at degree i (byte n-1-i) makes
        # lam(alpha^-i) zero. Only the n transmitted positions count: a root
        # in the shortened part means the damage is uncorrectable.
        pos = bytearray(nerr)
        found = 0
        for i in range(n):
            if _poly_eval(lam, EXP[(255 - i) % 255]) == 0:
                if found == nerr:  # cannot happen for a degree-nerr locator
                    found += 1
                    break
                pos[found] = i
                found += 1
        if found != nerr:
            raise CRCError("RS: error locator does not fit the codeword")
        # Forney (first root 0): e = X * omega(X^-1) / lam'(X^-1), with
        # omega = synd * lam mod x^nsym and X = alpha^i.
        omega = bytearray(nsym)
        for a in range(nsym):
            sa = synd[a]
            if sa:
                for b in range(len(lam)):
                    if a + b >= nsym:
                        break
                    omega[a + b] ^= gf_mul(sa, lam[b])
        # formal derivative: odd-degree terms only, shifted down one degree
        dlam = bytearray(nerr)
        for b in range(1, len(lam), 2):
            dlam[b - 1] = lam[b]
        out = bytearray(cw)
        for m in range(nerr):
            i = pos[m]
            xinv = EXP[(255 - i) % 255]
            den = _poly_eval(dlam, xinv)
            if den == 0:
                raise CRCError("RS: error magnitude undefined")
            mag = gf_mul(EXP[i], gf_div(_poly_eval(omega, xinv), den))
            out[n - 1 - i] ^= mag
        if self.syndromes(out)[1]:
            raise CRCError("RS: correction did not give a codeword")
        return bytes(out[:k]), nerr


def _berlekamp_massey(synd):
    # Shortest LFSR (error locator lam, lowest degree first, lam[0] = 1)
    # that generates the syndromes. Returns lam trimmed to its degree.
    nsym = len(synd)
    lam = bytearray(nsym + 1)
    lam[0] = 1
    prev = bytearray(nsym + 1)
    prev[0] = 1
    tmp = bytearray(nsym + 1)
    ell = 0  # current LFSR length
    shift = 1  # steps since prev was last updated
    pd = 1  # discrepancy when prev was last updated
    for r in range(nsym):
        d = synd[r]
        for i in range(1, ell + 1):
            if lam[i] and synd[r - i]:
                d ^= EXP[LOG[lam[i]] + LOG[synd[r - i]]]
        if d == 0:
            shift += 1
            continue
        coef = gf_div(d, pd)
        if 2 * ell <= r:
            tmp[:] = lam
            for i in range(shift, nsym + 1):
                if prev[i - shift]:
                    lam[i] ^= gf_mul(coef, prev[i - shift])
            ell = r + 1 - ell
            prev[:] = tmp
            pd = d
            shift = 1
        else:
            for i in range(shift, nsym + 1):
                if prev[i - shift]:
                    lam[i] ^= gf_mul(coef, prev[i - shift])
            shift += 1
    # the locator's degree must be ell; a higher non-zero term means the
    # syndromes are inconsistent (more errors than the code can locate)
    deg = nsym
    while deg > 0 and lam[deg] == 0:
        deg -= 1
    if deg != ell:
        raise CRCError("RS: error locator degree mismatch")
    return lam[: deg + 1]
