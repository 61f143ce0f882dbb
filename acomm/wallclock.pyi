from typing import Callable, Optional

MIN_S: int


class WallClock:
    ticks: Callable[[], int]
    path: Optional[str]
    epoch_s: int
    source: str
    saves: int
    def __init__(
        self,
        wall: Optional[Callable[[], float]] = ...,
        ticks: Optional[Callable[[], int]] = ...,
        path: Optional[str] = ...,
        epoch_s: int = ...,
        host: bool = ...,
    ) -> None: ...
    def wall(self, now: Optional[int] = ...) -> int: ...
    def uncertainty_ms(self, now: Optional[int] = ...) -> Optional[int]: ...
    def on_step(self, fn: Callable[[int], object]) -> None: ...
    def fix(self, now: int, source: str, secs: int, ms: int, unc_ms: int) -> bool: ...
    def poll(self, now: int) -> None: ...
