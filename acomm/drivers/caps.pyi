from typing import List

CAP_ADDRESSING: int
CAP_RELIABLE: int
CAP_BROADCAST: int
CAP_DISCOVERY: int
CAP_RANGING: int
CAP_DELIVERY: int

class Capabilities:
    manufacturer: str
    model: str
    serial: str
    cost_tx: float
    cost_rx: float
    energy_tx: float
    energy_rx: float
    mtu_tx: int
    mtu_rx: int
    bitrate: int
    latency_ms: int
    flags: int
    def __init__(
        self,
        manufacturer: str = ...,
        model: str = ...,
        serial: str = ...,
        cost_tx: float = ...,
        cost_rx: float = ...,
        energy_tx: float = ...,
        energy_rx: float = ...,
        mtu_tx: int = ...,
        mtu_rx: int = ...,
        bitrate: int = ...,
        latency_ms: int = ...,
        flags: int = ...,
    ) -> None: ...
    def has(self, flag: int) -> bool: ...
    def copy(self) -> Capabilities: ...
    def __eq__(self, other: object) -> bool: ...
    def flag_names(self) -> List[str]: ...
