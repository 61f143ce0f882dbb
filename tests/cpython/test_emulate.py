# `acomm emulate`: the command is started as a real process, its pseudo-
# terminals are opened with pyserial by path (the symlinks it makes), and
# acomm's own drivers exchange frames through them, exactly as with modems
# behind USB-serial adapters. Also the TCP side (EvoLogics modems are reached
# over TCP as well) and acomm_cpython.streams.TcpStream's reconnection.
# CPython only; every wait is bounded and no timing is asserted.

import os
import subprocess
import sys
import time

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm.events import DELIVERED, EV_RECEIVED, EV_STATUS, is_final  # noqa: E402
from acomm.node import Node  # noqa: E402
from acomm_cpython.emulate.host import MODEMS, EmulatorHost, emulator_class, parse_peer  # noqa: E402
from acomm_cpython.modems import parse_value  # noqa: E402
from acomm_cpython.streams import TcpStream, open_serial  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TIMEOUT_S = 15


def available(modem):
    try:
        emulator_class(modem)
        return True
    except ImportError:
        return False


# per modem: fast emulator options, the driver for an address, a raw probe
# written to the port and the start of the expected answer
def seatrac_driver(addr):
    from acomm.drivers.seatrac import SeatracDriver

    return SeatracDriver(addr, margin_ms=1000, packet_ms=100, byte_ms=8, turnaround_ms=50)


def micromodem_driver(addr):
    from acomm.drivers.micromodem import MicroModemDriver

    return MicroModemDriver(addr, air_scale=0.1, max_range_m=300, modem_wait_ms=1000, margin_ms=500,
                            reboot_wait_ms=200, retry_ms=500)


EVO_FAST = {"packet_ms": 30, "im_bitrate": 9600, "burst_bitrate": 40000, "turnaround_ms": 20, "max_range_m": 300}


def evologics_driver(addr):
    from acomm.drivers.evologics import EvologicsDriver

    return EvologicsDriver(addr, margin_ms=1000, cmd_timeout_ms=2000, **EVO_FAST)


def benthos_driver(addr):
    from acomm.drivers.benthos import BenthosDriver

    return BenthosDriver(addr, packet_ms=100, guard_ms=150, cmd_timeout_ms=1000, prompt_timeout_ms=1000,
                         ac_rsp_tmo_ms=2000)


CASES = {
    "seatrac": (["packet_ms=100", "byte_ms=8", "turnaround_ms=50"], seatrac_driver, b"#0281C1\r\n", b"$02"),
    "benthos": (["packet_ms=100", "guard_ms=100", "turnaround_ms=50", "boot_ms=200"], benthos_driver, b"+++",
                b"user:1>"),
    "evologics": (["%s=%s" % kv for kv in EVO_FAST.items()], evologics_driver, b"AT?AL\n", b"1\r\n"),
    "micromodem": (["air_scale=0.1", "max_range_m=300", "data_timeout_ms=1000"], micromodem_driver,
                   b"$CCCFG,SRC,1*31\r\n", b"$CACFG,SRC,1*33"),
}


class Emulate:
    # `acomm emulate MODEM --link A --peer 2:B` as a child process
    def __init__(self, tmp_path, modem, options, extra=()):
        self.links = (str(tmp_path / ("%s-1" % modem)), str(tmp_path / ("%s-2" % modem)))
        cmd = [sys.executable, "-m", "acomm_cpython.cli", "emulate", modem, "--link", self.links[0],
               "--peer", "2:%s:150" % self.links[1]]
        for o in options:
            cmd += ["--option", o]
        cmd += list(extra)
        env = dict(os.environ)
        env["PYTHONPATH"] = os.pathsep.join([ROOT, os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "sim")])
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
        self.banner = [self.proc.stdout.readline() for _ in range(2)]
        assert all("address" in line for line in self.banner), (self.banner, self.proc.stderr.read())
        for p in self.links:
            assert os.path.islink(p) and os.readlink(p).startswith("/dev/")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)
        assert self.proc.returncode == 0, self.proc.stderr.read()
        for p in self.links:
            assert not os.path.lexists(p)  # it cleans up after itself


def read_until(port, prefix, seconds=5):
    got = bytearray()
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        got += port.read(4096)
        if prefix in got:
            return bytes(got)
        time.sleep(0.01)
    return bytes(got)


def final(events, rid):
    for ev in events:
        if ev[0] == EV_STATUS and ev[2] == rid and is_final(ev[3]):
            return ev[3]
    return None


def run_until(nodes, cond, seconds=TIMEOUT_S):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        for n in nodes:
            n.step()
        if cond():
            return True
        time.sleep(0.002)
    return False


@pytest.mark.parametrize("modem", sorted(CASES))
def test_emulate_command_answers_and_carries_frames(tmp_path, modem):
    if not available(modem):
        pytest.skip("no %s emulator" % modem)
    options, make_driver, probe, answer = CASES[modem]
    em = Emulate(tmp_path, modem, options)
    ports = []
    try:
        # a terminal program's view: raw bytes in, the modem's answer out
        raw = open_serial(em.links[0], 19200)
        time.sleep(0.3)  # some modems want a quiet line first (Benthos: the +++ guard)
        raw.write(probe)
        got = read_until(raw, answer)
        assert answer in got, got
        raw.close()
        # acomm's drivers on both ports, through the emulated water
        nodes = []
        events = ([], [])
        for i, (name, addr) in enumerate((("buoy", 1), ("diver", 2))):
            port = open_serial(em.links[i], 19200)
            ports.append(port)
            node = Node(name, addr, listener=events[i].append)
            node.names.add("buoy", 1)
            node.names.add("diver", 2)
            node.add_link("acoustic", make_driver(addr), port, advert_period_ms=600000)
            nodes.append(node)
        assert run_until(nodes, lambda: all(n.links["acoustic"].driver.ready(n.clock()) for n in nodes))
        rid = nodes[0].send("acoustic", "diver", b"hello from the pty", 30, 2, True)
        assert run_until(nodes, lambda: final(events[0], rid) is not None)
        assert final(events[0], rid) == DELIVERED
        got = [bytes(e[4]) for e in events[1] if e[0] == EV_RECEIVED]
        assert got == [b"hello from the pty"]
    finally:
        for p in ports:
            p.close()
        em.stop()


def test_every_modem_is_registered_and_options_parse():
    assert sorted(MODEMS) == ["benthos", "evologics", "gsm", "iridium", "micromodem", "seatrac"]
    assert parse_value("100") == 100 and parse_value("0.5") == 0.5 and parse_value("on") is True
    assert parse_value("X150") == "X150"
    assert parse_peer("2") == (2, None, None)
    assert parse_peer("3:/tmp/m3") == (3, "/tmp/m3", None)
    assert parse_peer("4::250") == (4, None, 250.0)


def test_refuses_to_replace_a_file_and_reports_unknown_modems(tmp_path):
    f = tmp_path / "not-a-link"
    f.write_text("keep me")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT, os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "sim")])
    r = subprocess.run([sys.executable, "-m", "acomm_cpython.cli", "emulate", "seatrac", "--link", str(f)],
                       capture_output=True, text=True, env=env, timeout=30)
    assert r.returncode == 1 and "not a symlink" in r.stderr
    assert f.read_text() == "keep me"
    with pytest.raises(ValueError):
        emulator_class("popoto")


def test_tcp_clients_share_the_modem_and_the_stream_reconnects(tmp_path):
    host = EmulatorHost("seatrac", str(tmp_path / "st"), 1, tcp_port=0)
    port = host.stations[0].tcp.port
    s = TcpStream("127.0.0.1", port, backoff_s=(0.05, 0.2))
    try:
        got = bytearray()
        end = time.monotonic() + TIMEOUT_S
        while b"$02" not in got and time.monotonic() < end:
            if s.connected and not got:
                s.write(b"#0281C1\r\n")
                got += b" "
            host.step(0.005)
            got += s.read()
        assert b"$02" in got and s.connects == 1
        # the modem end drops every client: the stream comes back by itself
        for c in list(host.stations[0].tcp.clients):
            host.stations[0].tcp.drop(c)
        end = time.monotonic() + TIMEOUT_S
        while s.connects < 2 and time.monotonic() < end:
            host.step(0.005)
            s.read()
        assert s.connects == 2
        got = bytearray()
        s.write(b"#0281C1\r\n")
        end = time.monotonic() + TIMEOUT_S
        while b"$02" not in got and time.monotonic() < end:
            host.step(0.005)
            got += s.read()
        assert b"$02" in got
    finally:
        s.close()
        host.close()
    assert not os.path.lexists(str(tmp_path / "st"))


def test_evologics_over_tcp_and_serial_in_one_water(tmp_path):
    # modem 1 is reached over TCP (as on port 9200 of a real one), modem 2
    # over its pty: acomm's driver on each, a frame each way
    if not available("evologics"):
        pytest.skip("no evologics emulator")
    host = EmulatorHost("evologics", str(tmp_path / "evo1"), 1, [(2, str(tmp_path / "evo2"), 150.0)],
                        EVO_FAST, tcp_port=0)
    tcp = TcpStream("127.0.0.1", host.stations[0].tcp.port, backoff_s=(0.05, 0.2))
    ser = open_serial(str(tmp_path / "evo2"), 19200)
    events = ([], [])
    nodes = []
    try:
        for i, (name, addr, stream) in enumerate((("topside", 1, tcp), ("auv", 2, ser))):
            node = Node(name, addr, listener=events[i].append)
            node.names.add("topside", 1)
            node.names.add("auv", 2)
            node.add_link("acoustic", evologics_driver(addr), stream, advert_period_ms=600000)
            nodes.append(node)

        def step_all():
            host.step(0.002)
            for n in nodes:
                n.step()

        def until(cond):
            end = time.monotonic() + TIMEOUT_S
            while time.monotonic() < end:
                step_all()
                if cond():
                    return True
            return False

        assert until(lambda: all(n.links["acoustic"].driver.ready(n.clock()) for n in nodes))
        r1 = nodes[0].send("acoustic", "auv", b"dive to 20 m", 30, 2, True)
        assert until(lambda: final(events[0], r1) is not None) and final(events[0], r1) == DELIVERED
        r2 = nodes[1].send("acoustic", "topside", b"at 20 m", 30, 2, True)
        assert until(lambda: final(events[1], r2) is not None) and final(events[1], r2) == DELIVERED
        assert [bytes(e[4]) for e in events[1] if e[0] == EV_RECEIVED] == [b"dive to 20 m"]
        assert [bytes(e[4]) for e in events[0] if e[0] == EV_RECEIVED] == [b"at 20 m"]
        assert tcp.connects == 1
    finally:
        tcp.close()
        ser.close()
        host.close()
