from typing import Any, Tuple, Union

_BytesLike = Union[bytes, bytearray, memoryview]

VERSION: int

DATA: int
ACK: int
ADVERT: int
RANGE: int
CONTROL: int
SEGMENT: int
REPLY: int

F_ACK_REQ: int
F_FRAG: int
F_COMPRESSED: int
F_AUTH: int

BROADCAST: int
MAX_ADDR: int

SEQ_MOD_RAW: int
SEQ_MOD_ELIDED: int

RAW_OVERHEAD_SHORT: int
RAW_OVERHEAD_WIDE: int
RAW_OVERHEAD_MAX: int
ELIDED_OVERHEAD: int

class Frame:
    ftype: int
    src: Any
    dst: Any
    seq: int
    flags: int
    payload: bytes
    authed: bool
    ctr: int
    def __init__(self, ftype: int, src: Any, dst: Any, seq: int, payload: bytes = ..., flags: int = ...) -> None: ...
    def __eq__(self, other: object) -> bool: ...

def addr_bytes(a: int) -> bytes: ...
def get_addr(data: _BytesLike, i: int, end: int = ...) -> Tuple[int, int]: ...
def raw_overhead(src: int, dst: int) -> int: ...
def encode_raw_into(
    buf: bytearray, ftype: int, src: int, dst: int, seq: int, payload: _BytesLike, flags: int = ...
) -> int: ...
def encode_raw(frame: Frame) -> bytes: ...
def check_raw(data: _BytesLike) -> int: ...
def raw_addresses(data: _BytesLike) -> Tuple[int, int]: ...
def decode_raw(data: _BytesLike) -> Frame: ...
def encode_elided_into(buf: bytearray, ftype: int, seq: int, payload: _BytesLike, flags: int = ...) -> int: ...
def encode_elided(frame: Frame) -> bytes: ...
def decode_elided(data: _BytesLike, src: Any, dst: Any) -> Frame: ...
