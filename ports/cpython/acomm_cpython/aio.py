# acomm for asyncio programs on CPython: open a node on modems and IP
# links with one call, await a send's final status, iterate over what
# arrives, range, move files through the store-and-forward transport,
# and send and decode catalog messages.
#
#     async with open_node("buoy", 1, modems=["seatrac:/dev/ttyUSB0"], known={"diver": 2}) as node:
#         status = await node.send("diver", b"surface in 5 min", lifespan_s=60, priority=3, ack=True)
#         async for msg in node.messages():
#             print(msg.source, msg.data)
#
# Underneath is the same sans-IO core a board runs (acomm.node.Node, its
# links, drivers and transport), stepped by acomm_cpython.ioloop.NodeLoop
# when bytes arrive and when its timers fall due. Every awaited request
# ends with exactly one final status; cancelling the awaiting task cancels
# the request (its final status is then `canceled`). The blocking form for
# scripts without asyncio is acomm_cpython.blocking; docs/python-api.md
# is the reference.
#
# This module is the library's one import: the node is
# acomm_cpython.asyncnode, opening it acomm_cpython.opennode, what it
# hands back acomm_cpython.results.

from .asyncnode import BROADCAST, AsyncNode, CatalogChannel
from .opennode import build_node, open_node
from .results import CatalogMessage, Message, Progress, Status, Subscription

__all__ = ["AsyncNode", "BROADCAST", "CatalogChannel", "CatalogMessage", "Message", "Progress", "Status",
           "Subscription", "build_node", "open_node"]
