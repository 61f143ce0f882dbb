# Events with names, for Python programs on CPython. The core passes its
# events as plain tuples read by position (acomm/events.py): one small
# allocation each, the same on a board. Here each kind gets a read-only
# view with named fields over the very tuple the core passed (`raw`), so a
# topside program writes ev.status_name instead of STATUS_NAMES[ev[3]],
# and the core's tuples stay as they are.

from __future__ import annotations

from typing import Any, Dict, List, Optional, Tuple

from acomm import events as E

Raw = Tuple[Any, ...]


class Event:
    """A view of one core event tuple: `raw` is the tuple, `kind` what it is ("status", "received", ...)."""

    __slots__ = ("raw",)
    kind = "event"

    def __init__(self, raw: Raw) -> None:
        self.raw = raw

    def __repr__(self) -> str:
        fields = ", ".join("%s=%r" % (k, getattr(self, k)) for k in self._fields)
        return "%s(%s)" % (type(self).__name__, fields)

    _fields: Tuple[str, ...] = ()

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Event) and other.raw == self.raw

    def __hash__(self) -> int:
        return hash(self.raw)


class _OnLink(Event):
    # events that come from one link (its name)
    __slots__ = ()

    @property
    def link(self) -> str:
        return str(self.raw[E.LINK].name)


class _Outcome(Event):
    # a request's or a packet's status: where in the tuple it sits
    __slots__ = ()
    _STATUS = E.STATUS
    _REASON = E.REASON

    @property
    def status(self) -> int:
        return int(self.raw[self._STATUS])

    @property
    def status_name(self) -> str:
        return E.STATUS_NAMES[self.raw[self._STATUS]]

    @property
    def reason(self) -> str:
        return str(self.raw[self._REASON])

    @property
    def final(self) -> bool:
        return bool(E.is_final(self.raw[self._STATUS]))


class LinkStatus(_OnLink, _Outcome):
    """A link request's status: queued, transmitting, waiting, then one final one."""

    __slots__ = ()
    kind = "status"
    _fields = ("link", "request_id", "status_name", "reason", "final")

    @property
    def request_id(self) -> int:
        return int(self.raw[E.REQ_ID])


class Received(_OnLink):
    """A frame that arrived on a link (its transport fragments never show here)."""

    __slots__ = ()
    kind = "received"
    _fields = ("link", "source", "destination", "data", "authenticated")

    @property
    def source(self) -> str:
        return str(self.raw[E.SRC])

    @property
    def destination(self) -> str:
        return str(self.raw[E.DST])

    @property
    def data(self) -> bytes:
        return bytes(self.raw[E.DATA])

    @property
    def authenticated(self) -> Optional[bool]:
        """Whether the frame's tag verified; None when the node has no key."""
        return bool(self.raw[E.AUTHED]) if len(self.raw) > E.AUTHED else None


class Availability(_OnLink):
    """A node became available or unavailable on a link (heard, or silent too long)."""

    __slots__ = ()
    kind = "availability"
    _fields = ("link", "name", "state_name")

    @property
    def name(self) -> str:
        return str(self.raw[E.NAME])

    @property
    def state(self) -> int:
        return int(self.raw[E.STATE])

    @property
    def state_name(self) -> str:
        return E.AVAIL_NAMES[self.raw[E.STATE]]

    @property
    def available(self) -> bool:
        return bool(self.raw[E.STATE] == E.AVAILABLE)


class Caps(_OnLink):
    """A link's capabilities (MTU, rate, ...) became known or changed."""

    __slots__ = ()
    kind = "caps"
    _fields = ("link", "caps")

    @property
    def caps(self) -> Any:
        return self.raw[E.CAPS]


class Ranges(_OnLink):
    """The ranges of a ranging request: one per name asked, None where nobody answered."""

    __slots__ = ()
    kind = "ranges"
    _fields = ("link", "request_id", "metres")

    @property
    def request_id(self) -> int:
        return int(self.raw[E.REQ_ID])

    @property
    def metres(self) -> Dict[str, Optional[float]]:
        return dict(zip(self.raw[E.NAMES], self.raw[E.METRES]))


class PacketStatus(_Outcome):
    """A transport packet's status at its sender; one final one per packet."""

    __slots__ = ()
    kind = "packet_status"
    _fields = ("packet_id", "status_name", "reason", "final")
    _STATUS = E.PACKET_STATUS
    _REASON = E.PACKET_REASON

    @property
    def packet_id(self) -> int:
        return int(self.raw[E.PID])


# (EV_RELAY_STATUS, origin_name, pid, status, reason): acomm/events.py names no indices for it
# (a name there is a dict slot on every board's heap), so they are named here, for the view and
# the console's lines
RELAY_ORIGIN, RELAY_PID, RELAY_STATUS, RELAY_REASON = 1, 2, 3, 4


class RelayStatus(_Outcome):
    """A packet this node took custody of as a relay, ended here undelivered (expired or failed).
    Its origin heard `transmitted` when custody moved and hears nothing more: this is the one
    place that loss is told."""

    __slots__ = ()
    kind = "relay_status"
    _fields = ("origin", "packet_id", "status_name", "reason", "final")
    _STATUS = RELAY_STATUS
    _REASON = RELAY_REASON

    @property
    def origin(self) -> str:
        return str(self.raw[RELAY_ORIGIN])

    @property
    def packet_id(self) -> int:
        return int(self.raw[RELAY_PID])


class Packet(Event):
    """A whole transport packet that arrived for this node."""

    __slots__ = ()
    kind = "packet"
    _fields = ("source", "destination", "data", "authenticated")

    @property
    def source(self) -> str:
        return str(self.raw[E.PACKET_SRC])

    @property
    def destination(self) -> str:
        return str(self.raw[E.PACKET_DST])

    @property
    def data(self) -> bytes:
        return bytes(self.raw[E.PACKET_DATA])

    @property
    def authenticated(self) -> Optional[bool]:
        """Whether every fragment verified; None when the node has no key."""
        return bool(self.raw[E.PACKET_AUTHED]) if len(self.raw) > E.PACKET_AUTHED else None


class Refused(Event):
    """A command without a valid tag that the node's key policy refused."""

    __slots__ = ()
    kind = "refused"
    _fields = ("link", "source", "reason")

    @property
    def link(self) -> Optional[str]:
        """The link it came on; None for a transport packet."""
        link = self.raw[E.LINK]
        return None if link is None else str(link.name)

    @property
    def source(self) -> str:
        return str(self.raw[E.REFUSED_SRC])

    @property
    def reason(self) -> str:
        return str(self.raw[E.REFUSED_REASON])


_VIEWS: Dict[int, "type[Event]"] = {
    E.EV_STATUS: LinkStatus,
    E.EV_RECEIVED: Received,
    E.EV_AVAILABILITY: Availability,
    E.EV_CAPS: Caps,
    E.EV_RANGE_RECEIVED: Ranges,
    E.EV_PACKET_STATUS: PacketStatus,
    E.EV_RELAY_STATUS: RelayStatus,
    E.EV_PACKET: Packet,
    E.EV_REFUSED: Refused,
}


def view(raw: Raw) -> Event:
    """The named view of a core event tuple (an Event subclass; a plain Event for codes without one)."""
    cls = _VIEWS.get(raw[0], Event)
    ev: Event = cls(raw)
    return ev


def kinds() -> List[str]:
    """The kinds a view can have, for documentation and tests."""
    return sorted(c.kind for c in _VIEWS.values())
