# Shared harness for the modem driver tests over real pseudo-terminals
# (CPython only): each Node's link drives its modem through one end of a
# PtyPair opened with pyserial, and the modem's emulator answers on the other
# end, as a modem behind a USB-serial adapter would, on real time. Every wait
# is bounded. Importing this skips the importing test module where pyserial
# or POSIX pseudo-terminals are missing, so import it before the drivers.
#
# pytest puts this directory on sys.path (rootdir-relative "prepend" import
# mode, as there is no __init__.py here), so the test files import it by name.

import sys
import time

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm.compat import ticks_ms  # noqa: E402
from acomm.events import EV_RANGE_RECEIVED, EV_RECEIVED, EV_STATUS, is_final  # noqa: E402
from acomm.node import Node  # noqa: E402
from acomm_cpython.emulate.pty import PtyPair  # noqa: E402
from acomm_cpython.streams import open_serial  # noqa: E402
from acomm_sim.medium import Medium  # noqa: E402

# a bound, not a timing: on a loaded 2-core machine (two emulated boards
# beside pytest) a 10 s bound once ran out before the first acknowledged send
TIMEOUT_S = 30
PEERS = (("buoy", 1), ("diver", 2))


class Modem:
    # One node, its pty pair, and the emulated modem on the far end:
    # driver(addr, **drv_opts), emulator(medium, addr, now=..., **emu_opts).
    def __init__(self, medium, name, node_id, addr, driver, emulator, drv_opts=None, emu_opts=None, baud=115200, peers=PEERS):
        self.events = []
        self.ptys = PtyPair()
        self.host = open_serial(self.ptys.path_a, baud)
        self.port = open_serial(self.ptys.path_b, baud)  # the modem's side
        self.emu = emulator(medium, addr, now=ticks_ms(), **(emu_opts or {}))
        self.node = Node(name, node_id, listener=self.events.append)
        for other, oid in peers:
            self.node.names.add(other, oid)
        self.driver = driver(addr, **(drv_opts or {}))
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

    def last_range(self):
        return [e for e in self.events if e[0] == EV_RANGE_RECEIVED][-1]

    def close(self):
        self.host.close()
        self.port.close()
        self.ptys.close()


def pair(driver, emulator, drv_opts=None, emu_opts=None, baud=115200, distance=120.0):
    # For a fixture to yield from: the buoy (node 1, modem 1) and the diver
    # (node 2, modem 2) on one medium; closed afterwards, pty threads ended.
    medium = Medium(default_distance=distance)
    a = Modem(medium, "buoy", 1, 1, driver, emulator, drv_opts, emu_opts, baud)
    b = Modem(medium, "diver", 2, 2, driver, emulator, drv_opts, emu_opts, baud)
    try:
        yield a, b
    finally:
        a.close()
        b.close()
    assert not a.ptys.running and not b.ptys.running


def run(ends, until):
    # Steps every end until until() holds (True) or TIMEOUT_S passes (False).
    t0 = time.monotonic()
    while time.monotonic() - t0 < TIMEOUT_S:
        for e in ends:
            e.step()
        if until():
            return True
        time.sleep(0.002)
    return False


def all_ready(ends):
    return lambda: all(e.driver.ready(ticks_ms()) for e in ends)
