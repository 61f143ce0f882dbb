# acomm for asyncio programs on CPython: open a node on modems and IP
# links with one call, await a send's final status, iterate over what
# arrives, range, move files through the store-and-forward transport,
# and send and decode catalog messages.
#
#     async with open_node("buoy", 1, modems=["seatrac:/dev/ttyUSB0"], known={"diver": 2}) as node:
#         status = await node.send("diver", b"surface in 5 min", lifespan_s=60, priority=3, ack=True)
#         async for msg in node.messages():
#             print(msg.source, msg.data)
#
# Underneath is the same sans-IO core a board runs (acomm.node.Node, its
# links, drivers and transport), stepped by acomm_cpython.ioloop.NodeLoop
# when bytes arrive and when its timers fall due. Every awaited request
# ends with exactly one final status; cancelling the awaiting task cancels
# the request (its final status is then `canceled`). The blocking form for
# scripts without asyncio is acomm_cpython.blocking.

from __future__ import annotations

import asyncio
import math
import os
import time
from typing import Any, AsyncIterator, Callable, Dict, Iterable, List, Mapping, NamedTuple, Optional, Sequence, Tuple, Union, cast

from acomm import events as E
from acomm.errors import AcommError
from acomm.node import Node

from .eventview import Event, view
from .hosttransport import HostTransport
from .ioloop import NodeLoop

BROADCAST = "*"


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
        return self.times.get(self.name, time.monotonic() - self.started) if self.final else time.monotonic() - self.started

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

    def __init__(self, owner: "AsyncNode", pick: Callable[[Tuple[Any, ...]], Any], maxsize: int) -> None:
        self._owner = owner
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
            self._owner._unsubscribe(self)
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


def _as_messages(ev: Tuple[Any, ...]) -> Sequence[Message]:
    if ev[0] == E.EV_RECEIVED:
        authed = bool(ev[E.AUTHED]) if len(ev) > E.AUTHED else None
        return (Message(ev[E.SRC], ev[E.DST], ev[E.LINK].name, bytes(ev[E.DATA]), authed, False),)
    if ev[0] == E.EV_PACKET:
        authed = bool(ev[E.PACKET_AUTHED]) if len(ev) > E.PACKET_AUTHED else None
        return (Message(ev[E.PACKET_SRC], ev[E.PACKET_DST], None, bytes(ev[E.PACKET_DATA]), authed, True),)
    return ()


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
        s = Subscription(self, pick, maxsize)
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
        return self._subscribe(_as_messages, maxsize)

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
        for m in _as_messages(ev):
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


class open_node:
    """`async with open_node(name, node_id, ...) as node:` an AsyncNode on real links, started.

    modems: --modem texts ("seatrac:/dev/ttyUSB0", "evologics:tcp://HOST:9200", ...); udp:
    "[HOST:]PORT" of a UDP link (0: any port); tcp_listen / tcp_connect: a TCP server or client
    link; known: other nodes' names -> ids; key_file: the network key (hex in a file only its owner
    reads); store: a folder for the transport's persistent store (None: in RAM); transport=False:
    none. udp_peers: static UDP peers, id -> "HOST:PORT"; multicast=False: the UDP link announces
    itself neither by multicast nor by broadcast (static and learnt peers only).
    driver_options go to the modems' drivers, link_options to every link. ModemSpecError for
    a bad modem text, ModemError when a modem cannot be opened or does not start in time."""

    def __init__(self, name: str, node_id: int, modems: Sequence[str] = (), udp: Optional[str] = None,
                 tcp_listen: Optional[str] = None, tcp_connect: Optional[str] = None,
                 known: Optional[Mapping[str, int]] = None, key_file: Optional[str] = None,
                 store: Optional[str] = None, transport: bool = True,
                 driver_options: Optional[Mapping[str, Any]] = None, link_options: Optional[Mapping[str, Any]] = None,
                 startup_timeout_s: float = 15.0, udp_peers: Optional[Mapping[int, str]] = None,
                 multicast: bool = True) -> None:
        self._args: Dict[str, Any] = dict(name=name, node_id=node_id, modems=list(modems), udp=udp, tcp_listen=tcp_listen,
                          tcp_connect=tcp_connect, known=dict(known or {}), key_file=key_file, store=store,
                          transport=transport, driver_options=dict(driver_options or {}),
                          link_options=dict(link_options or {}), udp_peers=dict(udp_peers or {}),
                          multicast=multicast)
        self._timeout = startup_timeout_s
        self._node: Optional[AsyncNode] = None

    async def __aenter__(self) -> AsyncNode:
        node = build_node(**self._args)
        try:
            await node.start(self._timeout)
        except BaseException:
            await node.close()
            raise
        self._node = node
        return node

    async def __aexit__(self, *exc: Any) -> None:
        if self._node is not None:
            await self._node.close()


def build_node(name: str, node_id: int, modems: Sequence[str] = (), udp: Optional[str] = None,
               tcp_listen: Optional[str] = None, tcp_connect: Optional[str] = None,
               known: Optional[Mapping[str, int]] = None, key_file: Optional[str] = None,
               store: Optional[str] = None, transport: bool = True,
               driver_options: Optional[Mapping[str, Any]] = None, link_options: Optional[Mapping[str, Any]] = None,
               udp_peers: Optional[Mapping[int, str]] = None, multicast: bool = True) -> AsyncNode:
    """The AsyncNode open_node starts, not yet started (links opened, nothing stepped)."""
    from .modems import add_modem_link, hostport, load_key

    core = Node(name, node_id)
    for k, v in (known or {}).items():
        core.names.add(k, int(v))
    closers: List[Any] = []
    ports: Dict[str, Any] = {}
    port: Any
    watches: List[Tuple[str, Any]] = []
    lopts = dict(link_options or {})
    try:
        if key_file is not None:
            from acomm.apps.policy import commands
            from acomm.frame.auth import Auth

            core.set_auth(Auth(load_key(key_file)), commands())
        for spec in modems:
            lname, stream, watch = add_modem_link(core, spec, options=dict(driver_options or {}), **lopts)
            closers.append(stream)
            ports[lname] = stream
            watches.append((lname, watch))
        if udp is not None:
            from .udp import DEFAULT_GROUP, udp_link

            peers = dict((int(k), hostport(v, "127.0.0.1")) for k, v in (udp_peers or {}).items())
            _, port = udp_link(core, "udp", bind=hostport(udp), group=DEFAULT_GROUP if multicast else None,
                               broadcast="255.255.255.255" if multicast else None, peers=peers, **lopts)
            closers.append(port)
            ports["udp"] = port
        if tcp_listen is not None:
            from .tcp import tcp_server_link

            _, port = tcp_server_link(core, "tcp", bind=hostport(tcp_listen), **lopts)
            closers.append(port)
            ports["tcp"] = port
        if tcp_connect is not None:
            from .tcp import tcp_client_link

            host, p = hostport(tcp_connect, "127.0.0.1")
            lname = "tcp" if tcp_listen is None else "tcp-out"
            _, port = tcp_client_link(core, host, p, lname, **lopts)
            closers.append(port)
            ports[lname] = port
        t: Optional[HostTransport] = None
        if transport:
            st = None
            if store is not None:
                from acomm.transport.store import Store

                os.makedirs(store, exist_ok=True)
                st = Store(os.path.join(store, "acomm.store"), capacity_bytes=1 << 22, max_record=1024)
                closers.append(st)
            t = cast(HostTransport, HostTransport.of(core, store=st))
    except BaseException:
        for c in closers:
            try:
                c.close()
            except OSError:
                pass
        raise
    return AsyncNode(core, t, ports, closers, watches)
