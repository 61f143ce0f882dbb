# IEEE-754 binary64 bit patterns built and read with integer arithmetic.
#
# IMC carries its packet timestamp (seconds since 1970, about 1.7e9) and
# Announce's lat/lon as fp64. Many MicroPython boards build with single
# precision floats, where 1.7e9 as a float is only good to 128 s, so the
# patterns are made from exact integers (seconds, microseconds, any
# fraction num/den) and read back into exact fractions; a float is only one
# of the ways in and out. Rounding is IEEE's: to nearest, ties to even, so a
# double-precision host gets the same bits as struct.pack("<d").

import math
import struct

from ..errors import DecodeError, EncodeError

MASK64 = 0xFFFFFFFFFFFFFFFF
_SIGN = 0x8000000000000000
_INF = 0x7FF0000000000000
NAN = 0x7FF8000000000000  # the quiet NaN every encoder writes
_FRAC = 0xFFFFFFFFFFFFF  # 52 bits
_HIDDEN = 0x10000000000000  # 2**52
_TWO53 = 9007199254740992.0  # 2**53, exact in single precision too


def bitlen(n):
    # Bits of a non-negative int (MicroPython ints have no bit_length).
    b = 0
    while n >> (b + 32):
        b += 32
    while n >> b:
        b += 1
    return b


def from_ratio(num, den=1):
    # The binary64 nearest to num/den (ints, den > 0), ties to even.
    # Raises EncodeError when the value is beyond the largest double.
    if not isinstance(num, int) or not isinstance(den, int) or den <= 0:
        raise EncodeError("fp64 needs int num and int den > 0")
    sign = 0
    if num < 0:
        sign = _SIGN
        num = -num
    if num == 0:
        return sign
    # Scale so the quotient has 55 or 56 bits: 53 kept, the rest decide
    # the rounding together with the remainder.
    s = 55 - (bitlen(num) - bitlen(den))
    if s >= 0:
        q, r = divmod(num << s, den)
    else:
        q, r = divmod(num, den << -s)
    lq = bitlen(q)
    e = lq - 1 - s  # exponent of the leading bit
    keep = 53 if e >= -1022 else e + 1075  # subnormals keep fewer bits
    drop = lq - keep
    m = q >> drop
    rest = q & ((1 << drop) - 1)
    half = 1 << (drop - 1)
    if rest > half or (rest == half and (r or (m & 1))):
        m += 1
        if m >> 53:
            m >>= 1
            drop += 1
    # value = m * 2**(drop - s); a normal m holds its hidden bit (2**52)
    if m < _HIDDEN:
        return sign | m  # subnormal (drop - s == -1074 here) or zero
    biased = drop - s + 52 + 1023
    if biased >= 2047:
        raise EncodeError("%s%d/%d beyond fp64 range" % ("-" if sign else "", num, den))
    return sign | (biased << 52) | (m - _HIDDEN)


def from_float(x):
    # The pattern of a float. On a double build this equals
    # struct.pack("<d", x); on a single build it is the single's exact value.
    if x != x:
        return NAN
    if x != 0 and x == x * 2:
        return _INF | (_SIGN if x < 0 else 0)
    if x == 0:
        # only the sign tells 0.0 from -0.0; a single keeps it too
        return _SIGN if struct.pack("<f", x)[3] & 0x80 else 0
    m, e = math.frexp(x)
    mant = int(m * _TWO53)  # exact: m has at most 53 significant bits
    e -= 53
    if e >= 0:
        return from_ratio(mant << e, 1)
    return from_ratio(mant, 1 << -e)


def parts(bits):
    # (sign, mantissa, exponent) with value = (-1)**sign * mantissa * 2**exponent.
    # Raises DecodeError for infinities and NaNs, which have no such value.
    sign = 1 if bits & _SIGN else 0
    ef = (bits >> 52) & 0x7FF
    frac = bits & _FRAC
    if ef == 0x7FF:
        raise DecodeError("fp64 is %s" % ("NaN" if frac else "infinite"))
    if ef == 0:
        return sign, frac, -1074
    return sign, frac | _HIDDEN, ef - 1075


def to_ratio(bits):
    # The exact value as (num, den), den a power of two.
    sign, m, e = parts(bits)
    if sign:
        m = -m
    if e >= 0:
        return m << e, 1
    return m, 1 << -e


def to_scaled(bits, scale):
    # round(value * scale) for an int scale, ties to even: scale 10**6 gives
    # microseconds, 1 whole seconds.
    num, den = to_ratio(bits)
    neg = num < 0
    if neg:
        num = -num
    q, r = divmod(num * scale, den)
    if 2 * r > den or (2 * r == den and (q & 1)):
        q += 1
    return -q if neg else q


def to_float(bits):
    # A float of the pattern: exact on a double build; on a single build the
    # nearest single (or 0 / inf outside its range), deterministically.
    ef = (bits >> 52) & 0x7FF
    if ef == 0x7FF:
        if bits & _FRAC:
            return float("nan")
        return float("-inf") if bits & _SIGN else float("inf")
    sign, m, e = parts(bits)
    v = math.ldexp(float(m), e)
    return -v if sign else v


class F64:
    # An fp64 value kept as its exact bit pattern. Message dicts may hold one
    # wherever IMC has an fp64 field; decoders return them with exact=True.

    def __init__(self, bits):
        if not isinstance(bits, int) or bits < 0 or bits > MASK64:
            raise EncodeError("F64 needs a 64-bit pattern")
        self.bits = bits

    @staticmethod
    def seconds(sec, micros=0):
        # A time from integer seconds and microseconds (what an RTC gives).
        return F64(from_ratio(sec * 1000000 + micros, 1000000))

    @staticmethod
    def ratio(num, den=1):
        return F64(from_ratio(num, den))

    def micros(self):
        # Nearest integer microseconds; DecodeError for inf/NaN.
        return to_scaled(self.bits, 1000000)

    def to_float(self):
        return to_float(self.bits)

    def __eq__(self, other):
        return isinstance(other, F64) and other.bits == self.bits

    def __ne__(self, other):
        return not self.__eq__(other)

    def __hash__(self):
        return hash(self.bits)

    def __repr__(self):
        return "F64(0x%016x)" % self.bits


def bits_of(v):
    # The pattern of an fp64 field value: an F64, an int (exact), or a float.
    if isinstance(v, F64):
        return v.bits
    if isinstance(v, int):
        return from_ratio(v, 1)
    if isinstance(v, float):
        return from_float(v)
    raise EncodeError("%r is not a number" % (v,))
