# `acomm bridge mavlink` end to end: two bridge processes on two beacons of
# `acomm emulate seatrac` (real pseudo-terminals), a scripted GCS and a
# scripted autopilot speaking pymavlink over real UDP sockets on loopback
# (acomm_cpython.bench.workloads.mavpeers). The tests run in file order on
# one set of processes: sticks, arming, a link cut by noise in the water
# (the emulator's SIGUSR1) and back, an attacker's beacon without the key
# and with a wrong one, a damaged MAVLink stream, then the counters each
# bridge prints at SIGTERM. A replay of a sealed arm command is made in the
# simulated ocean, where the attacker can send as the topside's modem.
import json
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

pytest.importorskip("pymavlink")

from acomm_cpython.bench.workloads.mavpeers import Autopilot, GroundStation  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as M  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PY = [sys.executable, "-m", "acomm_cpython.cli"]
TIMEOUT_S = 10.0  # the vehicle's failsafe timeout on a SeaTrac (the bridge's default)


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [os.path.join(ROOT, "ports", p) for p in ("cpython", "sim")])
    return env


class Bridge:
    # a bridge process whose JSON lines are collected by a thread
    def __init__(self, args):
        self.p = subprocess.Popen(PY + ["bridge", "mavlink", "--json"] + args, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True, env=_env(), cwd=ROOT)
        self.lines = []
        self.ready = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.p.stdout:
            d = json.loads(line)
            self.lines.append(d)
            if d["event"] == "ready":
                self.ready.set()

    def texts(self):
        return [d["text"] for d in self.lines if d["event"] == "bridge"]

    def stop(self):
        self.p.send_signal(signal.SIGTERM)
        self.p.wait(15)
        time.sleep(0.2)
        return next(d for d in self.lines if d["event"] == "stats")


def _wait(cond, timeout_s, step_s=0.05):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        got = cond()
        if got:
            return got
        time.sleep(step_s)
    return cond()


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    d = str(tmp_path_factory.mktemp("mav"))
    key, wrong = os.path.join(d, "key"), os.path.join(d, "wrong")
    for path in (key, wrong):
        with open(path, "w") as f:
            f.write(os.urandom(16).hex())
        os.chmod(path, 0o600)
    emu = subprocess.Popen(PY + ["emulate", "seatrac", "--link", d + "/veh", "--address", "2",
                                 "--peer", "1:%s/top:85" % d, "--peer", "3:%s/eve:60" % d],
                           stdout=subprocess.PIPE, text=True, env=_env(), cwd=ROOT)
    for _ in range(3):
        assert "emulator, address" in emu.stdout.readline()
    ap, gcs = Autopilot(), GroundStation()
    ap.start()
    gcs.start()
    veh = Bridge(["--vehicle", "udpout:127.0.0.1:%d" % ap.port, "--modem", "seatrac:%s/veh" % d,
                  "--key-file", key])
    top = Bridge(["--gcs", "udpout:127.0.0.1:%d" % gcs.port, "--modem", "seatrac:%s/top" % d, "--key-file", key])
    rig = {"dir": d, "emu": emu, "ap": ap, "gcs": gcs, "veh": veh, "top": top, "key": key, "wrong": wrong}
    try:
        assert veh.ready.wait(30) and top.ready.wait(30), (veh.p.stderr, top.p.stderr)
        time.sleep(6)  # the start-up states and the first poll go by
        yield rig
    finally:
        for b in (veh, top):
            if b.p.poll() is None:
                b.p.kill()
        emu.terminate()
        emu.wait(10)
        ap.stop()
        gcs.stop()


def _stick_at_autopilot(ap, since, want, timeout_s):
    # the first MANUAL_CONTROL after `since` carrying `want` (x, y, z) within a quantization step
    def hit():
        return next((t for t, v in ap.manual_since(since) if all(abs(a - b) <= 40 for a, b in zip(v, want))), None)
    return _wait(hit, timeout_s)


def test_sticks_arrive_in_order_and_quantized(rig):
    ap, gcs = rig["ap"], rig["gcs"]
    t0 = time.monotonic()
    # GCS values -> what the teleop catalog's 1/15 steps make of them
    moves = [((500, 0, 500), (533, 0, 500)), ((0, -300, 500), (0, -333, 500)), ((0, 0, 850), (0, 0, 867))]
    for sent, want in moves:
        t = time.monotonic()
        gcs.move(*sent)
        assert _stick_at_autopilot(ap, t, want, 12), (sent, rig["veh"].texts())
    seen = []
    for _, v in ap.manual_since(t0):
        if v[:3] != (0, 0, 500) and (not seen or seen[-1] != v[:3]):
            seen.append(v[:3])
    assert seen == [w for _, w in moves]  # in order, nothing in between, each exactly quantized
    assert ap.pilot_failsafe_trips == 0


def test_arm_from_the_gcs_arrives_sealed_and_is_acknowledged(rig):
    ap, gcs = rig["ap"], rig["gcs"]
    assert not ap.armed
    gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
    ack = _wait(lambda: [a for a in gcs.acks() if a[1] == M.MAV_CMD_COMPONENT_ARM_DISARM], 30)
    assert ack and ack[0][2] == M.MAV_RESULT_ACCEPTED, rig["top"].texts()
    assert ap.armed
    assert "autopilot: arm -> accepted" in rig["veh"].texts()
    # the GCS sees the vehicle armed in the topside's HEARTBEAT once the state says so
    assert _wait(lambda: any(m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED and m.type == M.MAV_TYPE_SUBMARINE
                             for _, m in gcs.messages("HEARTBEAT")), 25)


def test_noise_in_the_water_gives_neutral_within_the_timeout_then_control_resumes(rig):
    ap, gcs, emu = rig["ap"], rig["gcs"], rig["emu"]
    gcs.move(600, 0, 500)
    assert _stick_at_autopilot(ap, time.monotonic(), (600, 0, 500), 12)
    jam = time.monotonic()
    emu.send_signal(signal.SIGUSR1)
    neutral = _stick_at_autopilot(ap, jam, (0, 0, 500), TIMEOUT_S + 3)
    # from the last packet heard, which came before the noise: within the timeout and a tick of it
    assert neutral and neutral - jam <= TIMEOUT_S + 0.2, rig["veh"].texts()
    assert any(t.startswith("failsafe: timeout") for t in rig["veh"].texts())
    assert ap.pilot_failsafe_trips == 0  # the bridge kept MANUAL_CONTROL flowing: ArduSub's own failsafe is quiet
    emu.send_signal(signal.SIGUSR2)
    back = time.monotonic()
    gcs.move(-400, 0, 500)
    assert _stick_at_autopilot(ap, back, (-400, 0, 500), 20), rig["veh"].texts()
    assert any(t.startswith("failsafe: recovered") for t in rig["veh"].texts())


def _eve(rig, key_file):
    # another beacon in the same water sends an arm command to the vehicle's beacon
    from acomm.catalog import rovcontrol as R
    from acomm_cpython.blocking import Node

    arm = R.CATALOG.pack([("command", {"cmd": R.CMD_ARM, "force": 1, "mode": 0, "tag": 9})])
    opts = {"modems": ["seatrac:%s/eve" % rig["dir"]], "known": {"vehicle": 2}, "transport": False}
    if key_file is not None:
        opts["key_file"] = key_file
    eve = Node.open("eve", 3, **opts)
    try:
        for _ in range(4):  # until the vehicle's beacon has it (the half-duplex water may be busy)
            st = eve.send_and_wait("vehicle", arm, lifespan_s=20, ack=True, timeout_s=25)
            if st.ok:
                break
    finally:
        eve.close()
    return st


def test_forged_arm_commands_never_reach_the_autopilot(rig):
    ap, gcs = rig["ap"], rig["gcs"]
    gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0.0)  # disarm first, so an arm would show
    assert _wait(lambda: not ap.armed, 30)
    assert _wait(lambda: len(gcs.acks()) == 2, 30), rig["top"].texts()
    commands = len(ap.messages("COMMAND_LONG"))
    st = _eve(rig, None)  # no key: unsealed
    assert st.ok, st
    assert _wait(lambda: any("refused from" in t for t in rig["veh"].texts()), 10), rig["veh"].texts()
    st = _eve(rig, rig["wrong"])  # sealed with another key: the tag does not verify
    assert st.ok, st
    time.sleep(3)
    assert len(ap.messages("COMMAND_LONG")) == commands and not ap.armed


def test_a_damaged_mavlink_stream_does_not_stop_the_bridge(rig):
    ap, gcs = rig["ap"], rig["gcs"]
    good = M.MAVLink(None, 255, 190).manual_control_encode(1, 0, 0, 500, 0, 0).pack(M.MAVLink(None, 255, 190))
    bad_crc = bytearray(good)
    bad_crc[-3] ^= 0x55
    unknown = bytes([0xFD, 2, 0, 0, 7, 255, 190, 0x60, 0xEA, 0x00, 1, 2, 0x12, 0x34])  # id 60000
    # (random bytes last: a stray 0xFE or 0xFD in them starts a frame that swallows what follows)
    for junk in (unknown, b"\x00\x11garbage", bytes(bad_crc), os.urandom(300)):
        gcs.send_raw(junk)
    t = time.monotonic()
    gcs.move(0, 700, 500)
    assert _stick_at_autopilot(ap, t, (0, 733, 500), 15), rig["veh"].texts()  # 0.7: 10.5 steps, half up


def test_counters_at_the_end(rig):
    top = rig["top"].stop()
    veh = rig["veh"].stop()
    assert top["mavlink"]["bad_crc"] >= 1 and top["mavlink"]["unknown"] >= 1 and top["mavlink"]["bad_bytes"] >= 1, top
    assert top["side"]["acks"] == 2 and top["side"]["command_timeouts"] == 0, (top["side"], rig["gcs"].acks())
    assert veh["side"]["commands"] == 2, veh  # arm and disarm: none of eve's
    assert veh["bridge"]["refused"] >= 1, veh
    assert veh["side"]["manual_control"] > 0 and rig["ap"].pilot_failsafe_trips == 0, veh


def test_a_replayed_arm_command_is_refused():
    # the simulated ocean: the topside arms, then disarms; a recording of the
    # arm frame, sent again as the topside's modem, changes nothing
    from acomm_cpython.bench.workloads.mavlink_workload import _world
    from acomm_cpython.bench.workloads.mavsim import SimBridges

    w, top, veh = _world("bpsk")
    sb = SimBridges(w, top, veh, lambda now: (0, 0, 500, 0, 0, 0))
    w.add_task(sb)
    w.run(5000)
    before = len(sb.uplink)
    sb.command(w.now(), M.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
    w.run(15000)
    assert sb.armed
    arm_frames = sb.uplink[before:]  # the topside's packets on the water, the sealed arm among them
    sb.command(w.now(), M.MAV_CMD_COMPONENT_ARM_DISARM, 0.0)
    w.run(15000)
    assert not sb.armed and sb.vehicle.stats["commands"] == 2
    for packet, airtime in arm_frames:
        w.channel.transmit(w.now(), top.address, packet, airtime)
        w.run(3000)
    assert not sb.armed and sb.vehicle.stats["commands"] == 2
    assert veh.node.auth.stats["replayed"] >= 1


def _cli(args):
    return subprocess.run(PY + ["bridge", "mavlink"] + args, capture_output=True, text=True, env=_env(), cwd=ROOT,
                          timeout=60)


def test_the_command_line_refuses_what_would_be_unsafe_or_ambiguous(tmp_path):
    key = tmp_path / "key"
    key.write_text(os.urandom(16).hex())
    key.chmod(0o600)
    common = ["--udp", "127.0.0.1:0", "--key-file", str(key)]
    # a GCS port anyone on the network could reach drives the vehicle: only when asked
    r = _cli(["--gcs", "udpin:0.0.0.0:0"] + common)
    assert r.returncode == 2 and "--allow-remote-gcs" in r.stderr
    r = _cli(["--gcs", "udpout:127.0.0.1:14550", "--vehicle", "udpout:127.0.0.1:14551"] + common)
    assert r.returncode == 2 and "not both" in r.stderr
    r = _cli(["--vehicle", "udpout:127.0.0.1:14551", "--key-file", str(key)])
    assert r.returncode == 2 and "--modem" in r.stderr
    r = _cli(["--vehicle", "bluetooth:x"] + common)
    assert r.returncode == 2 and "MAVLink connection" in r.stderr
    r = _cli(["--modem", "seatrac:/dev/ttyUSB0"])  # no key: sticks would be taken on anyone's word
    assert r.returncode == 2 and "--key-file" in r.stderr
    # asked for, over a UDP link (a tether): it starts, says ready with the bound port, and stops
    r = _cli(["--gcs", "udpin:0.0.0.0:0", "--allow-remote-gcs", "--seconds", "1", "--json"] + common)
    assert r.returncode == 0, r.stderr
    lines = [json.loads(x) for x in r.stdout.splitlines()]
    assert lines[0]["event"] == "ready" and lines[0]["mavlink_port"] > 0 and lines[-1]["event"] == "stats"
