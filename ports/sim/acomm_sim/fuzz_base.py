# What the fuzz engine (acomm_sim.fuzz) and its targets (fuzz_control,
# fuzz_decoders, fuzz_drivers, fuzz_store) share: the Failure an oracle
# raises, the Target record, and the mutators. A leaf: it imports nothing
# of acomm_sim, so the engine's registry is the only import that reaches
# the targets, and no target imports the engine back.


class Failure(Exception):
    # An oracle broken by an input (not an acomm error: it must escape).
    pass


class Target:
    # name, corpus and run(data, rng) of a fuzz target (acomm_sim.fuzz's
    # header); make(rng), when given, makes inputs of its own
    def __init__(self, name, corpus, run, make=None):
        self.name = name
        self.corpus = corpus
        self.run = run
        if make is not None:
            self.make = make


# -- mutators ---------------------------------------------------------------
# Each takes (rng, data, corpus) and returns new bytes. Sizes stay bounded
# (at most the input plus 64 bytes per step, a few steps per case) so a
# decoder's time per case stays small.

def _flip(rng, d, corpus):
    if not d:
        return d
    b = bytearray(d)
    for _ in range(1 + rng.below(4)):
        p = rng.below(len(b) * 8)
        b[p >> 3] ^= 0x80 >> (p & 7)
    return bytes(b)


_SPECIAL = (0, 1, 0x7F, 0x80, 0xFF, 0x0A, 0x0D, 0x24, 0x2C, 0x2A, 0xC0, 0xDB, 0xFE)


def _set(rng, d, corpus):
    if not d:
        return d
    b = bytearray(d)
    for _ in range(1 + rng.below(3)):
        b[rng.below(len(b))] = _SPECIAL[rng.below(len(_SPECIAL))] if rng.chance(0.5) else rng.below(256)
    return bytes(b)


def _truncate(rng, d, corpus):
    if not d:
        return d
    if rng.chance(0.5):
        return d[: rng.below(len(d))]
    return d[rng.below(len(d)) :]


def _extend(rng, d, corpus):
    tail = rng.bytes(1 + rng.below(32))
    return d + tail if rng.chance(0.7) else tail + d


def _insert(rng, d, corpus):
    p = rng.below(len(d) + 1)
    return d[:p] + rng.bytes(1 + rng.below(16)) + d[p:]


def _delete(rng, d, corpus):
    if len(d) < 2:
        return d
    p = rng.below(len(d))
    return d[:p] + d[p + 1 + rng.below(min(8, len(d) - p)) :]


def _splice(rng, d, corpus):
    # the head of one valid input and the tail of another
    o = corpus[rng.below(len(corpus))]
    return d[: rng.below(len(d) + 1)] + o[rng.below(len(o) + 1) :]


def _concat(rng, d, corpus):
    # two valid inputs back to back, maybe garbage in between
    o = corpus[rng.below(len(corpus))]
    mid = rng.bytes(rng.below(8)) if rng.chance(0.5) else b""
    return d + mid + o


def _repeat(rng, d, corpus):
    if not d:
        return d
    a = rng.below(len(d))
    n = 1 + rng.below(min(16, len(d) - a))
    return d[: a + n] + d[a : a + n] * (1 + rng.below(3)) + d[a + n :]


MUTATORS = (_flip, _set, _truncate, _extend, _insert, _delete, _splice, _concat, _repeat)


def mutate(rng, corpus, limit=4096):
    # A valid input changed by 1..3 mutators, or (1 in 16) plain noise.
    if not corpus or rng.below(16) == 0:
        return rng.bytes(rng.below(64))
    d = corpus[rng.below(len(corpus))]
    for _ in range(1 + rng.below(3)):
        d = MUTATORS[rng.below(len(MUTATORS))](rng, d, corpus)
    return d[:limit]
