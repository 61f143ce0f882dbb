# Types of acomm.apps.policy: the command policy a keyed node enforces.
from typing import Any, Callable, Iterable, Optional

from ..link.guard import Guard

def catalog_check(catalog: Any, names: Iterable[str],
                  unwrap: Optional[Callable[[bytes], bytes]] = ...) -> Callable[[bytes], bool]: ...
def commands(strict: bool = ...) -> Guard: ...
