# `acomm run boards/diver_esp32s3`: the diver's tablet program (its
# config.py, its main.py's make_report, the acomm_mp assembly) on CPython,
# its UART1 on a beacon of an `acomm emulate seatrac` water, talking to an
# `acomm node` on the other beacon through both consoles; and the board
# errors named with exit status 2. CPython only; every wait is bounded.

import os
import shutil
import sys

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux"):
    pytest.skip("needs Linux pseudo-terminals", allow_module_level=True)

from consoleprocs import ROOT, Proc, Water, run  # noqa: E402

DIVER = os.path.join(ROOT, "boards", "diver_esp32s3")
FAST = ["--driver-option", "packet_ms=25", "--driver-option", "byte_ms=4", "--driver-option", "turnaround_ms=15"]


def test_the_diver_board_runs_against_an_emulated_beacon(tmp_path):
    with Water(tmp_path, time_scale=20) as water:
        buoy = Proc(["node", "--name", "buoy", "--id", "1", "--known", "diver=2", "--modem",
                     "seatrac:" + water.paths[0]] + FAST)
        diver = Proc(["run", DIVER, "--uart", "UART1=" + water.paths[1], "--store", str(tmp_path / "store")])
        try:
            assert diver.expect("acoustic:") == "acoustic: seatrac on %s, up" % water.paths[1]
            diver.expect("ready: node diver (2) on acoustic")
            buoy.expect("ready")
            buoy.send("send diver surface now --ack")
            assert buoy.expect("status acoustic") == "status acoustic 1 delivered"
            assert diver.expect("received acoustic") == "received acoustic buoy -> diver: surface now"
            # the board's station: a CADDY alarm through the transport to its alarm_to (the buoy)
            diver.send("alarm low_air")
            diver.expect("packet 1 to buoy: alarm low_air, queued")
            assert buoy.expect("received packet") == ('received packet diver -> buoy: 1 bytes; '
                                                     'CADDY alarm {"alarm": "low_air"}')
            assert diver.expect("packet 1 ", timeout=60) == "packet 1 delivered"
            diver.send("status")
            diver.expect("store: 0 packets pending, ")
        finally:
            for p in (buoy, diver):
                rc, err = p.finish()
                assert rc == 0 and "Traceback" not in err, (err, p.lines)
    assert os.path.isfile(str(tmp_path / "store" / "acomm.store"))


def test_board_errors_are_named(tmp_path):
    broken = tmp_path / "broken"
    shutil.copytree(DIVER, str(broken))
    text = (broken / "config.py").read_text().replace('"node_id": 2', '"node_id": 300')
    (broken / "config.py").write_text(text)
    nomain = tmp_path / "nomain"
    shutil.copytree(DIVER, str(nomain))
    (nomain / "main.py").write_text("import sensors_we_do_not_have\n")
    cases = [
        ([str(nomain), "--uart", "UART1=/dev/null"], "main.py does not run: ModuleNotFoundError"),
        ([DIVER, "--uart", "UART0=/dev/null"], "does not use UART0 (it uses UART1)"),
        ([DIVER], "give --uart UART1=DEVICE for its acoustic link (seatrac)"),
        ([DIVER, "--uart", "COM3"], "give UARTn=DEVICE[:BAUD]"),
        ([str(broken), "--uart", "UART1=/dev/null"], "node_id: an integer 1..254, not 300"),
        (["nosuch"], "no board 'nosuch'"),
    ]
    for args, want in cases:
        rc, out, err = run(["run"] + args, timeout=30)
        assert rc == 2 and want in err and len(err.strip().splitlines()) == 1, (args, rc, err)
        assert "Traceback" not in err
    rc, out, err = run(["run", DIVER, "--uart", "UART1=%s/nosuch" % tmp_path], timeout=30)
    assert rc == 1 and "cannot open %s/nosuch: no such device" % tmp_path in err, err
