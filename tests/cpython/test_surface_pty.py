# The Iridium SBD and GSM SMS drivers over real pseudo-terminals opened with
# pyserial, against `acomm emulate iridium` and `acomm emulate gsm` run as
# real processes: two emulated modems (--link and --peer) share one
# emulated gateway / SMS centre, and --mt leaves a message waiting for the
# first. The emulated world runs ten times faster than real time (sessions
# and network delays shrink); the drivers run on real time. CPython only;
# every wait is bounded and no timing is asserted.

import os
import subprocess
import sys
import time

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm import frame as fr  # noqa: E402
from acomm.events import EV_RECEIVED, EV_STATUS, TRANSMITTED, is_final  # noqa: E402
from acomm.node import Node  # noqa: E402
from acomm_cpython.streams import open_serial  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# a bound on waits that take 1 to 3 s alone: `make test` runs this beside
# the emulated boards at a higher priority, and once it ran out of 20 s
TIMEOUT_S = 60


class Emulated:
    # `acomm emulate MODEM --link A --peer 2:B ...` as a child process
    def __init__(self, tmp_path, modem, extra):
        self.links = (str(tmp_path / (modem + "-1")), str(tmp_path / (modem + "-2")))
        cmd = [sys.executable, "-m", "acomm_cpython.cli", "emulate", modem, "--link", self.links[0],
               "--peer", "2:" + self.links[1], "--time-scale", "10"] + list(extra)
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([ROOT, os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "sim")])
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
        banner = [self.proc.stdout.readline() for _ in range(2)]
        assert all("address" in line for line in banner), (banner, self.proc.stderr.read())

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)
        assert self.proc.returncode == 0, self.proc.stderr.read()
        for p in self.links:
            assert not os.path.lexists(p)


def probe(path, command, answer):
    # a terminal program's view: a command in, the modem's answer out
    port = open_serial(path, 19200)
    try:
        port.write(command)
        got = bytearray()
        end = time.monotonic() + 5
        while answer not in got and time.monotonic() < end:
            got += port.read(4096)
            time.sleep(0.01)
        return bytes(got)
    finally:
        port.close()


def nodes_on(em, make_driver, link_name):
    ports, nodes, events = [], [], ([], [])
    for i, (name, nid) in enumerate((("buoy", 1), ("shore", 2))):
        port = open_serial(em.links[i], 19200)
        ports.append(port)
        node = Node(name, nid, listener=events[i].append)
        node.names.add("buoy", 1)
        node.names.add("shore", 2)
        node.add_link(link_name, make_driver(nid), port, advert_period_ms=3600000, ack_timeout_ms=60000)
        nodes.append(node)
    return ports, nodes, events


def run_until(nodes, cond, seconds=TIMEOUT_S):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for n in nodes:
            n.step()
        if cond():
            return True
        time.sleep(0.002)
    return False


def final(events, rid):
    for ev in events:
        if ev[0] == EV_STATUS and ev[2] == rid and is_final(ev[3]):
            return ev[3]
    return None


def received(events):
    return [(e[2], e[3], bytes(e[4])) for e in events if e[0] == EV_RECEIVED]


def test_iridium_driver_against_acomm_emulate_iridium(tmp_path):
    from acomm.drivers.iridium import IridiumDriver

    # a frame from the shore node waits at the gateway for the buoy's modem
    waiting = fr.encode_raw(fr.Frame(fr.DATA, 2, 1, 0, b"from the gateway"))
    em = Emulated(tmp_path, "iridium", ["--option", "session_ms=3000", "--mt", waiting.hex()])
    ports = []
    try:
        got = probe(em.links[0], b"AT+CSQ\r", b"OK\r\n")
        assert b"AT+CSQ\r\r\n+CSQ:5\r\n\r\nOK\r\n" in got, got  # echo, then V.250 verbose framing
        ports, nodes, events = nodes_on(em, lambda a: IridiumDriver(a, mo_mtu=270, mailbox_check_ms=1000),
                                        "satellite")
        # the buoy's first mailbox check fetches the waiting frame
        assert run_until(nodes, lambda: received(events[0]))
        assert received(events[0]) == [("shore", "buoy", b"from the gateway")]
        rid = nodes[0].send("satellite", "shore", b"from the buoy", 60, 2)
        assert run_until(nodes, lambda: received(events[1]))
        assert final(events[0], rid) == TRANSMITTED
        assert received(events[1]) == [("buoy", "shore", b"from the buoy")]
        for n in nodes:
            d = n.links["satellite"].driver
            assert d.junk == {} and d.stats["unexpected"] == 0 and d.at.stats["timeouts"] == 0
    finally:
        for p in ports:
            p.close()
        em.stop()


def test_sms_driver_against_acomm_emulate_gsm(tmp_path):
    from acomm.drivers.sms import SmsDriver
    from acomm_sim.gsm import default_number

    numbers = {1: default_number(1), 2: default_number(2)}
    em = Emulated(tmp_path, "gsm", ["--option", "send_ms=500", "--mt", b"nobody we know".hex()])
    ports = []
    try:
        got = probe(em.links[0], b"AT+CPIN?\r", b"OK\r\n")
        assert b"\r\n+CPIN: READY\r\n\r\nOK\r\n" in got, got
        ports, nodes, events = nodes_on(em, lambda a: SmsDriver(a, numbers), "gsm")
        assert run_until(nodes, lambda: all(n.links["gsm"].driver.ready(n.clock()) for n in nodes))
        rid = nodes[0].send("gsm", "shore", b"surfaced", 60, 2, ack=True)
        assert run_until(nodes, lambda: final(events[0], rid) is not None)
        assert final(events[0], rid) == 5  # delivered: the shore's link ack came back by SMS
        assert received(events[1]) == [("buoy", "shore", b"surfaced")]
        d = nodes[0].links["gsm"].driver
        # the message from an unknown number (--mt) was read, dropped and deleted
        assert d.stats["rx_unknown_sender"] == 1 and d.stats["deleted"] >= 1
        for n in nodes:
            d = n.links["gsm"].driver
            assert d.junk == {} and d.stats["unexpected"] == 0
    finally:
        for p in ports:
            p.close()
        em.stop()
