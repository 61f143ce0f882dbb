# kill -9, over and over, of a process writing what a node keeps on disk:
# acomm.transport.store records (puts, replacements, deletes, compactions),
# the transport's delivered pairs (PacketStore.save_done, in a store of
# their own) and a receiver's replay counters (acomm.frame.auth.Auth with a
# counter file: open() then commit(), as the node does when it accepts a
# command). The writer is a fork of this process (starting a Python per
# life would take most of a minute for 1,000 lives); it reports each write
# on a pipe before it begins and after it returned, and is killed with
# SIGKILL at a random moment, KILLS times over the same files.
#
# After each kill a copy of the files is opened as a restarted node would
# and checked: every put() that returned is there with exactly its data,
# every delete() that returned is gone, the last save_done() that returned
# (or the one that was cut) is what the transport gets back, and the last
# frame whose commit() returned is refused as a replay (its counter is not
# above the highest the file remembers). The one write that was cut has
# happened whole or not at all.
#
# sync=False: the stores only flush to the OS. A killed process loses
# nothing the kernel has, so fsync adds nothing here but time (it matters
# for a power cut, which a kill is not); Auth's file is written the same way.

import os
import random
import shutil
import signal
import time

from acomm.errors import AuthError, StoreFull
from acomm.frame.auth import Auth
from acomm.transport.packetstore import PacketStore
from acomm.transport.store import Store

KILLS = 1000
CAPACITY = 16 * 1024
KEYS = 50
KEY = bytes(range(1, 17))
SRC, DST, FTYPE = 5, 1, 3


def _data(key, ver):
    # verifiable: derived from the key and the version only
    n = 1 + (key * 7 + ver) % 200
    return bytes((key * 131 + ver * 17 + i * 3) & 0xFF for i in range(n))


def _writer(d, seed, ver, fd):
    # the child: writes until it is killed; never returns
    rng = random.Random(seed)

    def say(s):
        os.write(fd, (s + "\n").encode())

    s = Store(os.path.join(d, "store"), capacity_bytes=CAPACITY, max_record=256, sync=False)
    done = PacketStore(Store(os.path.join(d, "done"), capacity_bytes=4096, max_record=256, sync=False))
    tx = Auth(KEY, path=os.path.join(d, "tx"))  # the command's sender, its counter resumed from its file
    rx = Auth(KEY, path=os.path.join(d, "rx"))
    say("R")
    while True:
        r = rng.random()
        k = rng.randrange(KEYS)
        if r < 0.02:
            say("B C")
            s.compact()
        elif r < 0.22:
            say("B D %d" % k)
            s.delete(k)
        elif r < 0.37:
            pairs = bytes(rng.randrange(256) for _ in range(15))
            say("B S %s" % pairs.hex())
            done.save_done(pairs)
        elif r < 0.52:
            frame = tx.seal(FTYPE, SRC, DST, b"do it")
            say("B A %s" % frame.hex())
            rx.open(FTYPE, SRC, DST, frame)
            rx.commit()
        else:
            ver += 1
            say("B P %d %d" % (k, ver))
            try:
                s.put(k, _data(k, ver))
            except StoreFull:
                say("F")
                continue
        say("E")


def _life(d, seed, ver, rng):
    # one writer from start to kill -> the lines it reported (whole ones)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        try:
            os.close(r)
            _writer(d, seed, ver, w)
        finally:
            os._exit(1)
    os.close(w)
    seen = b""
    try:
        while b"\n" not in seen:  # "R": it has recovered and starts writing
            more = os.read(r, 4096)
            if not more:
                break
            seen += more
        # a random number of writes, then a random moment more: the kill
        # lands anywhere, inside compactions in proportion to their time
        want = rng.randint(0, 60)
        deadline = time.monotonic() + 0.1
        while seen.count(b"\n") <= want and time.monotonic() < deadline:
            more = os.read(r, 4096)
            if not more:
                break
            seen += more
        time.sleep(rng.uniform(0.0, 0.002))
    finally:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
    while True:
        more = os.read(r, 65536)
        if not more:
            break
        seen += more
    os.close(r)
    lines = seen.decode().split("\n")[:-1]
    assert lines and lines[0] == "R", lines[:1]
    return lines[1:]


def _copy(d, names):
    # the files as a restarted node finds them, copied so that the writer's
    # own recovery of the originals is exercised in its next life
    c = os.path.join(d, "check")
    shutil.rmtree(c, ignore_errors=True)
    os.mkdir(c)
    for n in os.listdir(d):
        if n.split(".")[0] in names:
            shutil.copyfile(os.path.join(d, n), os.path.join(c, n))
    return c


def test_kill_9_loses_no_acknowledged_write(tmp_path):
    d = str(tmp_path)
    rng = random.Random(37)
    model = {}  # key -> version
    pairs = b""  # the delivered pairs last saved
    frame = None  # the last frame whose commit() returned
    kills = acked = cut = 0
    t0 = time.monotonic()
    while kills < KILLS:
        lines = _life(d, kills, kills * 100000, rng)
        kills += 1
        pending = None
        for line in lines:
            f = line.split()
            if f[0] == "B":
                pending = f[1:]
            elif f[0] == "F":
                pending = None  # refused: the capacity, not the disk
            elif f[0] == "E":
                acked += 1
                op = pending
                pending = None
                if op[0] == "P":
                    model[int(op[1])] = int(op[2])
                elif op[0] == "D":
                    model.pop(int(op[1]), None)
                elif op[0] == "S":
                    pairs = bytes.fromhex(op[1])
                elif op[0] == "A":
                    frame = bytes.fromhex(op[1])
        cut += pending is not None
        c = _copy(d, ("store", "done", "rx"))
        # the store: every acknowledged put there, every acknowledged delete gone
        s = Store(os.path.join(c, "store"), capacity_bytes=CAPACITY, max_record=256, sync=False)
        try:
            ck = int(pending[1]) if pending and pending[0] in ("P", "D") else None
            for k in set(s.keys()) | set(model):
                got, want = s.get(k), (_data(k, model[k]) if k in model else None)
                if k == ck and got != want:  # the cut write happened whole
                    if pending[0] == "P":
                        assert got == _data(k, int(pending[2])), (kills, k)
                        model[k] = int(pending[2])
                    else:
                        assert got is None, (kills, k)
                        del model[k]
                    continue
                assert got == want, (kills, k, got, want)
            assert s.stats["corrupt_dropped"] == 0
        finally:
            s.close()
        # the delivered pairs as the restarted transport reads them back
        st = Store(os.path.join(c, "done"), capacity_bytes=4096, max_record=256, sync=False)
        try:
            ps = PacketStore(st)
            ps.recover()
            cand = [pairs] + ([bytes.fromhex(pending[1])] if pending and pending[0] == "S" else [])
            assert ps.done in cand or (not pairs and ps.done == b""), (kills, ps.done.hex(), pairs.hex())
            pairs = ps.done
        finally:
            st.close()
        # the receiver's counters: the last committed frame is a replay now
        if frame is not None:
            rx = Auth(KEY, path=os.path.join(c, "rx"))
            try:
                rx.open(FTYPE, SRC, DST, frame)
            except AuthError:
                pass
            else:
                raise AssertionError("kill %d: a committed frame was taken again after the restart" % kills)
    dt = time.monotonic() - t0
    print("kill -9: %d kills, %d acknowledged writes, %d cut mid-write, %d keys stored, in %.1f s"
          % (kills, acked, cut, len(model), dt))
    assert kills >= 1000 and acked > 3 * kills and cut > kills // 2
