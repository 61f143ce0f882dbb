# The teleop catalog (seed 004) with the two messages a piloted ROV needs
# beside its sticks: a command (arm, disarm, change mode) and the vehicle's
# state (armed, mode, depth, attitude, battery, failsafe flags, and the
# answer to the last command). It keeps teleop's ids 0 (thrust) and 1
# (heartbeat) and fills the two it left free, so a vehicle that speaks only
# teleop still reads every stick message of this one, and the 2-bit id
# costs nothing more. A module of its own, not two more messages in
# teleop.py: the buoy freezes teleop and pays heap for every Message it
# builds at import; this catalog is built only where a vehicle is piloted.
#
# On a half-duplex channel the vehicle speaks when asked: the topside polls
# (a command with cmd CMD_POLL, which also carries the keep-alive's seq) and
# holds its sticks for the answer, a state. Commands move a vehicle, so
# they travel sealed (guard_check below claims thrust, heartbeat and
# command). Each carries a 4-bit tag
# (1..15, 0 is "none"); the vehicle answers in its next state message with
# the tag and a result, the MAV_RESULT codes of MAVLink (0 accepted,
# 1 temporarily rejected, 2 denied, 3 unsupported, 4 failed, 5 in progress,
# 6 cancelled) and 7 for "the autopilot did not answer".
#
# Sizes: command 2 + 2 + 1 + 5 + 4 = 14 bits (2 bytes); state 2 + 66 = 68
# bits (9 bytes). docs/mavlink.md has the field choices.

from ..codec.fields import Fixed, UInt
from ..codec.message import Catalog, Message
from ..compat import const, ticks_diff
from ..errors import AcommError
from . import teleop

CMD_DISARM = const(0)
CMD_ARM = const(1)
CMD_MODE = const(2)
CMD_POLL = const(3)  # "send your state now"; mode carries the last thrust seq, so it is a keep-alive too
TAGS = const(16)  # tag values; 0 means none
NO_ANSWER = const(7)  # the result when the autopilot never acknowledged

COMMAND = Message("command", 2, (
    UInt("cmd", 0, 3),
    UInt("force", 0, 1),  # arm or disarm past the autopilot's checks (emergency stop)
    UInt("mode", 0, 31),  # the autopilot's custom mode number, for CMD_MODE
    UInt("tag", 0, TAGS - 1),
))

STATE = Message("state", 3, (
    UInt("armed", 0, 1),
    UInt("mode", 0, 31),
    Fixed("depth", -5.0, 400.0, 0.1, saturate=True),  # metres, down positive
    Fixed("heading", 0.0, 358.0, 2.0, saturate=True),  # degrees
    Fixed("roll", -180.0, 180.0, 2.0, saturate=True),
    Fixed("pitch", -90.0, 90.0, 2.0, saturate=True),
    Fixed("voltage", 0.0, 51.0, 0.2, saturate=True),  # battery, volts
    UInt("battery", 0, 101),  # percent remaining; 101: unknown
    UInt("failsafe", 0, 1),  # the acoustic teleop failsafe holds neutral
    UInt("autopilot_lost", 0, 1),  # no heartbeat from the autopilot
    UInt("critical", 0, 1),  # the autopilot reports a critical or emergency state
    UInt("ack_tag", 0, TAGS - 1),
    UInt("ack_result", 0, 7),
))

CATALOG = Catalog("rovcontrol", id_bits=2, messages=(teleop.THRUST, teleop.HEARTBEAT, COMMAND, STATE))
SEALED = ("thrust", "heartbeat", "command")  # what a vehicle takes only with a valid tag


def guard_check(payload):
    """For acomm.link.guard.Guard: True when the payload holds a stick, keep-alive or command
    message of this catalog (so it needs a valid tag); bytes that do not decode are not."""
    try:
        for m, _ in CATALOG.unpack(payload):
            if m.name in SEALED:
                return True
    except AcommError:  # not this catalog's: another check may claim it
        return False
    return False


class CommandFilter:
    """Vehicle side: a command is carried out once. admit(now, values) -> True for a new command,
    False for a repeat of the last one (same tag and contents within window_ms: a link
    retransmission), which is answered again but not carried out again."""

    def __init__(self, window_ms=60000):
        self.window_ms = window_ms
        self._last = None  # (tag, cmd, force, mode)
        self._at = 0

    def admit(self, now, values):
        key = (values["tag"], values["cmd"], values["force"], values["mode"])
        if key == self._last and ticks_diff(now, self._at) < self.window_ms:
            return False
        self._last = key
        self._at = now
        return True


class StateTrigger:
    """Vehicle side: when to send the state. update(now, values) -> True when it should go now:
    at once (but not within min_gap_ms of the last) when a discrete field changed (armed, mode,
    flags, ack), when depth moved by depth_step or heading by heading_step since the last sent,
    and every period_ms otherwise. sent(now, values) records what went out."""

    DISCRETE = ("armed", "mode", "failsafe", "autopilot_lost", "critical", "ack_tag", "ack_result")

    def __init__(self, period_ms, min_gap_ms=1000, depth_step=1.0, heading_step=10.0):
        self.period_ms = period_ms
        self.min_gap_ms = min_gap_ms
        self.depth_step = depth_step
        self.heading_step = heading_step
        self.last = None
        self._at = None

    def update(self, now, values):
        if self._at is None:
            return True
        since = ticks_diff(now, self._at)
        if since >= self.period_ms:
            return True
        if since < self.min_gap_ms:
            return False
        last = self.last
        for k in self.DISCRETE:
            if values[k] != last[k]:
                return True
        if abs(values["depth"] - last["depth"]) >= self.depth_step:
            return True
        d = abs(values["heading"] - last["heading"]) % 360.0
        return min(d, 360.0 - d) >= self.heading_step

    def sent(self, now, values):
        self.last = dict(values)
        self._at = now

    def due_ms(self, now):
        """ms until update() may next say True for a change (0: now)."""
        if self._at is None:
            return 0
        left = self.min_gap_ms - ticks_diff(now, self._at)
        return left if left > 0 else 0
