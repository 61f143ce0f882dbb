# The Benthos driver against emulated ATM-9xx modems over real pseudo-terminals
# opened with pyserial, on real time: each Node's link drives its modem
# through one end of a PtyPair, and the emulator answers on the other end, as
# a modem on a serial port would. CPython only (the harness, and the skip
# where pyserial or ptys are missing, are ptynet's).
#
# The timing is scaled down so the test takes a few seconds: 100 ms packet
# overhead (driver and emulator share it), a 100 ms escape guard time on the
# modem and 150 ms in the driver, the shortest @AcRspTmOut (2 s). Every wait
# is bounded; no timing is asserted, only outcomes.

import ptynet  # first: it skips this module where pyserial or ptys are missing
import pytest
from ptynet import all_ready, run

from acomm.compat import ticks_ms
from acomm.drivers.benthos import BenthosDriver
from acomm.events import DELIVERED, TRANSMITTED
from acomm.link import BROADCAST
from acomm_sim.benthos import BenthosEmulator

FAST_DRIVER = {"packet_ms": 100, "guard_ms": 150, "cmd_timeout_ms": 1000, "prompt_timeout_ms": 1000, "ac_rsp_tmo_ms": 2000}
FAST_MODEM = {"packet_ms": 100, "guard_ms": 100, "turnaround_ms": 50, "boot_ms": 200}


@pytest.fixture
def pair():
    yield from ptynet.pair(BenthosDriver, BenthosEmulator, FAST_DRIVER, FAST_MODEM)


def test_unicast_broadcast_and_range_over_ptys(pair):
    a, b = pair
    assert run(pair, all_ready(pair))
    # acknowledged by the diver's link: the modem itself reports no delivery
    rid = a.node.send("acoustic", "diver", b"hello over a pty", 30, 2, ack=True)
    assert run(pair, lambda: a.final(rid) is not None)
    assert a.final(rid) == DELIVERED
    assert b.received() == [("buoy", "diver", b"hello over a pty")]
    rid = b.node.send("acoustic", BROADCAST, b"all surface", 30, 2)
    assert run(pair, lambda: b.final(rid) is not None and a.received())
    assert b.final(rid) == TRANSMITTED and a.received() == [("diver", BROADCAST, b"all surface")]
    assert a.link.range(ticks_ms(), 500, ["diver"], 30)
    assert run(pair, lambda: a.final(500) is not None)
    r = a.last_range()
    assert r[3] == ["diver"] and r[4] == [120.0]
    assert a.final(500) == DELIVERED
    # the host side really spoke the dialogue: nothing damaged, nothing
    # unanswered, and the modem never ran an unknown command
    for m in (a, b):
        assert m.driver.junk == {} and m.driver.stats["cmd_timeouts"] == 0
        assert m.emu.ignored == 0 and "+++" not in m.emu.commands
