# The shore through the real command lines: `acomm emulate iridium` with the
# gateway's shore services (--directip, --directip-mt, --rockblock-post,
# --rockblock-mt, --rockblock-credentials, --rockblock-public-key,
# --shore-retry) and `acomm node --iridium directip:...` / `rockblock:...`
# as child processes, and a buoy (acomm's Iridium driver on the emulated
# modem's pty) in this process. The buoy's frame reaches the shore node,
# and the shore's `send buoy ... --ack` reaches the buoy as an MT message
# and is acknowledged. The emulated world runs 20 times faster than real
# time. A RockBLOCK shore given no key= verifies with Rock7's published key
# (the TEST key's POST is refused). Usage errors end with exit 2 and one line.
import json
import os
import queue
import socket
import subprocess
import sys
import threading
import time

import pytest

pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm.drivers.iridium import IridiumDriver  # noqa: E402
from acomm.events import DELIVERED, EV_AVAILABILITY, EV_RECEIVED, EV_STATUS  # noqa: E402
from acomm.node import Node  # noqa: E402
from acomm_cpython.bench.workloads.surface_rig import write_private  # noqa: E402
from acomm_cpython.streams import open_serial  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
IMEI = "300234010000001"  # the emulated modem at address 1
TIMEOUT_S = 30


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [os.path.join(ROOT, "ports", p) for p in ("cpython", "sim")])
    return env


def _acomm(*args, **kw):
    return subprocess.Popen([sys.executable, "-m", "acomm_cpython.cli"] + list(args), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, stdin=subprocess.PIPE, text=True, env=_env(), cwd=ROOT, **kw)


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _lines(proc):
    q = queue.Queue()

    def pump():
        for line in proc.stdout:
            q.put(line)

    threading.Thread(target=pump, daemon=True).start()
    return q


def _wait_line(q, needle, seen, timeout=TIMEOUT_S):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            line = q.get(timeout=0.1)
        except queue.Empty:
            continue
        seen.append(line)
        if needle in line:
            return line
    raise AssertionError("no %r in %s" % (needle, seen))


@pytest.mark.parametrize("service", ["directip", "rockblock"])
def test_the_buoy_and_a_shore_node_talk_through_acomm_emulate_iridium(tmp_path, service):
    shore_port = _free_port()
    link = str(tmp_path / "sbd")
    if service == "directip":
        emu_args = ["--directip", "127.0.0.1:%d" % shore_port, "--directip-mt", "127.0.0.1:0"]
        mt_mark = "MT DirectIP on"
    else:
        creds = write_private(str(tmp_path / "rock7.creds"), "username=buoyteam\npassword=s3cret\n")
        key = str(tmp_path / "rock7-test.pem")
        emu_args = ["--rockblock-post", "http://127.0.0.1:%d/mo" % shore_port, "--rockblock-mt", "127.0.0.1:0",
                    "--rockblock-credentials", creds, "--rockblock-public-key", key]
        mt_mark = "RockBLOCK MT API on"
    emu = _acomm("emulate", "iridium", "--link", link, "--time-scale", "20", "--shore-retry", "5", *emu_args)
    shore = None
    serial = None
    try:
        eq, seen = _lines(emu), []
        mt_line = _wait_line(eq, mt_mark, seen)
        _wait_line(eq, "address 1", seen)
        mt = mt_line.split(" on ")[1].strip()
        if service == "directip":
            spec = "directip:127.0.0.1:%d,mt=%s,imei=%s,gateway=127.0.0.1" % (shore_port, mt, IMEI)
        else:
            spec = "rockblock:127.0.0.1:%d,key=%s,mt=%s,credentials=%s,imei=%s" % (shore_port, key, mt, creds, IMEI)
        shore = _acomm("node", "--name", "shore", "--id", "3", "--known", "buoy=1", "--iridium", spec, "--json")
        sq, sseen = _lines(shore), []
        _wait_line(sq, "ready", sseen)
        events = []
        buoy = Node("buoy", 1, listener=events.append)
        buoy.names.add("shore", 3)
        serial = open_serial(link, 19200)
        buoy.add_link("satellite", IridiumDriver(), serial, advert_period_ms=3600000, ack_timeout_ms=60000)

        def run_until(cond):
            end = time.monotonic() + TIMEOUT_S
            while time.monotonic() < end and not cond():
                buoy.step()
                time.sleep(0.005)
                while not sq.empty():
                    sseen.append(sq.get())
            return cond()

        def shore_said(**kv):
            evs = [json.loads(ln) for ln in sseen if ln.startswith("{")]
            return any(all(e.get(k) == v for k, v in kv.items()) for e in evs)

        # the shore's advert comes as an MT message (its imei= lets it go at once)
        assert run_until(lambda: any(e[0] == EV_AVAILABILITY and e[2] == "shore" for e in events)), (sseen, events)
        buoy.send("satellite", "shore", b"buoy: diver report relayed", 600, ack=True)
        assert run_until(lambda: shore_said(event="received", src="buoy")), (sseen, events)
        assert run_until(lambda: any(e[0] == EV_STATUS and e[3] == DELIVERED for e in events)), events
        shore.stdin.write("send buoy shore: come up --ack\n")
        shore.stdin.flush()
        assert run_until(lambda: any(e[0] == EV_RECEIVED and e[4] == b"shore: come up" for e in events)), sseen
        assert run_until(lambda: shore_said(event="status", status="delivered")), sseen
    finally:
        if serial is not None:
            serial.close()
        for p in (shore, emu):
            if p is not None:
                p.terminate()
                p.wait(10)
    assert shore.returncode == 0 and emu.returncode == 0, (shore.stderr.read(), emu.stderr.read())


def test_a_rockblock_shore_without_key_verifies_with_rock7s_published_key(tmp_path):
    # `--iridium rockblock:PORT` with no key=: a POST the emulator's TEST key signed is forged to it
    import http.client

    from acomm_cpython.emulate.rock7_testkey import PRIVATE_PEM
    from acomm_cpython.shore import jwt_rs256
    from acomm_cpython.shore import rockblock as rb

    shore = _acomm("node", "--name", "shore", "--id", "3", "--json", "--iridium", "rockblock:127.0.0.1:0")
    try:
        line = _wait_line(_lines(shore), "rockblock listening", [])
        port = int(json.loads(line)["text"].rsplit(":", 1)[1])
        fields = {"imei": IMEI, "serial": "12345", "momsn": "1", "transmit_time": "21-10-31 10:41:50",
                  "iridium_latitude": "52.3867", "iridium_longitude": "0.2938", "iridium_cep": "8", "data": "00"}
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
        c.request("POST", "/", rb.mo_form(fields, jwt_rs256.private_key(PRIVATE_PEM)),
                  {"Content-Type": "application/x-www-form-urlencoded"})
        assert c.getresponse().status == 401
    finally:
        shore.terminate()
        shore.wait(10)


def test_usage_errors_say_what_is_missing_in_one_line(tmp_path):
    p = _acomm("node", "--name", "shore", "--id", "3", "--iridium", "rockblock:0,mt=http://127.0.0.1:1/")
    _, err = p.communicate(timeout=20)
    assert p.returncode == 2 and "credentials=FILE" in err and len(err.strip().splitlines()) == 1, err
    p = _acomm("node", "--name", "shore", "--id", "3", "--iridium", "satphone:0")
    _, err = p.communicate(timeout=20)
    assert p.returncode == 2 and "directip:" in err, err
    p = _acomm("emulate", "seatrac", "--link", str(tmp_path / "x"), "--directip", "127.0.0.1:1")
    _, err = p.communicate(timeout=20)
    assert p.returncode == 2 and "for iridium" in err, err
    from acomm_cpython.emulate.rockblockgw import public_test_pem

    creds = tmp_path / "open.creds"
    creds.write_text("username=u\npassword=secret-pw\n")
    creds.chmod(0o644)
    key = write_private(str(tmp_path / "k.pem"), public_test_pem())
    p = _acomm("node", "--name", "shore", "--id", "3", "--iridium",
               "rockblock:127.0.0.1:0,key=%s,mt=http://127.0.0.1:1/,credentials=%s" % (key, creds))
    _, err = p.communicate(timeout=20)
    assert p.returncode == 1 and "too open" in err and "chmod 600" in err and "secret-pw" not in err, err
    bad = write_private(str(tmp_path / "bad.pem"), "not a key")
    p = _acomm("node", "--name", "shore", "--id", "3", "--iridium", "rockblock:127.0.0.1:0,key=%s" % bad)
    _, err = p.communicate(timeout=20)
    assert p.returncode == 1 and "not a PEM key" in err, err
