# A Raspberry Pi Pico (RP2040) running MicroPython's rp2 firmware in the
# rp2040js emulator: tools/rp2040/runner.mjs under node, its USB CDC REPL,
# UART0 and UART1 on TCP ports, each with a socat pty in front of it, which
# mpremote, pyserial and acomm's modem emulators open as serial ports.
#
#   with PicoBoard(firmware("rp2040-stock")) as b:
#       t = b.transport()            # mpremote's SerialTransport on b.usb
#       t.enter_raw_repl(soft_reset=False)
#       print(t.exec("print(1 + 1)"))
#       b.uart0, b.uart1             # pty paths of the board's UARTs
#       b.reset(); b.stats()         # hard reset over the ctl port; counters
#
# flash: a 2 MiB flash image loaded at start when it exists (the firmware is
# then written over its first 640 KiB only, so the littlefs at 0x100a0000
# survives a firmware change) and written back by save() and stop(). The
# emulator runs at about 0.6x real time when busy and never faster than real
# time when idle (speed_cap: that bound as a multiple of real time, 0 for
# none); sim_ms() is the board's clock. mpremote opens a pty exclusively:
# close_transport() before running the mpremote CLI on .usb. Needs node, the runner's
# node_modules (`npm ci --prefix tools/rp2040`), the RP2040 boot ROM and socat:
# runner_available() says which is missing.
import json
import os
import select
import shutil
import signal
import socket
import subprocess
import tempfile
import threading
import time

from .boardfiles import repo_root
from .procs import die_with_parent

BOOTROM_NAME = "rp2040-bootrom-b1.bin"
START_TIMEOUT_S = 20
PTY_TIMEOUT_S = 5
CTL_TIMEOUT_S = 30


class PicoError(Exception):
    pass


def runner_dir():
    return os.path.join(repo_root(), "tools", "rp2040")


def bootrom():
    """Path of the RP2040 boot ROM (B1), or None: $ACOMM_RP2040_BOOTROM, else
    vendor/ in $ACOMM_SHARED or in ../shared beside the repository."""
    env = os.environ.get("ACOMM_RP2040_BOOTROM")
    if env:
        return env if os.path.isfile(env) else None
    dirs = [os.path.join(os.environ["ACOMM_SHARED"], "vendor")] if os.environ.get("ACOMM_SHARED") else []
    dirs.append(os.path.join(os.path.dirname(repo_root()), "shared", "vendor"))
    for d in dirs:
        p = os.path.join(d, BOOTROM_NAME)
        if os.path.isfile(p):
            return p
    return None


def firmware(name="rp2040-stock"):
    """build/firmware/NAME.uf2 (tools/firmware.py), else $ACOMM_RP2040_FIRMWARE, else None."""
    p = os.path.join(repo_root(), "build", "firmware", name + ".uf2")
    if os.path.isfile(p):
        return p
    env = os.environ.get("ACOMM_RP2040_FIRMWARE")
    return env if env and os.path.isfile(env) else None


def runner_available(ptys=True):
    """None when a PicoBoard can start here, else one line saying what is missing."""
    if shutil.which("node") is None:
        return "node is not installed (the RP2040 runner is a node program)"
    if not os.path.isdir(os.path.join(runner_dir(), "node_modules", "rp2040js")):
        return "rp2040js is not installed: run `npm ci --prefix tools/rp2040`"
    if bootrom() is None:
        if os.environ.get("ACOMM_RP2040_BOOTROM"):
            return "no RP2040 boot ROM at ACOMM_RP2040_BOOTROM=%s" % os.environ["ACOMM_RP2040_BOOTROM"]
        return ("no RP2040 boot ROM: set ACOMM_RP2040_BOOTROM or put %s in ../shared/vendor/ "
                "beside the repository (or $ACOMM_SHARED/vendor/)" % BOOTROM_NAME)
    if ptys and shutil.which("socat") is None:
        return "socat is not installed (it puts a pty in front of each TCP port)"
    return None


class PicoBoard:
    """The runner with `firmware` (.uf2 or .bin); .usb, .uart0, .uart1 are pty
    paths (None without ptys), .ports the TCP ports. Stop with stop() or `with`."""

    def __init__(self, firmware, flash=None, uart_baud=(115200, 19200), ptys=True, speed_cap=None,
                 host="127.0.0.1"):
        if not firmware or not os.path.isfile(firmware):
            raise PicoError("no firmware %r: build it with 'make firmware'" % (firmware,))
        missing = runner_available(ptys)
        if missing:
            raise PicoError(missing)
        self.host = host
        self.usb = self.uart0 = self.uart1 = None
        self._t = None
        self._ctl = None
        self._ctl_lock = threading.Lock()
        self._socats = []
        self._dir = tempfile.mkdtemp(prefix="picoboard-")
        self._err = open(os.path.join(self._dir, "runner.err"), "w+b")
        self.args = ["node", os.path.join(runner_dir(), "runner.mjs"), "--firmware", firmware,
                     "--bootrom", bootrom(), "--host", host,
                     "--uart0-baud", str(uart_baud[0]), "--uart1-baud", str(uart_baud[1])]
        if flash:
            self.args += ["--flash", flash]
        if speed_cap is not None:
            self.args += ["--speed-cap", str(speed_cap)]
        # stderr goes to a file: a pipe nobody reads could fill and stop the board
        self.proc = subprocess.Popen(self.args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=self._err, preexec_fn=die_with_parent)
        try:
            self.ports = self._ready()
            if ptys:
                for name in ("usb", "uart0", "uart1"):
                    setattr(self, name, self._pty(name))
        except BaseException:
            self.stop()
            raise

    def _ready(self):
        line = b""
        end = time.monotonic() + START_TIMEOUT_S
        while not line.endswith(b"\n") and time.monotonic() < end:
            r, _, _ = select.select([self.proc.stdout], [], [], 0.1)
            if r:
                chunk = os.read(self.proc.stdout.fileno(), 4096)
                if not chunk:
                    break
                line += chunk
        try:
            ready = json.loads(line)
            if ready.get("ready"):
                return {k: ready[k] for k in ("usb", "uart0", "uart1", "ctl")}
        except ValueError:
            pass
        raise PicoError("the RP2040 runner did not start (%s): %s" % (" ".join(self.args), (line + self._stderr()).decode(errors="replace").strip()))

    def _pty(self, name):
        link = os.path.join(self._dir, name)
        p = subprocess.Popen(["socat", "pty,link=%s,raw,echo=0" % link, "tcp:%s:%d" % (self.host, self.ports[name])],
                             stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             preexec_fn=die_with_parent)
        self._socats.append(p)
        end = time.monotonic() + PTY_TIMEOUT_S
        while not os.path.exists(link):
            if p.poll() is not None or time.monotonic() > end:
                raise PicoError("socat gave no pty for %s: %s" % (name, p.stderr.read().decode(errors="replace").strip() if p.poll() is not None else "timeout"))
            time.sleep(0.01)
        return link

    def _stderr(self):
        try:
            self._err.seek(0)
            return self._err.read()
        except (ValueError, OSError):
            return b""

    def ctl(self, command):
        """One command on the control port (reset, save, time, stats); its answer line."""
        with self._ctl_lock:
            if self._ctl is None:
                self._ctl = socket.create_connection((self.host, self.ports["ctl"]), timeout=CTL_TIMEOUT_S)
                self._ctl_buf = b""
            self._ctl.sendall(command.encode() + b"\n")
            while b"\n" not in self._ctl_buf:
                chunk = self._ctl.recv(65536)
                if not chunk:
                    raise PicoError("the RP2040 runner closed its control port: %s" % self._stderr().decode(errors="replace"))
                self._ctl_buf += chunk
            line, self._ctl_buf = self._ctl_buf.split(b"\n", 1)
            return line.decode()

    def _ok(self, command):
        answer = self.ctl(command)
        if answer != "ok":
            raise PicoError("%s: %s" % (command, answer))

    def reset(self):
        """Hard reset (a power cycle: RAM cleared, flash kept); the REPL comes back on .usb."""
        self._ok("reset")

    def save(self):
        """Writes the flash image given as flash=."""
        self._ok("save")

    def sim_ms(self):
        """The board's simulated time since start, in ms (resets included)."""
        return float(self.ctl("time"))

    def stats(self):
        """The runner's counters: resets, watchdog_resets, flash_erases, uartN_rx_dropped..."""
        return json.loads(self.ctl("stats"))

    def transport(self):
        """mpremote's SerialTransport on the board's USB REPL pty (opened once)."""
        if self._t is None:
            if self.usb is None:
                raise PicoError("no pty: the board was started with ptys=False")
            from mpremote.transport_serial import SerialTransport

            self._t = SerialTransport(self.usb, baudrate=115200)
        return self._t

    def close_transport(self):
        """Closes transport()'s serial port (mpremote opens ptys exclusively), e.g. to run the mpremote CLI."""
        if self._t is not None:
            try:
                self._t.close()
            except Exception:  # noqa: BLE001 - the pty may be gone already
                pass
            self._t = None

    def alive(self):
        return self.proc.poll() is None

    def stop(self):
        """Stops the board (saving its flash image when it has one); returns the runner's stderr."""
        self.close_transport()
        if self._ctl is not None:
            self._ctl.close()
            self._ctl = None
        for p in self._socats:
            if p.poll() is None:
                p.kill()
            p.wait()
            p.stderr.close()
        self._socats = []
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)  # the runner saves the flash image, then exits
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.proc.stdout.close()
        err = self._stderr().decode(errors="replace")
        self._err.close()
        shutil.rmtree(self._dir, ignore_errors=True)
        return err

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
