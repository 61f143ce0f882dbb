# The vocabulary shared by drivers, links and the node: request statuses and
# event codes. Events are plain tuples whose first item is one of the EV_*
# codes, so they cost one small allocation and run on both runtimes.

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
# Transport -> application:
#   (EV_PACKET_STATUS, pid, status, reason)   statuses as for requests
#   (EV_PACKET, src_name, dst_name, data)     a whole packet arrived
#   (EV_PACKET, src_name, dst_name, data, authed)   the same, with a key:
#                                             every fragment verified
EV_PACKET_STATUS = const(26)
EV_PACKET = const(27)
# when the node has a key (acomm.frame.auth) and a frame or packet without a valid
# tag holds a command (acomm.link.guard): (EV_REFUSED, link or None,
# src_name, reason); the command is not passed on
EV_REFUSED = const(28)
