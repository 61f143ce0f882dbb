# The vehicle side of `acomm bridge mavlink`, without I/O: to the autopilot
# (ArduSub) it is the ground station; to the acoustic link it is the far end
# of the topside's sticks and commands (acomm.catalog.rovcontrol).
#
# - HEARTBEAT as a GCS every second, so ArduSub's GCS failsafe stays quiet.
# - MANUAL_CONTROL every manual_ms (10 Hz by default; ArduSub's pilot-input
#   failsafe trips after FS_PILOT_TIMEOUT, 3 s by default, without one): the
#   last acoustic stick vector while teleop's Failsafe holds it, neutral
#   from the moment it trips (nothing valid for timeout_ms, or a keep-alive
#   naming a command that never came), plus the configured failsafe action
#   (hold: ALT_HOLD, surface: SURFACE, disarm; neutral: nothing more).
# - Sealed arm, disarm and mode commands become COMMAND_LONG
#   (COMPONENT_ARM_DISARM, DO_SET_MODE), retried with `confirmation` raised
#   until the autopilot's COMMAND_ACK; its result (or NO_ANSWER) goes back
#   in the next state message, which is sent at once.
# - The state (armed, mode, depth, attitude, battery, flags) from the
#   autopilot's HEARTBEAT, ATTITUDE, VFR_HUD and SYS_STATUS goes back every
#   telemetry period and when it changes (rovcontrol.StateTrigger).
# Only authenticated acoustic messages count; the node's guard already
# refuses unsealed sticks, keep-alives and commands when it has a key.
#
# Feed it mavlink_in(now, msg) and acoustic_in(now, items, authenticated);
# call poll(now) at least every manual_ms; take_mavlink() and
# take_acoustic() return what to send, take_lines() what to tell the user.

from __future__ import annotations

from typing import Any, Dict, List, Optional, Tuple

from acomm.catalog import rovcontrol as R
from acomm.catalog import teleop
from acomm.compat import ticks_diff

from .mavwire import AUTOPILOT_COMPONENT, MAV, Outbox

ACTIONS = {"neutral": None, "hold": ("mode", MAV.SUB_MODE_ALT_HOLD), "surface": ("mode", MAV.SUB_MODE_SURFACE),
           "disarm": ("disarm", 0)}
FORCE_MAGIC = 21196  # COMPONENT_ARM_DISARM's param2 that skips the arming checks
NO_BATTERY = 101
# MAVLink's MAV_RESULT_CANCELLED (6), the rovcontrol answer for a command a
# newer one replaced; the ardupilotmega dialect of pymavlink 2.4.50 has no
# such name, and a missing one raised AttributeError in acoustic_in
CANCELLED = getattr(MAV, "MAV_RESULT_CANCELLED", 6)


def manual_control(mav: Any, target: int, vector: Tuple[float, ...]) -> Any:
    """MANUAL_CONTROL for a teleop vector (surge, sway, heave, roll, pitch, yaw in [-1, 1]):
    x, y, r in -1000..1000, z 0..1000 with 500 neutral (ArduSub's throttle), pitch and roll in the
    s and t extensions (enabled_extensions bits 0 and 1)."""
    surge, sway, heave, roll, pitch, yaw = vector
    return mav.manual_control_encode(target, int(round(surge * 1000)), int(round(sway * 1000)),
                                     500 + int(round(heave * 500)), int(round(yaw * 1000)), 0,
                                     enabled_extensions=3, s=int(round(pitch * 1000)), t=int(round(roll * 1000)))


class VehicleSide(Outbox):
    def __init__(self, mav: Any, now: int, timeout_ms: int = 5000, manual_ms: int = 100, action: str = "neutral",
                 telemetry_ms: int = 10000, command_timeout_ms: int = 3000, command_tries: int = 3,
                 lost_ms: int = 3000, slot_ms: int = 300) -> None:
        Outbox.__init__(self)
        if action not in ACTIONS:
            raise ValueError("failsafe action %r: one of %s" % (action, ", ".join(sorted(ACTIONS))))
        self.mav = mav  # a pymavlink MAVLink: the message builders
        self.failsafe = teleop.Failsafe(timeout_ms)
        self.manual_ms = manual_ms
        self.action = ACTIONS[action]
        self.command_timeout_ms = command_timeout_ms
        self.command_tries = command_tries
        self.lost_ms = lost_ms
        # the half-duplex channel: while the topside talks to us, we speak
        # when asked, within slot_ms after its poll or command (it holds its
        # sticks for our answer), or after a keep-alive when a flag, the
        # mode or the armed state changed (it must learn that we hold
        # neutral, to send its stick again); a topside
        # silent for a failsafe timeout asks nothing, and the state then
        # goes on its own schedule (StateTrigger)
        self.slot_ms = slot_ms
        self._slot_at: Optional[int] = None
        self._topside_at: Optional[int] = None
        self.target = 1  # the autopilot's system id, learnt from its HEARTBEAT
        self.trigger = R.StateTrigger(telemetry_ms)
        self.filter = R.CommandFilter()
        self.state: Dict[str, Any] = {"armed": 0, "mode": 0, "depth": 0.0, "heading": 0.0, "roll": 0.0, "pitch": 0.0,
                                      "voltage": 0.0, "battery": NO_BATTERY, "failsafe": 0, "autopilot_lost": 1,
                                      "critical": 0, "ack_tag": 0, "ack_result": 0}
        self._start = now
        self._heard_at: Optional[int] = None  # the autopilot's last HEARTBEAT
        self._told_lost = False
        self._beat_at: Optional[int] = None
        self._manual_at: Optional[int] = None
        self._commands: List[Dict[str, Any]] = []  # waiting for the autopilot, the first one sent
        self._state_now = False
        self.stats: Dict[str, int] = {"sticks": 0, "keepalives": 0, "commands": 0, "repeats": 0, "unsealed": 0,
                                      "failsafe_trips": 0, "states_sent": 0, "manual_control": 0,
                                      "polls": 0}

    # -- from the autopilot ------------------------------------------------------------
    def mavlink_in(self, now: int, msg: Any) -> None:
        """A message from the autopilot (only its autopilot component's are taken)."""
        if msg.get_srcComponent() != AUTOPILOT_COMPONENT:
            return
        t = msg.get_type()
        st = self.state
        if t == "HEARTBEAT":
            if msg.type == MAV.MAV_TYPE_GCS:
                return
            self.target = msg.get_srcSystem()
            st["armed"] = 1 if msg.base_mode & MAV.MAV_MODE_FLAG_SAFETY_ARMED else 0
            st["mode"] = msg.custom_mode if msg.custom_mode < 32 else 31
            st["critical"] = 1 if msg.system_status in (MAV.MAV_STATE_CRITICAL, MAV.MAV_STATE_EMERGENCY) else 0
            if self._heard_at is None or st["autopilot_lost"]:
                self._lines.append("autopilot: system %d heard (%s, mode %d)" % (
                    self.target, "armed" if st["armed"] else "disarmed", msg.custom_mode))
            st["autopilot_lost"] = 0
            self._told_lost = False
            self._heard_at = now
        elif t == "ATTITUDE":
            st["roll"] = _deg(msg.roll)
            st["pitch"] = _deg(msg.pitch)
        elif t == "VFR_HUD":
            st["heading"] = float(msg.heading % 360)
            st["depth"] = -float(msg.alt)
        elif t == "SYS_STATUS":
            st["voltage"] = msg.voltage_battery / 1000.0 if msg.voltage_battery != 65535 else 0.0
            st["battery"] = msg.battery_remaining if 0 <= msg.battery_remaining <= 100 else NO_BATTERY
        elif t == "COMMAND_ACK" and self._commands:
            c = self._commands[0]
            if msg.command != c["command"] or c["sent_at"] is None:
                return
            if msg.result == MAV.MAV_RESULT_IN_PROGRESS:
                c["sent_at"] = now  # still working: wait a timeout more
                return
            self._finish(c, msg.result)

    # -- from the topside ---------------------------------------------------------------
    def acoustic_in(self, now: int, items: List[Tuple[Any, Dict[str, Any]]], authenticated: bool) -> None:
        """Decoded rovcontrol messages from one acoustic packet."""
        if not authenticated:
            self.stats["unsealed"] += len(items)
            return
        self._topside_at = now
        for m, v in items:
            name = m.name
            if name == "thrust" or name == "heartbeat":
                if self.failsafe.on_message(now, name, v):
                    self.stats["sticks" if name == "thrust" else "keepalives"] += 1
                if name == "heartbeat" and (self.failsafe.tripped or self._changed()):
                    # news the topside must not wait a poll for (we hold
                    # neutral, the autopilot disarmed or was lost): answer
                    # its keep-alive, which it does not pause after, so
                    # only then
                    self._ask(now)
            elif name == "command" and v["cmd"] == R.CMD_POLL:
                self.failsafe.on_heartbeat(now, v["mode"])  # a poll is a keep-alive too
                self.stats["polls"] += 1
                self._ask(now)
            elif name == "command":
                self._slot_at = now  # the answer may be back within the slot
                if not self.filter.admit(now, v):
                    self.stats["repeats"] += 1  # a retransmission: answer again, do not act again
                    self._state_now = True
                    continue
                self.stats["commands"] += 1
                if v["cmd"] == R.CMD_MODE:
                    self._command("mode", v["mode"], v["tag"], False)
                elif v["cmd"] in (R.CMD_ARM, R.CMD_DISARM):
                    self._command("arm" if v["cmd"] == R.CMD_ARM else "disarm", 0, v["tag"], bool(v["force"]))
                else:
                    self._answer(v["tag"], MAV.MAV_RESULT_UNSUPPORTED)

    def _changed(self) -> bool:
        last = self.trigger.last
        return last is not None and any(self.state[k] != last[k] for k in R.StateTrigger.DISCRETE)

    def _ask(self, now: int) -> None:
        self._slot_at = now
        self._state_now = True

    def _command(self, kind: str, mode: int, tag: int, force: bool) -> None:
        if kind == "mode":
            cmd, p1, p2 = MAV.MAV_CMD_DO_SET_MODE, float(MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(mode)
        else:
            cmd, p1, p2 = MAV.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if kind == "arm" else 0.0, float(FORCE_MAGIC if force else 0)
        # a newer command replaces one of the same kind still waiting (its
        # tag gets no answer from the autopilot: it is answered as cancelled)
        for c in self._commands[1:]:
            if c["command"] == cmd:
                self._commands.remove(c)
                self._answer(c["tag"], CANCELLED)
        self._commands.append({"command": cmd, "p1": p1, "p2": p2, "tag": tag, "tries": 0, "sent_at": None,
                               "what": kind if kind != "mode" else "mode %d" % mode})

    def _finish(self, c: Dict[str, Any], result: int) -> None:
        self._commands.remove(c)
        self._lines.append("autopilot: %s -> %s" % (c["what"], _result_name(result)))
        self._answer(c["tag"], result)

    def _answer(self, tag: int, result: int) -> None:
        if tag:  # tag 0: the bridge's own failsafe action, which nobody awaits
            self.state["ack_tag"] = tag
            self.state["ack_result"] = result if 0 <= result < R.NO_ANSWER else MAV.MAV_RESULT_FAILED
            self._state_now = True

    # -- time -----------------------------------------------------------------------------
    def poll(self, now: int, stick_free: bool = True) -> None:
        """stick_free: the topside's (the runner passes it to either side; sticks are not ours)."""
        fs = self.failsafe
        vector = fs.poll(now)
        for ev in fs.pop_events():
            if ev == "tripped":
                self.stats["failsafe_trips"] += 1
                self._lines.append("failsafe: %s, sticks neutral%s" % (
                    fs.reason, "" if self.action is None else ", " + " ".join(str(x) for x in self.action)))
                if self.action is not None:
                    kind, mode = self.action
                    self._command(kind, mode, 0, False)
            else:
                self._lines.append("failsafe: recovered, sticks from the topside")
            self.state["failsafe"] = 1 if fs.tripped else 0
            self._state_now = True
        if self._beat_at is None or ticks_diff(now, self._beat_at) >= 1000:
            self._beat_at = now
            self._mav.append(self.mav.heartbeat_encode(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0,
                                                       MAV.MAV_STATE_ACTIVE))
            self._check_autopilot(now)
        if self._manual_at is None or ticks_diff(now, self._manual_at) >= self.manual_ms:
            self._manual_at = now
            self._mav.append(manual_control(self.mav, self.target, vector))
            self.stats["manual_control"] += 1
        self._send_commands(now)
        talk = self._may_talk(now)
        if talk == "slot" and self._state_now or talk == "free" and (
                self._state_now and self.trigger.due_ms(now) == 0 or self.trigger.update(now, self.state)):
            self._state_now = False
            self.trigger.sent(now, self.state)
            self._acoustic.append(("state", dict(self.state)))
            self.stats["states_sent"] += 1

    def _may_talk(self, now: int) -> Optional[str]:
        # -> "slot": answer now; "free": nobody asks, send when due; None: wait to be asked
        if self._slot_at is not None and ticks_diff(now, self._slot_at) <= self.slot_ms:
            return "slot"
        t = self._topside_at
        if t is None or ticks_diff(now, t) >= self.failsafe.timeout_ms:
            return "free"
        return None

    def _check_autopilot(self, now: int) -> None:
        since = self._heard_at if self._heard_at is not None else self._start
        if ticks_diff(now, since) >= self.lost_ms and not self._told_lost:
            self._told_lost = True
            self.state["autopilot_lost"] = 1
            self._lines.append("autopilot: no HEARTBEAT for %d s; still sending HEARTBEAT and MANUAL_CONTROL" % (
                ticks_diff(now, since) // 1000))

    def _send_commands(self, now: int) -> None:
        if not self._commands:
            return
        c = self._commands[0]
        if c["sent_at"] is not None and ticks_diff(now, c["sent_at"]) < self.command_timeout_ms:
            return
        if c["tries"] >= self.command_tries:
            self._commands.remove(c)
            self._lines.append("autopilot: %s not acknowledged after %d tries" % (c["what"], c["tries"]))
            if c["tag"]:
                self.state["ack_tag"] = c["tag"]
                self.state["ack_result"] = R.NO_ANSWER
                self._state_now = True
            return self._send_commands(now)
        self._mav.append(self.mav.command_long_encode(self.target, AUTOPILOT_COMPONENT, c["command"], c["tries"],
                                                      c["p1"], c["p2"], 0, 0, 0, 0, 0))
        c["tries"] += 1
        c["sent_at"] = now

    def next_ms(self, now: int) -> int:
        """ms until poll() has something to do (at most manual_ms)."""
        left = self.manual_ms - ticks_diff(now, self._manual_at) if self._manual_at is not None else 0
        return max(0, min(left, self.manual_ms))



def _deg(rad: float) -> float:
    return rad * 57.29577951308232


def _result_name(result: int) -> str:
    e = MAV.enums["MAV_RESULT"].get(result)
    return e.name[len("MAV_RESULT_"):].lower() if e is not None else str(result)
