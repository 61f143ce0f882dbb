# The writer that tests/cpython/test_store_crash.py kills: puts, replaces,
# deletes and compacts records in an acomm.transport.store at random, forever, and
# reports each operation on stdout before it starts ("B...") and after it
# returned ("E...", or "F..." when put() refused with StoreFull), so that
# the test knows what was acknowledged and which one operation was cut.
#
#   python store_crash_writer.py PATH SEED [piecewise]
#
# A kill cannot split one write() syscall to a regular file, and the store's
# buffered file hands each record to the kernel in one, so "piecewise" makes
# every write reach the file 7 bytes per syscall and 20 us or so, as a slow
# flash would take it: then kills leave torn records too.

import io
import random
import sys
import time

import acomm.transport.store
from acomm.errors import StoreFull
from acomm.transport.store import Store


class Piecewise:
    def __init__(self, raw):
        self._raw = raw

    def write(self, b):
        mv = memoryview(b)
        for i in range(0, len(mv), 7):
            self._raw.write(mv[i : i + 7])
            time.sleep(0.00002)
        return len(mv)

    def __getattr__(self, name):
        return getattr(self._raw, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self._raw.close()

CAPACITY = 40 * 1024
MAX_RECORD = 256
KEYS = 300


def data(key, ver):
    # verifiable: derived from the key and the version only
    n = 1 + (key * 7 + ver) % 200
    return bytes((key * 131 + ver * 17 + i * 3) & 0xFF for i in range(n))


def main(path, seed):
    rng = random.Random(seed)
    s = Store(path, capacity_bytes=CAPACITY, max_record=MAX_RECORD)
    out = sys.stdout

    def say(line):
        out.write(line + "\n")
        out.flush()

    say("R")
    while True:
        r = rng.random()
        k = rng.randrange(KEYS)
        if r < 0.03:
            say("BC")
            s.compact()
            say("EC")
        elif r < 0.28:
            say("BD %d" % k)
            s.delete(k)
            say("ED %d" % k)
        else:
            v = rng.randrange(1 << 20)
            say("BP %d %d" % (k, v))
            try:
                s.put(k, data(k, v))
            except StoreFull:
                say("FP %d %d" % (k, v))
                continue
            say("EP %d %d" % (k, v))


if __name__ == "__main__":
    if sys.argv[3:] == ["piecewise"]:
        # the store's module-level name shadows the builtin
        acomm.transport.store.open = lambda path, mode="r": Piecewise(io.open(path, mode, buffering=0))
    main(sys.argv[1], int(sys.argv[2]))
