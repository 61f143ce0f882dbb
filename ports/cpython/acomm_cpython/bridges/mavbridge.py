# `acomm bridge mavlink` on asyncio: one side (mavvehicle.VehicleSide or
# mavtopside.TopsideSide), one MAVLink connection (mavio) and one acomm
# AsyncNode, joined. MAVLink bytes are read when the connection is
# readable, acoustic messages when the node delivers them, and the side is
# polled on its own clock (every 100 ms at most); whatever the side wants
# sent goes out at once. The acoustic messages go to one peer, the other
# bridge, and only that peer's are taken.
#
# A stick or keep-alive is handed to the node only when the previous one has
# left (its final status): the side then sends the freshest vector, never
# a queue of old ones.

from __future__ import annotations

import asyncio
from typing import Any, Callable, Dict, List, Optional

from acomm import events as E
from acomm.catalog import rovcontrol as R
from acomm.compat import ticks_ms
from acomm.errors import AcommError

# name -> (priority, lifespan s, link ack): commands first, acknowledged by
# the vehicle's state (a link ACK's retransmissions would cross that answer
# on a half-duplex channel); sticks soon stale; the state least urgent
SENDING = {"command": (2, 5.0, False), "thrust": (3, 3.0, False), "heartbeat": (3, 3.0, False),
           "poll": (3, 3.0, False), "state": (5, 10.0, False)}
UPLINK = ("thrust", "heartbeat", "poll")  # one at a time: the freshest goes next


def kind(name: str, values: Dict[str, Any]) -> str:
    """A rovcontrol message's sending class: its name, or "poll" for a poll command."""
    return "poll" if name == "command" and values["cmd"] == R.CMD_POLL else name


class BridgeRunner:
    def __init__(self, side: Any, node: Any, conn: Any, endpoint: Any, peer: str,
                 emit: Callable[[Dict[str, Any]], None]) -> None:
        self.side = side
        self.node = node
        self.conn = conn
        self.endpoint = endpoint
        self.peer = peer
        self.emit = emit
        self._fd: Optional[int] = None
        self._stick: Optional["asyncio.Task[Any]"] = None
        self._tasks: List["asyncio.Task[Any]"] = []
        self.stats: Dict[str, int] = {"acoustic_sent": 0, "acoustic_failed": 0, "acoustic_in": 0,
                                      "acoustic_undecodable": 0, "acoustic_other_source": 0, "refused": 0}
        self.failures: Dict[str, int] = {}  # acoustic sends that did not go out, by status and reason
        self._wake = asyncio.Event()
        self._stopping = False

    def _line(self, text: str) -> None:
        self.emit({"event": "bridge", "text": text})

    def _on_event(self, ev: Any) -> None:
        if ev[0] == E.EV_REFUSED:
            self.stats["refused"] += 1
            self._line("refused from %s: %s" % (ev[2], ev[3]))

    def _readable(self) -> None:
        data = self.conn.read()
        if data:
            now = ticks_ms()
            for msg in self.endpoint.feed(data):
                self.side.mavlink_in(now, msg)
        self._flush()
        self._wake.set()  # a stick moved: the side decides at once, not at its next tick

    def _sync_reader(self) -> None:
        loop = asyncio.get_running_loop()
        fd = self.conn.fileno()
        if fd == self._fd:
            return
        if self._fd is not None:
            loop.remove_reader(self._fd)
        self._fd = fd
        if fd is not None:
            loop.add_reader(fd, self._readable)

    def _flush(self) -> None:
        side = self.side
        for m in side.take_mavlink():
            self.conn.write(self.endpoint.encode(m))
        for name, values in side.take_acoustic():
            data = R.CATALOG.pack([(name, values)])
            k = kind(name, values)
            prio, life, ack = SENDING[k]
            t = asyncio.get_running_loop().create_task(self._send(k, data, prio, life, ack))
            self._tasks.append(t)
            if k in UPLINK:
                self._stick = t
        for text in side.take_lines():
            self._line(text)

    async def _send(self, name: str, data: bytes, prio: int, life: float, ack: bool) -> None:
        try:
            st = await self.node.send(self.peer, data, life, prio, ack)
        except AcommError as e:
            self.stats["acoustic_failed"] += 1
            self._line("not sent: %s" % e)
        else:
            self.side.transmitted(ticks_ms(), name)
            self.stats["acoustic_sent" if st.ok else "acoustic_failed"] += 1
            if not st.ok:
                why = "%s: %s" % (st.name, st.reason) if st.reason else st.name
                self.failures[why] = self.failures.get(why, 0) + 1
        self._wake.set()  # a stick slot may be free

    async def _acoustic(self) -> None:
        async for m in self.node.messages():
            if m.source != self.peer:
                self.stats["acoustic_other_source"] += 1
                continue
            try:
                items = R.CATALOG.unpack(m.data)
            except AcommError:
                self.stats["acoustic_undecodable"] += 1
                continue
            self.stats["acoustic_in"] += 1
            self.side.acoustic_in(ticks_ms(), items, bool(m.authenticated))
            self._flush()
            self._wake.set()

    def _poll(self) -> int:
        now = ticks_ms()
        self.side.poll(now, self._stick is None or self._stick.done())
        self._flush()
        self._tasks = [t for t in self._tasks if not t.done()]
        self._sync_reader()
        return int(self.side.next_ms(now))

    def stop(self) -> None:
        """Ends run() at its next turn. A flag, not Task.cancel(): before Python 3.12,
        asyncio.wait_for drops a cancel that lands as the awaited event fires, and this
        loop's event fires with every MAVLink datagram."""
        self._stopping = True
        self._wake.set()

    async def run(self, seconds: Optional[float] = None) -> None:
        """Until stop() or cancellation, or for `seconds`."""
        loop = asyncio.get_running_loop()
        end = None if seconds is None else loop.time() + seconds
        self.node.core.listen(self._on_event)
        rx = loop.create_task(self._acoustic())
        try:
            while not self._stopping and (end is None or loop.time() < end):
                wait = min(self._poll(), 100) / 1000.0
                if end is not None:
                    wait = max(0.0, min(wait, end - loop.time()))
                self._wake.clear()
                try:
                    await asyncio.wait_for(self._wake.wait(), wait)
                except asyncio.TimeoutError:
                    pass
        finally:
            rx.cancel()
            for t in self._tasks:
                t.cancel()
            if self._fd is not None:
                loop.remove_reader(self._fd)
                self._fd = None
            self.node.core.unlisten(self._on_event)
