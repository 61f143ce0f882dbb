# The Micro-Modem's rate-0 (FH-FSK) transmit cycle, byte for byte: after
# $CCCYC the modem sends the cycle header as a mini-packet of its own and
# reports it ($CATXP,0 / $CATXF,0) before it asks for data with $CADRQ; PSK
# rates go straight to $CADRQ. Host software written for the real modem
# (pyacomms' WaitingForCiTxf state) waits for that $CATXF and would never
# send $CCTXD without it. Also: $CAACK only when the sender asked
# for an acknowledgement. Emulator and driver, both runtimes.
from acomm.drivers import micromodem_wire as nm
from acomm.drivers.micromodem import MicroModemDriver
from acomm.events import EV_DRIVER_UP, EV_RX, EV_TX_DONE
from acomm_sim.medium import Medium
from acomm_sim.micromodem import MicroModemEmulator
from modemnet import run_emulators

CYC0 = nm.sentence("CCCYC", 0, 1, 2, 0, 0, 1)
CACYC0 = nm.sentence("CACYC", 0, 1, 2, 0, 0, 1)
TXP0 = nm.sentence("CATXP", 0)
TXF0 = nm.sentence("CATXF", 0)


def pair():
    m = Medium(default_distance=375.15)
    a = MicroModemEmulator(m, 1)
    b = MicroModemEmulator(m, 2)
    a.take_output()
    b.take_output()
    return a, b


def test_emulator_rate0_cycle_init_comes_before_the_data_request():
    a, b = pair()
    a.feed(0, CYC0)
    assert a.take_output() == CACYC0 + TXP0  # no $CADRQ yet
    out_a, out_b = run_emulators((a, b), 0, 690)
    assert out_a == b"" and out_b == b""
    out_a, _ = run_emulators((a, b), 700, 700)
    assert out_a == TXF0 + nm.sentence("CADRQ", "120000", 1, 2, 0, 32, 1)
    a.feed(710, nm.sentence("CCTXD", 1, 2, 0, "48656C6C6F"))
    assert a.take_output() == nm.sentence("CATXD", 1, 2, 0, 5) + nm.sentence("CATXP", 5)
    out_a, out_b = run_emulators((a, b), 710, 8000)
    # 800 ms gap + 5 bytes at 80 bit/s after the init; no ack was asked for
    assert out_a == nm.sentence("CATXF", 5)
    assert out_b == nm.sentence("CARXP", 0) + CACYC0 + nm.sentence("CARXD", 1, 2, 0, 1, "48656C6C6F")
    assert b"CAACK" not in out_a


def test_emulator_psk_rates_ask_for_data_at_once_and_ack_only_when_asked():
    a, b = pair()
    a.feed(0, nm.sentence("CCCYC", 0, 1, 2, 1, 0, 1))
    assert a.take_output() == nm.sentence("CACYC", 0, 1, 2, 1, 0, 1) + nm.sentence("CADRQ", "120000", 1, 2, 0, 64, 1)
    a.feed(10, nm.sentence("CCTXD", 1, 2, 0, "41"))
    a.take_output()
    out_a, out_b = run_emulators((a, b), 10, 6000)
    assert out_a == nm.sentence("CATXF", 1) and nm.sentence("CARXD", 1, 2, 0, 1, "41") in out_b


def test_emulator_restart_during_the_cycle_init_asks_for_nothing():
    a, b = pair()
    a.feed(0, CYC0)
    a.take_output()
    a.reboot(100)
    out_a, _ = run_emulators((a, b), 100, 3000)
    assert b"CADRQ" not in out_a and b"CATXF" not in out_a and b"INIT" in out_a


def up0():
    d = MicroModemDriver(1, rate=0)
    d.poll(0)
    assert d.take_output() == nm.sentence("CCCFG", "SRC", 1)
    d.feed(1, nm.sentence("CACFG", "SRC", 1))
    assert d.take_events() == [(EV_DRIVER_UP,)]
    return d


def test_driver_rate0_cycle_waits_through_the_cycle_init():
    d = up0()
    h = d.send(10, 2, b"Hello", False)
    assert d.take_output() == CYC0
    d.feed(20, CACYC0 + TXP0)
    assert d.take_output() == b"" and d.take_events() == [] and d.stats["stale"] == 0
    # the init takes its airtime; a $CADRQ after it is still for our cycle
    d.poll(20 + 700 + d.modem_wait_ms - 1)
    assert d.take_events() == []
    d.feed(730, TXF0 + nm.sentence("CADRQ", "120000", 1, 2, 0, 32, 1))
    assert d.take_output() == nm.sentence("CCTXD", 1, 2, 0, "48656C6C6F")
    d.feed(740, nm.sentence("CATXD", 1, 2, 0, 5) + nm.sentence("CATXP", 5))
    d.feed(1640, nm.sentence("CATXF", 5))
    assert d.take_events() == [(EV_TX_DONE, h)] and d.ready(1640) and d.stats["stale"] == 0


def test_driver_rate0_with_its_cacyc_lost():
    d = up0()
    h = d.send(10, 2, b"x", False)
    d.take_output()
    d.feed(20, TXP0 + TXF0)  # the $CACYC never reached us: no resend of $CCCYC
    d.poll(20 + d.modem_wait_ms)
    assert d.take_output() == b""
    d.feed(800, nm.sentence("CADRQ", "120000", 1, 2, 0, 32, 1))
    assert d.take_output() == nm.sentence("CCTXD", 1, 2, 0, "78")
    d.feed(900, nm.sentence("CATXD", 1, 2, 0, 1) + nm.sentence("CATXF", 1))
    assert d.take_events() == [(EV_TX_DONE, h)]


def test_driver_and_emulator_at_rate0():
    m = Medium(default_distance=200.0)
    a = MicroModemEmulator(m, 1)
    b = MicroModemEmulator(m, 2)
    da = MicroModemDriver(1, rate=0)
    db = MicroModemDriver(2, rate=0)
    got = []
    sent = []
    t = 0
    h = None
    while t < 20000:
        for emu, drv, evs in ((a, da, sent), (b, db, got)):
            emu.feed(t, drv.take_output())
            emu.poll(t)
            m.poll(t)
            drv.feed(t, emu.take_output())
            drv.poll(t)
            evs.extend(drv.take_events())
        if h is None and da.ready(t) and db.ready(t):
            h = da.send(t, 2, b"rate zero", False)
        t += 10
    assert (EV_TX_DONE, h) in sent and (EV_RX, 1, 2, b"rate zero") in got
    assert da.stats["errors"] == 0  # no $CAERR (DATA_TIMEOUT) on the way
