# The EvoLogics driver against emulated S2C modems over real pseudo-terminals
# opened with pyserial, on real time: each Node's link drives its modem
# through one end of a PtyPair, and the emulator answers on the other end,
# as a modem on a serial line would. CPython only (the harness, and the skip
# where pyserial or ptys are missing, are ptynet's).
#
# The acoustic timing is scaled down (short packets, fast rates, a short
# range limit) so the test is quick; driver and emulator are given the same
# figures. Every wait is bounded; no timing is asserted, only outcomes.

import ptynet  # first: it skips this module where pyserial or ptys are missing
import pytest
from ptynet import all_ready, run

from acomm.compat import ticks_ms
from acomm.drivers.evologics import EvologicsDriver
from acomm.events import DELIVERED, TRANSMITTED
from acomm.link import BROADCAST
from acomm_sim.evologics import EvologicsEmulator

FAST = {"packet_ms": 30, "im_bitrate": 9600, "burst_bitrate": 40000, "turnaround_ms": 20, "max_range_m": 300}


@pytest.fixture
def pair():
    yield from ptynet.pair(EvologicsDriver, EvologicsEmulator, dict(FAST, margin_ms=1000, cmd_timeout_ms=2000), FAST)


def test_unicast_broadcast_and_ranging_over_ptys(pair):
    a, b = pair
    assert run(pair, all_ready(pair))
    rid = a.node.send("acoustic", "diver", b"hello over a pty", 30, 2, ack=True)
    assert run(pair, lambda: a.final(rid) is not None)
    assert a.final(rid) == DELIVERED
    assert b.received() == [("buoy", "diver", b"hello over a pty")]
    # burst data, with CR LF inside the payload
    big = b"\r\n".join([b"line %d" % i for i in range(40)])
    rid = a.node.send("acoustic", "diver", big, 30, 2, ack=True)
    assert run(pair, lambda: a.final(rid) is not None)
    assert a.final(rid) == DELIVERED and b.received()[-1] == ("buoy", "diver", big)
    rid = b.node.send("acoustic", BROADCAST, b"all surface", 30, 2)
    assert run(pair, lambda: b.final(rid) is not None and a.received())
    assert b.final(rid) == TRANSMITTED and a.received() == [("diver", BROADCAST, b"all surface")]
    assert a.link.range(ticks_ms(), 500, ["diver"], 30)
    assert run(pair, lambda: a.final(500) is not None)
    r = a.last_range()
    assert r[3] == ["diver"] and r[4] == [120.0]
    assert a.final(500) == DELIVERED
    # the host side really spoke the protocol: no damaged lines either way
    for m in (a, b):
        assert m.driver.junk == {} and m.emu.ignored == 0 and m.driver.stats["unknown"] == 0
