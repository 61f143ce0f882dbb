from typing import Any, Callable, Dict, List, Mapping, Optional, Protocol, Tuple, Union

from ..frame.auth import Auth
from ..link import Link
from ..link.guard import Guard
from ..link.names import NameTable
from ..node import Node

_Event = Tuple[Any, ...]
_BytesLike = Union[bytes, bytearray, memoryview]

class _RecordStore(Protocol):
    # what a packet store backend offers: acomm.transport.store.Store (a file)
    # or acomm.transport.memorystore.MemoryStore (RAM)
    def put(self, key: int, data: _BytesLike) -> None: ...
    def delete(self, key: int) -> None: ...
    def get(self, key: int) -> Optional[bytes]: ...
    def length(self, key: int) -> Optional[int]: ...
    def keys(self) -> List[int]: ...

class Transport:
    node_id: int
    names: NameTable
    guard: Optional[Guard]
    auth: Optional[Auth]
    # acomm.transport.packetstore.PacketStore and acomm.transport.route.Router
    packets: Any
    router: Any
    wall: Callable[[], float]
    max_packet: int
    compress: bool
    stats: Dict[str, int]
    def __init__(
        self,
        node_id: int,
        names: NameTable,
        links: Mapping[str, Link],
        next_id: Callable[[], int],
        emit: Callable[[_Event], object],
        store: Optional[_RecordStore] = ...,
        routes: Optional[Mapping[str, str]] = ...,
        wall: Optional[Callable[[], float]] = ...,
        max_packet: int = ...,
        compress: bool = ...,
        urgent: int = ...,
        routing: Union[None, bool, Mapping[str, Any]] = ...,
    ) -> None: ...
    @classmethod
    def of(
        cls,
        node: Node,
        *,
        store: Optional[_RecordStore] = ...,
        routes: Optional[Mapping[str, str]] = ...,
        wall: Optional[Callable[[], float]] = ...,
        max_packet: int = ...,
        compress: bool = ...,
        urgent: int = ...,
        routing: Union[None, bool, Mapping[str, Any]] = ...,
    ) -> Transport: ...
    @property
    def store(self) -> _RecordStore: ...
    @property
    def routes(self) -> Dict[str, str]: ...
    def send(
        self, now: int, dst: str, data: _BytesLike, lifespan_s: float, priority: int = ..., medium: Optional[str] = ...
    ) -> int: ...
    def pending(self) -> List[int]: ...
    def clock_stepped(self, delta_s: int) -> None: ...
    def poll(self, now: int) -> None: ...
    # the node's calls (acomm.node.Node): a link request's status -> True when it was the transport's
    def on_link_status(self, now: int, rid: int, status: int, reason: str) -> bool: ...
    def on_control(self, now: int, link: Link, src: int, payload: bytes, authed: bool = ...) -> None: ...
    def flood(self, now: int, data: _BytesLike, hops_limit: Optional[int] = ...) -> int: ...
    def on_segment(
        self, now: int, link: Link, src: int, dst: Optional[int], head: int, payload: bytes, authed: bool = ...
    ) -> None: ...
