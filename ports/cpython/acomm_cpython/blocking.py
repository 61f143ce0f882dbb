# acomm for scripts that do not use asyncio: the same AsyncNode
# (acomm_cpython.aio), run on an event loop in a thread of its own, with
# calls that block until their answer.
#
#     with Node.open("buoy", 1, modems=["seatrac:/dev/ttyUSB0"], known={"diver": 2}) as node:
#         status = node.send_and_wait("diver", b"surface in 5 min", ack=True)
#         msg = node.receive(timeout_s=60)
#
# Every call goes through that loop, so the core node is only ever touched
# from one thread. A call interrupted by Ctrl-C cancels its request, as
# cancelling the awaiting task does in the asyncio form.

from __future__ import annotations

import asyncio
import concurrent.futures
import threading
from typing import Any, Callable, Coroutine, Dict, Optional, TypeVar

from .aio import AsyncNode, CatalogMessage, Message, Progress, Status, build_node

T = TypeVar("T")


class Node:
    """A started node whose methods block; made by Node.open(...) (same arguments as aio.open_node)."""

    def __init__(self, anode: AsyncNode, loop: asyncio.AbstractEventLoop, thread: threading.Thread) -> None:
        self._node = anode
        self._loop = loop
        self._thread = thread
        self._inbox = self._call(self._subscribe)

    @classmethod
    def open(cls, name: str, node_id: int, startup_timeout_s: float = 15.0, **options: Any) -> "Node":
        """Opens the links, starts the node on its own loop thread and waits for the modems' start-up.

        options: as for acomm_cpython.aio.open_node. ModemSpecError or ModemError as there."""
        loop = asyncio.new_event_loop()
        thread = threading.Thread(target=loop.run_forever, name="acomm-%s" % name, daemon=True)
        thread.start()

        async def make() -> AsyncNode:
            node = build_node(name, node_id, **options)
            try:
                await node.start(startup_timeout_s)
            except BaseException:
                await node.close()
                raise
            return node

        try:
            anode = asyncio.run_coroutine_threadsafe(make(), loop).result()
        except BaseException:
            loop.call_soon_threadsafe(loop.stop)
            thread.join(5)
            loop.close()
            raise
        return cls(anode, loop, thread)

    async def _subscribe(self) -> Any:
        return self._node.messages()

    def _call(self, fn: Callable[[], Coroutine[Any, Any, T]], timeout_s: Optional[float] = None) -> T:
        fut: concurrent.futures.Future[T] = asyncio.run_coroutine_threadsafe(fn(), self._loop)
        try:
            return fut.result(timeout_s)
        except concurrent.futures.TimeoutError:
            fut.cancel()  # the request is cancelled on the loop: its final status is `canceled`
            raise TimeoutError("no final status within %g s" % (timeout_s or 0)) from None
        except KeyboardInterrupt:
            fut.cancel()
            raise

    @property
    def core(self) -> Any:
        """The acomm.node.Node underneath (touch it only from callbacks run on the node's loop)."""
        return self._node.core

    @property
    def name(self) -> str:
        return self._node.name

    @property
    def ports(self) -> Dict[str, Any]:
        """Link name -> its stream or port (a UdpPort's .address: where it listens)."""
        return self._node.ports

    def send_and_wait(self, dst: str, data: bytes, lifespan_s: float = 60, priority: int = 10, ack: bool = False,
                      link: Optional[str] = None, timeout_s: Optional[float] = None) -> Status:
        """Sends one frame and blocks until its final Status (aio.AsyncNode.send). timeout_s: give up
        waiting after that long (TimeoutError; the request is then cancelled)."""
        return self._call(lambda: self._node.send(dst, data, lifespan_s, priority, ack, link), timeout_s)

    def range(self, *names: str, link: Optional[str] = None, lifespan_s: float = 30) -> Dict[str, Optional[float]]:
        """Pings each node named; -> name -> metres (None where it did not answer)."""
        return self._call(lambda: self._node.range(*names, link=link, lifespan_s=lifespan_s))

    def transfer(self, dst: str, data: bytes, lifespan_s: float = 600, priority: int = 8,
                 progress: Optional[Callable[[Progress], None]] = None, timeout_s: Optional[float] = None) -> Status:
        """Sends data through the transport and blocks until the packet's final Status. progress is
        called on the node's loop thread."""
        return self._call(lambda: self._node.transfer(dst, data, lifespan_s, priority, progress), timeout_s)

    def send_catalog(self, catalog: Any, dst: str, items: Any, lifespan_s: float = 600, priority: int = 10) -> Status:
        """Packs catalog messages ((message, values) or a list of them) and sends them as one packet."""
        ch = self._node.catalog(catalog)
        return self._call(lambda: ch.send(dst, items, lifespan_s, priority))

    def decode(self, catalog: Any, msg: Message) -> list[CatalogMessage]:
        """The catalog messages in a received Message (empty when it does not decode as that catalog)."""
        return self._node.catalog(catalog).decode(msg)

    def receive(self, timeout_s: Optional[float] = None) -> Optional[Message]:
        """The next frame or packet that arrived since open (oldest first); None after timeout_s."""
        try:
            msg: Message = self._call(lambda: self._inbox.get(timeout_s))
            return msg
        except (asyncio.TimeoutError, TimeoutError):
            return None

    def available(self, name: str) -> list[str]:
        """The links on which name was heard lately."""
        async def ask() -> list[str]:
            return self._node.available(name)

        return self._call(ask)

    def close(self) -> None:
        """Stops the node, closes its links and store, and ends its loop thread."""
        if self._loop.is_closed():
            return
        try:
            self._call(self._node.close, 10)
        finally:
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(10)
            self._loop.close()

    def __enter__(self) -> "Node":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
