# Events are plain tuples whose first item is an EV_* code (typed
# Tuple[Any, ...]); read their fields with the index constants below:
#   if ev[0] == EV_STATUS and is_final(ev[STATUS]): ...

from typing import Tuple

QUEUED: int
TRANSMITTING: int
WAITING: int
TRANSMITTED: int
DELIVERED: int
EXPIRED: int
CANCELED: int
FAILED: int

STATUS_NAMES: Tuple[str, ...]

def is_final(status: int) -> bool: ...

UNKNOWN: int
AVAILABLE: int
UNAVAILABLE: int

AVAIL_NAMES: Tuple[str, ...]

EV_RX: int
EV_TX_DONE: int
EV_DELIVERED: int
EV_TX_FAILED: int
EV_RANGE: int
EV_DRIVER_UP: int
EV_DRIVER_DOWN: int
EV_REPLIED: int
EV_TIME: int

EV_STATUS: int
EV_RECEIVED: int
EV_AVAILABILITY: int
EV_CAPS: int
EV_RANGE_RECEIVED: int
EV_SEGMENT: int
EV_CONTROL: int
EV_PACKET_STATUS: int
EV_PACKET: int
EV_RELAY_STATUS: int
EV_REFUSED: int

HANDLE: int
RX_SRC: int
RX_DST: int
RX_DATA: int
FAIL_REASON: int
RANGE_ADDR: int
RANGE_METRES: int
RANGE_EXTRA: int
DOWN_REASON: int
TIME_SOURCE: int
TIME_SECS: int
TIME_MS: int
TIME_UNC: int
TIME_AT: int
LINK: int
REQ_ID: int
STATUS: int
REASON: int
SRC: int
DST: int
DATA: int
AUTHED: int
NAME: int
STATE: int
CAPS: int
NAMES: int
METRES: int
SEG_SRC: int
SEG_DST: int
SEG_HEAD: int
SEG_PAYLOAD: int
SEG_AUTHED: int
PID: int
PACKET_STATUS: int
PACKET_REASON: int
PACKET_SRC: int
PACKET_DST: int
PACKET_DATA: int
PACKET_AUTHED: int
REFUSED_SRC: int
REFUSED_REASON: int
