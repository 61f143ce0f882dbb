# tools/fakeboard.py proven with the real mpremote command: every test
# starts a fake board (the MicroPython unix port behind a pty) on a flash
# directory and a link in tmp_path, drives it with mpremote subprocesses
# (each bounded by a timeout) and always stops it afterwards.
#
# Skips only when the micropython or mpremote command is missing.

import os
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

if not sys.platform.startswith("linux"):
    pytest.skip("fakeboard needs Linux ptys and /proc", allow_module_level=True)

BIN = Path(sys.executable).parent
FAKEBOARD = Path(__file__).resolve().parents[2] / "tools" / "fakeboard.py"
MPREMOTE = BIN / "mpremote"
MICROPYTHON = BIN / "micropython" if (BIN / "micropython").exists() else shutil.which("micropython")
TIMEOUT_S = 30

if not MPREMOTE.exists():
    pytest.skip("no mpremote next to %s" % sys.executable, allow_module_level=True)
if MICROPYTHON is None:
    pytest.skip("no micropython command", allow_module_level=True)


def children(pid):
    # pids whose parent is pid (from /proc, so no ps needed)
    out = []
    for d in os.listdir("/proc"):
        try:
            with open("/proc/%s/stat" % d) as f:
                if int(f.read().rsplit(")", 1)[1].split()[1]) == pid:
                    out.append(int(d))
        except (OSError, ValueError, IndexError):
            pass
    return out


class Board:
    def __init__(self, tmp_path, heap="192wk"):
        self.flash = tmp_path / "flash"
        self.link = str(tmp_path / "ttyFAKE")
        self.errlog = open(tmp_path / "fakeboard.err", "w+")
        self.proc = subprocess.Popen(
            [sys.executable, str(FAKEBOARD), "--link", self.link, "--flash", str(self.flash),
             "--heap", heap, "--micropython", str(MICROPYTHON)],
            stdout=subprocess.PIPE, stderr=self.errlog, text=True)
        self.wait_line("fakeboard: ready %s\n" % self.link, "fakeboard did not start: ")

    def wait_line(self, want, what):
        # the board process says when it is ready, or reset: wait for that line
        deadline = time.monotonic() + TIMEOUT_S
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or self.proc.poll() is not None:
                self.stop()
                raise AssertionError(what + self.stderr())
            if select.select([self.proc.stdout], [], [], left)[0]:
                if self.proc.stdout.readline() == want:
                    return

    def stderr(self):
        self.errlog.seek(0)
        return self.errlog.read()

    def mp(self, *args, ok=True):
        # One mpremote call; returns its stdout.
        r = subprocess.run([str(MPREMOTE), "connect", self.link, *args],
                           capture_output=True, text=True, timeout=TIMEOUT_S)
        if ok:
            assert r.returncode == 0, (args, r.stdout, r.stderr, self.stderr())
        return r.stdout

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stdout.close()
        self.errlog.close()


@pytest.fixture
def board(tmp_path):
    b = Board(tmp_path)
    try:
        yield b
    finally:
        b.stop()


def test_exec(board):
    assert board.mp("exec", "print(1+1)").strip() == "2"


def test_fs_cp_lands_in_flash_lib_and_imports(board, tmp_path):
    src = tmp_path / "x.py"
    src.write_text("V = 42\n")
    board.mp("fs", "cp", str(src), ":/lib/x.py")
    assert (board.flash / "lib" / "x.py").read_text() == "V = 42\n"
    assert board.mp("exec", "import x; print(x.V)").strip() == "42"
    assert "x.py" in board.mp("fs", "ls", "/lib")
    assert "V = 42" in board.mp("fs", "cat", "/lib/x.py")
    # the device's / is the flash directory, with a board's sys.path
    out = board.mp("exec", "import os, sys; print(os.getcwd(), sorted(os.listdir('/')), sys.path)")
    assert out.strip() == "/ ['lib'] ['', '.frozen', '/lib']"


def test_soft_reset_and_reconnects(board):
    board.mp("exec", "A = 1")
    assert board.mp("resume", "exec", "print(A)").strip() == "1"  # no reset: state kept
    board.mp("soft-reset")
    assert board.mp("resume", "exec", "print('A' in globals())").strip() == "False"
    assert board.mp("soft-reset", "+", "exec", "print('after')").strip() == "after"
    for i in range(5):  # connect, soft reset, exec, disconnect
        assert board.mp("exec", "print(%d * 3)" % i).strip() == str(i * 3)


def test_ctrl_c_interrupts_running_code(board):
    board.mp("exec", "--no-follow", "while True: pass")
    assert board.mp("exec", "print('alive')").strip() == "alive"
    # resume (no soft reset): the same interpreter was interrupted, not restarted
    board.mp("exec", "--no-follow", "n = 0\nwhile True: n += 1")
    assert board.mp("resume", "exec", "print('alive', n > 0)").strip() == "alive True"
    board.mp("resume", "exec", "--no-follow", "import time; time.sleep(100)")
    assert board.mp("resume", "exec", "print('awake', n > 0)").strip() == "awake True"


def test_run_host_script(board, tmp_path):
    script = tmp_path / "script.py"
    script.write_text("import sys\nprint('ran on', sys.implementation.name)\n")
    assert board.mp("run", str(script)).strip() == "ran on micropython"


def test_mount_host_dir(board, tmp_path):
    d = tmp_path / "host"
    d.mkdir()
    (d / "mod.py").write_text("print('mod from host')\n")
    out = board.mp("mount", str(d), "exec", "import mod")
    assert "mod from host" in out
    assert not (board.flash / "mod.py").exists()


def test_hard_reset_and_clean_stop(board):
    board.mp("exec", "B = 2")
    board.proc.send_signal(signal.SIGUSR1)  # power cycle: state gone
    board.wait_line("fakeboard: reset\n", "fakeboard did not come back from the reset: ")
    assert board.mp("resume", "exec", "print('B' in globals())").strip() == "False"
    kids = children(board.proc.pid)
    assert len(kids) == 1  # the interpreter
    board.proc.terminate()
    assert board.proc.wait(10) == 0
    assert not os.path.lexists(board.link)
    for pid in kids:
        assert not os.path.exists("/proc/%d" % pid)


def test_refuses_to_replace_a_file(tmp_path):
    link = tmp_path / "notalink"
    link.write_text("keep me")
    r = subprocess.run([sys.executable, str(FAKEBOARD), "--link", str(link), "--flash",
                        str(tmp_path / "flash")], capture_output=True, text=True, timeout=TIMEOUT_S)
    assert r.returncode != 0 and "refusing" in r.stderr
    assert link.read_text() == "keep me"
