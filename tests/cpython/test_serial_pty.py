# The first real link: two Nodes talk over the transparent serial driver
# through real pseudo-terminals opened with pyserial, on real time with
# asyncio (the node clock is acomm.compat.ticks_ms), each node stepped by
# acomm_cpython.ioloop when its pty has bytes and at its deadlines. CPython only.
#
# Every wait is bounded; no timing is asserted, only outcomes.

import os
import sys
import threading
import time

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux") and sys.platform != "darwin":
    pytest.skip("needs POSIX pseudo-terminals", allow_module_level=True)

from acomm.drivers.transparent import TransparentDriver  # noqa: E402
from acomm.events import (  # noqa: E402
    AVAILABLE,
    DELIVERED,
    EV_AVAILABILITY,
    EV_RECEIVED,
    EV_STATUS,
    TRANSMITTED,
    is_final,
)
from acomm.link import BROADCAST  # noqa: E402
from acomm.node import Node  # noqa: E402
from acomm_cpython.ioloop import run  # noqa: E402
from acomm_cpython.emulate.pty import PtyPair  # noqa: E402
from acomm_cpython.streams import open_serial  # noqa: E402

BAUD = 115200
TIMEOUT_S = 5


class End:
    # One node with its event log (the listener keeps every event).
    def __init__(self, name, node_id, stream, advert_period_ms):
        self.events = []
        self.stream = stream
        self.node = Node(name, node_id, listener=self.events.append)
        # a generous ack timeout: a loaded test machine must not cause retries
        self.link = self.node.add_link(
            "ser", TransparentDriver(BAUD), stream, advert_period_ms=advert_period_ms, ack_timeout_ms=2000
        )

    def final(self, rid):
        for ev in self.events:
            if ev[0] == EV_STATUS and ev[2] == rid and is_final(ev[3]):
                return ev[3]
        return None

    def received(self):
        return [(ev[2], ev[3], ev[4]) for ev in self.events if ev[0] == EV_RECEIVED]

    def available(self):
        return [ev[2] for ev in self.events if ev[0] == EV_AVAILABILITY and ev[3] == AVAILABLE]


def _open_fds():
    return len(os.listdir("/proc/self/fd")) if os.path.isdir("/proc/self/fd") else None


@pytest.fixture
def pair(request):
    # (buoy, diver, ptys); the advert period can be set with
    # @pytest.mark.parametrize("pair", [ms], indirect=True).
    period = getattr(request, "param", 60000)
    ptys = PtyPair()
    sa = open_serial(ptys.path_a, BAUD)
    sb = open_serial(ptys.path_b, BAUD)
    a = End("buoy", 1, sa, period)
    b = End("diver", 2, sb, period)
    a.node.names.add("diver", 2)
    b.node.names.add("buoy", 1)
    yield a, b, ptys
    sa.close()
    sb.close()
    ptys.close()
    assert not ptys.running


def _run(a, b, until):
    return run([(a.node, [a.stream]), (b.node, [b.stream])], TIMEOUT_S, until)


def test_pty_pair_is_a_cable():
    fds = _open_fds()
    threads = threading.active_count()
    with PtyPair() as p:
        a = open_serial(p.path_a, 9600)
        b = open_serial(p.path_b, 9600)
        assert a.read(10) == b""
        # every byte value passes unchanged: raw mode, no flow control
        blob = bytes(range(256)) + b"\r\n\n\r"
        a.write(blob)
        b.write(b"back")
        got_b = bytearray()
        got_a = bytearray()
        t0 = time.monotonic()
        while (len(got_b) < len(blob) or len(got_a) < 4) and time.monotonic() - t0 < TIMEOUT_S:
            got_b += b.read(64)
            got_a += a.read(64)
            time.sleep(0.002)
        assert bytes(got_b) == blob
        assert bytes(got_a) == b"back"
        p.inject(0, b"noise")
        t0 = time.monotonic()
        got_a = bytearray()
        while len(got_a) < 5 and time.monotonic() - t0 < TIMEOUT_S:
            got_a += a.read(64)
            time.sleep(0.002)
        assert bytes(got_a) == b"noise"
        assert b.read(64) == b""
        a.close()
        b.close()
    assert not p.running
    assert threading.active_count() == threads
    if fds is not None:
        assert _open_fds() == fds


def test_pty_pair_backpressure_and_symlinks(tmp_path):
    # More than the kernel buffers hold, written while the other end reads:
    # the relay must neither lose bytes nor deadlock.
    la, lb = str(tmp_path / "buoy"), str(tmp_path / "diver")
    with PtyPair(links=(la, lb)) as p:
        assert p.path_a == la and os.readlink(la).startswith("/dev/")
        a = open_serial(la, 9600)
        b = open_serial(lb, 9600)
        blob = os.urandom(100000)
        w = threading.Thread(target=a.write, args=(blob,))
        w.start()
        got = bytearray()
        t0 = time.monotonic()
        while len(got) < len(blob) and time.monotonic() - t0 < TIMEOUT_S:
            got += b.read(4096)
            time.sleep(0.001)
        w.join(TIMEOUT_S)
        assert bytes(got) == blob
        a.close()
        b.close()
    assert not os.path.lexists(la) and not os.path.lexists(lb)


def test_unicast_with_ack_is_delivered_once(pair):
    a, b, _ = pair
    rid = a.node.send("ser", "diver", b"hello diver", 30, 2, ack=True)
    assert _run(a, b, lambda: a.final(rid) is not None and b.received())
    assert a.final(rid) == DELIVERED
    # run on a little: a second delivery (of a retry, say) would show up now
    run([(a.node, [a.stream]), (b.node, [b.stream])], 0.3)
    assert b.received() == [("buoy", "diver", b"hello diver")]


def test_broadcast_is_transmitted_and_received(pair):
    a, b, _ = pair
    rid = b.node.send("ser", BROADCAST, b"all stop", 30, 1)
    assert _run(a, b, lambda: b.final(rid) is not None and a.received())
    assert b.final(rid) == TRANSMITTED
    assert a.received() == [("diver", BROADCAST, b"all stop")]


def test_noise_between_frames_is_dropped_and_counted(pair):
    a, b, ptys = pair
    rid = a.node.send("ser", "diver", b"one", 30, 2, ack=True)
    assert _run(a, b, lambda: a.final(rid) is not None)
    assert a.final(rid) == DELIVERED
    bad0 = b.link.stats["rx_bad"]
    # a complete burst of garbage between SLIP delimiters, then garbage with
    # no delimiter that the next frame's leading END must flush
    ptys.inject(1, b"\xc0line noise \x00\xff\x7e\x01\xc0")
    ptys.inject(1, b"\x55\xaa\x55\xaa more noise")
    assert _run(a, b, lambda: b.link.stats["rx_bad"] > bad0)
    rid2 = a.node.send("ser", "diver", b"two", 30, 2, ack=True)
    assert _run(a, b, lambda: a.final(rid2) is not None and len(b.received()) == 2)
    assert a.final(rid2) == DELIVERED
    assert b.link.stats["rx_bad"] >= bad0 + 2
    assert [r[2] for r in b.received()] == [b"one", b"two"]
    # and the other direction still works
    rid3 = b.node.send("ser", "buoy", b"three", 30, 2, ack=True)
    assert _run(a, b, lambda: b.final(rid3) is not None)
    assert b.final(rid3) == DELIVERED
    assert a.received() == [("diver", "buoy", b"three")]


@pytest.mark.parametrize("pair", [300], indirect=True)
def test_nodes_discover_each_other(pair):
    a, b, _ = pair
    assert _run(a, b, lambda: a.available() and b.available())
    assert a.available() == ["diver"]
    assert b.available() == ["buoy"]
    assert a.link.availability("diver") == AVAILABLE
    assert b.link.availability("buoy") == AVAILABLE
    # adverts keep coming every 300 ms while the nodes have nothing to send
    sent = a.link.stats["adverts_sent"]
    assert _run(a, b, lambda: a.link.stats["adverts_sent"] >= sent + 2)
    assert a.link.availability("diver") == AVAILABLE
