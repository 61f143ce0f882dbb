# Shared harness for the tests that drive `acomm` commands as a user does:
# child processes whose standard output is read line by line with a
# deadline (a reader thread per process, so no wait can hang the suite),
# whose standard input takes console lines, and an `acomm emulate` water
# with beacons on pseudo-terminals. The command is `python -m
# acomm_cpython.cli` of this tree unless a test gives another (the wheel
# test runs the installed `acomm`).

import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TIMEOUT_S = 20


def tree_env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [os.path.join(ROOT, "ports", p) for p in ("cpython", "sim", "web",
                                                                                           "micropython")])
    return env


def acomm_cmd():
    return [sys.executable, "-m", "acomm_cpython.cli"]


class Proc:
    """A running command: expect() reads its output lines, send() types a line."""

    def __init__(self, args, cmd=None, env=None, cwd=None):
        self.args = list(args)
        self.p = subprocess.Popen((cmd or acomm_cmd()) + self.args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, env=env or tree_env(), cwd=cwd, text=True, bufsize=1)
        self.lines = []  # every line read so far
        self._q = queue.Queue()
        self._t = threading.Thread(target=self._read, daemon=True)
        self._t.start()

    def _read(self):
        for line in self.p.stdout:
            self._q.put(line.rstrip("\n"))
        self._q.put(None)

    def expect(self, want, timeout=TIMEOUT_S):
        """The first new line containing `want` (or for which want(line) is true); AssertionError at the deadline."""
        test = want if callable(want) else (lambda ln: want in ln)
        end = time.monotonic() + timeout
        while True:
            left = end - time.monotonic()
            try:
                line = self._q.get(timeout=max(0.01, left))
            except queue.Empty:
                line = None
                left = 0
            if line is not None:
                self.lines.append(line)
                if test(line):
                    return line
                continue
            if left <= 0 or self.p.poll() is not None:
                err = self.p.stderr.read() if self.p.poll() is not None else "(still running)"
                raise AssertionError("%r not seen from %s; output so far:\n%s\nstderr: %s" % (
                    want, " ".join(self.args), "\n".join(self.lines), err))

    def send(self, line):
        self.p.stdin.write(line + "\n")
        self.p.stdin.flush()

    def finish(self, how="eof", timeout=TIMEOUT_S):
        """Ends the command (end of input, or a signal) -> (exit status, stderr)."""
        if how == "eof":
            self.p.stdin.close()
        else:
            self.p.send_signal(how)
        try:
            rc = self.p.wait(timeout)
        except subprocess.TimeoutExpired:
            self.p.kill()
            self.p.wait()
            raise AssertionError("%s did not stop: %s" % (" ".join(self.args), "\n".join(self.lines)))
        self._t.join(5)
        while True:
            try:
                line = self._q.get_nowait()
            except queue.Empty:
                break
            if line is not None:
                self.lines.append(line)
        err = self.p.stderr.read()
        for f in (self.p.stdin, self.p.stdout, self.p.stderr):
            try:
                f.close()
            except (OSError, ValueError):
                pass
        return rc, err

    def kill(self):
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait()


def run(args, cmd=None, env=None, timeout=60, stdin=""):
    """Runs a command to its end -> (exit status, stdout, stderr)."""
    p = subprocess.run((cmd or acomm_cmd()) + list(args), capture_output=True, text=True, env=env or tree_env(),
                       timeout=timeout, input=stdin)
    return p.returncode, p.stdout, p.stderr


class Water:
    """`acomm emulate seatrac` with beacons 1..n on ptys at dir/beacon<i>, 150 m apart."""

    def __init__(self, tmpdir, n=2, time_scale=5, cmd=None, env=None):
        self.paths = [os.path.join(str(tmpdir), "beacon%d" % i) for i in range(1, n + 1)]
        args = ["emulate", "seatrac", "--link", self.paths[0], "--address", "1", "--time-scale", str(time_scale)]
        for i, path in enumerate(self.paths[1:], 2):
            args += ["--peer", "%d:%s:150" % (i, path)]
        self.proc = Proc(args, cmd, env)
        for path in self.paths:
            self.proc.expect(path)

    def close(self):
        rc, err = self.proc.finish(signal.SIGTERM)
        return rc

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self.proc.p.poll() is None:
            self.close()


def free_port():
    """A TCP port on loopback that nothing listens on now (for a server a test starts)."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port
