# Shared by the crash tests: start a writer script, let it run for a random
# moment after it said "R", kill it with SIGKILL, and return the whole lines
# it reported (the last piece may be half a line and is left out).
# Every other run passes "piecewise", so the writer tears its writes.

import os
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
        env=env,
    )
    try:
        assert p.stdout.readline() == b"R\n"
        time.sleep(rng.uniform(0.0, 0.03))
    finally:
        p.send_signal(signal.SIGKILL)
        p.wait()
    out = p.stdout.read().decode()
    p.stdout.close()
    return out.split("\n")[:-1]
