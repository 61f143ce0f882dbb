# The RP2040 runner (tools/rp2040/runner.mjs under node, rp2040js 1.4.1)
# with MicroPython's own RPI_PICO firmware (build/firmware/rp2040-stock.uf2,
# else $ACOMM_RP2040_FIRMWARE), reached as a board is: through socat ptys.
# mpremote runs and copies files over the USB REPL; bytes written on a UART's
# pty reach machine.UART on the board and its echo comes back whole (the
# runner paces them at the line's baud, the FIFO holds 32); littlefs keeps a
# file over a soft reset, a hard reset and, with a flash image, a restart of
# the runner; machine.reset() and an unfed machine.WDT reset the board, a
# fed one does not.
import os
import subprocess
import sys
import time

import pytest

from acomm_cpython.board.picoboard import PicoBoard, firmware, runner_available

MPREMOTE = os.path.join(os.path.dirname(sys.executable), "mpremote")
FIRMWARE = firmware("rp2040-stock")
_missing = runner_available() or (None if FIRMWARE else "no RP2040 firmware: build build/firmware/rp2040-stock.uf2 (make firmware) or set ACOMM_RP2040_FIRMWARE")
pytestmark = pytest.mark.skipif(_missing is not None, reason=_missing or "")

ECHO = """
from machine import UART, Pin
import time
u = UART(%d, %d, tx=Pin(%d), rx=Pin(%d), rxbuf=1024)
n = 0
t = time.ticks_ms()
print('READY')
while n < %d and time.ticks_diff(time.ticks_ms(), t) < 20000:
    d = u.read()
    if d:
        u.write(d)
        n += len(d)
print('ECHOED', n)
"""


@pytest.fixture(scope="module")
def pico():
    with PicoBoard(FIRMWARE) as b:
        b.transport().enter_raw_repl(soft_reset=False)
        yield b


def _repl_back(b):
    # after a hard reset the pty stays; the REPL answers once USB is up again
    t = b.transport()
    t.enter_raw_repl(soft_reset=False)
    return t


def _wait_stat(b, key, value, timeout=20):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        s = b.stats()
        if s[key] == value:
            return s
        time.sleep(0.05)
    return None


def _exec(b, code):
    return b.transport().exec(code).decode().strip()


def test_mpremote_exec_and_fs_cp_through_the_pty(pico, tmp_path):
    pico.close_transport()  # mpremote opens the pty exclusively
    r = subprocess.run([MPREMOTE, "connect", pico.usb, "exec", "print(1 + 1)"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == "2", r
    # 3 KiB through raw-paste mode: more than rp2040js's 512-byte USB FIFO at once
    src = tmp_path / "blob.txt"
    src.write_text("".join("line %04d of the blob\n" % i for i in range(150)))
    r = subprocess.run([MPREMOTE, "connect", pico.usb, "fs", "cp", str(src), ":blob.txt"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r
    t = pico.transport()
    t.enter_raw_repl(soft_reset=False)  # mpremote left the board in the friendly REPL
    assert t.fs_readfile("blob.txt") == src.read_bytes()


def test_usb_burst_beyond_512_bytes_is_not_dropped(pico):
    # a raw-REPL command written at once, without raw-paste flow control:
    # rp2040js's own CDC helper keeps 512 bytes and drops the rest
    t = pico.transport()
    code = "x = b'%s'\nprint(len(x), x == b'0123456789' * 800)" % ("0123456789" * 800)
    t.serial.write(code.encode() + b"\x04")
    assert t.read_until(1, b"OK", timeout=10).endswith(b"OK")
    out, err = t.follow(20)
    assert (out.strip(), err) == (b"8000 True", b"")


@pytest.mark.parametrize("uart, baud, tx, rx", [(0, 115200, 0, 1), (1, 19200, 4, 5)])
def test_uart_echo_arrives_whole(pico, uart, baud, tx, rx):
    import serial

    n = 300
    before = pico.stats()
    port = serial.Serial(getattr(pico, "uart%d" % uart), timeout=0.2)
    t = pico.transport()
    try:
        t.exec_raw_no_follow(ECHO % (uart, baud, tx, rx, n))
        assert t.read_until(1, b"READY\r\n", timeout=10).endswith(b"READY\r\n")
        data = bytes((i * 7 + uart) & 0xFF for i in range(n))
        port.write(data)  # all at once: the runner must pace it
        got = b""
        end = time.monotonic() + 20
        while len(got) < n and time.monotonic() < end:
            got += port.read(n - len(got))
        out, err = t.follow(20)
    finally:
        port.close()
    assert not err, err
    assert out.split() == [b"ECHOED", b"%d" % n], out
    assert got == data
    s = pico.stats()
    assert s["uart%d_rx_bytes" % uart] - before["uart%d_rx_bytes" % uart] == n
    assert s["uart%d_rx_overrun" % uart] == before["uart%d_rx_overrun" % uart]
    assert s["uart%d_fw_baud" % uart] == pytest.approx(baud, rel=0.01)


def test_littlefs_survives_soft_and_hard_reset(pico):
    _exec(pico, "f = open('keep.txt', 'w'); f.write('kept ' * 200); f.close()")
    t = pico.transport()
    t.exit_raw_repl()
    t.enter_raw_repl(soft_reset=True)  # Ctrl-D
    assert _exec(pico, "print(open('keep.txt').read() == 'kept ' * 200)") == "True"
    resets = pico.stats()["resets"]
    pico.reset()
    _repl_back(pico)
    assert pico.stats()["resets"] == resets + 1
    assert _exec(pico, "import machine; print(open('keep.txt').read() == 'kept ' * 200, machine.reset_cause() == machine.PWRON_RESET)") == "True True"


def test_machine_reset_brings_the_repl_back(pico):
    before = pico.stats()
    _exec(pico, "import builtins; builtins.marker = 1")
    pico.transport().exec_raw_no_follow("import machine; machine.reset()")
    # wait for it: a Ctrl-C from enter_raw_repl could interrupt the program first
    assert _wait_stat(pico, "machine_resets", before["machine_resets"] + 1)
    t = _repl_back(pico)
    # RAM was cleared; the watchdog's REASON says why, as on a Pico
    assert t.exec("import builtins, machine; print(hasattr(builtins, 'marker'), machine.reset_cause() == machine.WDT_RESET)").strip() == b"False True"


def test_watchdog_fed_holds_then_unfed_resets(pico):
    before = pico.stats()
    t = pico.transport()
    sim0 = pico.sim_ms()
    # fed every 200 ms for 2.5 s (2.5 timeouts): no reset
    out = t.exec("from machine import WDT\nimport time\nw = WDT(timeout=1000)\n"
                 "for i in range(12):\n    time.sleep_ms(200)\n    w.feed()\nprint('fed')").strip()
    assert out == b"fed"
    assert pico.sim_ms() - sim0 >= 2400
    assert pico.stats()["watchdog_resets"] == before["watchdog_resets"]
    # then not fed: the board resets about 1 s (simulated) later
    sim1 = pico.sim_ms()
    s = _wait_stat(pico, "watchdog_resets", before["watchdog_resets"] + 1)
    assert s
    # 1000 ms after the last feed, a little before sim1 (LOAD is 2 x timeout_us, RP2040-E1)
    assert 700 < s["last_reset_ms"] - sim1 <= 1000
    t = _repl_back(pico)
    assert t.exec("import machine; print(machine.reset_cause() == machine.WDT_RESET)").strip() == b"True"


def test_flash_image_survives_a_restart_of_the_runner(tmp_path):
    image = tmp_path / "flash.bin"
    with PicoBoard(FIRMWARE, flash=str(image)) as b:
        t = b.transport()
        t.enter_raw_repl(soft_reset=False)
        t.exec("f = open('saved.txt', 'w'); f.write('by save'); f.close()")
        b.save()
        assert image.stat().st_size == 2 * 1024 * 1024
        # written after the save: stop() (SIGTERM) must write the image again
        t.exec("f = open('stopped.txt', 'w'); f.write('by stop'); f.close()")
    with PicoBoard(FIRMWARE, flash=str(image)) as b:
        t = b.transport()
        t.enter_raw_repl(soft_reset=False)
        assert t.exec("print(open('saved.txt').read(), open('stopped.txt').read())").strip() == b"by save by stop"
    # without the image the filesystem is a new one
    with PicoBoard(FIRMWARE) as b:
        t = b.transport()
        t.enter_raw_repl(soft_reset=False)
        assert t.exec("import os; print(os.listdir())").strip() == b"[]"
