from typing import Any, Callable, Dict, List, Optional, Tuple, Union

from .frame.auth import Auth
from .link import Link
from .link.guard import Guard
from .link.names import NameTable
from .transport import Transport
from .wallclock import WallClock

# an event: a tuple whose first item is an acomm.events EV_* code
_Event = Tuple[Any, ...]
_Listener = Callable[[_Event], object]
_BytesLike = Union[bytes, bytearray, memoryview]

class Node:
    name: str
    node_id: int
    clock: Callable[[], int]
    names: NameTable
    listeners: List[_Listener]
    links: Dict[str, Link]
    auth: Optional[Auth]
    guard: Optional[Guard]
    backlog: List[_Event]
    backlog_dropped: int
    stream_errors: int
    moved: int
    transport: Optional[Transport]
    wallclock: Optional[WallClock]
    def __init__(
        self,
        name: str,
        node_id: int,
        clock: Optional[Callable[[], int]] = ...,
        names: Optional[NameTable] = ...,
        listener: Optional[_Listener] = ...,
        wallclock: Optional[WallClock] = ...,
    ) -> None: ...
    def set_auth(self, auth: Optional[Auth], guard: Optional[Guard] = ..., strict: bool = ...) -> None: ...
    def attach(self, transport: Transport) -> None: ...
    def listen(self, fn: _Listener) -> None: ...
    def unlisten(self, fn: _Listener) -> None: ...
    # stream: read(n) -> bytes or None, write(bytes) -> int or None; or a frame port with pump(now)
    def add_link(self, name: str, driver: Any, stream: Any = ..., **options: Any) -> Link: ...
    # source: take_times() -> EV_TIME tuples; with a stream also feed(now, bytes)
    def add_time_source(self, source: Any, stream: Any = ...) -> None: ...
    def link(self, name: str) -> Link: ...
    def next_req_id(self) -> int: ...
    def emit(self, ev: _Event) -> None: ...
    def take_events(self) -> List[_Event]: ...
    def send(
        self,
        link_name: str,
        dst: str,
        data: _BytesLike,
        lifespan_s: float,
        priority: int = ...,
        ack: bool = ...,
        now: Optional[int] = ...,
    ) -> int: ...
    def step(self, now: Optional[int] = ...) -> int: ...
    async def run(self, period_ms: int = ..., stop: Optional[Callable[[], bool]] = ...) -> None: ...
