# The asyncio library (acomm_cpython.aio) and its blocking form on real
# sockets: two nodes on UDP over the loopback, stepped by the event loop
# (acomm_cpython.ioloop). Sends end with one final status each, messages
# and packets arrive through `async for`, a cancelled task cancels its
# request, catalog messages decode by name, and an idle node sleeps.
# Every wait is bounded.

import asyncio
import random
import threading

import pytest

from acomm.catalog import caddy
from acomm.errors import AcommError
from acomm_cpython.aio import AsyncNode, Message, open_node
from acomm_cpython.blocking import Node as BlockingNode
from acomm_cpython.eventview import LinkStatus, PacketStatus, Received, view

ADVERT = {"advert_period_ms": 500}


async def _pair():
    # b first (its port), then a with b as a static peer; b learns a's port
    # from a's first datagram
    b = open_node("diver", 2, udp="127.0.0.1:0", multicast=False, known={"buoy": 1}, link_options=ADVERT)
    bn = await b.__aenter__()
    port = bn.ports["udp"].address[1]
    a = open_node("buoy", 1, udp="127.0.0.1:0", multicast=False, known={"diver": 2},
                  udp_peers={2: "127.0.0.1:%d" % port}, link_options=ADVERT)
    an = await a.__aenter__()
    return an, bn


def run(coro, timeout=30):
    return asyncio.run(asyncio.wait_for(coro, timeout))


def test_send_messages_and_statuses_over_udp():
    async def main():
        buoy, diver = await _pair()
        try:
            inbox = diver.messages()
            events = buoy.events()
            st = await buoy.send("diver", b"surface in 5 min", lifespan_s=10, priority=3, ack=True)
            assert st.name == "delivered" and st.ok and st.final and st.link == "udp", st
            assert "delivered" in st.times and st.elapsed_s >= 0
            msg = await inbox.get(5)
            assert isinstance(msg, Message)
            assert (msg.source, msg.destination, msg.link, msg.data, msg.packet) == ("buoy", "diver", "udp",
                                                                                     b"surface in 5 min", False)
            assert msg.authenticated is None  # no key
            # the named views of the same events, in order, one final status
            seen = []
            while True:
                ev = await events.get(5)
                if isinstance(ev, LinkStatus) and ev.request_id == st.request_id:
                    seen.append(ev.status_name)
                    if ev.final:
                        break
            assert seen[-1] == "delivered" and seen.count("delivered") == 1, seen
            # a request the link refuses (an unknown destination) ends at once with its one status
            st = await buoy.send("nobody", b"x")
            assert st.name == "failed" and "nobody" in st.reason, st
            with pytest.raises(AcommError):
                await buoy.send("diver", b"x", link="satellite")  # no such link
            # after the node closes, the iterators end
        finally:
            await buoy.close()
            await diver.close()
        assert [m async for m in inbox] == []

    run(main())


def test_transfer_with_progress_and_a_catalog_message():
    async def main():
        buoy, diver = await _pair()
        try:
            packets = diver.messages()
            statuses = diver.catalog(caddy).messages()
            progress = []
            data = random.Random(1).randbytes(3000)  # incompressible: three fragments at a 1024-byte MTU
            st = await buoy.transfer("diver", data, lifespan_s=20, progress=progress.append)
            assert st.name == "delivered" and st.link is None, st
            assert progress and progress[-1].total >= 3 and all(p.sent <= p.total for p in progress), progress
            assert progress[-1].acked == progress[-1].total, progress  # the last call: all acknowledged
            msg = await packets.get(5)
            assert msg.packet and msg.data == data and msg.link is None
            values = {"heart_rate": 72, "breathing_rate": 14, "body_temp": 36.6}
            st = await buoy.catalog(caddy).send("diver", (caddy.DIVER_STATUS, values), lifespan_s=20)
            assert st.ok
            # the transfer's packet came first on this iterator but does not decode as CADDY... or
            # does: skip until the diver status
            while True:
                m = await statuses.get(5)
                if m.message.name == "diver_status":
                    break
            assert m.values["heart_rate"] == 72 and m.values["breathing_rate"] == 14
            assert abs(m.values["body_temp"] - 36.6) < 0.1 and m.source == "buoy"
        finally:
            await buoy.close()
            await diver.close()

    run(main())


def test_cancelling_the_awaiting_task_cancels_the_request():
    async def main():
        # the diver is not there: the ack never comes, the request waits
        a = open_node("buoy", 1, udp="127.0.0.1:0", multicast=False, known={"diver": 2},
                      udp_peers={2: "127.0.0.1:9"}, link_options=ADVERT)
        async with a as buoy:
            events = buoy.events()
            task = asyncio.ensure_future(buoy.send("diver", b"never acknowledged", lifespan_s=30, ack=True))
            await asyncio.sleep(0.2)
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            finals = []
            while not finals:
                ev = await events.get(5)
                if isinstance(ev, LinkStatus) and ev.final:
                    finals.append(ev)
            assert finals[0].status_name == "canceled", finals
            # a packet through the transport, cancelled the same way
            task = asyncio.ensure_future(buoy.transfer("diver", b"p" * 3000, lifespan_s=30))
            await asyncio.sleep(0.2)
            task.cancel()
            with pytest.raises(asyncio.CancelledError):
                await task
            while True:
                ev = await events.get(5)
                if isinstance(ev, PacketStatus) and ev.final:
                    break
            assert ev.status_name == "canceled" and buoy.transport.pending() == []

    run(main())


def test_an_idle_node_sleeps_between_its_timers():
    async def main():
        async with open_node("buoy", 1, udp="127.0.0.1:0", multicast=False, link_options={"advert_period_ms": 60000}) as n:
            await asyncio.sleep(0.3)  # its first advert goes
            s0 = n.loop.steps
            await asyncio.sleep(1.0)
            return n.loop.steps - s0

    steps = run(main())
    # the 5 ms polling loop took 200 steps a second; the idle timer is 250 ms
    assert 1 <= steps <= 12, steps


def test_named_views_leave_the_core_tuples_alone():
    class L:
        name = "acoustic"

    raw = (21, L(), "buoy", "diver", b"hi", True)
    v = view(raw)
    assert isinstance(v, Received) and v.raw is raw and v.kind == "received"
    assert (v.link, v.source, v.destination, v.data, v.authenticated) == ("acoustic", "buoy", "diver", b"hi", True)
    assert "source='buoy'" in repr(v)
    with pytest.raises(AttributeError):
        v.source = "eve"


def test_the_blocking_form():
    b = BlockingNode.open("diver", 2, udp="127.0.0.1:0", multicast=False, known={"buoy": 1}, link_options=ADVERT)
    try:
        port = b.ports["udp"].address[1]
        with BlockingNode.open("buoy", 1, udp="127.0.0.1:0", multicast=False, known={"diver": 2},
                               udp_peers={2: "127.0.0.1:%d" % port}, link_options=ADVERT) as a:
            st = a.send_and_wait("diver", b"hello", ack=True, lifespan_s=10)
            assert st.name == "delivered", st
            msg = b.receive(timeout_s=5)
            assert msg is not None and msg.data == b"hello" and msg.source == "buoy"
            assert b.receive(timeout_s=0.1) is None
            st = a.send_catalog(caddy, "diver", (caddy.DIVER_STATUS, {"heart_rate": 60, "breathing_rate": 12,
                                                                     "body_temp": 36.0}))
            assert st.ok
            got = b.decode(caddy, b.receive(timeout_s=5))
            assert got and got[0].message.name == "diver_status" and got[0].values["heart_rate"] == 60
            assert threading.current_thread() is threading.main_thread()
    finally:
        b.close()


def test_closing_the_node_ends_the_calls_still_waiting():
    async def main():
        a = open_node("buoy", 1, udp="127.0.0.1:0", multicast=False, known={"diver": 2},
                      udp_peers={2: "127.0.0.1:9"}, link_options=ADVERT)
        buoy = await a.__aenter__()
        task = asyncio.ensure_future(buoy.send("diver", b"never acknowledged", lifespan_s=30, ack=True))
        await asyncio.sleep(0.1)
        await buoy.close()
        with pytest.raises(AcommError, match="closed"):
            await task

    run(main())
