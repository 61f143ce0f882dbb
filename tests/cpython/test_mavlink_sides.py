# `acomm bridge mavlink` without its sockets and modems: MavEndpoint on good
# and broken byte streams, VehicleSide against a scripted autopilot and
# TopsideSide against a scripted ground station, on a clock the test moves
# in integer milliseconds (several runs cross the 2**30 tick wrap), and
# mavio's URLs and a real loopback UDP pair. Everything a side sends goes
# through real pymavlink bytes (encode, then another endpoint's feed), and
# every acoustic message through the rovcontrol catalog's pack and unpack.
# Skipped when pymavlink (the `mavlink` extra) is not installed.
import asyncio
import math
import select
import socket

import pytest

pytest.importorskip("pymavlink")

from acomm.catalog import rovcontrol as R  # noqa: E402
from acomm.catalog import teleop  # noqa: E402
from acomm.compat import TICKS_MAX, ticks_add, ticks_diff  # noqa: E402
from acomm_cpython.bridges import mavio  # noqa: E402
from acomm_cpython.bridges.mavtopside import TopsideSide  # noqa: E402
from acomm_cpython.bridges.mavvehicle import VehicleSide  # noqa: E402
from acomm_cpython.bridges.mavwire import AUTOPILOT_COMPONENT, GCS_COMPONENT, GCS_SYSID, MAV, MavEndpoint  # noqa: E402

NEAR_WRAP = TICKS_MAX - 2500  # a start 2.5 s before the tick counter wraps to 0


def wire(src, dst, msgs):
    """msgs encoded by endpoint src, parsed by endpoint dst: what the far end reads."""
    return dst.feed(b"".join(src.encode(m) for m in msgs))


def acoustic(name, values):
    """One rovcontrol message as the far side decodes it from the water."""
    return R.CATALOG.unpack(R.CATALOG.pack([(name, values)]))


def command(cmd, tag, force=0, mode=0):
    return acoustic("command", {"cmd": cmd, "force": force, "mode": mode, "tag": tag})


def state_values(**kw):
    v = {"armed": 0, "mode": 0, "depth": 0.0, "heading": 0.0, "roll": 0.0, "pitch": 0.0, "voltage": 0.0,
         "battery": 101, "failsafe": 0, "autopilot_lost": 0, "critical": 0, "ack_tag": 0, "ack_result": 0}
    v.update(kw)
    return v


def of_type(log, t):
    return [(at, m) for at, m in log if m.get_type() == t]


# -- MavEndpoint ----------------------------------------------------------------------------------

def _unknown_frame(seq):
    # MAVLink 2 by hand: magic, len, incompat, compat, seq, sysid, compid, msgid (3 bytes LE), payload, CRC
    payload = bytes(range(1, 9))
    return bytes([0xFD, len(payload), 0, 0, seq, 1, 1]) + (60000).to_bytes(3, "little") + payload + b"\x12\x34"


def _endpoint_stream():
    ap = MavEndpoint(1, AUTOPILOT_COMPONENT)
    good = ap.encode(ap.mav.heartbeat_encode(MAV.MAV_TYPE_SUBMARINE, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 19, 4))
    att = ap.encode(ap.mav.attitude_encode(1234, 0.1, -0.2, 0.3, 0, 0, 0))
    bad = bytearray(ap.encode(ap.mav.attitude_encode(1235, 0.1, -0.2, 0.3, 0, 0, 0)))
    bad[10 + 5] ^= 0x01  # one bit of the payload (after the 10-byte MAVLink 2 header)
    garbage = b"\x00garbage\x11\x22"
    last = ap.encode(ap.mav.vfr_hud_encode(0, 0, 90, 0, -3.5, 0))
    return good, att, bytes(bad), garbage, _unknown_frame(9), last


def test_endpoint_counts_bad_input_and_resyncs():
    good, att, bad, garbage, unknown, last = _endpoint_stream()
    gcs = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
    got = gcs.feed(good + att)
    assert [m.get_type() for m in got] == ["HEARTBEAT", "ATTITUDE"]
    assert [m.get_seq() for m in got] == [0, 1]  # encode numbers its frames
    assert got[0].get_srcSystem() == 1 and got[0].get_srcComponent() == AUTOPILOT_COMPONENT
    assert got[0].custom_mode == 19 and got[1].time_boot_ms == 1234
    assert gcs.stats == {"rx": 2, "tx": 0, "bad_crc": 0, "unknown": 0, "bad_bytes": 0}

    assert gcs.feed(bad) == []
    assert gcs.stats["bad_crc"] == 1 and gcs.stats["rx"] == 2
    assert gcs.feed(garbage) == []
    assert gcs.stats["bad_bytes"] >= 1
    assert gcs.feed(unknown) == []
    assert gcs.stats["unknown"] == 1
    got = gcs.feed(last)
    assert [m.get_type() for m in got] == ["VFR_HUD"] and got[0].heading == 90
    assert gcs.stats["rx"] == 3 and gcs.stats["bad_crc"] == 1 and gcs.stats["unknown"] == 1


def test_endpoint_same_counts_in_one_buffer_and_byte_by_byte():
    good, att, bad, garbage, unknown, last = _endpoint_stream()
    stream = good + bad + garbage + unknown + att + last
    whole = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
    got = whole.feed(stream)
    assert [m.get_type() for m in got] == ["HEARTBEAT", "ATTITUDE", "VFR_HUD"]
    assert (whole.stats["rx"], whole.stats["bad_crc"], whole.stats["unknown"]) == (3, 1, 1)
    assert whole.stats["bad_bytes"] >= 1
    bytewise = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
    got = [m for i in range(len(stream)) for m in bytewise.feed(stream[i:i + 1])]
    assert [m.get_type() for m in got] == ["HEARTBEAT", "ATTITUDE", "VFR_HUD"]
    assert (bytewise.stats["rx"], bytewise.stats["bad_crc"], bytewise.stats["unknown"]) == (3, 1, 1)


def test_endpoint_encode_counts_and_wraps_its_sequence():
    a = MavEndpoint(3, 1)
    b = MavEndpoint(4, 1)
    seqs = [m.get_seq() for m in wire(a, b, [a.mav.heartbeat_encode(1, 1, 0, 0, 0) for _ in range(300)])]
    assert seqs == [i % 256 for i in range(300)]
    assert a.stats["tx"] == 300 and b.stats["rx"] == 300


# -- VehicleSide ----------------------------------------------------------------------------------

class VehicleRig:
    """A VehicleSide with a scripted autopilot (sysid ap_sysid) behind real bytes."""

    def __init__(self, now, ap_sysid=1, **kw):
        self.now = now
        self.end = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
        self.ap = MavEndpoint(ap_sysid, AUTOPILOT_COMPONENT)
        self.side = VehicleSide(self.end.mav, now, **kw)
        self.mav = []  # (t, message as the autopilot read it)
        self.states = []  # (t, values as the topside decodes them)
        self.lines = []

    def from_autopilot(self, msg):
        for m in wire(self.ap, self.end, [msg]):
            self.side.mavlink_in(self.now, m)

    def autopilot_heartbeat(self, armed=False, mode=MAV.SUB_MODE_MANUAL):
        base = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (MAV.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0)
        self.from_autopilot(self.ap.mav.heartbeat_encode(MAV.MAV_TYPE_SUBMARINE, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                         base, mode, MAV.MAV_STATE_ACTIVE))

    def ack(self, cmd, result=MAV.MAV_RESULT_ACCEPTED):
        self.from_autopilot(self.ap.mav.command_ack_encode(cmd, result))

    def acoustic_in(self, items, authenticated=True):
        self.side.acoustic_in(self.now, items, authenticated)

    def run(self, ms, step=10):
        """poll every step ms for ms (the first poll at the current time); now ends ms later."""
        end = ticks_add(self.now, ms)
        while ticks_diff(end, self.now) > 0:
            self.poll()
            self.now = ticks_add(self.now, step)

    def poll(self):
        side = self.side
        side.poll(self.now)
        for m in wire(self.end, self.ap, side.take_mavlink()):
            self.mav.append((self.now, m))
        for name, values in side.take_acoustic():
            assert name == "state"
            (m, v), = acoustic(name, values)
            self.states.append((self.now, v))
        self.lines += side.take_lines()

    def manual(self):
        return of_type(self.mav, "MANUAL_CONTROL")

    def commands(self):
        return of_type(self.mav, "COMMAND_LONG")


def _neutral(m):
    return (m.x, m.y, m.z, m.r, m.s, m.t) == (0, 0, 500, 0, 0, 0)


def test_vehicle_neutral_manual_control_every_manual_ms_across_the_wrap():
    rig = VehicleRig(NEAR_WRAP, manual_ms=100)
    rig.run(5000)
    manual = rig.manual()
    last = manual[-1][0]
    assert rig.side.next_ms(ticks_add(last, 30)) == 70 and rig.side.next_ms(rig.now) == 0
    assert len(manual) == 50
    assert all(ticks_diff(b, a) == 100 for (a, _), (b, _) in zip(manual, manual[1:]))
    assert all(_neutral(m) and m.target == 1 and m.enabled_extensions == 3 for _, m in manual)
    beats = of_type(rig.mav, "HEARTBEAT")
    assert len(beats) == 5 and all(m.type == MAV.MAV_TYPE_GCS for _, m in beats)
    assert all(m.get_srcSystem() == GCS_SYSID for _, m in beats)  # ArduSub's SYSID_MYGCS
    assert any(line.startswith("autopilot: no HEARTBEAT") for line in rig.lines)
    assert rig.side.state["autopilot_lost"] == 1


def test_vehicle_thrust_sealed_only_then_failsafe_neutral():
    rig = VehicleRig(NEAR_WRAP, timeout_ms=5000, manual_ms=100)
    rig.run(200)
    vec = (0.4, -0.2, 0.6, 2 / 15.0, -0.5, 1.0)  # surge, sway, heave, roll, pitch, yaw
    items = acoustic("thrust", teleop.thrust_values(vec, 1))
    rig.acoustic_in(items, authenticated=False)  # a forged stick
    assert rig.side.stats["unsealed"] == 1 and rig.side.stats["sticks"] == 0
    rig.run(300)
    assert all(_neutral(m) for _, m in rig.manual())

    t_stick = rig.now
    rig.acoustic_in(items)
    rig.run(300)
    assert rig.side.stats["sticks"] == 1
    after = [m for t, m in rig.manual() if ticks_diff(t, t_stick) >= 0]
    assert after
    v = items[0][1]
    for m in after:  # quantized as teleop sends it: 1/15 steps, -0.5 -> -8/15
        assert (m.x, m.y, m.z, m.r) == (400, -200, 800, 1000)
        assert (m.s, m.t) == (-533, 133)
        assert (m.x, m.z, m.s, m.t) == (round(v["surge"] * 1000), 500 + round(v["heave"] * 500),
                                        round(v["pitch"] * 1000), round(v["roll"] * 1000))

    rig.run(5000)  # nothing more from the topside: the failsafe trips at t_stick + 5000
    manual = rig.manual()
    held = [t for t, m in manual if not _neutral(m)]
    assert held and all(0 <= ticks_diff(t, t_stick) < 5000 for t in held)
    late = [m for t, m in manual if ticks_diff(t, t_stick) >= 5000]
    assert late and all(_neutral(m) for m in late)
    assert any(line.startswith("failsafe: timeout, sticks neutral") for line in rig.lines)
    assert rig.side.stats["failsafe_trips"] == 1 and rig.side.state["failsafe"] == 1
    assert not rig.commands()  # action "neutral": nothing more


def test_vehicle_keepalive_naming_a_missed_stick_goes_neutral():
    rig = VehicleRig(0)
    rig.acoustic_in(acoustic("thrust", teleop.thrust_values((0.6, 0, 0, 0, 0, 0), 3)))
    rig.run(200)
    assert rig.manual()[-1][1].x == 600
    rig.acoustic_in(acoustic("heartbeat", {"seq": 4}))  # stick 4 never arrived
    rig.run(200)
    assert _neutral(rig.manual()[-1][1])
    assert any(line.startswith("failsafe: missed_command") for line in rig.lines)
    rig.acoustic_in(acoustic("thrust", teleop.thrust_values((-0.2, 0, 0, 0, 0, 0), 5)))
    rig.run(200)
    assert rig.manual()[-1][1].x == -200
    assert "failsafe: recovered, sticks from the topside" in rig.lines


def test_vehicle_arm_goes_to_the_autopilot_it_heard_and_its_ack_comes_back():
    rig = VehicleRig(NEAR_WRAP, ap_sysid=7, slot_ms=300)
    rig.run(100)
    rig.autopilot_heartbeat()
    assert rig.side.target == 7 and rig.side.state["autopilot_lost"] == 0
    rig.acoustic_in(acoustic("thrust", teleop.thrust_values(teleop.NEUTRAL, 1)))  # the topside is talking
    rig.run(1000)
    rig.states.clear()
    assert all(m.target == 7 for _, m in rig.manual()[-5:])
    # a component other than the autopilot is not the autopilot
    cam = MavEndpoint(7, MAV.MAV_COMP_ID_CAMERA)
    for m in wire(cam, rig.end, [cam.mav.command_ack_encode(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 0)]):
        rig.side.mavlink_in(rig.now, m)

    rig.acoustic_in(command(R.CMD_ARM, 5))
    rig.run(10)
    (t, c), = rig.commands()
    assert (c.target_system, c.target_component, c.command) == (7, AUTOPILOT_COMPONENT, 400)
    assert (c.confirmation, c.param1, c.param2) == (0, 1.0, 0.0)
    assert rig.side.stats["commands"] == 1
    assert not rig.states  # the autopilot has not answered yet
    rig.ack(400)
    rig.run(10)  # within the slot: the answer goes at once
    (_, st), = rig.states
    assert (st["ack_tag"], st["ack_result"]) == (5, MAV.MAV_RESULT_ACCEPTED)
    assert "autopilot: arm -> accepted" in rig.lines
    rig.run(3000)
    assert len(rig.commands()) == 1  # acknowledged: no retry
    assert len(rig.states) == 1


def test_vehicle_ack_after_the_slot_waits_for_the_poll():
    rig = VehicleRig(NEAR_WRAP, slot_ms=300)
    rig.autopilot_heartbeat()
    rig.acoustic_in(acoustic("thrust", teleop.thrust_values(teleop.NEUTRAL, 1)))
    rig.run(500)
    rig.states.clear()
    rig.acoustic_in(command(R.CMD_DISARM, 6, force=1))
    rig.run(10)
    (_, c), = rig.commands()
    assert (c.command, c.param1, c.param2) == (400, 0.0, 21196.0)  # force: past the arming checks
    rig.run(1000)
    rig.ack(400, MAV.MAV_RESULT_DENIED)  # late: the slot is over, the topside holds the channel
    rig.acoustic_in(acoustic("heartbeat", {"seq": 1}))  # the topside still talking
    rig.run(1000)
    assert rig.states == []
    rig.acoustic_in(command(R.CMD_POLL, 0, mode=1))
    rig.run(100)
    (_, st), = rig.states
    assert (st["ack_tag"], st["ack_result"]) == (6, MAV.MAV_RESULT_DENIED)
    assert rig.side.stats["polls"] == 1


def test_vehicle_retries_then_answers_no_answer():
    rig = VehicleRig(NEAR_WRAP, command_timeout_ms=3000, command_tries=3, timeout_ms=5000)
    rig.autopilot_heartbeat()
    t0 = rig.now
    rig.acoustic_in(command(R.CMD_MODE, 9, mode=MAV.SUB_MODE_ALT_HOLD))
    rig.run(9500)
    sent = rig.commands()
    assert [m.confirmation for _, m in sent] == [0, 1, 2]
    assert [ticks_diff(t, t0) for t, _ in sent] == [0, 3000, 6000]
    assert all((m.command, m.param1, m.param2) == (MAV.MAV_CMD_DO_SET_MODE, 1.0, float(MAV.SUB_MODE_ALT_HOLD))
               for _, m in sent)
    answered = [(t, v) for t, v in rig.states if v["ack_tag"] == 9]
    assert answered and answered[0][1]["ack_result"] == R.NO_ANSWER == 7
    assert ticks_diff(answered[0][0], t0) >= 9000
    assert "autopilot: mode 2 not acknowledged after 3 tries" in rig.lines


def test_vehicle_in_progress_ack_waits_a_timeout_more():
    rig = VehicleRig(0, command_timeout_ms=3000)
    rig.autopilot_heartbeat()
    rig.acoustic_in(command(R.CMD_ARM, 2))
    rig.run(2000)
    rig.ack(400, MAV.MAV_RESULT_IN_PROGRESS)
    rig.run(2500)  # 4.5 s after the first try, 2.5 s after "in progress"
    assert len(rig.commands()) == 1
    rig.run(1000)
    assert [m.confirmation for _, m in rig.commands()] == [0, 1]


def test_vehicle_repeated_command_is_answered_not_repeated():
    rig = VehicleRig(NEAR_WRAP, slot_ms=300)
    rig.autopilot_heartbeat()
    rig.acoustic_in(acoustic("thrust", teleop.thrust_values(teleop.NEUTRAL, 1)))
    rig.run(500)
    rig.states.clear()
    items = command(R.CMD_ARM, 4)
    rig.acoustic_in(items)
    rig.run(10)
    rig.ack(400)
    rig.run(500)
    assert len(rig.commands()) == 1 and len(rig.states) == 1
    rig.acoustic_in(items)  # the link's retransmission: same tag, same command
    rig.run(100)
    assert rig.side.stats["repeats"] == 1 and rig.side.stats["commands"] == 1
    assert len(rig.commands()) == 1  # not carried out again
    assert len(rig.states) == 2 and rig.states[-1][1]["ack_tag"] == 4  # but answered again
    rig.acoustic_in(command(R.CMD_ARM, 5))  # a new tag is a new command
    rig.run(10)
    assert len(rig.commands()) == 2 and rig.side.stats["commands"] == 2


def test_vehicle_newer_command_of_a_kind_cancels_the_waiting_one():
    rig = VehicleRig(0, slot_ms=300)
    rig.autopilot_heartbeat()
    rig.acoustic_in(command(R.CMD_MODE, 1, mode=MAV.SUB_MODE_ALT_HOLD))
    rig.run(10)
    rig.acoustic_in(command(R.CMD_ARM, 2))  # waits behind the mode change
    rig.run(10)
    rig.acoustic_in(command(R.CMD_DISARM, 3))  # replaces the arm, which never reached the autopilot
    rig.run(10)
    (_, st), = [(t, v) for t, v in rig.states if v["ack_tag"] == 2]
    assert st["ack_result"] == 6  # MAV_RESULT_CANCELLED
    rig.ack(MAV.MAV_CMD_DO_SET_MODE)
    rig.run(10)
    assert [(m.command, m.param1) for _, m in rig.commands()] == [(176, 1.0), (400, 0.0)]
    rig.ack(400, 8)  # a result beyond those rovcontrol carries (COMMAND_INT_ONLY)
    rig.run(10)
    assert (rig.states[-1][1]["ack_tag"], rig.states[-1][1]["ack_result"]) == (3, MAV.MAV_RESULT_FAILED)
    assert "autopilot: mode 2 -> accepted" in rig.lines


def test_vehicle_unsealed_command_is_ignored():
    rig = VehicleRig(0)
    rig.autopilot_heartbeat()
    rig.acoustic_in(command(R.CMD_ARM, 3), authenticated=False)
    rig.run(1000)
    assert rig.commands() == []
    assert rig.side.stats["unsealed"] == 1 and rig.side.stats["commands"] == 0


def test_vehicle_poll_gets_exactly_one_state():
    rig = VehicleRig(NEAR_WRAP, slot_ms=300, telemetry_ms=10000)
    rig.run(100)
    assert len(rig.states) == 1  # nobody talks yet: the first state goes on its own
    rig.acoustic_in(acoustic("thrust", teleop.thrust_values(teleop.NEUTRAL, 1)))
    rig.autopilot_heartbeat(armed=True, mode=MAV.SUB_MODE_ALT_HOLD)  # a change, but nobody asked
    rig.run(2000)
    assert len(rig.states) == 1
    rig.acoustic_in(command(R.CMD_POLL, 0, mode=1))
    rig.run(1000)
    assert len(rig.states) == 2
    st = rig.states[-1][1]
    assert (st["armed"], st["mode"], st["autopilot_lost"]) == (1, MAV.SUB_MODE_ALT_HOLD, 0)
    assert rig.side.stats["polls"] == 1


def test_vehicle_answers_a_keepalive_only_when_something_discrete_changed():
    rig = VehicleRig(NEAR_WRAP, slot_ms=300, telemetry_ms=10000)
    rig.autopilot_heartbeat(armed=False)
    rig.run(100)
    rig.acoustic_in(command(R.CMD_POLL, 0, mode=0))
    rig.run(500)
    n = len(rig.states)
    rig.acoustic_in(acoustic("heartbeat", {"seq": 0}))  # nothing new: no answer
    rig.run(1000)
    assert len(rig.states) == n
    rig.autopilot_heartbeat(armed=True)  # armed by the pilot's hand at the vehicle, say
    rig.run(1000)
    assert len(rig.states) == n  # not asked: it waits
    rig.acoustic_in(acoustic("heartbeat", {"seq": 0}))
    rig.run(500)
    assert len(rig.states) == n + 1 and rig.states[-1][1]["armed"] == 1
    # depth alone is no news: it waits for the poll
    rig.from_autopilot(rig.ap.mav.vfr_hud_encode(0, 0, 90, 0, -30.0, 0))
    rig.acoustic_in(acoustic("heartbeat", {"seq": 0}))
    rig.run(500)
    assert len(rig.states) == n + 1


def test_vehicle_failsafe_disarm_action():
    rig = VehicleRig(NEAR_WRAP, timeout_ms=5000, action="disarm")
    rig.autopilot_heartbeat(armed=True)
    t_stick = rig.now
    rig.acoustic_in(acoustic("thrust", teleop.thrust_values((0.3, 0, 0, 0, 0, 0), 1)))
    rig.run(6000)
    (t, c), = rig.commands()
    assert ticks_diff(t, t_stick) == 5000
    assert (c.command, c.param1, c.param2) == (400, 0.0, 0.0)
    assert any(line.startswith("failsafe: timeout") and "disarm" in line for line in rig.lines)
    rig.ack(400)
    rig.run(100)
    assert "autopilot: disarm -> accepted" in rig.lines
    assert rig.side.state["ack_tag"] == 0  # nobody awaits the bridge's own action


def test_vehicle_unknown_failsafe_action_is_refused():
    with pytest.raises(ValueError):
        VehicleSide(MavEndpoint(GCS_SYSID, GCS_COMPONENT).mav, 0, action="sink")


# -- TopsideSide ----------------------------------------------------------------------------------

class TopsideRig:
    """A TopsideSide (system 1) with a scripted GCS (255/190) behind real bytes; the modem is a
    stick that stays busy busy_ms after it is handed over."""

    def __init__(self, now, busy_ms=0, **kw):
        self.now = now
        self.end = MavEndpoint(1, AUTOPILOT_COMPONENT)
        self.gcs = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
        self.side = TopsideSide(self.end.mav, now, **kw)
        self.busy_ms = busy_ms
        self._busy_until = None
        self.stick = None  # (x, y, z, r, s, t) the GCS sends at 50 Hz, or None for silence
        self._gcs_at = None
        self.mav = []  # (t, message as the GCS read it)
        self.out = []  # (t, name, values as the vehicle decodes them, stick_free when polled)
        self.lines = []

    def from_gcs(self, msg):
        for m in wire(self.gcs, self.end, [msg]):
            self.side.mavlink_in(self.now, m)
        self._collect(True)

    def command_long(self, cmd, p1=0.0, p2=0.0, confirmation=0, target=1):
        self.from_gcs(self.gcs.mav.command_long_encode(target, 1, cmd, confirmation, p1, p2, 0, 0, 0, 0, 0))

    def state_in(self, authenticated=True, **kw):
        (m, v), = acoustic("state", state_values(**kw))
        self.side.acoustic_in(self.now, [(m, v)], authenticated)
        self._collect(True)

    def free(self):
        return self._busy_until is None or ticks_diff(self.now, self._busy_until) >= 0

    def run(self, ms, step=10, hook=None):
        end = ticks_add(self.now, ms)
        while ticks_diff(end, self.now) > 0:
            if hook is not None:
                hook(self)
            if self.stick is not None and (self._gcs_at is None or ticks_diff(self.now, self._gcs_at) >= 20):
                self._gcs_at = self.now
                x, y, z, r, s, t = self.stick
                self.from_gcs(self.gcs.mav.manual_control_encode(1, x, y, z, r, 0, enabled_extensions=3, s=s, t=t))
            free = self.free()
            self.side.poll(self.now, free)
            self._collect(free)
            self.now = ticks_add(self.now, step)

    def _collect(self, free):
        for m in wire(self.end, self.gcs, self.side.take_mavlink()):
            self.mav.append((self.now, m))
        for name, values in self.side.take_acoustic():
            (m, v), = acoustic(name, values)
            self.out.append((self.now, name, v, free))
            if name in ("thrust", "heartbeat") or name == "command" and v["cmd"] == R.CMD_POLL:
                self._busy_until = ticks_add(self.now, self.busy_ms)
        self.lines += self.side.take_lines()

    def sent(self, name):
        return [(t, v, free) for t, n, v, free in self.out if n == name]

    def polls(self):
        return [(t, v) for t, v, _ in self.sent("command") if v["cmd"] == R.CMD_POLL]

    def acks(self):
        return of_type(self.mav, "COMMAND_ACK")


def test_topside_heartbeat_every_second_as_a_submarine():
    rig = TopsideRig(NEAR_WRAP)
    rig.run(3500)
    beats = of_type(rig.mav, "HEARTBEAT")
    assert [ticks_diff(t, NEAR_WRAP) for t, _ in beats] == [0, 1000, 2000, 3000]
    for _, m in beats:
        assert (m.type, m.autopilot) == (MAV.MAV_TYPE_SUBMARINE, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA)
        assert (m.get_srcSystem(), m.get_srcComponent()) == (1, AUTOPILOT_COMPONENT)
        assert not m.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED
    assert of_type(rig.mav, "ATTITUDE") == []  # no state yet: nothing to show
    assert rig.out == []  # no GCS stick: nothing on the water (the first poll is poll_ms away)


def test_topside_moving_stick_at_50hz_is_paced_by_the_gap_and_the_modem():
    rig = TopsideRig(NEAR_WRAP, busy_ms=700, stick_gap_ms=500, threshold=0.1)
    t0 = rig.now

    def slow_stick(r):  # surge and yaw swing over 10 s
        ms = ticks_diff(r.now, t0)
        r.stick = (int(800 * math.sin(2 * math.pi * ms / 10000)), 0, 500, int(600 * math.sin(math.pi * ms / 10000)),
                   0, 0)

    rig.run(10000, hook=slow_stick)
    assert rig.side.stats["manual_in"] == 500
    sticks = rig.sent("thrust")
    assert len(sticks) >= 6
    assert all(free for _, _, free in sticks)  # never while the last one waits for the modem
    gaps = [ticks_diff(b, a) for (a, _, _), (b, _, _) in zip(sticks, sticks[1:])]
    assert min(gaps) >= 700  # the modem's 700 ms, beyond the 500 ms gap
    uplink = sorted([t for t, _, _ in sticks] + [t for t, _, _ in rig.sent("heartbeat")] + [t for t, _ in rig.polls()],
                    key=lambda t: ticks_diff(t, t0))
    assert all(ticks_diff(b, a) >= 500 for a, b in zip(uplink, uplink[1:]))  # one on the water at a time
    seqs = [v["seq"] for _, v, _ in sticks]
    assert seqs == [(i + 1) % 16 for i in range(len(seqs))]
    for t, v, _ in sticks:  # the freshest stick, not an old one
        ms = ticks_diff(t, t0)
        assert abs(v["surge"] - 0.8 * math.sin(2 * math.pi * ms / 10000)) <= 1 / 15.0 + 0.03


def test_topside_stick_gap_alone():
    rig = TopsideRig(0, busy_ms=0, stick_gap_ms=500, threshold=0.1)

    def fast_stick(r):  # moves a lot every 20 ms
        r.stick = ((r.now // 20) % 2 * 900, 0, 500, 0, 0, 0)

    rig.run(5000, hook=fast_stick)
    sticks = rig.sent("thrust")
    assert 8 <= len(sticks) <= 10
    assert all(ticks_diff(b, a) >= 500 for (a, _, _), (b, _, _) in zip(sticks, sticks[1:]))


def test_topside_small_moves_under_the_threshold_send_nothing():
    rig = TopsideRig(NEAR_WRAP, threshold=0.1, keepalive_ms=2000)

    def wiggle(r):  # 0.28 .. 0.36: level 4 or 5 of 15, one level from the first
        r.stick = (280 + (r.now // 20) % 5 * 20, 0, 500, 0, 0, 0)

    rig.run(10000, hook=wiggle)
    sticks = rig.sent("thrust")
    # one stick, then that stick again as the keep-alive (it is off neutral), never a new seq
    first = sticks[0][1]
    assert all(v == first for _, v, _ in sticks)
    assert 4 <= len(sticks) <= 6 and rig.sent("heartbeat") == []
    gaps = [ticks_diff(b[0], a[0]) for a, b in zip(sticks, sticks[1:])]
    assert all(g >= 2000 for g in gaps)  # every keepalive_ms, no more often


def test_topside_arm_goes_once_and_its_ack_waits_for_the_state():
    rig = TopsideRig(NEAR_WRAP)
    rig.run(100)
    rig.mav.clear()
    rig.command_long(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
    (t, v, _), = rig.sent("command")
    assert (v["cmd"], v["force"], v["mode"]) == (R.CMD_ARM, 0, 0)
    tag = v["tag"]
    assert 1 <= tag < R.TAGS
    assert rig.acks() == []

    rig.command_long(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1.0, confirmation=1)  # the GCS retries
    assert len(rig.sent("command")) == 1 and rig.acks() == []
    assert rig.side.stats["commands_sent"] == 1

    rig.command_long(MAV.MAV_CMD_DO_SET_MODE, float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), 2.0)  # another one
    (_, a), = rig.acks()
    assert (a.command, a.result) == (MAV.MAV_CMD_DO_SET_MODE, MAV.MAV_RESULT_TEMPORARILY_REJECTED)
    assert (a.target_system, a.target_component) == (GCS_SYSID, GCS_COMPONENT)
    assert len(rig.sent("command")) == 1

    rig.run(2000)
    rig.state_in(ack_tag=tag % 15 + 1, ack_result=0)  # somebody else's answer
    assert len(rig.acks()) == 1
    rig.state_in(ack_tag=tag, ack_result=0, authenticated=False)  # forged
    assert len(rig.acks()) == 1 and rig.side.stats["unsealed"] == 1
    rig.state_in(armed=1, ack_tag=tag, ack_result=MAV.MAV_RESULT_ACCEPTED)
    (_, a) = rig.acks()[-1]
    assert len(rig.acks()) == 2
    assert (a.command, a.result) == (MAV.MAV_CMD_COMPONENT_ARM_DISARM, MAV.MAV_RESULT_ACCEPTED)
    assert (a.target_system, a.target_component) == (GCS_SYSID, GCS_COMPONENT)
    rig.state_in(armed=1, ack_tag=tag, ack_result=MAV.MAV_RESULT_ACCEPTED)  # answered once only
    assert len(rig.acks()) == 2
    rig.run(1000)
    assert of_type(rig.mav, "HEARTBEAT")[-1][1].base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED

    rig.command_long(MAV.MAV_CMD_DO_SET_MODE, float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), 2.0)  # free again
    (_, v2, _) = rig.sent("command")[-1]
    assert (v2["cmd"], v2["mode"]) == (R.CMD_MODE, 2) and v2["tag"] == tag % 15 + 1
    rig.state_in(ack_tag=v2["tag"], ack_result=R.NO_ANSWER)  # the autopilot never answered the vehicle
    assert rig.acks()[-1][1].result == MAV.MAV_RESULT_FAILED


def test_topside_set_mode_and_the_gcs_downloads():
    rig = TopsideRig(0)
    rig.run(100)
    rig.from_gcs(rig.gcs.mav.set_mode_encode(1, MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MAV.SUB_MODE_SURFACE))
    (_, v, _), = rig.sent("command")
    assert (v["cmd"], v["mode"]) == (R.CMD_MODE, MAV.SUB_MODE_SURFACE)
    rig.state_in(mode=MAV.SUB_MODE_SURFACE, ack_tag=v["tag"], ack_result=0)
    (_, a), = rig.acks()
    assert (a.command, a.result) == (MAV.MAVLINK_MSG_ID_SET_MODE, 0)  # as ArduPilot answers SET_MODE
    rig.mav.clear()
    rig.from_gcs(rig.gcs.mav.param_request_list_encode(1, 1))
    rig.from_gcs(rig.gcs.mav.mission_request_list_encode(1, 1, 0))
    (_, pv), (_, mc) = rig.mav
    assert pv.get_type() == "PARAM_VALUE" and (pv.param_count, pv.param_index) == (1, 0)
    assert mc.get_type() == "MISSION_COUNT" and mc.count == 0
    assert (mc.target_system, mc.target_component) == (GCS_SYSID, GCS_COMPONENT)


def test_topside_command_without_answer_fails_after_the_timeout():
    rig = TopsideRig(NEAR_WRAP, command_timeout_ms=20000, command_poll_ms=3000, poll_ms=10000)
    rig.run(500)
    t_cmd = rig.now
    rig.command_long(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 0.0, 21196.0)
    (_, v, _), = rig.sent("command")
    assert (v["cmd"], v["force"]) == (R.CMD_DISARM, 1)
    rig.run(19990)
    assert rig.acks() == []
    # while it waits, the command goes again every command_poll_ms (the same tag: carried out once)
    again = [(ticks_diff(t, t_cmd), v["tag"]) for t, v, _ in rig.sent("command")][1:]
    assert [t for t, _ in again] == [3000, 6000, 9000, 12000, 15000, 18000]
    assert set(tag for _, tag in again) == {v["tag"]} and rig.polls() == []
    rig.run(20)
    (t, a), = rig.acks()
    assert ticks_diff(t, t_cmd) == 20000
    assert (a.command, a.result, a.target_system) == (400, MAV.MAV_RESULT_FAILED, GCS_SYSID)
    assert rig.side.stats["command_timeouts"] == 1
    assert any(line.startswith("command: no answer") for line in rig.lines)


def test_topside_other_commands_are_unsupported_at_once():
    rig = TopsideRig(0)
    rig.run(100)
    rig.command_long(512, 33.0)  # REQUEST_MESSAGE
    (_, a), = rig.acks()
    assert (a.command, a.result) == (512, MAV.MAV_RESULT_UNSUPPORTED)
    assert (a.target_system, a.target_component) == (GCS_SYSID, GCS_COMPONENT)
    rig.command_long(MAV.MAV_CMD_DO_SET_MODE, float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), 40.0)  # no such mode
    assert rig.acks()[-1][1].result == MAV.MAV_RESULT_DENIED
    rig.command_long(MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1.0, target=9)  # for another system
    assert len(rig.acks()) == 2
    assert rig.sent("command") == []


def test_topside_telemetry_from_the_state_then_stale():
    rig = TopsideRig(NEAR_WRAP, stale_ms=5000)
    rig.run(2500)
    t_state = rig.now
    rig.mav.clear()
    rig.state_in(armed=1, mode=MAV.SUB_MODE_ALT_HOLD, depth=12.3, heading=270.0, roll=10.0, pitch=-4.0, voltage=15.8,
                 battery=76, failsafe=1)
    got = [m.get_type() for _, m in rig.mav]
    assert got == ["ATTITUDE", "VFR_HUD", "SYS_STATUS"]  # at once
    rig.run(12000)
    atts = of_type(rig.mav, "ATTITUDE")
    assert all(m.time_boot_ms == 2500 for _, m in atts)  # when it arrived, across the wrap too
    # at once, then with the heartbeats at 3000 .. 7000 ms of age < 5000
    assert [ticks_diff(t, t_state) for t, _ in atts] == [0, 500, 1500, 2500, 3500, 4500]
    _, att = atts[0]
    assert abs(math.degrees(att.roll) - 10.0) < 1.01 and abs(math.degrees(att.pitch) + 4.0) < 1.01
    assert abs(math.degrees(att.yaw) + 90.0) < 1.01  # heading 270 as yaw -90
    _, hud = of_type(rig.mav, "VFR_HUD")[0]
    assert hud.heading == 270 and abs(hud.alt + 12.3) < 0.06
    status = of_type(rig.mav, "SYS_STATUS")
    healthy = [m for t, m in status if ticks_diff(t, t_state) < 5000]
    stale = [m for t, m in status if ticks_diff(t, t_state) >= 5000]
    assert healthy and all(m.onboard_control_sensors_health != 0 for m in healthy)
    assert stale and all(m.onboard_control_sensors_health == 0 for m in stale)
    assert abs(healthy[0].voltage_battery - 15800) <= 1 and healthy[0].battery_remaining == 76
    warnings = of_type(rig.mav, "STATUSTEXT")
    assert len(warnings) == 1
    assert warnings[0][1].severity == MAV.MAV_SEVERITY_WARNING and b"5 s old" in warnings[0][1].text.encode()
    ages = [m.value for _, m in of_type(rig.mav, "NAMED_VALUE_FLOAT") if m.name == "TLM_AGE"]
    assert len(ages) >= 10 and all(b > a for a, b in zip(ages, ages[1:])) and ages[-1] >= 11.0
    beat = of_type(rig.mav, "HEARTBEAT")[-1][1]
    assert beat.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED and beat.custom_mode == MAV.SUB_MODE_ALT_HOLD
    assert beat.system_status == MAV.MAV_STATE_CRITICAL  # the acoustic failsafe holds the vehicle
    assert "telemetry: 5 s old, no longer repeated" in rig.lines

    rig.mav.clear()
    rig.state_in(failsafe=0)  # fresh again
    assert [m.get_type() for _, m in rig.mav] == ["ATTITUDE", "VFR_HUD", "SYS_STATUS"]
    assert rig.mav[0][1].time_boot_ms == ticks_diff(rig.now, NEAR_WRAP)
    assert "telemetry: fresh again" in rig.lines


def test_topside_operator_gone_sends_one_neutral_then_silence():
    rig = TopsideRig(NEAR_WRAP, operator_ms=1500, keepalive_ms=2000, poll_ms=60000)
    rig.stick = (600, 0, 700, 0, 0, 0)
    rig.run(6000)
    held = rig.sent("thrust")
    assert len(held) >= 3 and all(v == held[0][1] for _, v, _ in held)  # held: the stick again as the keep-alive
    rig.stick = None  # the GCS stops
    t_stop = rig.now
    t_last = rig._gcs_at  # its last MANUAL_CONTROL
    rig.run(10000)
    neutral = [(t, v) for t, v, _ in rig.sent("thrust") if ticks_diff(t, t_stop) > 0]
    (t, v), = neutral
    assert teleop.vector_of(v) == teleop.NEUTRAL
    assert 1500 <= ticks_diff(t, t_last) < 1510
    assert [x for x, _, _ in rig.sent("heartbeat") if ticks_diff(x, t) > 0] == []  # keep-alives stop
    assert any(line.startswith("operator: no MANUAL_CONTROL for 1.5 s") for line in rig.lines)
    rig.stick = (0, 400, 500, 0, 0, 0)  # back
    rig.run(1000)
    assert abs(teleop.vector_of(rig.sent("thrust")[-1][1])[1] - 0.4) < 1e-9
    assert sum(line.startswith("operator: MANUAL_CONTROL from system 255") for line in rig.lines) == 2


def test_topside_failsafe_state_resends_the_stick():
    rig = TopsideRig(0, threshold=0.1)
    rig.stick = (600, 0, 500, 0, 0, 0)
    rig.run(1000)
    assert len(rig.sent("thrust")) == 1
    rig.state_in(failsafe=1)  # the vehicle holds neutral: it needs our stick again
    rig.run(100)
    sticks = rig.sent("thrust")
    assert len(sticks) == 2 and sticks[1][1]["surge"] == sticks[0][1]["surge"]
    assert sticks[1][1]["seq"] == (sticks[0][1]["seq"] + 1) % 16


def _hold_rig():
    rig = TopsideRig(NEAR_WRAP, poll_ms=3000, reply_ms=1000, keepalive_ms=20000)
    rig.stick = (0, 0, 500, 0, 0, 0)
    rig.run(3010)
    (t_poll, _), = rig.polls()
    assert ticks_diff(t_poll, NEAR_WRAP) == 3000
    assert len(rig.sent("thrust")) == 1  # the first stick, neutral
    rig.run(50)
    rig.side.transmitted(rig.now, "poll")  # the poll has left the modem
    t_tx = rig.now
    rig.stick = (700, 0, 500, 0, 0, 0)
    return rig, t_tx


def test_topside_holds_sticks_after_a_poll_until_the_state():
    rig, t_tx = _hold_rig()
    rig.run(400)
    assert len(rig.sent("thrust")) == 1  # the first neutral only: the moved stick waits
    rig.state_in()
    t_state = rig.now
    rig.run(100)
    t, v, _ = rig.sent("thrust")[-1]
    assert ticks_diff(t, t_state) == 0 and abs(v["surge"] - 0.7) < 0.04


def test_topside_holds_sticks_after_a_poll_until_reply_ms():
    rig, t_tx = _hold_rig()
    rig.run(1500)
    moved = [t for t, v, _ in rig.sent("thrust") if v["surge"] > 0]
    assert moved and ticks_diff(moved[0], t_tx) == 1000


# -- mavio ----------------------------------------------------------------------------------------

def test_parse_url_forms():
    p = mavio.parse_url
    assert p("udpin:0.0.0.0:14550") == ("udpin", "0.0.0.0", 14550)
    assert p("udpin::14550") == ("udpin", "0.0.0.0", 14550)
    assert p("udpout:127.0.0.1:14550") == ("udpout", "127.0.0.1", 14550)
    assert p("tcp:192.168.2.2:5760") == ("tcp", "192.168.2.2", 5760)
    assert p("tcpin:localhost:5760") == ("tcpin", "localhost", 5760)
    assert p("serial:/dev/ttyACM0:57600") == ("serial", "/dev/ttyACM0", 57600)
    assert p("serial:/dev/ttyACM0") == ("serial", "/dev/ttyACM0", 115200)
    assert p("/dev/serial/by-id/usb-ArduPilot") == ("serial", "/dev/serial/by-id/usb-ArduPilot", 115200)
    assert p("/dev/ttyUSB0:921600") == ("serial", "/dev/ttyUSB0", 921600)
    assert p("rfc2217://host:4000") == ("serial", "rfc2217://host:4000", 115200)


@pytest.mark.parametrize("url", ["", "udpin", "udp:127.0.0.1:14550", "udpin:127.0.0.1", "udpin:127.0.0.1:",
                                 "tcp:host:port", "tcpin:host:-1", "udpout:127.0.0.1:70000",
                                 "serial:/dev/ttyS0:fast", "14550"])
def test_parse_url_refuses_junk(url):
    with pytest.raises(ValueError):
        mavio.parse_url(url)


def _readable(conn, seconds=2.0):
    r, _, _ = select.select([conn.fileno()], [], [], seconds)
    return bool(r)


def test_udp_loopback_both_ways_and_the_connected_filter():
    listen = mavio.open_connection("udpin:127.0.0.1:0")
    out = mavio.open_connection("udpout:127.0.0.1:%d" % listen.port)
    stranger = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        assert not listen.listens_beyond_loopback() and not out.listens_beyond_loopback()
        assert listen.peer is None and out.peer == "127.0.0.1:%d" % listen.port
        listen.write(b"nobody yet")  # no peer: dropped, counted
        assert listen.dropped == 1
        assert listen.read() == b""

        gcs = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
        veh = MavEndpoint(1, AUTOPILOT_COMPONENT)
        out.write(gcs.encode(gcs.mav.heartbeat_encode(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 4)))
        assert _readable(listen)
        got = veh.feed(listen.read())
        assert [m.get_type() for m in got] == ["HEARTBEAT"] and got[0].get_srcSystem() == GCS_SYSID
        assert listen.peer == "127.0.0.1:%d" % out.port  # answers whoever sent last

        listen.write(veh.encode(veh.mav.heartbeat_encode(MAV.MAV_TYPE_SUBMARINE, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                         0, 0, 4)))
        assert _readable(out)
        got = gcs.feed(out.read())
        assert [m.get_type() for m in got] == ["HEARTBEAT"] and got[0].type == MAV.MAV_TYPE_SUBMARINE

        # a third socket's datagram to the udpout socket: the kernel drops it (connected socket);
        # the listener's datagram sent after it is the only one there
        stranger.sendto(b"not from the peer", ("127.0.0.1", out.port))
        listen.write(b"from the peer")
        assert _readable(out)
        assert out.read() == b"from the peer"
        assert out.read() == b""
        assert out.dropped == 0
    finally:
        stranger.close()
        listen.close()
        out.close()


def test_listens_beyond_loopback():
    wide = mavio.open_connection("udpin:0.0.0.0:0")
    try:
        assert wide.listens_beyond_loopback()
    finally:
        wide.close()
    local = mavio.open_connection("tcpin:127.0.0.1:0")
    try:
        assert not local.listens_beyond_loopback()
    finally:
        local.close()


def test_tcp_client_retries_until_a_server_listens_then_carries_bytes():
    probe = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()  # a port nobody listens on (yet)
    conn = mavio.open_connection("tcp:127.0.0.1:%d" % port)
    conn.RETRY_S = 0.05
    try:
        fd = conn.fileno()
        if fd is not None:  # the refused connect settles: readable, then dropped
            select.select([fd], [], [], 2.0)
            assert conn.read() == b"" and conn.peer is None
        conn.write(b"lost")
        assert conn.dropped >= 1
        server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        server.bind(("127.0.0.1", port))
        server.listen(1)
        server.settimeout(5)
        c = None
        for _ in range(100):  # the client tries again on its own when asked for its descriptor
            if conn.fileno() is None:
                select.select([], [], [], 0.05)  # between attempts (RETRY_S)
            else:
                try:
                    c, _ = server.accept()
                    break
                except socket.timeout:
                    pass
        assert c is not None
        c.sendall(b"\xfe\x09hello")
        select.select([conn.fileno()], [], [], 2.0)
        assert conn.read() == b"\xfe\x09hello" and conn.peer is not None
        c.close()
        server.close()
    finally:
        conn.close()


class _QuietNode:
    # what BridgeRunner asks of an AsyncNode, with nothing ever arriving acoustically
    class core:
        listen = unlisten = staticmethod(lambda fn: None)

    async def messages(self):
        await asyncio.Event().wait()
        yield  # pragma: no cover

    async def send(self, *args):
        await asyncio.Event().wait()  # the modem never finishes: the poll stays in flight


def test_runner_stop_ends_run_while_datagrams_keep_waking_it():
    # SIGTERM calls stop(): the run must end even while the wake event fires with every
    # datagram (Task.cancel() could be dropped there by Python 3.11's wait_for)
    from acomm_cpython.bridges.mavbridge import BridgeRunner

    async def main():
        listen = mavio.open_connection("udpin:127.0.0.1:0")
        out = mavio.open_connection("udpout:127.0.0.1:%d" % listen.port)
        end = MavEndpoint(1, AUTOPILOT_COMPONENT)
        gcs = MavEndpoint(GCS_SYSID, GCS_COMPONENT)
        hb = gcs.encode(gcs.mav.heartbeat_encode(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 4))
        runner = BridgeRunner(TopsideSide(end.mav, 0), _QuietNode(), listen, end, "veh", lambda d: None)
        task = asyncio.get_running_loop().create_task(runner.run())
        try:
            for i in range(400):
                out.write(hb)
                if i == 200:
                    runner.stop()
                await asyncio.sleep(0.001)
            await asyncio.wait_for(task, 2.0)
            assert task.done() and end.stats["rx"] > 100  # the datagrams were read and woke it
        finally:
            task.cancel()
            listen.close()
            out.close()

    asyncio.run(main())
