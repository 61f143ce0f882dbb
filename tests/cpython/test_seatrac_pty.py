# The SeaTrac driver against emulated beacons over real pseudo-terminals
# opened with pyserial, on real time: each Node's link drives its beacon
# through one end of a PtyPair, and the emulator answers on the other end,
# exactly as a beacon behind a USB-serial adapter would. CPython only (the
# harness, and the skip where pyserial or ptys are missing, are ptynet's).
#
# The acoustic timing is scaled down (100 ms packets) so the test is quick;
# driver and emulator are given the same figures. Every wait is bounded; no
# timing is asserted, only outcomes.

import ptynet  # first: it skips this module where pyserial or ptys are missing
import pytest
from ptynet import all_ready, run

from acomm.compat import ticks_ms
from acomm.drivers.seatrac import SeatracDriver
from acomm.events import DELIVERED
from acomm_sim.seatrac import SeatracEmulator

FAST = {"packet_ms": 100, "byte_ms": 8, "turnaround_ms": 50}


@pytest.fixture
def pair():
    yield from ptynet.pair(SeatracDriver, SeatracEmulator, dict(FAST, margin_ms=1000), FAST)


def test_unicast_with_ack_and_ping_over_ptys(pair):
    a, b = pair
    assert run(pair, lambda: all_ready(pair)() and a.driver.caps.model == "X150")
    rid = a.node.send("acoustic", "diver", b"hello over a pty", 30, 2, ack=True)
    assert run(pair, lambda: a.final(rid) is not None)
    assert a.final(rid) == DELIVERED
    assert b.received() == [("buoy", "diver", b"hello over a pty")]
    assert a.link.range(ticks_ms(), 500, ["diver"], 30)
    assert run(pair, lambda: a.final(500) is not None)
    r = a.last_range()
    assert r[3] == ["diver"] and r[4] == [120.0]
    assert a.final(500) == DELIVERED
    # the host side really spoke the protocol: no damaged lines either way
    assert a.driver.junk == {} and a.emu.ignored == 0
