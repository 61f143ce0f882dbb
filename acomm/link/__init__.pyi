from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

from ..drivers.caps import Capabilities
from .discovery import Discovery
from .guard import Guard
from .names import AddressMap, NameTable
from .txqueue import TxQueue

_Event = Tuple[Any, ...]
_Listener = Callable[[_Event], object]
_BytesLike = Union[bytes, bytearray, memoryview]

# destination name meaning every node on the link
BROADCAST: str

class Link:
    name: str
    medium: str
    # the sans-IO driver (acomm.drivers.*): caps, ready, send, feed, poll, take_events, take_output
    driver: Any
    node_id: int
    names: NameTable
    listener: Optional[_Listener]
    queue: TxQueue
    discovery: Discovery
    addr_map: AddressMap
    elided: bool
    modem_acks: bool
    # acomm.link.framing.LinkFraming
    framing: Any
    seq_mod: int
    guard: Optional[Guard]
    max_retries: int
    dup_window_ms: int
    overhear: bool
    # set by a transport that learns routes: SEGMENT frames between two others are handed up too
    overhear_segments: bool
    ack_timeout_ms: int
    stats: Dict[str, int]
    def __init__(
        self,
        name: str,
        driver: Any,
        node_id: int,
        names: NameTable,
        listener: Optional[_Listener] = ...,
        queue_capacity: int = ...,
        advert_period_ms: int = ...,
        lost_after: int = ...,
        ack_timeout_ms: Optional[int] = ...,
        max_retries: int = ...,
        aging_ms: int = ...,
        addr_map: Optional[AddressMap] = ...,
        dup_window_ms: int = ...,
        ack_window: int = ...,
        overhear: bool = ...,
        medium: Optional[str] = ...,
        fec: int = ...,
    ) -> None: ...
    @property
    def caps(self) -> Capabilities: ...
    def advertise_caps(self) -> Capabilities: ...
    def mtu_for(self, dst_id: Optional[int]) -> int: ...
    def addressable(self, nid: int) -> bool: ...
    def request(
        self,
        now: int,
        req_id: int,
        dst: str,
        data: _BytesLike,
        lifespan_s: float,
        priority: int = ...,
        ack: bool = ...,
        retries: Optional[int] = ...,
        ftype: int = ...,
        seq: Optional[int] = ...,
    ) -> bool: ...
    def set_reply(self, now: int, payload: Optional[_BytesLike]) -> None: ...
    def cancel(self, now: int, req_id: int, reason: str = ...) -> bool: ...
    def availability(self, name: str) -> int: ...
    def poll(self, now: int) -> None: ...
    def idle(self, now: int) -> bool: ...
    def feed(self, now: int, data: _BytesLike) -> None: ...
    def take_output(self) -> bytes: ...
    def range(self, now: int, req_id: int, names: Sequence[str], lifespan_s: float, priority: int = ...) -> bool: ...
