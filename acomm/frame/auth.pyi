from typing import Callable, Dict, Optional, Tuple, Union

_BytesLike = Union[bytes, bytearray, memoryview]

CTR_LEN: int
EPOCH_LEN: int
ANNOUNCE_EXTRA: int
ANNOUNCE_FRAMES: int

KEY_CMD: bytes
OP_INSTALL: int
OP_USE: int
OP_DROP: int

def key_command(op: int, phase: int, nonce: bytes = ...) -> bytes: ...

class Auth:
    phase: int
    tag_len: int
    overhead: int
    path: Optional[str]
    reserve: int
    wall: Callable[[], float]
    epoch: int
    last: int
    stats: Dict[str, int]
    def __init__(
        self,
        key: Union[bytes, bytearray],
        tag_len: int = ...,
        path: Optional[str] = ...,
        reserve: int = ...,
        wall: Optional[Callable[[], float]] = ...,
    ) -> None: ...
    def add_key(self, key: Union[bytes, bytearray], phase: int) -> None: ...
    def key_command(self, payload: _BytesLike) -> bool: ...
    def announcing(self) -> bool: ...
    def seal(
        self, ftype: int, src: int, dst: int, payload: _BytesLike, seq: int = ..., announce: bool = ...,
        again: int = ...
    ) -> bytes: ...
    def open(
        self, ftype: int, src: int, dst: int, body: _BytesLike, seq: int = ..., again: bool = ...
    ) -> Tuple[Optional[bytes], int]: ...
    def ack_tag(
        self, src: int, dst: int, seq: int, ctr: int, tag: Optional[_BytesLike] = ...
    ) -> Union[bytes, bool, None]: ...
    def commit(self) -> None: ...
