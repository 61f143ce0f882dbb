# The Micro-Modem driver against emulated modems over real pseudo-terminals
# opened with pyserial, on real time: each Node's link drives its modem
# through one end of a PtyPair, and the emulator answers on the other end,
# as a modem on a serial port would. CPython only (the harness, and the skip
# where pyserial or ptys are missing, are ptynet's).
#
# The acoustic timing is scaled down to a tenth (air_scale) and the driver's
# waits shortened so the test is quick; driver and emulator share the
# figures. Every wait is bounded; no timing is asserted, only outcomes.

import ptynet  # first: it skips this module where pyserial or ptys are missing
import pytest
from ptynet import all_ready, run

from acomm.compat import ticks_ms
from acomm.drivers.micromodem import MicroModemDriver
from acomm.events import DELIVERED, TRANSMITTED
from acomm.link import BROADCAST
from acomm_sim.micromodem import MicroModemEmulator

BAUD = 19200  # the modem's default
SHARED = {"air_scale": 0.1, "max_range_m": 300}
DRIVER = dict(SHARED, modem_wait_ms=1000, margin_ms=500, reboot_wait_ms=200, retry_ms=500)
EMULATOR = dict(SHARED, data_timeout_ms=1000)


@pytest.fixture
def pair():
    # node ids are the modem addresses
    yield from ptynet.pair(MicroModemDriver, MicroModemEmulator, DRIVER, EMULATOR, baud=BAUD)


def test_unicast_broadcast_and_ping_over_ptys(pair):
    a, b = pair
    assert run(pair, all_ready(pair))
    rid = a.node.send("acoustic", "diver", b"hello over a pty", 30, 2, ack=True)
    assert run(pair, lambda: a.final(rid) is not None)
    assert a.final(rid) == DELIVERED
    assert b.received() == [("buoy", "diver", b"hello over a pty")]
    rid = b.node.send("acoustic", BROADCAST, b"to everyone", 30, 2)
    assert run(pair, lambda: b.final(rid) is not None and a.received())
    assert b.final(rid) == TRANSMITTED
    assert a.received() == [("diver", BROADCAST, b"to everyone")]
    assert a.link.range(ticks_ms(), 500, ["diver"], 30)
    assert run(pair, lambda: a.final(500) is not None)
    r = a.last_range()
    assert r[3] == ["diver"] and abs(r[4][0] - 120.0) < 1.0
    assert a.final(500) == DELIVERED
    # the host side really spoke the protocol: no damaged lines either way
    assert a.driver.junk == {} and a.emu.ignored == 0 and b.emu.sentences.get("CCMUC") == 1
