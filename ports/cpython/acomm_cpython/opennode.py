# Opening a node on real links (acomm_cpython.aio's open_node): modems
# named as on the command line, UDP and TCP links, the network key, the
# transport and its store, closed again when anything fails on the way.
# The node it returns is an AsyncNode (acomm_cpython.asyncnode).

from __future__ import annotations

import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, cast

from acomm.node import Node

from .asyncnode import AsyncNode
from .hosttransport import HostTransport


class open_node:
    """`async with open_node(name, node_id, ...) as node:` an AsyncNode on real links, started.

    modems: --modem texts ("seatrac:/dev/ttyUSB0", "evologics:tcp://HOST:9200", ...); udp:
    "[HOST:]PORT" of a UDP link (0: any port); tcp_listen / tcp_connect: a TCP server or client
    link; iridium: --iridium texts of shore links through the Iridium gateway, no modem
    ("directip:10800,mt=HOST:PORT", "rockblock:8080,mt=URL,credentials=FILE", key=PEM only to
    verify with another key than Rock7's published one; docs/drivers-iridium.md),
    each a link named "satellite" (then "satellite2", ...); known: other nodes' names -> ids; key_file: the network key (hex in a file only its owner
    reads); store: a folder for the transport's persistent store (None: in RAM); transport=False:
    none. udp_peers: static UDP peers, id -> "HOST:PORT"; multicast=False: the UDP link announces
    itself neither by multicast nor by broadcast (static and learnt peers only).
    driver_options go to the modems' drivers, link_options to every link. ModemSpecError for
    a bad modem text, ModemError when a modem cannot be opened or does not start in time.
    guard: what needs a valid tag with the key (an acomm.link.guard.Guard; default
    acomm.apps.policy.commands(), the seed catalogs' commands)."""

    def __init__(self, name: str, node_id: int, modems: Sequence[str] = (), udp: Optional[str] = None,
                 tcp_listen: Optional[str] = None, tcp_connect: Optional[str] = None,
                 known: Optional[Mapping[str, int]] = None, key_file: Optional[str] = None,
                 store: Optional[str] = None, transport: bool = True,
                 driver_options: Optional[Mapping[str, Any]] = None, link_options: Optional[Mapping[str, Any]] = None,
                 startup_timeout_s: float = 15.0, udp_peers: Optional[Mapping[int, str]] = None,
                 multicast: bool = True, guard: Optional[Any] = None, iridium: Sequence[str] = ()) -> None:
        self._args: Dict[str, Any] = dict(name=name, node_id=node_id, modems=list(modems), udp=udp, tcp_listen=tcp_listen,
                          tcp_connect=tcp_connect, known=dict(known or {}), key_file=key_file, store=store,
                          transport=transport, driver_options=dict(driver_options or {}),
                          link_options=dict(link_options or {}), udp_peers=dict(udp_peers or {}),
                          multicast=multicast, guard=guard, iridium=list(iridium))
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
               udp_peers: Optional[Mapping[int, str]] = None, multicast: bool = True,
               guard: Optional[Any] = None, iridium: Sequence[str] = ()) -> AsyncNode:
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

            core.set_auth(Auth(load_key(key_file)), guard if guard is not None else commands())
        for spec in modems:
            lname, stream, watch = add_modem_link(core, spec, options=dict(driver_options or {}), **lopts)
            closers.append(stream)
            ports[lname] = stream
            watches.append((lname, watch))
        for i, spec in enumerate(iridium):
            from .shore.spec import add_shore_link, link_name

            lname = link_name(i)
            _, port = add_shore_link(core, spec, lname, **lopts)
            closers.append(port)
            ports[lname] = port
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
