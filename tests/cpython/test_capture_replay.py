# Record and replay: the capture format (acomm_cpython.emulate.capture),
# `acomm replay` (acomm_cpython.emulate.replay) over the shipped fixture of every
# device (tests/cpython/fixtures/captures, made by tools/make_captures.py
# from acomm_cpython.emulate.capture_sessions), damaged files reported by line, and
# `acomm emulate --log` on a real pseudo-terminal whose capture replays.
# CPython only.

import io
import os
import sys
import threading
import time

import pytest

from acomm.events import EV_DELIVERED, EV_DRIVER_UP, EV_RX, EV_TX_DONE
from acomm_cpython import cli
from acomm_cpython.emulate.capture import CaptureError, CaptureWriter, read_capture
from acomm_cpython.emulate.capture_sessions import BACK, MODEMS, run_session
from acomm_cpython.emulate.replay import make_driver, replay

FIXTURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "fixtures", "captures")


def fixture(modem):
    with open(os.path.join(FIXTURES, modem + ".jsonl")) as f:
        return f.read()


@pytest.mark.parametrize("modem", MODEMS)
def test_fixture_is_what_the_session_makes_and_replays_to_its_events(modem):
    buf = io.StringIO()
    w = CaptureWriter(buf, modem)
    live = run_session(modem, w)
    assert buf.getvalue() == fixture(modem), "run tools/make_captures.py %s and read the diff" % modem
    header, records = read_capture(fixture(modem).splitlines())
    assert header["modem"] == modem
    opts = {"rate": 0} if modem == "micromodem" else {}
    got = replay(records, make_driver(modem, 1, opts))
    assert got == live
    kinds = [e[0] for _, e in got]
    assert kinds[0] == EV_DRIVER_UP and EV_TX_DONE in kinds
    assert (EV_DELIVERED in kinds) == (modem in ("seatrac", "evologics", "micromodem"))
    assert [e for _, e in got if e[0] == EV_RX][0][-1] == BACK


def test_replay_command_prints_the_events(capsys):
    path = os.path.join(FIXTURES, "micromodem.jsonl")
    assert cli.main(["replay", path, "--option", "rate=0"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith("EV_DRIVER_UP") and out[1].endswith("send 1 2")
    assert out[-1].split(" ", 1)[1] == "EV_RX 2 1 %s (%r)" % (BACK.hex(), BACK)
    # the writes, and the capture's own modem overridden
    assert cli.main(["replay", path, "--driver", "micromodem", "--option", "rate=0", "--writes"]) == 0
    assert "> 2443434346472c5352432c312a33310d0a" in capsys.readouterr().out  # $CCCFG,SRC,1*31


DAMAGED = [
    ('{"capture": "acomm", "version": 1, "modem": "iridium"}\n{"t": 1, "to": "host", "hex": "4f4b"}\n{"t": 2, "to"\n',
     3, "not a JSON object"),
    ('{"capture": "acomm", "version": 1}\n{"t": 5, "to": "host", "hex": "4f4b"}\n{"t": 4, "to": "host", "hex": "4f"}\n',
     3, "time goes back"),
    ('{"t": 5, "to": "host", "hex": "4f4b"}\n', 1, "header"),
    ('{"capture": "acomm", "version": 1}\n\n{"t": 5, "to": "host", "hex": "4f4"}\n', 3, "hex"),
    ('{"capture": "acomm", "version": 1}\n{"t": 5, "to": "modem", "hex": "4f"}\n', 2, '"to"'),
    ('{"capture": "acomm", "version": 1}\n{"t": -1, "to": "host", "hex": "4f"}\n', 2, '"t"'),
    ('{"capture": "acomm", "version": 1}\n{"t": 1, "send": {"addr": "2", "hex": "4f"}}\n', 2, '"send"'),
    ('{"capture": "acomm", "version": 2}\n', 1, "version"),
    ('[1, 2]\n', 1, "not a JSON object"),
    ('', 1, "empty"),
]


@pytest.mark.parametrize("text,line,what", DAMAGED)
def test_damaged_capture_is_refused_with_its_line(tmp_path, capsys, text, line, what):
    with pytest.raises(CaptureError) as e:
        read_capture(text.splitlines(True))
    assert e.value.line == line and what in e.value.reason
    path = tmp_path / "bad.jsonl"
    path.write_text(text)
    assert cli.main(["replay", str(path), "--driver", "iridium"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("%s:%d: damaged capture: " % (path, line)), err
    assert "Traceback" not in err


def test_replay_refuses_a_missing_file_and_an_unknown_driver(tmp_path, capsys):
    assert cli.main(["replay", str(tmp_path / "none.jsonl")]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert cli.main(["replay", os.path.join(FIXTURES, "gsm.jsonl"), "--driver", "nosuch"]) == 2
    assert "unknown driver" in capsys.readouterr().err


def test_emulate_log_on_a_pty_replays_the_frame_the_modem_heard(tmp_path):
    serial = pytest.importorskip("serial")
    if not sys.platform.startswith("linux") and sys.platform != "darwin":
        pytest.skip("needs POSIX pseudo-terminals")
    from acomm.drivers import micromodem_wire as nm
    from acomm_cpython.emulate.host import EmulatorHost

    log = tmp_path / "mm.jsonl"
    a, b = str(tmp_path / "mm1"), str(tmp_path / "mm2")
    host = EmulatorHost("micromodem", a, 1, [(2, b, None)], {"air_scale": 0.1}, time_scale=1,
                        log=CaptureWriter(open(str(log), "w"), "micromodem"))
    stop = []
    t = threading.Thread(target=host.run, args=(lambda: stop,), daemon=True)
    t.start()
    try:
        p1 = serial.Serial(a, 19200, timeout=5)  # a host on modem 1 that only listens
        p2 = serial.Serial(b, 19200, timeout=5)  # and one on modem 2 that sends 1 a frame
        p1.write(nm.sentence("CCCFG", "SRC", 1))
        assert p1.read_until(nm.sentence("CACFG", "SRC", 1)).endswith(nm.sentence("CACFG", "SRC", 1))
        p2.write(nm.sentence("CCCYC", 0, 2, 1, 1, 0, 1))
        assert p2.read_until(b"$CADRQ").endswith(b"$CADRQ")
        p2.write(nm.sentence("CCTXD", 2, 1, 0, nm.hexlify(b"logged")))
        want = nm.sentence("CARXD", 2, 1, 0, 1, nm.hexlify(b"logged"))
        assert p1.read_until(want).endswith(want)
        time.sleep(0.1)
        p1.close()
        p2.close()
    finally:
        stop.append(1)
        t.join(5)
        host.close()
    header, records = read_capture(log.read_text().splitlines())
    assert header["modem"] == "micromodem"
    first_out = [r for r in records if r[1] == "host"][0]
    assert b"$CAREV" in first_out[2]  # the power-up banner
    assert any(r[1] == "device" and r[2] == nm.sentence("CCCFG", "SRC", 1) for r in records)
    got = replay(records, make_driver("micromodem", 1, {}))
    assert (EV_RX, 2, 1, b"logged") in [e for _, e in got]


def test_emulate_command_writes_its_log(tmp_path):
    # `acomm emulate iridium --link PATH --log FILE` as a process, stopped
    # with SIGTERM: the file holds the header and both directions
    import subprocess

    serial = pytest.importorskip("serial")
    if not sys.platform.startswith("linux") and sys.platform != "darwin":
        pytest.skip("needs POSIX pseudo-terminals")
    link, log = str(tmp_path / "rb"), str(tmp_path / "rb.jsonl")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([root, os.path.join(root, "ports", "cpython"), os.path.join(root, "ports", "sim")])
    proc = subprocess.Popen([sys.executable, "-m", "acomm_cpython.cli", "emulate", "iridium", "--link", link,
                             "--option", "boot_ms=0", "--log", log], stdout=subprocess.PIPE, env=env, text=True)
    try:
        assert "address 1" in proc.stdout.readline()
        p = serial.Serial(link, 19200, timeout=5)
        p.write(b"AT+GMM\r")
        assert p.read_until(b"OK\r\n").endswith(b"OK\r\n")
        p.close()
    finally:
        proc.terminate()
        proc.wait(10)
    assert proc.returncode == 0
    with open(log) as f:
        header, records = read_capture(f)
    assert header["modem"] == "iridium"
    assert b"".join(r[2] for r in records if r[1] == "device") == b"AT+GMM\r"
    assert b"".join(r[2] for r in records if r[1] == "host") == (
        b"AT+GMM\r\r\nIRIDIUM 9600 Family SBD Transceiver\r\n\r\nOK\r\n")
