# Shared by the crash tests: start a writer script, let it report a random
# number of lines after it said "R" (its operations begin and end in
# pairs; at most 0.2 s of them), then a random moment more, kill it with SIGKILL, and return the
# whole lines it reported (the last piece may be half a line and is left
# out). Counting lines first keeps enough work done before each kill on a
# loaded machine; the moment after lands kills inside long operations
# (compactions) in proportion to the time they take.
# Every other run passes "piecewise", so the writer tears its writes.

import os
import select
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def kill_at_random(script, path, run, rng):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join((ROOT, HERE, env.get("PYTHONPATH", "")))
    p = subprocess.Popen(
        [sys.executable, os.path.join(HERE, script), path, str(run)] + (["piecewise"] if run & 1 else []),
        stdout=subprocess.PIPE,
        bufsize=0,
        env=env,
    )
    fd = p.stdout.fileno()
    seen = b""
    try:
        while b"\n" not in seen:  # "R": the writer has recovered and starts
            more = os.read(fd, 4096)
            if not more:
                break
            seen += more
        want = rng.randint(20, 100)
        deadline = time.monotonic() + 0.2  # a full store makes every put a compaction: slow
        while seen.count(b"\n") <= want:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                break
            more = os.read(fd, 4096)
            if not more:
                break
            seen += more
        time.sleep(rng.uniform(0.0, 0.01))
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait()
    while True:
        more = os.read(fd, 65536)
        if not more:
            break
        seen += more
    p.stdout.close()
    lines = seen.decode().split("\n")[:-1]
    assert lines and lines[0] == "R", lines[:1]
    return lines[1:]
