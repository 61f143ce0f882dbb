from typing import Any, Dict, Tuple

from acomm.link import Link
from acomm.node import Node

SERVICES: Tuple[str, ...]
LINK_OPTIONS: Dict[str, Any]

def parse_spec(text: str) -> Tuple[str, Tuple[str, int], Dict[str, Any]]: ...
def link_name(i: int) -> str: ...
def add_shore_link(node: Node, text: str, name: str = ..., **link_options: Any) -> Tuple[Link, Any]: ...
