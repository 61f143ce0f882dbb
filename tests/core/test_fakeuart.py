# FakeUART tests (acomm_sim.fakeuart). Plain functions with bare asserts: they run
# under pytest on CPython and under tools/mp_runtests.py on MicroPython.
# Time is a ManualClock: nothing here depends on the wall clock.

from acomm_sim.clock import ManualClock
from acomm.compat import TICKS_MAX
from acomm_sim.fakeuart import FakeUART, uart_pair


def _bits_differing(a, b):
    n = 0
    for x, y in zip(a, b):
        d = x ^ y
        while d:
            n += d & 1
            d >>= 1
    return n


def test_pair_read_semantics():
    a, b = uart_pair()
    assert a.peer is b and b.peer is a
    assert a.clock is b.clock
    assert b.read() is None
    assert b.read(4) is None
    assert b.any() == 0
    assert a.write(b"hello") == 5
    assert a.written == 5
    assert b.any() == 5
    assert a.any() == 0  # nothing echoes back
    assert b.read(2) == b"he"
    assert b.any() == 3
    assert b.read(10) == b"llo"  # more than waiting: what there is
    assert b.read() is None
    assert a.write(bytearray(b"xy")) == 2
    assert a.write(memoryview(b"z")) == 1
    assert a.write(b"") == 0
    assert b.read() == b"xyz"
    # the other direction is independent
    b.write(b"back")
    assert a.read() == b"back"
    assert b.read() is None


def test_readinto_with_and_without_nbytes():
    a, b = uart_pair()
    buf = bytearray(4)
    assert b.readinto(buf) is None
    assert b.readinto(buf, 2) is None
    a.write(b"abcdefg")
    assert b.readinto(buf, 2) == 2
    assert buf == bytearray(b"ab\x00\x00")
    assert b.readinto(buf) == 4
    assert buf == bytearray(b"cdef")
    assert b.readinto(buf, 10) == 1  # nbytes larger than what is waiting
    assert buf == bytearray(b"gdef")
    assert b.readinto(buf) is None
    a.write(b"123456")
    assert b.readinto(buf, 10) == 4  # nbytes larger than the buffer
    assert buf == bytearray(b"1234")
    mv = memoryview(bytearray(8))
    assert b.readinto(mv[3:]) == 2
    assert bytes(mv) == b"\x00\x00\x0056\x00\x00\x00"
    assert b.any() == 0


def test_fault_drop():
    a, b = uart_pair()
    a.set_faults(drop=1.0)
    assert a.write(b"gone") == 4  # the sender cannot tell
    assert a.dropped == 1
    assert b.any() == 0 and b.read() is None and b.in_flight() == 0
    # half the writes: every write either arrives whole or not at all
    a.set_faults(drop=0.5, seed=3)
    arrived = 0
    for i in range(200):
        a.write(bytes([i, i]))
        got = b.read()
        if got is not None:
            assert got == bytes([i, i])
            arrived += 1
    assert a.dropped == 1 + (200 - arrived)
    assert 0 < arrived < 200
    a.set_faults()
    a.write(b"ok")
    assert b.read() == b"ok"


def test_fault_flip_exactly_one_bit():
    a, b = uart_pair()
    a.set_faults(flip=1.0, seed=9)
    positions = {}
    for i in range(100):
        msg = bytes([0x55, 0xAA, i, 0, 0xFF])
        a.write(msg)
        got = b.read()
        assert len(got) == len(msg)
        assert _bits_differing(got, msg) == 1
        for k in range(len(msg)):
            if got[k] != msg[k]:
                positions[k] = 1
    assert a.flipped == 100
    assert len(positions) > 1  # not always the same byte
    a.set_faults()
    a.write(b"clean")
    assert b.read() == b"clean"
    assert a.flipped == 100


def test_fault_split_into_chunks_1ms_apart():
    clock = ManualClock(1000)
    a, b = uart_pair(clock=clock)
    a.set_faults(split=3, seed=5)
    msg = b"0123456789abcdefghij"
    a.write(msg)
    seen = []
    got = b""
    steps = 0
    while len(got) < len(msg):
        chunk = b.read()
        assert chunk is not None  # one chunk arrives every millisecond
        assert 1 <= len(chunk) <= 3
        seen.append(len(chunk))
        got += chunk
        clock.advance(1)
        steps += 1
        assert steps <= len(msg)
    assert got == msg  # in order, nothing lost
    assert sum(seen) == len(msg)
    assert len(seen) >= len(msg) // 3
    assert b.in_flight() == 0
    # nothing more arrives later
    clock.advance(100)
    assert b.read() is None


def test_fault_split_chunks_not_read_accumulate():
    clock = ManualClock()
    a, b = uart_pair(clock=clock)
    a.set_faults(split=1)
    a.write(b"abcd")
    assert b.any() == 1
    assert b.in_flight() == 3
    clock.advance(2)
    assert b.any() == 3
    clock.advance(1)
    assert b.read() == b"abcd"


def test_fault_delay_ms():
    clock = ManualClock()
    a, b = uart_pair(clock=clock)
    a.set_faults(delay_ms=50)
    a.write(b"late")
    assert b.any() == 0 and b.read() is None
    assert b.in_flight() == 4
    clock.advance(49)
    assert b.read() is None
    clock.advance(1)
    assert b.any() == 4
    assert b.in_flight() == 0
    assert b.read() == b"late"
    # a later write never overtakes an earlier one
    a.write(b"first")
    a.set_faults(delay_ms=10)
    a.write(b"second")
    clock.advance(10)
    assert b.read() is None
    clock.advance(40)
    assert b.read() == b"firstsecond"


def test_delay_across_ticks_wrap():
    clock = ManualClock(TICKS_MAX - 10)
    a, b = uart_pair(clock=clock)
    a.set_faults(delay_ms=30)
    a.write(b"wrap")
    clock.advance(29)
    assert clock() < 100  # the clock wrapped
    assert b.read() is None
    clock.advance(1)
    assert b.read() == b"wrap"


def test_inject_noise():
    a, b = uart_pair()
    b.inject(b"\x00\xff~")
    assert b.any() == 3
    a.write(b"data")
    assert b.read() == b"\x00\xff~data"
    b.inject(bytearray(b"\x13"))
    assert b.read() == b"\x13"
    assert a.read() is None  # noise on b's side only


def test_rx_buffer_overrun_counted():
    a, b = uart_pair(rxbuf=8)
    a.write(b"0123456789")
    assert b.any() == 8
    assert b.overruns == 2
    assert b.read() == b"01234567"
    a.write(b"abc")
    a.write(b"defgh")
    a.write(b"ij")
    assert b.overruns == 4
    assert b.read(3) == b"abc"
    a.write(b"XYZ")  # room for 3 again
    assert b.overruns == 4
    assert b.read() == b"defghXYZ"
    b.inject(b"n" * 9)
    assert b.overruns == 5
    assert b.read() == b"n" * 8


def test_overrun_with_split_chunks():
    clock = ManualClock()
    a, b = uart_pair(rxbuf=4, clock=clock)
    a.set_faults(split=2, seed=2)
    a.write(b"abcdefgh")
    clock.advance(10)
    assert b.any() == 4
    assert b.overruns == 4
    assert b.read() == b"abcd"


def test_single_fakeuart_defaults():
    u = FakeUART()
    assert u.peer is None
    assert u.any() == 0 and u.read() is None
    assert u.written == 0 and u.dropped == 0 and u.flipped == 0 and u.overruns == 0
    u.inject(b"x")
    assert u.read() == b"x"
