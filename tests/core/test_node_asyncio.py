# Node.run on the runtime's own asyncio and real time (the subset of asyncio
# that MicroPython shares with CPython: run, gather, sleep).
import asyncio

from acomm.compat import ticks_diff, ticks_ms
from acomm.drivers.transparent import TransparentDriver
from acomm.events import DELIVERED, EV_RECEIVED
from acomm_sim.fakeuart import uart_pair
from acomm.node import Node
from linkcheck import Recorder


def test_two_nodes_on_asyncio_real_time():
    a, b = uart_pair(clock=ticks_ms)
    nodes = []
    for (name, nid), u in ((("buoy", 1), a), (("diver", 2), b)):
        n = Node(name, nid, listener=Recorder())
        n.names.add("buoy", 1)
        n.names.add("diver", 2)
        n.add_link("radio", TransparentDriver(115200), u, advert_period_ms=200, ack_timeout_ms=2000)
        nodes.append(n)
    buoy, diver = nodes
    rid = diver.send("radio", "buoy", b"hello from below", 10, ack=True)
    t0 = ticks_ms()

    def done():
        return diver.listeners[0].final(rid) is not None or ticks_diff(ticks_ms(), t0) > 5000

    async def main():
        await asyncio.gather(buoy.run(2, done), diver.run(2, done))

    asyncio.run(main())
    assert diver.listeners[0].final(rid) == DELIVERED
    assert [bytes(e[4]) for e in buoy.listeners[0].of(EV_RECEIVED)] == [b"hello from below"]
