# IMC 5.4 (LSTS Inter-Module Communication), the protocol of DUNE and Neptus:
# packets, messages as dicts, a stream parser (docs/imc.md).
#
#   from acomm import imc
#   data = imc.encode({"abbrev": "Abort"}, src=0x1234, dst=0x16, timestamp=imc.F64.seconds(t))
#   pkt = imc.decode(data)            # pkt.msg == {"abbrev": "Abort"}

from .fp64 import F64
from .messages import by_id, by_name, define
from .packet import MAX_DEPTH, Packet, decode, decode_inline, encode, encode_inline
from .stream import StreamParser

__all__ = (
    "F64",
    "MAX_DEPTH",
    "Packet",
    "StreamParser",
    "by_id",
    "by_name",
    "decode",
    "decode_inline",
    "define",
    "encode",
    "encode_inline",
)
