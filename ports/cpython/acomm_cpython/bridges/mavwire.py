# MAVLink on the wire for `acomm bridge mavlink`, without I/O: pymavlink's
# parser and encoders (the ArduPilot dialect over MAVLink 2, which also
# reads MAVLink 1) behind bytes in, messages out, and counters for what was
# dropped. pymavlink is the optional extra `acomm[mavlink]`.
#
# Bad input is counted and dropped, never raised: pymavlink's robust mode
# turns a bad CRC or stray bytes into a "bad data" message, and a message id
# the dialect does not know into an "unknown" one; neither reaches a side.

from __future__ import annotations

from typing import Any, Dict, List, Tuple

try:
    from pymavlink.dialects.v20 import ardupilotmega as mavlink
except ImportError as e:  # the extra is not installed
    raise ImportError("acomm bridge mavlink needs pymavlink: pip install 'acomm[mavlink]'") from e

MAV = mavlink  # the dialect module: constants and message classes

# ids of the autopilot and of a ground station (ArduSub's SYSID_MYGCS, 255 by
# default, is the only system whose MANUAL_CONTROL it takes)
AUTOPILOT_COMPONENT = mavlink.MAV_COMP_ID_AUTOPILOT1
GCS_SYSID = 255
GCS_COMPONENT = mavlink.MAV_COMP_ID_MISSIONPLANNER


class MavEndpoint:
    """One MAVLink peer's parser and encoder. feed(bytes) -> the good messages; encode(msg) ->
    its bytes, numbered in this endpoint's sequence. stats: rx, tx, bad_crc, unknown, bad_bytes."""

    def __init__(self, sysid: int, compid: int) -> None:
        self.mav = mavlink.MAVLink(None, sysid, compid)
        self.mav.robust_parsing = True
        self.stats: Dict[str, int] = {"rx": 0, "tx": 0, "bad_crc": 0, "unknown": 0, "bad_bytes": 0}

    def feed(self, data: bytes) -> List[Any]:
        got = self.mav.parse_buffer(data) or []
        good = []
        for m in got:
            t = m.get_type()
            if t == "BAD_DATA":
                reason = getattr(m, "reason", "")
                self.stats["bad_crc" if "CRC" in reason else "bad_bytes"] += 1
            elif t.startswith("UNKNOWN_"):
                self.stats["unknown"] += 1
            else:
                self.stats["rx"] += 1
                good.append(m)
        return good

    def encode(self, msg: Any) -> bytes:
        data = bytes(msg.pack(self.mav))
        self.mav.seq = (self.mav.seq + 1) % 256
        self.stats["tx"] += 1
        return data


class Outbox:
    """What a bridge side wants done, collected until its runner takes it: MAVLink messages for
    its peer, rovcontrol (name, values) for the water, lines for the user."""

    def __init__(self) -> None:
        self._mav: List[Any] = []
        self._acoustic: List[Tuple[Any, ...]] = []
        self._lines: List[str] = []

    def transmitted(self, now: int, name: str) -> None:
        """The runner: our message `name` has left the modem (its final status). A side that
        waits for an answer after some messages overrides this."""

    def take_mavlink(self) -> List[Any]:
        out, self._mav = self._mav, []
        return out

    def take_acoustic(self) -> List[Tuple[Any, ...]]:
        out, self._acoustic = self._acoustic, []
        return out

    def take_lines(self) -> List[str]:
        out, self._lines = self._lines, []
        return out
