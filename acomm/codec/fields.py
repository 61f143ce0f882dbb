# Field kinds of the message codec (docs/codec.md).
#
# Every field has name, max_bits, min_bits, limit_bits (log2 of the number
# of distinct values: the information content), encode(writer, value) and
# decode(reader). Scalar kinds (UInt, Fixed, Enum, Bool) map a value to one
# code 0 <= code < ncodes written in `bits` bits; the width is the smallest
# that holds every code, and a code the field cannot produce is rejected on
# decode, so random bytes never turn into a plausible value silently.
#
# Errors raised here carry no field name: the container that holds the field
# (Message, Nested, Array) names it, so a nested failure reads
# "buddy_to_diver.buddy.x: ..." without every field knowing its parents.

import math
import sys

from ..errors import DecodeError, EncodeError

# a few units in the last place of this runtime's float: double on CPython
# and the unix ports, single on boards built with float32 (RP2040, ESP32,
# the Cortex-M3 test firmware), where 1 + 2**-40 rounds to 1
_ROUNDING = 2.0**-50 if 1.0 + 2.0**-40 != 1.0 else 2.0**-21

# A Fixed field of at most this many codes keeps its decoded values in a
# tuple (value(c) is then one look-up, not a call that computes it; on
# CPython about 25 ns less per field, 150 ns of a teleop command's 4 us
# round trip): on 64-bit runtimes (topside computers, the unix port), not
# on 32-bit boards, whose heap holds every float of such a table as an object
_VALUE_TABLE = 64 if sys.maxsize > (1 << 32) else 0


def width(n):
    # Bits needed for the codes 0..n (MicroPython ints have no bit_length).
    b = 0
    while n >> b:
        b += 1
    return b


def fail(cls, detail, path=None):
    # An error with the failing field's path and the bare detail as attributes.
    e = cls(detail if path is None else path + ": " + detail)
    e.field = path
    e.detail = detail
    return e


def pathed(e, name):
    # The same kind of error, one container level up: name + the inner path.
    sub = getattr(e, "field", None)
    if sub:
        name = name + ("" if sub[0] == "[" else ".") + sub
    return fail(type(e), getattr(e, "detail", None) or str(e), name)


def log2_series(step, count):
    # log2(sum of 2**(k*step) for k in 0..count): the information of a
    # variable-length field of 0..count items of `step` bits each, without
    # building the (possibly huge) integer sum.
    if step == 0:
        return math.log2(count + 1)
    s = 0.0
    k = 0
    while k <= count:
        t = 2.0 ** (-k * step)
        if t < 1e-17:
            break  # the rest cannot change a double
        s += t
        k += 1
    return count * step + math.log2(s)


def write_count(w, n, fixed, most, prefix_bits, unit):
    # The length rule of Bytes and Array: a fixed size must match exactly; a
    # variable one is bounded and goes on the wire as a prefix.
    if fixed:
        if n != most:
            raise fail(EncodeError, "%d %s, needs exactly %d" % (n, unit, most))
        return
    if n > most:
        raise fail(EncodeError, "%d %s, at most %d" % (n, unit, most))
    w.write(n, prefix_bits)


class Field:
    """The field interface: name, min_bits, max_bits, limit_bits; encode(w, v) and decode(r) on acomm.codec.bits."""
    saturate = False


class Scalar(Field):
    # Subclasses set name, bits, ncodes and define code(v) / value(c).

    def _sizes(self, ncodes):
        self.ncodes = ncodes
        self.bits = width(ncodes - 1)
        self.max_bits = self.min_bits = self.bits
        self.limit_bits = math.log2(ncodes)

    def encode(self, w, v):
        w.write(self.code(v), self.bits)

    def decode(self, r):
        c = r.read(self.bits)
        if c >= self.ncodes:
            raise fail(DecodeError, "code %d past the last %d" % (c, self.ncodes - 1))
        return self.value(c)


class UInt(Scalar):
    """An integer lo..hi in the fewest bits; EncodeError outside it, unless saturate clamps."""

    def __init__(self, name, lo, hi, saturate=False):
        if hi < lo:
            raise ValueError("%s: hi < lo" % name)
        self.name = name
        self.lo = lo
        self.hi = hi
        self.saturate = saturate
        self._sizes(hi - lo + 1)

    def code(self, v):
        if not isinstance(v, int):
            raise fail(EncodeError, "%r is not an int" % (v,))
        if v < self.lo or v > self.hi:
            if not self.saturate:
                raise fail(EncodeError, "%d outside [%d, %d]" % (v, self.lo, self.hi))
            v = self.lo if v < self.lo else self.hi
        return v - self.lo

    def value(self, c):
        return self.lo + c


class Fixed(Scalar):
    """A number lo..hi at resolution res (a float decodes to the nearest step); EncodeError outside, unless saturate."""
    # A quantized real: code = round((v - lo) / res), half up, so the
    # decoded lo + code*res is within res/2 of v. steps = round((hi-lo)/res)
    # makes hi reachable even when (hi-lo)/res is off an integer by float
    # noise (51.2 - -51.1 = 102.29999...). A value within res/1024 outside
    # [lo, hi] counts as the bound, for the same noise.

    def __init__(self, name, lo, hi, res, saturate=False):
        if res <= 0 or hi < lo:
            raise ValueError("%s: need res > 0 and hi >= lo" % name)
        self.name = name
        self.lo = lo
        self.hi = hi
        self.res = res
        self.saturate = saturate
        self.steps = int((hi - lo) / res + 0.5)
        tol = res / 1024
        self._lo_t = lo - tol
        self._hi_t = hi + tol
        self._sizes(self.steps + 1)
        if self.ncodes <= _VALUE_TABLE:
            # the same floats as value() computes, looked up (callers check
            # 0 <= c < ncodes first, as they do before value())
            t = tuple(Fixed.value(self, c) for c in range(self.ncodes))
            self.value = lambda c: t[c]

    def code(self, v):
        # written so that NaN fails every comparison and lands in the error
        if not (self._lo_t <= v <= self._hi_t):
            if not self.saturate or v != v:
                raise fail(EncodeError, "%r outside [%r, %r]" % (v, self.lo, self.hi))
            v = self.lo if v < self.lo else self.hi
        # v >= lo - res/1024 here, so c >= 0; above steps only inside the tolerance
        c = int((v - self.lo) / self.res + 0.5)
        return c if c <= self.steps else self.steps

    def value(self, c):
        v = self.lo + c * self.res
        # when steps*res overshoots hi, the top code still means hi; so it
        # does when it falls short of hi by float rounding only (a board's
        # float32 gives 89.999984 for -90 + 648000 * (1/3600))
        if v > self.hi or (c == self.steps and self.hi - v <= (abs(self.lo) + abs(self.hi)) * _ROUNDING):
            return self.hi
        return v


class Enum(Scalar):
    """One of the labels (strings), sent as its index."""

    def __init__(self, name, labels):
        if not labels:
            raise ValueError("%s: no labels" % name)
        self.name = name
        self.labels = tuple(labels)
        self._index = {}
        for i, lab in enumerate(self.labels):
            if lab in self._index:
                raise ValueError("%s: duplicate label %r" % (name, lab))
            self._index[lab] = i
        self._sizes(len(self.labels))

    def code(self, v):
        c = self._index.get(v) if isinstance(v, str) else None
        if c is None:
            raise fail(EncodeError, "%r is not one of its labels" % (v,))
        return c

    def value(self, c):
        return self.labels[c]


class Bool(Scalar):
    """True or False in one bit."""

    def __init__(self, name):
        self.name = name
        self._sizes(2)

    def code(self, v):
        if v is True:
            return 1
        if v is False:
            return 0
        raise fail(EncodeError, "%r is not a bool" % (v,))

    def value(self, c):
        return c == 1


class Wide(Scalar):
    """Another scalar field written in a fixed, larger number of bits (a layout fixed by an outside table)."""
    # A scalar field written in more bits than it needs, for layouts whose
    # width is fixed by an outside table (CADDY legacy positions). Codes
    # past the inner field's range are still rejected on decode.

    def __init__(self, field, bits):
        if bits < field.bits:
            raise ValueError("%s: %d bits < the %d it needs" % (field.name, bits, field.bits))
        self.field = field
        self.name = field.name
        self.saturate = field.saturate
        self.ncodes = field.ncodes
        self.bits = self.max_bits = self.min_bits = bits
        self.limit_bits = field.limit_bits
        self.code = field.code
        self.value = field.value


class Bytes(Field):
    """Up to max_len bytes (exactly max_len when fixed), with a length prefix when not fixed."""

    def __init__(self, name, max_len, fixed=False):
        self.name = name
        self.max_len = max_len
        self.fixed = fixed
        self.len_bits = 0 if fixed else width(max_len)
        self.max_bits = self.len_bits + 8 * max_len
        self.min_bits = self.max_bits if fixed else self.len_bits
        self.limit_bits = 8.0 * max_len if fixed else log2_series(8, max_len)

    def encode(self, w, v):
        if isinstance(v, str) or not isinstance(v, (bytes, bytearray, memoryview)):
            raise fail(EncodeError, "%s is not bytes" % type(v).__name__)
        write_count(w, len(v), self.fixed, self.max_len, self.len_bits, "bytes")
        w.write_bytes(v)

    def decode(self, r):
        n = self.max_len
        if not self.fixed:
            n = r.read(self.len_bits)
            if n > self.max_len:
                raise fail(DecodeError, "length %d past %d" % (n, self.max_len))
        return bytes(r.read_bytes(n))


class Optional(Field):
    """A presence bit, then the field when the value is not None."""
    # A presence bit, then the field when present. None means absent.
    def __init__(self, field):
        self.field = field
        self.name = field.name
        self.max_bits = 1 + field.max_bits
        self.min_bits = 1
        # log2(1 + 2**L), safe for large L
        L = field.limit_bits
        self.limit_bits = L + math.log2(1.0 + 2.0 ** (-L)) if L < 1000 else float(L)

    def encode(self, w, v):
        if v is None:
            w.write(0, 1)
        else:
            w.write(1, 1)
            self.field.encode(w, v)

    def decode(self, r):
        if r.read(1):
            return self.field.decode(r)
        return None


class Array(Field):
    """Up to max_count values of one field (exactly max_count when fixed), with a count prefix when not fixed."""
    # `fixed` arrays always hold max_count items; others get a count prefix.
    def __init__(self, field, max_count, fixed=False):
        self.field = field
        self.name = field.name
        self.max_count = max_count
        self.fixed = fixed
        self.count_bits = 0 if fixed else width(max_count)
        self.max_bits = self.count_bits + max_count * field.max_bits
        self.min_bits = max_count * field.min_bits if fixed else self.count_bits
        L = field.limit_bits
        self.limit_bits = max_count * L if fixed else log2_series(L, max_count)

    def encode(self, w, v):
        if isinstance(v, (str, bytes, dict)):
            raise fail(EncodeError, "%s is not a list" % type(v).__name__)
        n = len(v)
        write_count(w, n, self.fixed, self.max_count, self.count_bits, "items")
        f = self.field
        i = 0
        try:
            for i in range(n):
                f.encode(w, v[i])
        except EncodeError as e:
            raise pathed(e, "[%d]" % i) from None

    def decode(self, r):
        n = self.max_count
        if not self.fixed:
            n = r.read(self.count_bits)
            if n > self.max_count:
                raise fail(DecodeError, "count %d past %d" % (n, self.max_count))
        f = self.field
        out = []
        i = 0
        try:
            for i in range(n):
                out.append(f.decode(r))
        except DecodeError as e:
            raise pathed(e, "[%d]" % i) from None
        return out


class Nested(Field):
    """A whole message's body as one field (its values dict)."""
    # The body of another Message (no id), as a dict.
    def __init__(self, name, message):
        self.name = name
        self.message = message
        self.max_bits = message.max_bits
        self.min_bits = message.min_bits
        self.limit_bits = message.limit_bits

    def encode(self, w, v):
        self.message.encode_body(w, v)

    def decode(self, r):
        return self.message.decode_body(r)
