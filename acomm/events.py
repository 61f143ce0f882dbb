# The vocabulary shared by drivers, links and the node: request statuses,
# event codes and the names of the events' fields. Events are plain tuples
# whose first item is one of the EV_* codes, so they cost one small
# allocation and run on both runtimes; read their fields by name:
#   if ev[0] == EV_STATUS and is_final(ev[STATUS]): done[ev[REQ_ID]] = ev[STATUS]
# (modules on a board's path keep private const() copies of what they read:
# inlined, they cost no RAM).

from .compat import const

# Request statuses (seed 000 section III.D, plus `delivered` when the link or
# the modem confirms receipt).
QUEUED = const(1)
TRANSMITTING = const(2)
WAITING = const(3)  # transmitted, waiting for the acknowledgement
TRANSMITTED = const(4)  # final when no acknowledgement was asked for
DELIVERED = const(5)
EXPIRED = const(6)
CANCELED = const(7)
FAILED = const(8)

# Names indexed by the status. Name tables are tuples of constants, never
# dicts: frozen into firmware a constant tuple stays in flash, while a dict
# is built on the heap at import (a board's 64 KiB).
STATUS_NAMES = ("?", "queued", "transmitting", "waiting", "transmitted", "delivered", "expired", "canceled", "failed")


def is_final(status):
    return status >= TRANSMITTED


# Link availability of a remote node (seed 000 section III.H).
UNKNOWN = const(0)
AVAILABLE = const(1)
UNAVAILABLE = const(2)

AVAIL_NAMES = ("unknown", "available", "unavailable")  # indexed by the availability

# Driver -> link events.
#   (EV_RX, src_addr, dst_addr, data)      src/dst None on links without addressing
#   (EV_TX_DONE, handle)                   the frame has left the modem
#   (EV_DELIVERED, handle)                 the modem's own ack arrived
#   (EV_TX_FAILED, handle, reason)
#   (EV_RANGE, handle, addr, metres[, extra])   addr None when the ping failed;
#                                          extra, when present, a dict of what
#                                          else the fix says (bearing,
#                                          elevation, position, signal level)
#   (EV_DRIVER_UP,) / (EV_DRIVER_DOWN, reason)   modem (re)configured / lost
#   (EV_REPLIED,)                          the modem answered an interrogation
#                                          by itself with the queued reply: the
#                                          node was heard, as after an advert
EV_RX = const(1)
EV_TX_DONE = const(2)
EV_DELIVERED = const(3)
EV_TX_FAILED = const(4)
EV_RANGE = const(5)
EV_DRIVER_UP = const(6)
EV_DRIVER_DOWN = const(7)
EV_REPLIED = const(8)
# (EV_TIME, source, secs, ms, uncertainty_ms, at): a driver that can tell
# the time did ("iridium": AT-MSSTM, "gsm": AT+CCLK?, "gps": NMEA): secs
# from 2020-01-01 UTC, ms past it, how far off it may be, and the ticks
# (ms) at which it held. The link passes it to the node, whose wall clock
# (acomm.wallclock) takes it; it is not given to the listeners
EV_TIME = const(9)

# Link -> node/application events, passed to the listener as tuples:
#   (EV_STATUS, link, req_id, status, reason)
#   (EV_RECEIVED, link, src_name, dst_name, data)
#   (EV_RECEIVED, link, src_name, dst_name, data, authed)   with a key
#   (EV_AVAILABILITY, link, name, state)
#   (EV_CAPS, link, caps)
#   (EV_RANGE_RECEIVED, link, req_id, names, metres)
EV_STATUS = const(20)
EV_RECEIVED = const(21)
EV_AVAILABILITY = const(22)
EV_CAPS = const(23)
EV_RANGE_RECEIVED = const(24)
# Link -> transport (the node hands these to its transport, not to the
# application): (EV_SEGMENT, link, src_id, dst_id or None, head, payload,
# authed),
# head: the frame header's sequence field (acomm.transport.segment)
EV_SEGMENT = const(25)
# (EV_CONTROL, link, src_id, payload, authed): a route control frame's
# payload (acomm.transport.routing), for the transport's routing
EV_CONTROL = const(29)
# Transport -> application:
#   (EV_PACKET_STATUS, pid, status, reason)   statuses as for requests
#   (EV_PACKET, src_name, dst_name, data)     a whole packet arrived
#   (EV_PACKET, src_name, dst_name, data, authed)   the same, with a key:
#                                             every fragment verified
EV_PACKET_STATUS = const(26)
EV_PACKET = const(27)
# (EV_RELAY_STATUS, origin_name, pid, status, reason): a packet this node took custody of as a
# relay ended here undelivered (expired or failed). Its origin saw `transmitted` when custody
# moved and hears nothing more, so this is the only place the loss is told (the relay's console
# and logs; the soak counts it)
EV_RELAY_STATUS = const(30)
# when the node has a key (acomm.frame.auth) and a frame or packet without a valid
# tag holds a command (acomm.link.guard): (EV_REFUSED, link or None,
# src_name, reason); the command is not passed on
EV_REFUSED = const(28)

# The fields of the events, by position (ev[0] is always the code).
# Driver -> link:
HANDLE = const(1)  # EV_TX_DONE, EV_DELIVERED, EV_TX_FAILED, EV_RANGE: the send's or ping's handle
RX_SRC = const(1)  # EV_RX: the sender's interface address (None without addressing)
RX_DST = const(2)  # EV_RX: the destination address
RX_DATA = const(3)  # EV_RX: the bytes
FAIL_REASON = const(2)  # EV_TX_FAILED
RANGE_ADDR = const(2)  # EV_RANGE: who answered (None when the ping failed)
RANGE_METRES = const(3)  # EV_RANGE
RANGE_EXTRA = const(4)  # EV_RANGE, when present: a dict of what else the fix says
DOWN_REASON = const(1)  # EV_DRIVER_DOWN
TIME_SOURCE = const(1)  # EV_TIME: "iridium", "gsm", "gps"
TIME_SECS = const(2)  # EV_TIME: seconds from 2020-01-01 UTC
TIME_MS = const(3)  # EV_TIME: ms past them
TIME_UNC = const(4)  # EV_TIME: its uncertainty in ms
TIME_AT = const(5)  # EV_TIME: the ticks (ms) at which it held
# Link -> node and application (LINK: the Link, in every one of them):
LINK = const(1)
REQ_ID = const(2)  # EV_STATUS, EV_RANGE_RECEIVED: the request's id
STATUS = const(3)  # EV_STATUS: QUEUED .. FAILED
REASON = const(4)  # EV_STATUS: text, "" when there is nothing to say
SRC = const(2)  # EV_RECEIVED: the sender's name
DST = const(3)  # EV_RECEIVED: the destination's name (BROADCAST for all)
DATA = const(4)  # EV_RECEIVED: the bytes
AUTHED = const(5)  # EV_RECEIVED with a key: whether the tag verified
NAME = const(2)  # EV_AVAILABILITY: whose
STATE = const(3)  # EV_AVAILABILITY: UNKNOWN, AVAILABLE or UNAVAILABLE
CAPS = const(2)  # EV_CAPS: the link's acomm.drivers.caps.Capabilities
NAMES = const(3)  # EV_RANGE_RECEIVED: the names asked, in order
METRES = const(4)  # EV_RANGE_RECEIVED: one range per name, None where none answered
SEG_SRC = const(2)  # EV_SEGMENT: the neighbour's id
SEG_DST = const(3)  # EV_SEGMENT: the destination id, or None
SEG_HEAD = const(4)  # EV_SEGMENT: the frame header's sequence field
SEG_PAYLOAD = const(5)  # EV_SEGMENT
SEG_AUTHED = const(6)  # EV_SEGMENT
# Transport -> application:
PID = const(1)  # EV_PACKET_STATUS: the packet's id
PACKET_STATUS = const(2)  # EV_PACKET_STATUS: QUEUED .. FAILED
PACKET_REASON = const(3)  # EV_PACKET_STATUS
PACKET_SRC = const(1)  # EV_PACKET: the origin's name
PACKET_DST = const(2)  # EV_PACKET: the final destination's name
PACKET_DATA = const(3)  # EV_PACKET: the bytes
PACKET_AUTHED = const(4)  # EV_PACKET with a key: every fragment verified
REFUSED_SRC = const(2)  # EV_REFUSED: who sent it (LINK is None for a packet)
REFUSED_REASON = const(3)  # EV_REFUSED
