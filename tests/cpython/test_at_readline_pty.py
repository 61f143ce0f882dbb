# The emulated Iridium 9602, GSM, EvoLogics and Micro-Modem as a simple host script sees
# them: a real pseudo-terminal opened with pyserial, the emulator at its
# factory defaults (echo on, verbose results), and nothing but readline()
# (and read_until for the prompts and blocks that end no line). This is how
# RockBLOCK and SMS example scripts are written; an emulator that framed its
# answers other than the real unit would leave them waiting (the
# READY of +SBDWB glued to the echo). CPython only; every read has a
# timeout, so a hang is a failure, not a stuck test.

import os
import sys
import threading

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm.drivers import iridium_wire as w  # noqa: E402
from acomm_cpython.emulate.host import EmulatorHost  # noqa: E402


class Running:
    # an EmulatorHost stepped by a thread; the port opened as a host would
    def __init__(self, tmp_path, modem, options, incoming=()):
        link = str(tmp_path / modem)
        self.host = EmulatorHost(modem, link, 1, [(2, None, None)], options, time_scale=10, incoming=incoming)
        self._stop = []
        self._t = threading.Thread(target=self.host.run, args=(lambda: self._stop,), daemon=True)
        self._t.start()
        self.port = serial.Serial(link, 19200, timeout=5)

    def close(self):
        self.port.close()
        self._stop.append(1)
        self._t.join(5)
        self.host.close()


def lines(port, n):
    out = [port.readline() for _ in range(n)]
    assert all(ln.endswith(b"\n") for ln in out), out  # a timeout ends a line without it
    return out


def test_rockblock_session_from_a_readline_host(tmp_path):
    # the RockBLOCK documentation's exchange, read line by line
    r = Running(tmp_path, "iridium", {"session_ms": 1000, "boot_ms": 0}, [b"from shore"])
    p = r.port
    try:
        p.write(b"AT\r")
        assert lines(p, 2) == [b"AT\r\r\n", b"OK\r\n"]
        p.write(b"AT+GMM\r")
        assert lines(p, 4) == [b"AT+GMM\r\r\n", b"IRIDIUM 9600 Family SBD Transceiver\r\n", b"\r\n", b"OK\r\n"]
        p.write(b"AT+CGSN\r")
        assert lines(p, 4)[1].rstrip().isdigit()
        p.write(b"AT+SBDWB=12\r")
        assert lines(p, 2) == [b"AT+SBDWB=12\r\r\n", b"READY\r\n"]
        p.write(w.sbdwb_data(b"hello world!"))
        assert lines(p, 4) == [b"\r\n", b"0\r\n", b"\r\n", b"OK\r\n"]
        p.write(b"AT+SBDIX\r")
        got = lines(p, 4)
        assert got[0] == b"AT+SBDIX\r\r\n" and got[2:] == [b"\r\n", b"OK\r\n"], got
        assert got[1] == b"+SBDIX: 0, 1, 1, 1, 10, 0\r\n", got
        p.write(b"AT+SBDRB\r")
        assert p.read_until(b"AT+SBDRB\r") == b"AT+SBDRB\r"  # the block follows the echo at once
        block = p.read(2 + 10 + 2)
        assert block == w.sbdrb_block(b"from shore"), block
        assert lines(p, 2) == [b"\r\n", b"OK\r\n"]
        p.write(b"AT+NOSUCH\r")
        assert lines(p, 2) == [b"AT+NOSUCH\r\r\n", b"ERROR\r\n"]
        # echo off, numeric results: "0" CR, information text CR LF
        p.write(b"ATE0V0\r")
        assert p.read(9) == b"ATE0V0\r0\r"
        p.write(b"AT+CSQ\r")
        assert p.read(10) == b"+CSQ:5\r\n0\r"
        p.write(b"ATV1\r")
        assert lines(p, 2) == [b"\r\n", b"OK\r\n"]
    finally:
        r.close()


def test_sms_send_and_read_from_a_readline_host(tmp_path):
    # 27.005 text mode: +CMGS with its "> " prompt, then +CMTI and +CMGR
    r = Running(tmp_path, "gsm", {"send_ms": 200, "boot_ms": 0})
    p = r.port
    try:
        p.write(b"AT+CMGF=1\r")
        # the echo's CR, then CR LF OK CR LF: the line reader's first line
        # is the echo, the second the result
        assert lines(p, 2) == [b"AT+CMGF=1\r\r\n", b"OK\r\n"]
        p.write(b"AT+CNMI=2,1,0,0,0\r")
        assert lines(p, 2)[1] == b"OK\r\n"
        p.write(b"AT+GMM\r")
        assert lines(p, 4)[3] == b"OK\r\n"
        p.write(b'AT+CMGS="+447700900002"\r')
        assert p.read_until(b"> ") == b'AT+CMGS="+447700900002"\r\r\n> '
        p.write(b"Hello\x1a")
        assert lines(p, 4) == [b"\r\n", b"+CMGS: 1\r\n", b"\r\n", b"OK\r\n"]
        # the peer (+447700900002) is headless; to ourselves, to read it back
        p.write(b'AT+CMGS="+447700900001"\r')
        p.read_until(b"> ")
        p.write(b"to me\x1a")
        got = lines(p, 6)
        assert got[:4] == [b"\r\n", b"+CMGS: 2\r\n", b"\r\n", b"OK\r\n"], got
        assert got[4:] == [b"\r\n", b'+CMTI: "SM",1\r\n'], got
        p.write(b"AT+CMGR=1\r")
        got = lines(p, 5)
        assert got[0] == b"AT+CMGR=1\r\r\n", got
        assert got[1].startswith(b'+CMGR: "REC UNREAD","+447700900001",,"'), got
        assert got[2:] == [b"to me\r\n", b"\r\n", b"OK\r\n"], got  # the text right under its header
        p.write(b"AT+CMGR=9\r")
        assert lines(p, 2)[1] == b"+CMS ERROR: 321\r\n"
    finally:
        r.close()


def test_evologics_im_from_a_readline_host(tmp_path):
    # the S2C in NET mode: no echo, every reply and notification a CR LF
    # line; the IM exchange of the reference (section 2.6) read line by line
    r = Running(tmp_path, "evologics", {"boot_ms": 0, "banner": ()})
    p = r.port
    try:
        p.write(b"AT?MODE\n")
        assert lines(p, 1) == [b"NET\r\n"]
        p.write(b"AT@ZX1\n")
        assert lines(p, 1) == [b"OK\r\n"]
        p.write(b"AT*SENDIM,5,2,ack,hello\n")
        got = lines(p, 4)
        assert got[0] == b"OK\r\n" and got[1].startswith(b"SENDSTART,2,im,") and got[2].startswith(b"SENDEND,2,im,")
        assert got[3] == b"DELIVEREDIM,2\r\n"
        p.write(b"AT?T\n")
        assert lines(p, 1) == [b"66667\r\n"]  # 100 m at 1500 m/s, in microseconds
        p.write(b"AT?NOSUCH\n")
        assert lines(p, 1) == [b"ERROR WRONG FORMAT\r\n"]
    finally:
        r.close()


def test_micromodem_rate0_from_a_host_that_waits_for_the_cycle_init(tmp_path):
    # a host written for the real modem (pyacomms' states): after $CACYC at
    # rate 0 it waits for the cycle init's $CATXF before it expects $CADRQ,
    # and only then sends $CCTXD (the emulator used to skip it,
    # and such a host never sent its data)
    from acomm.drivers import micromodem_wire as nm

    r = Running(tmp_path, "micromodem", {"air_scale": 0.1, "banner": False})
    p = r.port
    try:
        p.write(nm.sentence("CCCYC", 0, 1, 2, 0, 1, 1))
        seen = []
        while not seen or not seen[-1].startswith(b"$CATXF"):
            seen.append(lines(p, 1)[0])
            assert not seen[-1].startswith(b"$CADRQ"), seen  # not before the cycle init
        assert seen[0] == nm.sentence("CACYC", 0, 1, 2, 0, 1, 1), seen
        drq = lines(p, 1)[0]
        assert drq.startswith(b"$CADRQ,") and drq.split(b",")[5] == b"32", drq
        p.write(nm.sentence("CCTXD", 1, 2, 1, nm.hexlify(b"fsk")))
        got = [lines(p, 1)[0] for _ in range(4)]
        assert got[:3] == [nm.sentence("CATXD", 1, 2, 1, 3), nm.sentence("CATXP", 3), nm.sentence("CATXF", 3)], got
        assert got[3] == nm.sentence("CAACK", 1, 2, 1, 1)  # the headless peer acknowledged
    finally:
        r.close()
