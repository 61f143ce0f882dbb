# The piloted-ROV catalog (acomm.catalog.rovcontrol): wire compatibility
# with teleop, the sizes it promises, the guard's claim, the command
# filter's once-only rule and the state trigger's timing, across the
# 2**30 tick wrap.

from acomm.catalog import rovcontrol as R
from acomm.catalog import teleop as T
from acomm.compat import TICKS_MAX, ticks_add

STATE = {"armed": 1, "mode": 19, "depth": 12.34, "heading": 271.0, "roll": -3.0, "pitch": 5.0,
         "voltage": 15.9, "battery": 87, "failsafe": 0, "autopilot_lost": 0, "critical": 0,
         "ack_tag": 3, "ack_result": 0}


def test_teleop_messages_read_the_same_in_both_catalogs():
    thrust = T.thrust_values((0.5, 0.0, -0.2, 0.0, 0.0, 1.0), 7)
    wire = T.CATALOG.pack([("thrust", thrust)])
    assert R.CATALOG.pack([("thrust", thrust)]) == wire
    (m, v), = R.CATALOG.unpack(wire)
    assert m.name == "thrust" and v == T.CATALOG.unpack(wire)[0][1]
    hb = R.CATALOG.pack([("heartbeat", {"seq": 7})])
    assert T.CATALOG.unpack(hb)[0][1] == {"seq": 7}


def test_sizes_and_values():
    cmd = {"cmd": R.CMD_MODE, "force": 0, "mode": 19, "tag": 15}
    assert len(R.CATALOG.pack([("command", cmd)])) == 2
    wire = R.CATALOG.pack([("state", STATE)])
    assert len(wire) == 9
    (m, v), = R.CATALOG.unpack(wire)
    assert m.name == "state"
    assert abs(v["depth"] - 12.3) < 1e-6 and v["heading"] == 272.0 and v["ack_tag"] == 3
    # out of range readings saturate rather than fail the whole report
    odd = dict(STATE, depth=900.0, voltage=80.0, roll=-200.0)
    (_, v), = R.CATALOG.unpack(R.CATALOG.pack([("state", odd)]))
    assert v["depth"] == 400.0 and v["voltage"] == 51.0 and v["roll"] == -180.0


def test_guard_claims_sticks_keepalives_and_commands_not_state():
    assert R.guard_check(R.CATALOG.pack([("command", {"cmd": 1, "force": 0, "mode": 0, "tag": 1})]))
    assert R.guard_check(R.CATALOG.pack([("heartbeat", {"seq": 1})]))
    assert R.guard_check(R.CATALOG.pack([("command", {"cmd": R.CMD_POLL, "force": 0, "mode": 9, "tag": 0})]))
    assert R.guard_check(T.CATALOG.pack([("thrust", T.thrust_values(T.NEUTRAL, 1))]))
    assert not R.guard_check(R.CATALOG.pack([("state", STATE)]))
    assert not R.guard_check(b"")
    assert not R.guard_check(b"\xff\xff\xff")  # a code past the field's last: not ours


def test_command_filter_runs_a_command_once_across_the_wrap():
    f = R.CommandFilter(window_ms=60000)
    t = TICKS_MAX - 10
    arm = {"cmd": R.CMD_ARM, "force": 0, "mode": 0, "tag": 4}
    assert f.admit(t, arm)
    assert not f.admit(ticks_add(t, 5000), arm)  # a retransmission
    assert f.admit(ticks_add(t, 6000), dict(arm, tag=5))
    assert f.admit(ticks_add(t, 7000), arm)  # tag 4 again after another: new
    assert not f.admit(ticks_add(t, 8000), arm)
    assert f.admit(ticks_add(t, 70000), arm)  # the same long after: a restarted topside


def test_state_trigger_period_changes_and_min_gap():
    tr = R.StateTrigger(period_ms=10000, min_gap_ms=1000, depth_step=1.0, heading_step=10.0)
    t = TICKS_MAX - 500
    assert tr.update(t, STATE)  # nothing sent yet
    tr.sent(t, STATE)
    assert not tr.update(ticks_add(t, 500), dict(STATE, armed=0))  # within the gap
    assert tr.due_ms(ticks_add(t, 500)) == 500
    assert tr.update(ticks_add(t, 1000), dict(STATE, armed=0))
    assert not tr.update(ticks_add(t, 2000), dict(STATE, depth=12.9, heading=279.0))
    assert tr.update(ticks_add(t, 2000), dict(STATE, depth=13.4))
    # heading across north: 355 -> 4 is 9 degrees, not 351
    tr.sent(t, dict(STATE, heading=356.0))
    assert not tr.update(ticks_add(t, 2000), dict(STATE, heading=4.0))
    assert tr.update(ticks_add(t, 2000), dict(STATE, heading=8.0))
    assert tr.update(ticks_add(t, 10000), dict(STATE, heading=356.0))  # the period
