# The asyncio node (acomm_cpython.aio's AsyncNode): a core acomm.node.Node
# stepped by acomm_cpython.ioloop.NodeLoop, whose requests are awaited to
# their one final status, whose arrivals are iterated, and whose catalog
# messages are packed and decoded by name (CatalogChannel). It listens to
# the core node's event tuples and never changes them. Opening the links
# it runs on is acomm_cpython.opennode's.

from __future__ import annotations

import asyncio
import math
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

from acomm import events as E
from acomm.errors import AcommError
from acomm.node import Node

from .eventview import view
from .hosttransport import HostTransport
from .ioloop import NodeLoop
from .results import CatalogMessage, Message, Progress, Status, Subscription, as_messages

BROADCAST = "*"


class AsyncNode:
    """A node on asyncio: `core` is the acomm.node.Node, `transport` its HostTransport (None without).
    Made by open_node(); usable as `async with`."""

    def __init__(self, core: Node, transport: Optional[HostTransport] = None, ports: Optional[Mapping[str, Any]] = None,
                 closers: Sequence[Any] = (), watches: Sequence[Tuple[str, Any]] = ()) -> None:
        self.core = core
        self.transport = transport
        # link name -> its byte stream or frame port (a UdpPort's .address, a TcpStream's .connected)
        self.ports: Dict[str, Any] = dict(ports or {})
        self.loop = NodeLoop(core, list(self.ports.values()))
        self.loop.after.append(self._after_step)
        self._closers = list(closers)
        self._watches = list(watches)
        self._requests: Dict[Tuple[str, Optional[str], int], Status] = {}
        self._early: Dict[Tuple[str, Optional[str], int], Tuple[int, str]] = {}
        self._progress: Dict[int, Tuple[Callable[[Progress], None], Optional[Progress]]] = {}
        self._subs: List[Subscription] = []
        self._up = asyncio.Event()
        self._closed = False
        core.listen(self._on_event)

    @property
    def name(self) -> str:
        return str(self.core.name)

    @property
    def links(self) -> List[str]:
        return list(self.core.links)

    # -- life ----------------------------------------------------------------------
    async def start(self, timeout_s: float = 15.0) -> "AsyncNode":
        """Starts stepping and waits until every modem finished its start-up; ModemError naming the
        first that did not within timeout_s."""
        from .modems import ModemError

        self.loop.start()
        if not self._all_up():
            try:
                await asyncio.wait_for(self._up.wait(), timeout_s)
            except asyncio.TimeoutError:
                late = [n for n, w in self._watches if not w.up][0]
                raise ModemError("the modem of link %s did not answer its start-up within %g s" % (late, timeout_s)) from None
        return self

    def _all_up(self) -> bool:
        if all(w.up for _, w in self._watches):
            self._up.set()
            return True
        return False

    async def close(self) -> None:
        """Stops the node and closes its ports and store. Requests still running are left as they
        are (a persistent store keeps the transport's packets for the next start); a call still
        awaiting one raises AcommError."""
        if self._closed:
            return
        self._closed = True
        self.loop.close()
        for s in list(self._subs):
            s.close()
        for st in self._requests.values():
            if st._future is not None and not st._future.done():
                # no final status will come: the awaiting call learns why
                st._future.set_exception(AcommError("the node closed before %r had its final status" % st))
        for c in self._closers:
            try:
                c.close()
            except OSError:
                pass

    async def __aenter__(self) -> "AsyncNode":
        return self

    async def __aexit__(self, *exc: Any) -> None:
        await self.close()

    # -- events ----------------------------------------------------------------------
    def _on_event(self, ev: Tuple[Any, ...]) -> None:
        code = ev[0]
        if code == E.EV_STATUS:
            self._status(("link", ev[E.LINK].name, ev[E.REQ_ID]), ev[E.STATUS], ev[E.REASON])
        elif code == E.EV_PACKET_STATUS:
            self._status(("packet", None, ev[E.PID]), ev[E.PACKET_STATUS], ev[E.PACKET_REASON])
        elif code == E.EV_RANGE_RECEIVED:
            st = self._requests.get(("link", ev[E.LINK].name, ev[E.REQ_ID]))
            if st is not None:
                st.ranges = dict(zip(ev[E.NAMES], ev[E.METRES]))
        for s in self._subs:
            s._offer(ev)

    def _status(self, key: Tuple[str, Optional[str], int], code: int, reason: str) -> None:
        st = self._requests.get(key)
        if st is None:
            # a status before its request returned (a refusal comes at once)
            # or of someone else's request: kept a little while, bounded
            if E.is_final(code):
                if len(self._early) >= 64:
                    del self._early[next(iter(self._early))]
                self._early[key] = (code, reason)
            return
        st._update(code, reason)
        if st.final:
            del self._requests[key]
            if key[0] == "packet":
                fn, last = self._progress.pop(key[2], (None, None))
                if fn is not None and last is not None and code == E.DELIVERED and last.acked < last.total:
                    fn(Progress(last.total, last.total, last.total))  # the last SACK ends the transfer

    def _after_step(self, now: int) -> None:
        if not self._up.is_set():
            self._all_up()
        t = self.transport
        if t is None:
            return
        for pid, (fn, last) in list(self._progress.items()):
            p = t.progress(pid)
            if p is not None and p != last:
                prog = Progress(*p)
                self._progress[pid] = (fn, prog)
                fn(prog)

    def _subscribe(self, pick: Callable[[Tuple[Any, ...]], Any], maxsize: int) -> Subscription:
        s = Subscription(self._unsubscribe, pick, maxsize)
        if self._closed:
            s.close()
        else:
            self._subs.append(s)
        return s

    def _unsubscribe(self, s: Subscription) -> None:
        if s in self._subs:
            self._subs.remove(s)

    def messages(self, maxsize: int = 256) -> Subscription:
        """An async iterator of Message: every frame and transport packet that arrives from now on."""
        return self._subscribe(as_messages, maxsize)

    def events(self, maxsize: int = 1024) -> Subscription:
        """An async iterator of every event from now on, as named views (acomm_cpython.eventview)."""
        return self._subscribe(lambda ev: (view(ev),), maxsize)

    # -- requests ----------------------------------------------------------------------
    def _pick_link(self, dst: str, link: Optional[str]) -> Any:
        links = self.core.links
        if link is not None:
            if link not in links:
                raise AcommError("no link %r (this node has %s)" % (link, ", ".join(links) or "none"))
            return links[link]
        if not links:
            raise AcommError("this node has no links")
        for candidate in links.values():
            if dst == BROADCAST or candidate.availability(dst) == E.AVAILABLE:
                return candidate
        return next(iter(links.values()))

    async def _await(self, key: Tuple[str, Optional[str], int], st: Status, cancel: Callable[[], Any]) -> Status:
        early = self._early.pop(key, None)
        if early is not None:
            st._update(*early)
            return st
        if st.final:
            self._requests.pop(key, None)
            return st
        self._requests[key] = st
        fut: asyncio.Future[Status] = asyncio.get_running_loop().create_future()
        st._future = fut
        self.loop.wake()
        try:
            return await fut
        except asyncio.CancelledError:
            if not self._closed and not st.final:
                cancel()  # its final status (canceled) goes to the listeners
            raise

    async def send(self, dst: str, data: bytes, lifespan_s: float = 60, priority: int = 10, ack: bool = False,
                   link: Optional[str] = None) -> Status:
        """Sends one frame to dst ("*": everyone) and returns its final Status. link: the link's name;
        by default the first on which dst is available, else the first link. Priority 1 (first)
        to 16; the frame is dropped when it waits longer than lifespan_s. A request the link refuses
        (an unknown destination, too big) ends at once with status `failed` and the reason;
        AcommError for a link name this node does not have."""
        lk = self._pick_link(dst, link)
        rid = self.core.next_req_id()
        st = Status(lk.name, rid)
        key = ("link", lk.name, rid)
        self._requests[key] = st  # before the request: its first statuses may come at once
        try:
            lk.request(self.core.clock(), rid, dst, bytes(data), _seconds(lifespan_s), priority, ack)
        except BaseException:
            self._requests.pop(key, None)
            raise
        return await self._await(key, st, lambda: lk.cancel(self.core.clock(), rid, "canceled by the caller"))

    async def range(self, *names: str, link: Optional[str] = None, lifespan_s: float = 30) -> Dict[str, Optional[float]]:
        """Pings each node named and returns name -> metres (None where it did not answer)."""
        if not names:
            raise AcommError("range whom?")
        lk = self._pick_link(names[0], link)
        rid = self.core.next_req_id()
        st = Status(lk.name, rid)
        st.ranges = dict((n, None) for n in names)
        key = ("link", lk.name, rid)
        self._requests[key] = st
        try:
            lk.range(self.core.clock(), rid, list(names), _seconds(lifespan_s))
        except BaseException:
            self._requests.pop(key, None)
            raise
        await self._await(key, st, lambda: lk.cancel(self.core.clock(), rid, "canceled by the caller"))
        return st.ranges

    async def transfer(self, dst: str, data: bytes, lifespan_s: float = 600, priority: int = 8,
                       progress: Optional[Callable[[Progress], None]] = None, medium: Optional[str] = None) -> Status:
        """Sends data of any size (up to the transport's max_packet) through the store-and-forward
        transport and returns the packet's final Status. progress(Progress) is called whenever its
        fragments sent or acknowledged change. medium: only links of that medium ("acoustic", ...)."""
        t = self._transport()
        pid = t.send(self.core.clock(), dst, bytes(data), _seconds(lifespan_s), priority, medium)
        if progress is not None:
            self._progress[pid] = (progress, None)
        st = Status(None, pid)
        try:
            return await self._await(("packet", None, pid), st, lambda: t.cancel(self.core.clock(), pid, "canceled by the caller"))
        finally:
            self._progress.pop(pid, None)

    def _transport(self) -> HostTransport:
        if self.transport is None:
            raise AcommError("this node was opened without a transport")
        return self.transport

    def available(self, name: str) -> List[str]:
        """The links on which name is available (heard lately), in the node's order."""
        return [n for n, lk in self.core.links.items() if lk.availability(name) == E.AVAILABLE]

    def catalog(self, catalog: Any) -> "CatalogChannel":
        """Sending and receiving messages of a catalog (a module such as acomm.catalog.caddy, or its CATALOG)."""
        return CatalogChannel(self, getattr(catalog, "CATALOG", catalog))


class CatalogChannel:
    """One catalog's messages over a node: send() packs them, messages() decodes what arrives."""

    def __init__(self, node: AsyncNode, catalog: Any) -> None:
        self.node = node
        self.catalog = catalog
        self.undecodable = 0

    def pack(self, items: Union[Tuple[Any, Mapping[str, Any]], Iterable[Tuple[Any, Mapping[str, Any]]]]) -> bytes:
        """The bytes of one (message, values) pair or of a list of them."""
        if isinstance(items, tuple) and len(items) == 2 and isinstance(items[1], Mapping):
            items = [items]
        return bytes(self.catalog.pack(list(items)))

    async def send(self, dst: str, items: Any, lifespan_s: float = 600, priority: int = 10,
                   link: Optional[str] = None) -> Status:
        """Sends the messages as one transport packet (or as one frame on `link` when given); -> final Status."""
        data = self.pack(items)
        if link is not None:
            return await self.node.send(dst, data, lifespan_s, priority, True, link)
        return await self.node.transfer(dst, data, lifespan_s, priority)

    def decode(self, m: Message) -> List[CatalogMessage]:
        """The catalog messages in one received Message; [] (counted in `undecodable`) when it does
        not decode as this catalog."""
        try:
            decoded = self.catalog.unpack(m.data)
        except (AcommError, ValueError, IndexError, KeyError):
            self.undecodable += 1
            return []
        return [CatalogMessage(m.source, m.destination, m.link, msg, dict(values), m.authenticated)
                for msg, values in decoded]

    def _decode(self, ev: Tuple[Any, ...]) -> List[CatalogMessage]:
        out: List[CatalogMessage] = []
        for m in as_messages(ev):
            out.extend(self.decode(m))
        return out

    def messages(self, maxsize: int = 256) -> Subscription:
        """An async iterator of CatalogMessage decoded from every frame and packet that arrives
        (what does not decode as this catalog is skipped and counted in `undecodable`)."""
        return self.node._subscribe(self._decode, maxsize)


def _seconds(lifespan_s: float) -> int:
    if lifespan_s <= 0:
        raise AcommError("a lifespan must be positive")
    return int(math.ceil(lifespan_s))
