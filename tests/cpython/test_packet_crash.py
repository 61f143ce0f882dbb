# The transport's packets under SIGKILL: packet_crash_writer.py accepts and
# finishes multi-record packets on a store file and is killed at a random
# moment, 200 times over the same file (every other run writing a few bytes
# per syscall, so kills also tear records). After each kill a copy of the
# file is recovered through acomm.transport.packetstore, as a restarted transport
# would: every packet whose put() returned is there with exactly its bytes,
# every packet whose delete() returned is gone, the one operation that was
# cut happened whole or not at all (never half a packet), and no packet id
# the writer used is handed out again.

import os
import random
import shutil
import sys

from acomm.transport.packetstore import PacketStore
from acomm.transport.store import Store

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from killer import kill_at_random  # noqa: E402
from packet_crash_writer import CAPACITY, MAX_RECORD, body  # noqa: E402

RUNS = 200


def _recover(path):
    chk = path + "-check"
    for suffix in ("", ".tmp"):
        if os.path.exists(chk + suffix):
            os.remove(chk + suffix)
        if os.path.exists(path + suffix):
            shutil.copyfile(path + suffix, chk + suffix)
    st = Store(chk, capacity_bytes=CAPACITY, max_record=MAX_RECORD)
    try:
        ps = PacketStore(st)
        got = dict((s.pid, ps.body(s.key)) for s in ps.recover())
        return got, ps.next_pid()
    finally:
        st.close()


def test_packets_survive_kills(tmp_path):
    rng = random.Random(20261122)
    path = str(tmp_path / "store")
    live = set()
    used = 0
    acked = cut = multi = 0
    for run in range(RUNS):
        lines = kill_at_random("packet_crash_writer.py", path, run, rng)
        pending = None
        for line in lines:
            f = line.split()
            pid = int(f[1])
            if f[0][0] == "B":
                pending = (f[0], pid)
                if f[0] == "BP":
                    used = max(used, pid)
            else:
                pending = None
                acked += 1
                if f[0] == "EP":
                    live.add(pid)
                elif f[0] == "ED":
                    live.discard(pid)
        got, next_pid = _recover(path)
        if pending is not None:
            cut += 1
            op, pid = pending
            # the cut operation: whole or not at all
            if pid in got:
                live.add(pid)
            else:
                live.discard(pid)
        assert set(got) == live, (run, sorted(set(got) ^ live))
        for pid in got:
            assert got[pid] == body(pid), pid
            multi += len(got[pid]) > MAX_RECORD
        assert next_pid > used  # never an id the writer may have used
    print("kills %d acked %d cut %d multi-record packets seen %d" % (RUNS, acked, cut, multi))
    assert acked > 5 * RUNS and cut > RUNS // 2 and multi > 0
