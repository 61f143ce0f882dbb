# What the asyncio library (acomm_cpython.aio) hands back: a request's
# final Status, the Messages that arrive, a transfer's Progress, decoded
# CatalogMessages, and the bounded Subscription iterators they come
# through. Plain values, no I/O: the node that makes them is
# acomm_cpython.asyncnode.

from __future__ import annotations

import asyncio
import time
from typing import Any, Callable, Dict, NamedTuple, Optional, Sequence, Tuple

from acomm import events as E


class Status:
    """The outcome of a request: `name` (delivered, transmitted, expired, canceled, failed, or
    queued ... while it runs), `reason`, where it went (`link`, or None for a transport packet)
    and when each status came (`times`: name -> seconds after the request)."""

    def __init__(self, link: Optional[str], request_id: int) -> None:
        self.link = link
        self.request_id = request_id
        self.code = E.QUEUED
        self.reason = ""
        self.started = time.monotonic()
        self.times: Dict[str, float] = {}
        self.ranges: Dict[str, Optional[float]] = {}
        self._future: Optional[asyncio.Future[Status]] = None

    @property
    def name(self) -> str:
        return E.STATUS_NAMES[self.code]

    @property
    def final(self) -> bool:
        return bool(E.is_final(self.code))

    @property
    def ok(self) -> bool:
        """True when delivered, or transmitted when no acknowledgement was asked for."""
        return self.code in (E.DELIVERED, E.TRANSMITTED)

    @property
    def elapsed_s(self) -> float:
        """Seconds from the request to its final status (so far, while it runs)."""
        if self.final:
            return self.times[self.name]
        return time.monotonic() - self.started

    def _update(self, code: int, reason: str) -> None:
        self.code = code
        self.reason = reason
        self.times[E.STATUS_NAMES[code]] = round(time.monotonic() - self.started, 6)
        if self.final and self._future is not None and not self._future.done():
            self._future.set_result(self)

    def __repr__(self) -> str:
        where = "packet" if self.link is None else self.link
        return "Status(%s %d %s%s)" % (where, self.request_id, self.name, (": " + self.reason) if self.reason else "")


class Message(NamedTuple):
    """A frame (packet=False, on `link`) or a transport packet (packet=True, link None) that arrived.
    authenticated: whether its tag verified; None when the node has no key."""

    source: str
    destination: str
    link: Optional[str]
    data: bytes
    authenticated: Optional[bool]
    packet: bool


class Progress(NamedTuple):
    """A transfer's fragments: sent (acknowledged, or handed to the link this round), acknowledged, in all."""

    sent: int
    acked: int
    total: int


class CatalogMessage(NamedTuple):
    """One decoded catalog message: `message` its definition (message.name), `values` its fields by name."""

    source: str
    destination: str
    link: Optional[str]
    message: Any
    values: Dict[str, Any]
    authenticated: Optional[bool]


class Subscription:
    """An async iterator over what arrives, from when it was made until the node closes. Bounded:
    beyond `maxsize` waiting items the oldest is dropped (and counted in `dropped`)."""

    _END = object()

    def __init__(self, unsubscribe: Callable[["Subscription"], None], pick: Callable[[Tuple[Any, ...]], Any],
                 maxsize: int) -> None:
        self._unsubscribe = unsubscribe
        self._pick = pick
        self._q: asyncio.Queue[Any] = asyncio.Queue()
        self.maxsize = maxsize
        self.dropped = 0
        self._closed = False

    def _offer(self, ev: Tuple[Any, ...]) -> None:
        for item in self._pick(ev) or ():
            if self._q.qsize() >= self.maxsize:
                self._q.get_nowait()
                self.dropped += 1
            self._q.put_nowait(item)

    def close(self) -> None:
        """Ends the iteration once what waits has been taken."""
        if not self._closed:
            self._closed = True
            self._unsubscribe(self)
            self._q.put_nowait(self._END)

    def __aiter__(self) -> "Subscription":
        return self

    async def __anext__(self) -> Any:
        item = await self._q.get()
        if item is self._END:
            self._q.put_nowait(self._END)  # every later call ends too
            raise StopAsyncIteration
        return item

    async def get(self, timeout_s: Optional[float] = None) -> Any:
        """The next item; asyncio.TimeoutError after timeout_s; StopAsyncIteration once closed."""
        return await asyncio.wait_for(self.__anext__(), timeout_s)


def as_messages(ev: Tuple[Any, ...]) -> Sequence[Message]:
    if ev[0] == E.EV_RECEIVED:
        authed = bool(ev[E.AUTHED]) if len(ev) > E.AUTHED else None
        return (Message(ev[E.SRC], ev[E.DST], ev[E.LINK].name, bytes(ev[E.DATA]), authed, False),)
    if ev[0] == E.EV_PACKET:
        authed = bool(ev[E.PACKET_AUTHED]) if len(ev) > E.PACKET_AUTHED else None
        return (Message(ev[E.PACKET_SRC], ev[E.PACKET_DST], None, bytes(ev[E.PACKET_DATA]), authed, True),)
    return ()
