# The topside side of `acomm bridge mavlink`, without I/O: to the ground
# station (QGroundControl, or any GCS) it is the vehicle; to the acoustic
# link it is the operator of acomm.catalog.rovcontrol.
#
# - HEARTBEAT every second as an ArduPilot submarine, armed and mode from
#   the last state the vehicle sent.
# - The vehicle's telemetry as ATTITUDE, VFR_HUD and SYS_STATUS, each time a
#   state arrives and then every second while it is fresh, with
#   time_boot_ms the time it arrived, never the time it is repeated. Once it
#   is older than stale_ms it is no longer repeated: SYS_STATUS says no
#   sensor is healthy, one STATUSTEXT warning says how old it is, and the
#   named value TLM_AGE (seconds) counts on every second.
# - MANUAL_CONTROL from the GCS's joystick becomes a teleop vector; teleop's
#   TeleopSender decides what goes on the water (deadband, quantization,
#   keep-alive), never more often than one stick message every stick_gap_ms
#   and never while the previous one still waits for the modem (the
#   freshest vector goes next: a queue of old sticks is worse than none).
#   While the stick is held off neutral the keep-alive repeats it.
#   Keep-alives flow only while the GCS keeps sending MANUAL_CONTROL; when
#   it stops for operator_ms the sticks go neutral once and the keep-alive
#   stops, so the vehicle's failsafe trips as it would for a lost link.
# - COMMAND_LONG COMPONENT_ARM_DISARM and DO_SET_MODE, and SET_MODE, go on
#   the water as sealed rovcontrol commands with a tag, sent again every
#   command_poll_ms until the vehicle's state answers; the GCS gets its
#   COMMAND_ACK only when the vehicle's state answers that tag, or
#   MAV_RESULT_FAILED after command_timeout_ms. The GCS's retries of a
#   waiting command are not sent again. Other commands are answered
#   UNSUPPORTED at once: nothing else crosses the water (docs/mavlink.md).

from __future__ import annotations

import random
from typing import Any, Dict, List, Optional, Tuple

from acomm.catalog import rovcontrol as R
from acomm.catalog import teleop
from acomm.compat import ticks_add, ticks_diff

from .mavwire import MAV, Outbox

_HEALTH = (MAV.MAV_SYS_STATUS_SENSOR_3D_GYRO | MAV.MAV_SYS_STATUS_SENSOR_3D_ACCEL | MAV.MAV_SYS_STATUS_SENSOR_3D_MAG
           | MAV.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | MAV.MAV_SYS_STATUS_SENSOR_BATTERY)


def stick_vector(msg: Any) -> Tuple[float, ...]:
    """MANUAL_CONTROL -> (surge, sway, heave, roll, pitch, yaw), each clamped to [-1, 1]; pitch and
    roll only when enabled_extensions says s and t carry them."""
    ext = getattr(msg, "enabled_extensions", 0) or 0
    v = (msg.x / 1000.0, msg.y / 1000.0, (msg.z - 500) / 500.0,
         msg.t / 1000.0 if ext & 2 else 0.0, msg.s / 1000.0 if ext & 1 else 0.0, msg.r / 1000.0)
    return tuple(-1.0 if x < -1.0 else 1.0 if x > 1.0 else x for x in v)


class TopsideSide(Outbox):
    def __init__(self, mav: Any, now: int, threshold: float = 0.1, keepalive_ms: int = 2000,
                 stick_gap_ms: int = 500, operator_ms: int = 1500, stale_ms: int = 25000,
                 command_timeout_ms: int = 20000, reply_ms: int = 1000, poll_ms: int = 10000,
                 command_poll_ms: int = 3000) -> None:
        Outbox.__init__(self)
        self.mav = mav
        self.sender = teleop.TeleopSender(threshold, keepalive_ms)
        self.stick_gap_ms = stick_gap_ms
        self.operator_ms = operator_ms
        self.stale_ms = stale_ms
        self.command_timeout_ms = command_timeout_ms
        # the vehicle speaks when asked (rovcontrol): a poll every poll_ms,
        # every command_poll_ms while a command waits for its answer; after
        # a poll or a command has left the modem, sticks wait up to reply_ms
        # for the state (on a half-duplex channel a stick sent then is lost)
        self.reply_ms = reply_ms
        self.poll_ms = poll_ms
        self.command_poll_ms = command_poll_ms
        self._hold_until: Optional[int] = None
        self._polled_at = now
        self.state: Optional[Dict[str, Any]] = None
        # time since start, accumulated from small tick steps: ticks_diff
        # spans only 2**29 ms (6.2 days), and a bridge may run longer
        self._up_ms = 0
        self._up_at = now
        self._state_up = 0  # _uptime() when the last state arrived
        self._stick: Optional[Tuple[float, ...]] = None
        self._stick_at: Optional[int] = None  # the GCS's last MANUAL_CONTROL
        self._stick_sent_at: Optional[int] = None
        self._operator = False
        self._beat_at: Optional[int] = None
        self._told_stale = False
        self._tag = random.randrange(1, R.TAGS)  # a restarted topside does not reuse its last tag
        self._pending: Optional[Dict[str, Any]] = None
        self.stats: Dict[str, int] = {"manual_in": 0, "sticks_sent": 0, "keepalives_sent": 0, "commands_sent": 0,
                                      "acks": 0, "command_timeouts": 0, "states": 0, "unsealed": 0, "polls": 0,
                                      "commands_resent": 0}

    # -- from the GCS -----------------------------------------------------------------------
    def mavlink_in(self, now: int, msg: Any) -> None:
        t = msg.get_type()
        me = self.mav.srcSystem
        if t == "MANUAL_CONTROL":
            if msg.target not in (0, me):
                return
            self.stats["manual_in"] += 1
            self._stick = stick_vector(msg)
            self._stick_at = now
            if not self._operator:
                self._operator = True
                self._lines.append("operator: MANUAL_CONTROL from system %d" % msg.get_srcSystem())
        elif t == "COMMAND_LONG" and msg.target_system in (0, me):
            if msg.command == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
                cmd = R.CMD_ARM if msg.param1 >= 0.5 else R.CMD_DISARM
                self._command(now, msg, msg.command, cmd, int(round(msg.param2)) == 21196, 0)
            elif msg.command == MAV.MAV_CMD_DO_SET_MODE and int(msg.param1) & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                self._command(now, msg, msg.command, R.CMD_MODE, False, int(msg.param2))
            else:
                self._ack(msg, msg.command, MAV.MAV_RESULT_UNSUPPORTED)
        elif t == "SET_MODE" and msg.target_system == me and msg.base_mode & MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            # ArduPilot answers SET_MODE with a COMMAND_ACK whose command is the message id
            self._command(now, msg, MAV.MAVLINK_MSG_ID_SET_MODE, R.CMD_MODE, False, msg.custom_mode)
        elif t == "PARAM_REQUEST_LIST" and msg.target_system == me:
            # no parameters cross the water: a list of one, ours, ends the GCS's download
            self._mav.append(self.mav.param_value_encode(b"ACOMM_BRIDGE", 1.0, MAV.MAV_PARAM_TYPE_REAL32, 1, 0))
        elif t == "MISSION_REQUEST_LIST" and msg.target_system == me:
            self._mav.append(self.mav.mission_count_encode(msg.get_srcSystem(), msg.get_srcComponent(), 0,
                                                           getattr(msg, "mission_type", 0)))

    def _command(self, now: int, msg: Any, command: int, cmd: int, force: bool, mode: int) -> None:
        if not 0 <= mode < 32:
            return self._ack(msg, command, MAV.MAV_RESULT_DENIED)
        what = (cmd, int(force), mode)
        p = self._pending
        if p is not None:
            if p["what"] == what:
                return  # the GCS retrying the command that waits for the vehicle
            return self._ack(msg, command, MAV.MAV_RESULT_TEMPORARILY_REJECTED)
        self._tag = self._tag % (R.TAGS - 1) + 1
        values = {"cmd": cmd, "force": int(force), "mode": mode, "tag": self._tag}
        self._pending = {"what": what, "tag": self._tag, "command": command, "at": now, "values": values,
                         "to": (msg.get_srcSystem(), msg.get_srcComponent())}
        self._acoustic.append(("command", values))
        self._polled_at = now  # a command asks for the state as a poll does
        self.stats["commands_sent"] += 1

    def _ack(self, msg: Any, command: int, result: int) -> None:
        self._mav.append(self.mav.command_ack_encode(command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()))

    # -- from the vehicle ---------------------------------------------------------------------
    def acoustic_in(self, now: int, items: List[Tuple[Any, Dict[str, Any]]], authenticated: bool) -> None:
        if not authenticated:
            self.stats["unsealed"] += len(items)
            return
        for m, v in items:
            if m.name != "state":
                continue
            self.stats["states"] += 1
            self._hold_until = None  # the answer came: the channel is ours
            if v["failsafe"] and self._operator and self._stick is not None:
                self.sender.last = None  # the vehicle holds neutral: our stick goes again, with a new seq
            self.state = v
            self._state_up = self._uptime(now)
            if self._told_stale:
                self._told_stale = False
                self._lines.append("telemetry: fresh again")
            self._telemetry(now)
            p = self._pending
            if p is not None and v["ack_tag"] == p["tag"]:
                self._pending = None
                result = v["ack_result"]
                self._mav.append(self.mav.command_ack_encode(
                    p["command"], MAV.MAV_RESULT_FAILED if result == R.NO_ANSWER else result, 0, 0, *p["to"]))
                self.stats["acks"] += 1

    # -- time -------------------------------------------------------------------------------
    def poll(self, now: int, stick_free: bool = True) -> None:
        """stick_free: no stick message of ours still waits for the modem."""
        self._uptime(now)
        if self._beat_at is None or ticks_diff(now, self._beat_at) >= 1000:
            self._beat_at = now
            self._second(now)
        p = self._pending
        if p is not None and ticks_diff(now, p["at"]) >= self.command_timeout_ms:
            self._pending = None
            self.stats["command_timeouts"] += 1
            self._lines.append("command: no answer from the vehicle in %d s" % (self.command_timeout_ms // 1000))
            self._mav.append(self.mav.command_ack_encode(p["command"], MAV.MAV_RESULT_FAILED, 0, 0, *p["to"]))
        self._sticks(now, stick_free)

    def transmitted(self, now: int, name: str) -> None:
        """The runner: message `name` of ours has left the modem (its final status)."""
        if name in ("poll", "command"):
            self._hold_until = ticks_add(now, self.reply_ms)

    def _sticks(self, now: int, free: bool) -> None:
        if self._operator and ticks_diff(now, self._stick_at) >= self.operator_ms:
            self._operator = False
            self._stick = teleop.NEUTRAL  # one neutral, then silence: the vehicle's failsafe takes over
            self._lines.append("operator: no MANUAL_CONTROL for %.1f s; sticks neutral, keep-alive stopped"
                               % (self.operator_ms / 1000.0))
        if not free:
            return
        if self._hold_until is not None:
            if ticks_diff(now, self._hold_until) < 0:
                return
            self._hold_until = None
        # a stick first: a poll only delays telemetry
        if self._stick is not None and (self._stick_sent_at is None
                                        or ticks_diff(now, self._stick_sent_at) >= self.stick_gap_ms):
            out = self.sender.update(now, self._stick)
            if out is not None:
                self._stick_sent_at = now
                self._acoustic.append(out)
                self.stats["sticks_sent"] += 1
                return
        since = ticks_diff(now, self._polled_at)
        if self._pending is not None and since >= self.command_poll_ms:
            # no answer yet: the command again, which the vehicle carries out
            # once (its tag) and answers like a poll; no link-level ACK, whose
            # retransmissions would cross the answer on a half-duplex channel
            self._polled_at = now
            self._acoustic.append(("command", self._pending["values"]))
            self.stats["commands_resent"] += 1
            return
        if since >= self.poll_ms:
            self._polled_at = now
            self._acoustic.append(("command", {"cmd": R.CMD_POLL, "force": 0, "mode": self.sender.seq, "tag": 0}))
            self.stats["polls"] += 1
            return
        if self._operator:
            hb = self.sender.poll(now)
            if hb is not None:
                last = self.sender.last
                if last is not None and any(last):
                    # a stick held off neutral: the keep-alive is that stick
                    # again (4 bytes more), so a lost one is made good at the
                    # next keep-alive, not after a failsafe trip and a poll
                    values = {"seq": self.sender.seq}
                    for i in range(6):
                        values[teleop.AXES[i]] = last[i] / teleop.STEPS
                    hb = ("thrust", values)
                self._acoustic.append(hb)
                self.stats["keepalives_sent"] += 1

    def _second(self, now: int) -> None:
        st = self.state
        base = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | MAV.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        status = MAV.MAV_STATE_STANDBY
        mode = 0
        if st is not None:
            mode = st["mode"]
            if st["armed"]:
                base |= MAV.MAV_MODE_FLAG_SAFETY_ARMED
                status = MAV.MAV_STATE_ACTIVE
            if st["critical"] or st["failsafe"] or st["autopilot_lost"]:
                status = MAV.MAV_STATE_CRITICAL
        self._mav.append(self.mav.heartbeat_encode(MAV.MAV_TYPE_SUBMARINE, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, base, mode,
                                                   status))
        if st is None:
            return
        up = self._uptime(now)
        age = up - self._state_up
        self._mav.append(self.mav.named_value_float_encode(up & 0xFFFFFFFF, b"TLM_AGE", age / 1000.0))
        if age < self.stale_ms:
            self._telemetry(now)
        else:
            self._mav.append(self._sys_status(st, healthy=False))
            if not self._told_stale:
                self._told_stale = True
                text = "acomm: vehicle telemetry %d s old" % (age // 1000)
                self._lines.append("telemetry: %d s old, no longer repeated" % (age // 1000))
                self._mav.append(self.mav.statustext_encode(MAV.MAV_SEVERITY_WARNING, text.encode()))

    def _telemetry(self, now: int) -> None:
        st = self.state
        assert st is not None
        at = self._state_up & 0xFFFFFFFF  # when it arrived, however often it is repeated
        rad = 0.017453292519943295
        yaw = st["heading"] if st["heading"] <= 180 else st["heading"] - 360.0
        self._mav.append(self.mav.attitude_encode(at, st["roll"] * rad, st["pitch"] * rad, yaw * rad, 0, 0, 0))
        self._mav.append(self.mav.vfr_hud_encode(0, 0, int(st["heading"]), 0, -st["depth"], 0))
        self._mav.append(self._sys_status(st, healthy=True))

    def _sys_status(self, st: Dict[str, Any], healthy: bool) -> Any:
        mv = int(st["voltage"] * 1000) if st["voltage"] > 0 else 65535
        pct = st["battery"] if st["battery"] <= 100 else -1
        return self.mav.sys_status_encode(_HEALTH, _HEALTH, _HEALTH if healthy else 0, 0, mv, -1, pct,
                                          0, 0, 0, 0, 0, 0)

    def _uptime(self, now: int) -> int:
        self._up_ms += ticks_diff(now, self._up_at)
        self._up_at = now
        return self._up_ms

    def next_ms(self, now: int) -> int:
        return 100

