# Schema-driven bit packing for acoustic links (docs/codec.md): field kinds,
# messages with a small id, and catalogs that pack several messages into one
# frame. `from acomm.codec import UInt, Fixed, Message, Catalog`.

from .fields import Array, Bool, Bytes, Enum, Fixed, Nested, Optional, UInt, Wide
from .message import Catalog, Message
from .text6 import Text6
