# EvoLogics S2C with extended notifications (AT@ZX1): a reception is
# announced as the firmware does it, RECVSTART when it begins, RECVEND with
# its figures, then the RECVIM line (ref/modem-protocols.md 2.3; evins
# role_at.erl). Emulator byte for byte, and the driver takes the lifecycle
# lines as known and quiet. Both runtimes.
from acomm.drivers.evologics import EvologicsDriver
from acomm.events import EV_RX
from acomm_sim.evologics import EvologicsEmulator
from acomm_sim.medium import Medium
from modemnet import run_emulators


def test_reception_with_extended_notifications():
    m = Medium(default_distance=100.0)
    a = EvologicsEmulator(m, 1)
    b = EvologicsEmulator(m, 2)
    b.feed(0, b"AT@ZX1\n")
    assert b.take_output() == b"OK\r\n"
    a.feed(0, b"AT*SENDIM,5,2,noack,hello\n")
    assert a.take_output() == b"OK\r\n"  # a has no @ZX1: no SENDSTART
    _, out_b = run_emulators((a, b), 0, 1000)
    lines = out_b.split(b"\r\n")
    assert lines[0] == b"RECVSTART"
    assert lines[1].startswith(b"RECVEND,") and len(lines[1].split(b",")) == 5
    assert lines[2] == b"RECVIM,5,1,2,noack,191000,-45,198,0.00,hello" and lines[3:] == [b""]
    # the driver reads the three lines as one reception and nothing odd
    d = EvologicsDriver(2)
    d.feed(1000, out_b)
    assert [e for e in d.take_events() if e[0] == EV_RX] == [(EV_RX, 1, 2, b"hello")]
    assert d.stats.get("unexpected", 0) == 0 and not d.junk
