# Random and boundary values for codec fields, and a comparison that allows
# the quantization error. Shared by the codec and catalog tests.

from acomm.codec.fields import Array, Bool, Bytes, Enum, Fixed, Nested, Optional, UInt
from acomm.codec.text6 import ALPHABET, Text6
from checks import near


def _inner(f):
    # Wide and the catalogs' checked fields wrap a scalar in .field
    while not isinstance(f, (UInt, Fixed, Enum, Bool, Bytes, Text6, Optional, Array, Nested)):
        f = f.field
    return f


def random_value(f, rng):
    f = _inner(f)
    if isinstance(f, UInt):
        return rng.range(f.lo, f.hi)
    if isinstance(f, Fixed):
        v = f.lo + (f.hi - f.lo) * rng.next32() / 4294967295.0
        return f.hi if v > f.hi else v
    if isinstance(f, Enum):
        return f.labels[rng.below(len(f.labels))]
    if isinstance(f, Bool):
        return rng.below(2) == 1
    if isinstance(f, Bytes):
        n = f.max_len if f.fixed else rng.range(0, f.max_len)
        return rng.bytes(n)
    if isinstance(f, Text6):
        n = rng.range(0, f.max_chars)
        return "".join(ALPHABET[rng.below(len(ALPHABET))] for _ in range(n))
    if isinstance(f, Optional):
        return None if rng.below(3) == 0 else random_value(f.field, rng)
    if isinstance(f, Array):
        n = f.max_count if f.fixed else rng.range(0, f.max_count)
        return [random_value(f.field, rng) for _ in range(n)]
    if isinstance(f, Nested):
        return random_values(f.message, rng)
    raise AssertionError("no generator for %r" % f)


def random_values(m, rng):
    return {f.name: random_value(f, rng) for f in m.fields}


def boundary_values(f):
    # min, max and one step inside each, for scalar fields
    f = _inner(f)
    if isinstance(f, UInt):
        return [f.lo, f.hi, min(f.lo + 1, f.hi), max(f.hi - 1, f.lo)]
    if isinstance(f, Fixed):
        return [f.lo, f.hi, min(f.lo + f.res, f.hi), max(f.hi - f.res, f.lo)]
    if isinstance(f, Enum):
        return [f.labels[0], f.labels[-1]]
    if isinstance(f, Bool):
        return [False, True]
    raise AssertionError("no boundaries for %r" % f)


def same(f, sent, got):
    # True when got is what decoding sent must give
    f = _inner(f)
    if isinstance(f, Fixed):
        return abs(sent - got) <= f.res / 2 + near(abs(f.lo) + abs(f.hi)) and f.lo <= got <= f.hi
    if isinstance(f, Optional):
        if sent is None or got is None:
            return sent is None and got is None
        return same(f.field, sent, got)
    if isinstance(f, Array):
        return len(sent) == len(got) and all(same(f.field, a, b) for a, b in zip(sent, got))
    if isinstance(f, Nested):
        return same_values(f.message, sent, got)
    if isinstance(f, Bytes):
        return bytes(sent) == got
    return sent == got


def same_values(m, sent, got):
    return sorted(got) == sorted(f.name for f in m.fields) and all(same(f, sent[f.name], got[f.name]) for f in m.fields)
