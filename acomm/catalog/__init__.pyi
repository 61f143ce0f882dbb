from typing import Tuple

from ..codec.message import Catalog

# the message sets: acomm.catalog.caddy, .seaware, .rendezvous, .teleop
MODULES: Tuple[str, ...]

def load(name: str) -> Catalog: ...
