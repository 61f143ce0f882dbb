# The Cortex-M3 board under QEMU: MicroPython's qemu port for MPS2-AN385
# (tools/firmware.py builds it into build/firmware/) started in
# qemu-system-arm with its UART on a pseudo-terminal, which mpremote and
# pyserial open as they would a board's USB serial port.
#
#   with QemuBoard(firmware("cm3-full"), heap=48 * 1024) as b:
#       t = b.transport()          # mpremote's SerialTransport on b.port
#       t.enter_raw_repl(soft_reset=False)
#       print(t.exec("print(1 + 1)"))
#
# heap: the GC heap in bytes, set at boot (a word qemu's -device loader puts
# at 0x21fffff8, read by the patched main.c), so one build serves every
# size. rom: a ROMFS image loaded at the board's ROMFS partition
# (0x21000000), mounted at /rom by the firmware's _boot.py. flash: an image
# of the board's littlefs (2 MiB, 4096-byte blocks) loaded at its RAM flash
# (0x21400000), which _boot.py then mounts at / instead of making a new one.
# A qemu that does not start raises QemuError with its stderr.
import os
import re
import subprocess
import time

from .boardfiles import repo_root
from .procs import die_with_parent

HEAP_WORD = 0x21FFFFF8
HEAP_MAGIC = 0x48454150
ROMFS_PART0 = 0x21000000
RAM_FLASH = 0x21400000
START_TIMEOUT_S = 10
START_GRACE_S = 0.3


class QemuError(Exception):
    pass


def firmware(name):
    """Path of build/firmware/NAME(.elf), or None when it has not been built (tools/firmware.py)."""
    base = os.path.join(repo_root(), "build", "firmware", name)
    for p in (base + ".elf", base):
        if os.path.isfile(p):
            return p
    return None


def qemu_args(elf, heap=None, rom=None, serial="pty", flash=None):
    args = ["qemu-system-arm", "-machine", "mps2-an385", "-display", "none", "-monitor", "null", "-semihosting",
            "-serial", serial, "-kernel", elf]
    if heap:
        args += ["-device", "loader,addr=0x%x,data=0x%x,data-len=8" % (HEAP_WORD, (HEAP_MAGIC << 32) | int(heap))]
    if rom:
        args += ["-device", "loader,file=%s,addr=0x%x,force-raw=on" % (rom, ROMFS_PART0)]
    if flash:
        args += ["-device", "loader,file=%s,addr=0x%x,force-raw=on" % (flash, RAM_FLASH)]
    return args


class QemuBoard:
    """qemu-system-arm running `elf`; .port is the pty of its UART. Stop with stop() or `with`."""

    def __init__(self, elf, heap=None, rom=None, flash=None):
        if not elf or not os.path.isfile(elf):
            raise QemuError("no firmware %r: build it with 'make firmware'" % (elf,))
        self.args = qemu_args(elf, heap, rom, flash=flash)
        self._t = None
        self.proc = subprocess.Popen(self.args, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, preexec_fn=die_with_parent)
        self.port = self._pty()

    def _pty(self):
        # qemu names the pty on stdout ("char device redirected to
        # /dev/pts/N (label serial0)") before the CPU starts
        import select

        buf = b""
        end = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < end:
            if self.proc.poll() is not None:
                break
            r, _, _ = select.select([self.proc.stdout], [], [], 0.1)
            if r:
                chunk = os.read(self.proc.stdout.fileno(), 4096)
                if not chunk:
                    break
                buf += chunk
                m = re.search(rb"(/dev/pts/\d+)", buf)
                if m:
                    # qemu names the pty before it sets up the devices; a
                    # bad -device (a missing ROMFS image) stops it just after
                    try:
                        self.proc.wait(START_GRACE_S)
                    except subprocess.TimeoutExpired:
                        return m.group(1).decode()
                    break
        err = self.stop()
        raise QemuError("qemu did not start (%s): %s" % (" ".join(self.args), (buf.decode(errors="replace") + err).strip()))

    def transport(self):
        """mpremote's SerialTransport on the board's UART (opened once)."""
        if self._t is None:
            from mpremote.transport_serial import SerialTransport

            self._t = SerialTransport(self.port, baudrate=115200)
        return self._t

    def alive(self):
        return self.proc.poll() is None

    def stop(self):
        """Kills qemu; returns what it wrote on stderr."""
        if self._t is not None:
            try:
                self._t.close()
            except Exception:  # noqa: BLE001 - the pty may be gone already
                pass
            self._t = None
        if self.proc.poll() is None:
            self.proc.kill()
        try:
            _, err = self.proc.communicate(timeout=5)
        except (subprocess.TimeoutExpired, ValueError, OSError):
            err = b""
        return (err or b"").decode(errors="replace")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()
