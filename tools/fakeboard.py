#!/usr/bin/env python3
# A fake MicroPython board for mpremote: the MicroPython unix port behind a
# pseudo-terminal, so deploy scripts and tests can use the real mpremote
# command without hardware.
#
#   python tools/fakeboard.py --link /tmp/ttyFAKE --flash /tmp/flash &
#   mpremote connect /tmp/ttyFAKE fs cp main.py :/main.py + exec "import main"
#
# A pty is not a null-modem cable: its slave is the only end with a path, so
# the interpreter cannot sit on the same pty mpremote opens. We use two raw
# ptys and relay between their masters:
#
#   mpremote <-> slave A (symlinked at --link) | master A <-> fakeboard
#   fakeboard <-> master B | slave B <-> micropython -i -c BOOT (cwd = flash)
#
# and emulate what the unix port lacks compared with a board:
#   * soft reset: the port exits on Ctrl-D in the raw REPL; we print
#     "MPY: soft reboot", start a new one and put it back in the raw REPL;
#   * Ctrl-C: the port only reacts to SIGINT (our ptys are raw, so the byte
#     0x03 raises nothing); while it runs code we send SIGINT instead;
#   * SIGUSR1 to fakeboard is a hard reset (power cycle, banner printed; it
#     says 'fakeboard: reset' on its stdout when the board is back).
# SIGTERM/SIGINT stop it: child killed, link removed.  Stdlib only.
import argparse
import os
import select
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tty

RAW_PROMPT = b"raw REPL; CTRL-B to exit\r\n>"
FRIENDLY_PROMPT = b">>> "
BANNER_END = b'Type "help()" for more information.\r\n'
SOFT_REBOOT = b"MPY: soft reboot\r\n"  # what boards print; mpremote waits for "soft reboot\r\n"
START_TIMEOUT_S = 10
SIGINT_GAP_S = 0.1
LOG = os.environ.get("FAKEBOARD_LOG")

# Run before the REPL: make the flash dir the device's "/" so ":/lib/x.py"
# is FLASH/lib/x.py on the host, and give sys.path a board's shape.
BOOT = """\
import vfs, os, sys
vfs.umount('/')
vfs.mount(vfs.VfsPosix({flash!r}), '/')
os.chdir('/')
sys.path.clear()
sys.path.extend(['', '.frozen', '/lib'])
del vfs, os, sys
"""


def catches_sigint(pid):
    # The unix port installs its SIGINT handler only while it executes code
    # (SIG_DFL otherwise, which would kill it). SigCgt is the caught-signals mask.
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("SigCgt:"):
                    return bool(int(line.split()[1], 16) & (1 << (signal.SIGINT - 1)))
    except OSError:
        pass
    return False


def write(fd, data):
    # Non-blocking write; returns how much went out.
    try:
        return os.write(fd, data)
    except BlockingIOError:
        return 0


def raw_pty():
    master, slave = os.openpty()
    tty.setraw(slave)  # also clears OPOST, so "\r\n" is not sent as "\r\r\n"
    os.set_blocking(master, False)
    return master, slave


class FakeBoard:
    def __init__(self, cmd, flash, heap):
        self.cmd, self.flash, self.heap = cmd, flash, heap
        self.proc = None
        self.board = -1  # master B: the interpreter's side
        self.raw = False  # is the interpreter in the raw REPL? (from its output)
        self.tail = b""
        self.to_host, self.to_board = b"", b""
        self.last_sigint, self.intr_due = 0.0, False
        self.stop = self.hard_reset = False
        # The host side lives as long as we do; keeping slave A open means
        # mpremote's close never gives us EIO, so it can reconnect any time.
        self.host, self.host_slave = raw_pty()
        self.wake_r, wake_w = os.pipe()
        os.set_blocking(wake_w, False)
        signal.set_wakeup_fd(wake_w)  # wakes select() when a signal arrives

    def kill(self):
        if self.proc is not None:
            if self.proc.poll() is None:  # its own session, so the whole group goes
                os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
            self.proc = None
        if self.board >= 0:
            os.close(self.board)
            self.board = -1

    def read_until(self, marker):
        # Read the interpreter's output up to marker (blocking, bounded).
        data, deadline = b"", time.monotonic() + START_TIMEOUT_S
        while not data.endswith(marker):
            left = deadline - time.monotonic()
            if self.stop or left <= 0:
                raise RuntimeError("interpreter did not print %r; got %r" % (marker, data))
            r, _, _ = select.select([self.board, self.wake_r], [], [], left)
            if self.wake_r in r:
                os.read(self.wake_r, 64)
            if self.board in r:
                try:
                    chunk = os.read(self.board, 4096)
                except BlockingIOError:
                    continue
                except OSError:  # EIO: it exited
                    chunk = b""
                if not chunk:
                    raise RuntimeError("interpreter exited during start: %r" % data)
                data += chunk
        return data

    def start(self, raw):
        # Start a fresh interpreter; return what a board would print on boot.
        self.kill()
        self.board, slave = raw_pty()
        boot = BOOT.format(flash=self.flash)
        argv = self.cmd + ["-X", "heapsize=" + self.heap, "-i", "-c", boot]
        self.log("start", "raw" if raw else "friendly")
        self.proc = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave,
                                     cwd=self.flash, start_new_session=True)
        os.close(slave)  # so its exit shows up as EIO on master B
        banner = self.read_until(FRIENDLY_PROMPT)
        # Input meant for the old interpreter is lost, as on a board.
        self.to_board, self.tail, self.intr_due = b"", b"", False
        self.raw = raw
        if not raw:
            return banner
        os.write(self.board, b"\r\x01")  # back into the raw REPL, banner swallowed
        self.read_until(RAW_PROMPT)
        return RAW_PROMPT

    def log(self, tag, data):
        if LOG:  # debugging aid: FAKEBOARD_LOG=file logs all traffic
            with open(LOG, "a") as f:
                f.write("%.3f %s %r\n" % (time.monotonic(), tag, data))

    def from_host(self, data):
        self.log("host>", data)
        if b"\x03" in data and catches_sigint(self.proc.pid):
            self.intr_due = True  # the port is running code: Ctrl-C means SIGINT
            data = data.replace(b"\x03", b"")
        self.to_board += data

    def interrupt(self):
        # Send a due SIGINT; return how long to wait before trying again. A
        # second SIGINT before the first is handled makes the port exit(1),
        # so they are spaced out (mpremote calls can come 0.1 s apart).
        left = self.last_sigint + SIGINT_GAP_S - time.monotonic()
        if left > 0:
            return left
        self.intr_due = False
        if catches_sigint(self.proc.pid):
            self.log("SIGINT", b"")
            os.kill(self.proc.pid, signal.SIGINT)
            self.last_sigint = time.monotonic()
        else:  # it finished meanwhile: deliver the plain byte
            self.to_board += b"\x03"
        return 1.0

    def from_board(self, data):
        self.log("<board", data)
        # Track raw/friendly REPL from the prompts the port prints.
        buf = self.tail + data
        i, j = buf.rfind(RAW_PROMPT[:-1]), buf.rfind(BANNER_END)
        if i >= 0 or j >= 0:
            self.raw = i > j
        self.tail = buf[-64:]
        self.to_host += data

    def loop(self):
        while not self.stop:
            if self.hard_reset:
                self.hard_reset = False
                self.to_host += self.start(raw=False)
                print("fakeboard: reset", flush=True)  # what a test waits on
            timeout = self.interrupt() if self.intr_due else 1.0
            rl = [self.wake_r]
            if not self.to_board:
                rl.append(self.host)
            if not self.to_host:  # backpressure, as a USB CDC port gives
                rl.append(self.board)
            wl = ([self.host] if self.to_host else []) + ([self.board] if self.to_board else [])
            r, w, _ = select.select(rl, wl, [], timeout)
            if self.wake_r in r:
                os.read(self.wake_r, 64)
                continue  # re-check the flags first
            if self.host in r:
                try:
                    self.from_host(os.read(self.host, 4096))
                except BlockingIOError:
                    pass
            if self.board in r:
                try:
                    data = os.read(self.board, 4096)
                except BlockingIOError:
                    continue
                except OSError:  # EIO: the interpreter has exited
                    data = b""
                if data:
                    self.from_board(data)
                else:
                    # Exit = soft reset (Ctrl-D, sys.exit(), machine.soft_reset()).
                    self.to_host += SOFT_REBOOT + self.start(raw=self.raw)
            if self.host in w:
                self.to_host = self.to_host[write(self.host, self.to_host):]
            if self.board in w:
                self.to_board = self.to_board[write(self.board, self.to_board):]


def main():
    ap = argparse.ArgumentParser(description="MicroPython unix port as a board for mpremote")
    ap.add_argument("--link", required=True, help="symlink to create for mpremote to connect to")
    ap.add_argument("--flash", required=True, help="host directory that is the device's /")
    ap.add_argument("--heap", default="192wk", help="micropython -X heapsize (default 192wk)")
    ap.add_argument("--micropython", default=None, help="interpreter command")
    args = ap.parse_args()
    near = os.path.join(os.path.dirname(sys.executable), "micropython")
    if args.micropython:
        cmd = shlex.split(args.micropython)
    else:  # the one in our venv, else the one on PATH
        cmd = [near if os.access(near, os.X_OK) else shutil.which("micropython") or "micropython"]
    flash = os.path.abspath(args.flash)
    os.makedirs(os.path.join(flash, "lib"), exist_ok=True)
    link = args.link
    if os.path.lexists(link):
        if not os.path.islink(link):
            sys.exit("fakeboard: refusing to replace %s: not a symlink" % link)
        os.unlink(link)

    fb = FakeBoard(cmd, flash, args.heap)

    # Handlers only set flags; the wakeup fd makes the loop look at them.
    signal.signal(signal.SIGTERM, lambda *_: setattr(fb, "stop", True))
    signal.signal(signal.SIGINT, lambda *_: setattr(fb, "stop", True))
    signal.signal(signal.SIGUSR1, lambda *_: setattr(fb, "hard_reset", True))
    target = os.ttyname(fb.host_slave)
    try:
        os.symlink(target, link)
        fb.start(raw=False)  # the first banner is printed to nobody, like a power-on
        print("fakeboard: ready %s" % link, flush=True)
        fb.loop()
    except (RuntimeError, OSError) as e:  # e.g. no micropython, or it would not start
        if not fb.stop:
            print("fakeboard: %s" % e, file=sys.stderr)
            return 1
    finally:
        fb.kill()
        if os.path.islink(link) and os.readlink(link) == target:
            os.unlink(link)
    return 0


if __name__ == "__main__":
    sys.exit(main())
