# `acomm node --modem` with its console, as a user runs it: two node
# processes on two beacons of one `acomm emulate seatrac` water, commands
# typed on standard input, events read from standard output (text and JSON
# lines), the --log file, Ctrl-C with a persistent store, an EvoLogics modem
# on TCP (tcp:// and socket://), and every kind of
# bad input answered with one line and the right exit status.
# CPython only (processes, pseudo-terminals); every wait is bounded.

import json
import signal
import sys

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux"):
    pytest.skip("needs Linux pseudo-terminals", allow_module_level=True)

from consoleprocs import Proc, Water, run  # noqa: E402


def _node(name, nid, other, oid, path, *extra):
    return Proc(["node", "--name", name, "--id", str(nid), "--known", "%s=%d" % (other, oid), "--modem",
                 "seatrac:" + path] + list(extra))


def _no_traceback(err):
    assert "Traceback" not in err, err


def test_two_consoles_exchange_an_acknowledged_send_in_text(tmp_path):
    with Water(tmp_path) as water:
        buoy = _node("buoy", 1, "diver", 2, water.paths[0], "--log", str(tmp_path / "buoy.log"))
        diver = _node("diver", 2, "buoy", 1, water.paths[1])
        try:
            assert buoy.expect("acoustic: seatrac on").endswith(", up")
            buoy.expect("ready: node buoy (1) on acoustic")
            diver.expect("ready: node diver (2)")
            buoy.send("send diver hello diver --ack --priority 3")
            assert buoy.expect("sent acoustic") == "sent acoustic 1 to diver (11 bytes, priority 3, ack)"
            assert buoy.expect("status acoustic 1") == "status acoustic 1 delivered"
            assert diver.expect("received") == "received acoustic buoy -> diver: hello diver"
            # and back, while the buoy's console is asked for its status
            diver.send("send buoy all ok --ack")
            assert diver.expect("status acoustic") == "status acoustic 1 delivered"
            assert buoy.expect("received") == "received acoustic diver -> buoy: all ok"
            buoy.send("status")
            buoy.expect("link acoustic: seatrac on %s" % water.paths[0])
            buoy.expect(lambda ln: ln.startswith("  diver (2) available, heard"))
            buoy.expect("last errors: none")
            buoy.send("frobnicate now")
            buoy.expect("error: unknown command 'frobnicate' (help lists them)")
            buoy.send("send diver")
            buoy.expect("error: send: usage: send DST TEXT")
            buoy.send("send diver x --priority 99")
            buoy.expect("error: send: --priority: 1 (most urgent) to 16, not 99")
            buoy.send("send nobody hi")
            buoy.expect("error: send: unknown node 'nobody' (give --known NAME=ID)")
            buoy.send("send diver " + "x" * 200)  # more than a SeaTrac frame holds: refused by the link
            assert buoy.expect("status acoustic") == "status acoustic 2 failed: 200 bytes exceed the acoustic MTU of 29"
            buoy.send("cancel 77")
            buoy.expect("error: cancel: no request 77 waiting on any link")
            buoy.send("help")
            buoy.expect("cancel ID")
            buoy.send("range diver")
            buoy.expect("ranging acoustic")
            assert buoy.expect("range acoustic").endswith("diver 150.0 m")
        finally:
            for p in (buoy, diver):
                rc, err = p.finish()
                assert rc == 0, (err, p.lines)
                _no_traceback(err)
    log = [json.loads(ln) for ln in open(str(tmp_path / "buoy.log"))]
    events = [d["event"] for d in log]
    for e in ("link_up", "ready", "sent", "status", "received", "report", "error", "range"):
        assert e in events, events
    assert all(isinstance(d["t"], float) for d in log)


def test_two_consoles_in_json(tmp_path):
    with Water(tmp_path) as water:
        buoy = _node("buoy", 1, "diver", 2, water.paths[0], "--json")
        diver = _node("diver", 2, "buoy", 1, water.paths[1], "--json")
        try:
            buoy.expect('"event": "ready"')
            diver.expect('"event": "ready"')
            buoy.send("send diver hello --ack")
            sent = json.loads(buoy.expect('"event": "sent"'))
            assert sent == {"event": "sent", "link": "acoustic", "id": 1, "dst": "diver", "bytes": 5, "priority": 10,
                            "ack": True}
            final = json.loads(buoy.expect(lambda ln: '"final": true' in ln))
            assert final["status"] == "delivered" and final["id"] == 1, final
            got = json.loads(diver.expect('"event": "received"'))
            assert got == {"event": "received", "link": "acoustic", "src": "buoy", "dst": "diver", "text": "hello",
                           "bytes": 5}
            buoy.send("send diver")
            assert json.loads(buoy.expect('"event": "error"'))["error"].startswith("send: usage")
            buoy.send("status")
            rep = json.loads(buoy.expect('"event": "report"'))
            assert rep["links"][0]["kind"] == "seatrac" and rep["links"][0]["queue"] == 0
        finally:
            for p in (buoy, diver):
                rc, err = p.finish()
                assert rc == 0, err
                _no_traceback(err)


def test_a_file_through_the_transport_and_ctrl_c_with_a_persistent_store(tmp_path):
    data = bytes((i * 73 + 11) & 0xFF for i in range(200))  # not compressible: several fragments
    src = tmp_path / "log.bin"
    src.write_bytes(data)
    inbox = tmp_path / "inbox"
    with Water(tmp_path, time_scale=20) as water:
        # the drivers' airtime model as fast as the emulated water
        fast = ["--driver-option", "packet_ms=25", "--driver-option", "byte_ms=4", "--driver-option",
                "turnaround_ms=15"]
        buoy = _node("buoy", 1, "diver", 2, water.paths[0], "--store", str(tmp_path / "store"), "--log",
                     str(tmp_path / "buoy.log"), *fast)
        diver = _node("diver", 2, "buoy", 1, water.paths[1], "--inbox", str(inbox), *fast)
        try:
            buoy.expect("ready")
            diver.expect("ready")
            buoy.send("file diver %s --priority 5" % src)
            assert buoy.expect("packet 1 to diver") == "packet 1 to diver: 200 bytes from %s, queued" % src
            assert buoy.expect("packet 1 ", timeout=60) == "packet 1 delivered"
            line = diver.expect("received packet")
            assert line.startswith("received packet buoy -> diver: 200 bytes, saved as " + str(inbox))
            saved = line.rsplit(" ", 1)[1]
            assert open(saved, "rb").read() == data
            # the diver leaves; a second file is queued, then Ctrl-C: exit 0
            rc, err = diver.finish()
            assert rc == 0, err
            buoy.send("file diver %s --lifespan 600" % src)
            buoy.expect("packet 2 to diver")
        finally:
            diver.kill()
            rc, err = buoy.finish(signal.SIGINT)
            assert rc == 0, err
            _no_traceback(err)
    # the transfer's progress went to the log, up to every fragment acknowledged
    progress = [d for d in map(json.loads, open(str(tmp_path / "buoy.log"))) if d["event"] == "progress"]
    assert progress and progress[0]["id"] == 1, progress
    assert all(d["acked"] <= d["sent"] <= d["count"] for d in progress), progress
    assert any(d["id"] == 1 and d["sent"] == d["count"] > 1 for d in progress), progress
    # the store holds the second file, and a transport opened on it resumes it
    from acomm.node import Node
    from acomm.transport.store import Store
    from acomm.transport import Transport

    with Store(str(tmp_path / "store" / "acomm.store"), capacity_bytes=1 << 22) as s:
        assert Transport.of(Node("buoy", 1), store=s).pending() == [2]


def test_commands_from_a_pipe_are_waited_for(tmp_path):
    # a script pipes commands in: at the end of its input the node waits
    # for their final statuses, then exits 0 (the water's beacon 2 answers
    # by itself, as a beacon in the water does)
    with Water(tmp_path) as water:
        rc, out, err = run(["node", "--name", "buoy", "--id", "1", "--known", "diver=2", "--modem",
                            "seatrac:" + water.paths[0]], stdin="send diver are you there --ack\nrange diver\n")
    assert rc == 0, err
    lines = out.splitlines()
    assert "end of input: waiting for 2 open requests to end (Ctrl-C leaves now)" in lines, lines
    assert "status acoustic 1 delivered" in lines and lines[-1] == "stopped", lines
    assert [ln for ln in lines if ln.startswith("range acoustic 2")] == ["range acoustic 2 diver 150.0 m"], lines


def test_bad_input_gives_one_line_and_the_exit_status(tmp_path):
    cases = [
        (["--modem", "sonar:/dev/ttyUSB0"], 2, "unknown modem kind 'sonar'"),
        (["--modem", "seatrac"], 2, "give KIND:DEVICE[:BAUD]"),
        (["--modem", "evologics:tcp://host"], 2, "give tcp://HOST:PORT"),
        (["--modem", "seatrac:/dev/null", "--driver-option", "bogus=1"], 2, "unexpected keyword argument 'bogus'"),
        (["--modem", "seatrac:%s/nosuch" % tmp_path], 1, "cannot open %s/nosuch: no such device" % tmp_path),
    ]
    for extra, status, want in cases:
        rc, out, err = run(["node", "--name", "a", "--id", "1"] + extra, timeout=30)
        assert rc == status and want in err, (extra, rc, out, err)
        assert len(err.strip().splitlines()) == 1, err
        _no_traceback(err)


def test_busy_and_silent_modems_are_named(tmp_path):
    from acomm_cpython.emulate.pty import PtyPair

    with PtyPair() as pair:
        # a port someone else holds: busy
        holder = serial.Serial(pair.path_a, 115200, exclusive=True)
        try:
            rc, out, err = run(["node", "--name", "a", "--id", "1", "--modem", "seatrac:" + pair.path_a], timeout=30)
            assert rc == 1 and "cannot open %s: busy" % pair.path_a in err, (rc, err)
            _no_traceback(err)
        finally:
            holder.close()
        # nothing on the other end: the start-up times out
        rc, out, err = run(["node", "--name", "a", "--id", "1", "--modem", "seatrac:" + pair.path_a,
                            "--startup-timeout", "1"], timeout=30)
        assert rc == 1 and err.strip() == ("acomm node: the seatrac modem on %s did not answer its start-up "
                                           "within 1 s" % pair.path_a), err


def test_modem_specs_parse():
    from acomm_cpython.modems import ModemSpecError, parse_spec

    assert parse_spec("seatrac:/dev/ttyUSB0") == ("seatrac", "/dev/ttyUSB0", None)
    assert parse_spec("iridium:/dev/ttyUSB1:19200") == ("iridium", "/dev/ttyUSB1", 19200)
    assert parse_spec("evologics:tcp://192.168.0.212:9200") == ("evologics", "tcp://192.168.0.212:9200", None)
    assert parse_spec("evologics:tcp:10.0.0.1:9200") == ("evologics", "tcp://10.0.0.1:9200", None)
    assert parse_spec("benthos:rfc2217://gw:4001") == ("benthos", "rfc2217://gw:4001", None)
    assert parse_spec("gsm:/dev/ttyACM0") == ("sms", "/dev/ttyACM0", None)
    for bad in ("", "seatrac:", "x:/dev/y", "seatrac:/dev/y:12", "evologics:tcp://h:0"):
        with pytest.raises(ModemSpecError):
            parse_spec(bad)


def test_the_progress_line_on_a_terminal():
    import io

    from acomm_cpython.console.eventlines import Output, progress_bar

    assert progress_bar(5, 20) == "[#####...............] 5/20"
    buf = io.StringIO()
    out = Output(buf, tty=True)
    out.emit({"event": "progress", "id": 3, "sent": 2, "acked": 0, "count": 8})
    out.emit({"event": "error", "error": "x"})
    out.emit({"event": "progress", "id": 3, "sent": 8, "acked": 8, "count": 8})
    bar2 = "packet 3 " + progress_bar(2, 8) + " sent, 0 acknowledged"
    bar8 = "packet 3 " + progress_bar(8, 8) + " sent, 8 acknowledged"
    # the bar, cleared for the line, drawn again under it, then redrawn in place
    assert buf.getvalue() == ("\r" + bar2 + "\r" + " " * len(bar2) + "\rerror: x\n" + bar2 + "\r" + bar8), buf.getvalue()
    out.emit({"event": "packet_status", "id": 3, "status": "delivered", "reason": "", "final": True})
    assert buf.getvalue().endswith(bar8 + "\r" + " " * len(bar8) + "\rpacket 3 delivered\n")  # the bar is gone
    piped = io.StringIO()
    Output(piped, tty=False).emit({"event": "progress", "id": 3, "sent": 2, "acked": 0, "count": 8})
    assert piped.getvalue() == ""  # no bar in a pipe or a file


EVO_FAST = {"packet_ms": 30, "im_bitrate": 9600, "burst_bitrate": 40000, "turnaround_ms": 20, "max_range_m": 300}


@pytest.mark.parametrize("scheme", ["tcp", "socket"])
def test_an_evologics_modem_on_ethernet(tmp_path, scheme):
    # modem 1 on TCP (tcp:// is acomm's reconnecting client, socket:// is
    # pyserial's URL, as for a serial server), modem 2 on its pty
    opts = []
    for k, v in EVO_FAST.items():
        opts += ["--option", "%s=%s" % (k, v)]
    evo1, evo2 = str(tmp_path / "evo1"), str(tmp_path / "evo2")
    emu = Proc(["emulate", "evologics", "--link", evo1, "--address", "1", "--tcp", "0", "--peer", "2:%s:150" % evo2]
               + opts)
    try:
        port = emu.expect("tcp 127.0.0.1:").rsplit(":", 1)[1]
        emu.expect(evo2)
        dopts = []
        for k, v in dict(EVO_FAST, margin_ms=1000, cmd_timeout_ms=2000).items():
            dopts += ["--driver-option", "%s=%s" % (k, v)]
        top = Proc(["node", "--name", "topside", "--id", "1", "--known", "auv=2", "--modem",
                    "evologics:%s://127.0.0.1:%s" % (scheme, port)] + dopts)
        auv = Proc(["node", "--name", "auv", "--id", "2", "--known", "topside=1", "--modem", "evologics:" + evo2]
                   + dopts)
        try:
            assert top.expect("acoustic:") == "acoustic: evologics on %s://127.0.0.1:%s, up" % (scheme, port)
            top.expect("ready")
            auv.expect("ready")
            top.send("send auv dive to 20 m --ack")
            assert top.expect("status acoustic 1") == "status acoustic 1 delivered"
            assert auv.expect("received") == "received acoustic topside -> auv: dive to 20 m"
        finally:
            for p in (top, auv):
                rc, err = p.finish()
                assert rc == 0, err
                _no_traceback(err)
    finally:
        emu.finish(signal.SIGTERM)


def test_a_node_and_a_board_drive_a_modem_with_the_same_class():
    from acomm_cpython.modems import DRIVERS, make_driver
    from acomm.drivers.registry import driver_class, names

    for kind in names():
        assert type(make_driver(kind, 3)) is driver_class(kind), kind
    assert sorted(DRIVERS) == sorted(names())
