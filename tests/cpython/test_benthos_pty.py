# The Benthos driver against emulated ATM-9xx modems over real pseudo-terminals
# opened with pyserial, on real time: each Node's link drives its modem
# through one end of a PtyPair, and the emulator answers on the other end, as
# a modem on a serial port would. CPython only.
#
# The timing is scaled down so the test takes a few seconds: 100 ms packet
# overhead (driver and emulator share it), a 100 ms escape guard time on the
# modem and 150 ms in the driver, the shortest @AcRspTmOut (2 s). Every wait
# is bounded; no timing is asserted, only outcomes.

import sys
import time

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm.compat import ticks_ms  # noqa: E402
from acomm.drivers.benthos import BenthosDriver  # noqa: E402
from acomm.events import DELIVERED, EV_RANGE_RECEIVED, EV_RECEIVED, EV_STATUS, TRANSMITTED, is_final  # noqa: E402
from acomm.link import BROADCAST  # noqa: E402
from acomm.node import Node  # noqa: E402
from acomm_cpython.streams import PtyPair, open_serial  # noqa: E402
from acomm_sim.benthos import BenthosEmulator  # noqa: E402
from acomm_sim.medium import Medium  # noqa: E402

BAUD = 115200
TIMEOUT_S = 10
FAST_DRIVER = {"packet_ms": 100, "guard_ms": 150, "cmd_timeout_ms": 1000, "prompt_timeout_ms": 1000, "ac_rsp_tmo_ms": 2000}
FAST_MODEM = {"packet_ms": 100, "guard_ms": 100, "turnaround_ms": 50, "boot_ms": 200}


class Modem:
    # One node, its pty pair, and the emulated modem on the far end.
    def __init__(self, medium, name, node_id, peers):
        self.events = []
        self.ptys = PtyPair()
        self.host = open_serial(self.ptys.path_a, BAUD)
        self.port = open_serial(self.ptys.path_b, BAUD)  # the modem's side
        self.emu = BenthosEmulator(medium, node_id, now=ticks_ms(), **FAST_MODEM)
        self.node = Node(name, node_id, listener=self.events.append)
        for other, oid in peers:
            self.node.names.add(other, oid)
        self.driver = BenthosDriver(node_id, **FAST_DRIVER)
        self.link = self.node.add_link("acoustic", self.driver, self.host, advert_period_ms=600000)

    def step(self):
        self.node.step()
        now = ticks_ms()
        data = self.port.read(4096)
        if data:
            self.emu.feed(now, data)
        self.emu.poll(now)
        out = self.emu.take_output()
        if out:
            self.port.write(out)

    def final(self, rid):
        for ev in self.events:
            if ev[0] == EV_STATUS and ev[2] == rid and is_final(ev[3]):
                return ev[3]
        return None

    def received(self):
        return [(e[2], e[3], e[4]) for e in self.events if e[0] == EV_RECEIVED]

    def close(self):
        self.host.close()
        self.port.close()
        self.ptys.close()


@pytest.fixture
def pair():
    medium = Medium(default_distance=120.0)
    peers = (("buoy", 1), ("diver", 2))
    a = Modem(medium, "buoy", 1, peers)
    b = Modem(medium, "diver", 2, peers)
    yield a, b
    a.close()
    b.close()
    assert not a.ptys.running and not b.ptys.running


def run(ends, until):
    t0 = time.monotonic()
    while time.monotonic() - t0 < TIMEOUT_S:
        for e in ends:
            e.step()
        if until():
            return True
        time.sleep(0.002)
    return False


def test_unicast_broadcast_and_range_over_ptys(pair):
    a, b = pair
    assert run(pair, lambda: a.driver.ready(ticks_ms()) and b.driver.ready(ticks_ms()))
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
    r = [e for e in a.events if e[0] == EV_RANGE_RECEIVED][-1]
    assert r[3] == ["diver"] and r[4] == [120.0]
    assert a.final(500) == DELIVERED
    # the host side really spoke the dialogue: nothing damaged, nothing
    # unanswered, and the modem never ran an unknown command
    for m in (a, b):
        assert m.driver.junk == {} and m.driver.stats["cmd_timeouts"] == 0
        assert m.emu.ignored == 0 and "+++" not in m.emu.commands
