# The fuzz engine of `acomm fuzz`: random and mutated inputs
# against acomm's decoders, drivers and store, on both runtimes.
#
# It lives in the simulator package, not in acomm/: it is test tooling that
# no board carries, and ports/sim is on the path of both the CPython tests
# and tools/mp_runtests.py, so the short fuzz of tests/core runs the same
# code under MicroPython. Portable Python, stdlib only; randomness from
# acomm.prng so that a seed gives the same inputs on both runtimes.
#
# A target is an object (fuzz_base.Target, or any with these) with
#   name          short name (the CLI's --target)
#   corpus        list of valid inputs (bytes), built with acomm's encoders
#   run(data, rng) feeds one input to the decoder and checks its oracle;
#                 raises Failure when the oracle is broken. Any exception
#                 that is not an acomm.errors.AcommError is a failure too.
#   optional make(rng) -> bytes: an input of its own (else mutate()).
#
# Every case is a function of (seed, target name, case number) alone: a
# failure is reproduced with `acomm fuzz --seed S --target T --case N`
# whatever ran before it. Targets keep no state between cases except what
# they check on purpose (the driver targets' long-lived drivers, which are
# reset by their own case numbers; see fuzz_drivers).

from acomm.errors import AcommError
from acomm.prng import Prng

from acomm.compat import ticks_diff as _diff
from acomm.compat import ticks_ms as _ms

# the leaf the targets share with the engine (acomm_sim.fuzz.Failure and
# .mutate stay importable from here)
from .fuzz_base import Failure, mutate


def name_hash(s):
    # FNV-1a of the name: the same on both runtimes (hash() is not)
    h = 0x811C9DC5
    for c in s.encode():
        h = ((h ^ c) * 0x01000193) & 0xFFFFFFFF
    return h


def case_rng(seed, name, case):
    return Prng((seed * 0x9E3779B1 + name_hash(name) + case * 0x85EBCA6B) & 0xFFFFFFFF)


# -- running ------------------------------------------------------------------

def input_of(target, rng):
    make = getattr(target, "make", None)
    if make is not None and rng.chance(0.5):
        return make(rng)
    return mutate(rng, target.corpus)


def run_case(target, seed, case, hook=None):
    # -> None, or (input bytes, description) when the case failed. hook:
    # None, or an object whose before() and after(target, data) bracket the
    # case (acomm fuzz --corpus: what lines of acomm the input reached)
    rng = case_rng(seed, target.name, case)
    data = b""
    if hook is not None:
        hook.before()
    try:
        data = input_of(target, rng)
        target.run(data, rng)
    except AcommError:
        pass  # bad input, refused the expected way
    except Failure as e:
        return data, "oracle: %s" % (e,)
    except Exception as e:  # anything else is a decoder bug
        return data, "%s: %s" % (type(e).__name__, e)
    finally:
        if hook is not None:
            hook.after(target, data)
    return None


class Result:
    def __init__(self, name):
        self.name = name
        self.inputs = 0
        self.failures = 0
        self.first = []  # up to 3 of (case, input, description)
        self.ms = 0


def run(targets, seed=1, ms=None, cases=None, on_failure=None, start=0, hook=None):
    # Runs the targets round robin, a batch of cases each turn, until `ms`
    # (real milliseconds) have passed or each has run `cases` cases. With
    # `ms`, each target's batch is sized to take about 50 ms, so every
    # target gets the same share of the time (a decoder runs thousands of
    # cases while a driver in a World runs tens). hook: see run_case.
    # -> [Result] in target order.
    results = [Result(t.name) for t in targets]
    t0 = _ms()
    nxt = [start] * len(targets)
    batch = [50] * len(targets)
    while True:
        busy = False
        for i, t in enumerate(targets):
            r = results[i]
            n = batch[i] if cases is None else min(batch[i], cases - r.inputs)
            if n <= 0:
                continue
            busy = True
            a = _ms()
            for _ in range(n):
                case = nxt[i]
                nxt[i] += 1
                bad = run_case(t, seed, case, hook)
                r.inputs += 1
                if bad is not None:
                    r.failures += 1
                    if len(r.first) < 3:
                        r.first.append((case, bad[0], bad[1]))
                    if on_failure is not None:
                        on_failure(t.name, case, bad[0], bad[1])
            took = _diff(_ms(), a)
            r.ms += took
            if cases is None:
                batch[i] = max(10, min(20000, n * 50 // max(took, 1)))
            if ms is not None and _diff(_ms(), t0) >= ms:
                return results
        if not busy:
            return results


def all_targets(names=None, tmpdir=None):
    # Every target, or those named. Imported here so a caller that fuzzes
    # one family does not build the others' corpora.
    from . import fuzz_control, fuzz_decoders, fuzz_drivers, fuzz_store

    ts = (fuzz_decoders.targets() + [fuzz_control.target(), fuzz_control.file_target(tmpdir)] + fuzz_drivers.targets()
          + fuzz_store.targets(tmpdir))
    if names:
        ts = [t for t in ts if t.name in names]
    return ts
