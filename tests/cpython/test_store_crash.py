# acomm.transport.store under SIGKILL: a writer process (store_crash_writer.py) puts,
# replaces, deletes and compacts at random and is killed at a random moment,
# 200 times over the same file; every other run writes a few bytes per
# syscall so that kills also tear records. After each kill a copy of the file (and of a
# leftover .tmp) is recovered and compared with what the writer reported:
# every put() that returned is there with exactly its data, every delete()
# that returned is gone, and the one operation that was cut has either
# happened whole or not at all. The writer itself recovers the original on
# its next start, so both the writer's recovery and later appends after a
# torn tail are exercised.

import os
import random
import shutil
import sys
import time

from acomm.transport.store import Store

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from killer import kill_at_random  # noqa: E402
from store_crash_writer import CAPACITY, MAX_RECORD, data  # noqa: E402

RUNS = 200


def _parse(lines, model):
    # Applies acknowledged operations to model (key -> version); returns the
    # operation begun but not acknowledged, or None.
    pending = None
    for line in lines:
        f = line.split()
        if f[0][0] == "B":
            pending = f
        elif f[0] == "EP":
            model[int(f[1])] = int(f[2])
            pending = None
        elif f[0] == "ED":
            model.pop(int(f[1]), None)
            pending = None
        else:  # EC, FP: nothing changes
            pending = None
    return pending


def _check(path, model, pending):
    # Recovers a copy of the store at path; returns its stats.
    chk = path + "-check"
    for suffix in ("", ".tmp"):
        if os.path.exists(chk + suffix):
            os.remove(chk + suffix)
        if os.path.exists(path + suffix):
            shutil.copyfile(path + suffix, chk + suffix)
    s = Store(chk, capacity_bytes=CAPACITY, max_record=MAX_RECORD)
    try:
        keys = s.keys()
        assert len(set(keys)) == len(keys)
        cut = int(pending[1]) if pending and pending[0] in ("BP", "BD") else None
        for k in set(keys) | set(model):
            got = s.get(k)
            want = data(k, model[k]) if k in model else None
            if k == cut and got != want:
                # the cut operation happened whole
                if pending[0] == "BP":
                    assert got == data(k, int(pending[2])), k
                    model[k] = int(pending[2])
                else:
                    assert got is None, k
                    del model[k]
                continue
            assert got == want, (k, got, want)
        assert s.stats["corrupt_dropped"] == 0
        return dict(s.stats)
    finally:
        s.close()


def test_store_survives_kills(tmp_path):
    rng = random.Random(20240607)
    path = str(tmp_path / "store")
    model = {}
    torn = cut_puts = cut_compactions = tmp_left = acked = 0
    t0 = time.monotonic()
    for run in range(RUNS):
        lines = kill_at_random("store_crash_writer.py", path, run, rng)
        acked += sum(1 for line in lines if line[:2] in ("EP", "ED"))
        pending = _parse(lines, model)
        if pending is not None:
            cut_puts += pending[0] == "BP"
            cut_compactions += pending[0] == "BC"
        tmp_left += os.path.exists(path + ".tmp")
        stats = _check(path, model, pending)
        torn += stats["torn_dropped"]
    dt = time.monotonic() - t0
    # the kills landed where they matter
    print("kills %d acked %d torn %d cut puts %d cut compactions %d tmp left %d in %.1f s"
          % (RUNS, acked, torn, cut_puts, cut_compactions, tmp_left, dt))
    assert acked > 20 * RUNS
    assert torn > 0 and cut_puts > 0 and tmp_left > 0
    assert len(model) > 50
