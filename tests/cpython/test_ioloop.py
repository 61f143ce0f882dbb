# acomm_cpython.ioloop.NodeLoop, the event loop under acomm node, acomm run
# and the asyncio library: a node steps when its pty has bytes, a port that
# hung up cannot spin the loop, a step that raises is reported once and the
# node carries on, and the wake plan follows what the node has to do.
# Counts are asserted, never timings.

import asyncio
import os
import sys

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux"):
    pytest.skip("needs Linux pseudo-terminals", allow_module_level=True)

from acomm.drivers.transparent import TransparentDriver  # noqa: E402
from acomm.events import EV_RECEIVED  # noqa: E402
from acomm.node import Node  # noqa: E402
from acomm_cpython.emulate.pty import set_raw  # noqa: E402
from acomm_cpython.ioloop import BUSY_MS, IDLE_MS, NodeLoop, next_wake_ms  # noqa: E402
from acomm_cpython.streams import SerialStream  # noqa: E402


def _node_on_pty(advert_period_ms=60000):
    master, slave = os.openpty()
    set_raw(slave)
    stream = SerialStream(serial.Serial(os.ttyname(slave), 115200, timeout=0))
    os.close(slave)
    events = []
    node = Node("topside", 1, listener=events.append)
    node.add_link("serial", TransparentDriver(115200), stream, advert_period_ms=advert_period_ms)
    return node, stream, master, events


def test_bytes_wake_the_node_and_an_idle_node_sleeps():
    node, stream, master, events = _node_on_pty()
    fed = []
    inner = node.links["serial"].driver.feed
    node.links["serial"].driver.feed = lambda now, data: (fed.append(bytes(data)), inner(now, data))

    async def main():
        nl = NodeLoop(node, [stream]).start()
        await asyncio.sleep(0.3)  # the start-up advert goes
        s0 = nl.steps
        await asyncio.sleep(1.0)
        idle = nl.steps - s0
        os.write(master, b"\x55" * 8)
        for _ in range(100):
            await asyncio.sleep(0.01)
            if fed:
                break
        nl.close()
        return idle

    try:
        idle = asyncio.run(main())
    finally:
        stream.close()
        os.close(master)
    assert fed and fed[0].startswith(b"\x55"), fed
    assert idle <= 1000 // IDLE_MS + 2, idle  # a 5 ms poll took 200 steps a second


def test_a_port_that_hung_up_cannot_spin_the_loop():
    node, stream, master, _ = _node_on_pty()
    os.close(master)  # the other end goes: the pty stays readable with nothing to read

    async def main():
        nl = NodeLoop(node, [stream]).start()
        await asyncio.sleep(1.0)
        nl.close()
        return nl.steps

    try:
        steps = asyncio.run(main())
    finally:
        stream.close()
    # at most one step per BUSY_MS while it rests, not thousands
    assert steps <= 2 * 1000 // BUSY_MS, steps


def test_a_step_that_raises_is_reported_once_and_the_node_carries_on():
    node, stream, master, _ = _node_on_pty()
    errors = []
    calls = []

    def bad_step():
        calls.append(1)
        if len(calls) < 20:
            raise ValueError("a driver fault")
        return node.step()

    async def main():
        nl = NodeLoop(node, [stream], on_error=errors.append, step=bad_step).start()
        for _ in range(100):  # bounded: a loaded machine only makes it slower
            await asyncio.sleep(0.05)
            if len(calls) >= 25:
                break
        nl.close()
        return nl

    try:
        nl = asyncio.run(main())
    finally:
        stream.close()
        os.close(master)
    assert len(errors) == 1 and isinstance(errors[0], ValueError), errors
    assert nl.step_errors >= 19 and nl.steps >= 1, (nl.step_errors, nl.steps)


def test_the_wake_plan_follows_the_work():
    node, stream, master, _ = _node_on_pty(advert_period_ms=60000)
    try:
        # on the node's own times, far apart: the start-up advert has left
        # the driver whatever the machine's load (no waiting on the clock)
        t0 = node.clock()
        for k in range(6):
            now = node.step(t0 + 500 * k)
        assert next_wake_ms(node, [stream], now) == IDLE_MS
        node.send("serial", "*", b"queued", 30)
        assert next_wake_ms(node, [stream], now) == BUSY_MS  # a request waits in the queue
    finally:
        stream.close()
        os.close(master)
