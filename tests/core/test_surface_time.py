# Time from the sky (issue 37 point 2): the Iridium driver's AT-MSSTM and
# the SMS driver's AT+CCLK? byte for byte, the emulators' answers as the
# real units give them, a board's GPS on its own UART, and a node whose
# wall clock an emulated Iridium modem sets, end to end.
from acomm.drivers import iridium_wire as iw
from acomm.drivers import sms_wire as sw
from acomm.drivers.iridium import IridiumDriver
from acomm.drivers.sms import SmsDriver
from acomm.errors import DecodeError
from acomm.events import EV_DRIVER_UP, EV_TIME
from acomm.node import Node
from acomm.transport import Transport
from acomm.civil import days2020
from acomm.wallclock import MIN_S, WallClock
from acomm_mp.assemble import build
from acomm_mp.boardconfig import ConfigError, check
from acomm_sim.clock import ManualClock
from acomm_sim.fakeuart import uart_pair
from acomm_sim.gsm import GsmEmulator
from acomm_sim.gsm_net import GsmNetwork
from acomm_sim.gsm_general import cclk_text, civil
from acomm_sim.iridium import IridiumEmulator
from acomm_sim.iridium_net import IridiumNetwork
from checks import raises
from surfacenet import Fed

ERA3 = 161720057  # 2025-02-14 18:14:17 UTC from 2020-01-01
ERA2 = -178018565  # 2014-05-11 14:23:55 UTC
# 2026-11-27 22:10:05 UTC
T = days2020(2026, 11, 27) * 86400 + 22 * 3600 + 10 * 60 + 5
NUMBERS = {5: "+447700900123"}


def msstm_of(secs, ms=0, epoch=ERA3):
    # the count a unit shows at that time, in its hex
    return b"%x" % ((((secs - epoch) * 1000 + ms) // 90) & 0xFFFFFFFF)


# -- the wire ----------------------------------------------------------------------------
def test_msstm_counts_90_ms_frames_from_the_era():
    assert iw.parse_msstm(b"-MSSTM: 0") == (ERA3, 0)
    assert iw.parse_msstm(b"-MSSTM: 1") == (ERA3, 90)
    assert iw.parse_msstm(b"-MSSTM: 10000") == (ERA3 + 5898, 240)  # 65536 frames
    assert iw.parse_msstm(b"-MSSTM: " + msstm_of(T)) == (T, 0)
    assert msstm_of(T) == b"25428810"  # docs/drivers-iridium.md's example
    # the documentation's example count, in era 2 (lower case, as printed)
    n = int("d1c6dd38", 16) * 90
    assert iw.parse_msstm(b"-MSSTM: d1c6dd38", ERA2) == (ERA2 + n // 1000, n % 1000)
    assert iw.parse_msstm(b"-MSSTM: D1C6DD38", ERA2) == iw.parse_msstm(b"-MSSTM: d1c6dd38", ERA2)
    assert iw.parse_msstm(b"-MSSTM: no network service") is None
    for bad in (b"-MSSTM: ", b"-MSSTM: 1g", b"-MSSTM: 123456789", b"+CSQ:5"):
        raises(DecodeError, iw.parse_msstm, bad)


def test_cclk_is_local_time_in_quarter_hours_and_a_power_up_date_is_no_time():
    assert sw.parse_cclk(b'+CCLK: "26/11/27,22:10:05+00"') == (T, 0)
    assert sw.parse_cclk(b'+CCLK: "26/11/27,23:10:05+04"') == (T, 0)  # UTC+1 h
    assert sw.parse_cclk(b'+CCLK: "26/11/27,17:10:05-20"') == (T, 0)  # UTC-5 h
    assert sw.parse_cclk(b'+CCLK: "26/11/27,22:10:05"') == (T, 0)  # no zone: UTC
    assert sw.parse_cclk(b'+CCLK: "26/11/27, 22:10:05+00"') == (T, 0)  # a space, as some print
    for never_set in (b'+CCLK: "80/01/06,00:01:02+00"', b'+CCLK: "00/01/01,00:00:10+00"',
                      b'+CCLK: "04/01/01,12:00:00"', b'+CCLK: "23/12/31,23:59:59+00"'):
        assert sw.parse_cclk(never_set) is None
    for bad in (b'+CCLK: "26/13/27,22:10:05+00"', b'+CCLK: "26/11/27"', b'+CCLK: "x"', b"+CSQ: 5,0"):
        raises(DecodeError, sw.parse_cclk, bad)


# -- the drivers, byte for byte ------------------------------------------------------------
def iridium_up(**opts):
    f = Fed(IridiumDriver(**opts))
    assert f.poll() == b"ATE0Q0V1\r"
    for cmd in (b"AT&K0\r", b"AT+SBDMTA=1\r", b"AT+SBDD0\r"):
        assert f.answer(b"OK\r\n") == cmd
    assert f.answer(b"0\r\nOK\r\n") == b"AT+CSQ\r"
    # up: the time is asked at once
    assert f.answer(b"+CSQ:4\r\nOK\r\n") == b"AT-MSSTM\r"
    assert f.take() == [(EV_DRIVER_UP,)]
    return f


def test_iridium_asks_msstm_when_up_after_no_service_after_sessions_and_hourly():
    f = iridium_up()
    d = f.d
    # not registered yet: no time, asked again a minute later
    assert f.answer(b"-MSSTM: no network service\r\nOK\r\n") == b""
    assert not d.take_times()
    assert f.poll(59000) == b""
    assert f.poll(1000) == b"AT-MSSTM\r"
    t = f.t + 1
    # (the signal is due too, and asked next)
    assert f.answer(b"-MSSTM: " + msstm_of(T, 270) + b"\r\nOK\r\n") == b"AT+CSQ\r"
    assert list(d.take_times()) == [(EV_TIME, "iridium", T, 270, 500, t)]
    assert f.answer(b"+CSQ:4\r\nOK\r\n") == b""
    assert not d.take_times()
    # a session: the time again after it (the unit has just heard the network)
    h = d.send(f.t, None, b"hi")
    assert f.poll() == b"AT+SBDWB=2\r"
    assert f.answer(b"READY\r\n") == b"hi" + iw.checksum(b"hi").to_bytes(2, "big")
    assert f.answer(b"0\r\nOK\r\n") == b"AT+SBDIX\r"
    assert f.answer(b"+SBDIX: 0, 1, 0, 0, 0, 0\r\nOK\r\n") == b"AT+SBDD0\r"
    assert f.answer(b"0\r\nOK\r\n") == b"AT-MSSTM\r"
    assert f.answer(b"-MSSTM: " + msstm_of(T + 30) + b"\r\nOK\r\n") == b""
    assert [e[2] for e in d.take_times()][0] in (T + 29, T + 30)  # the count is whole 90 ms frames
    assert (2, h) in [e[:2] for e in f.take()]
    # an ERROR (a unit without the command) is not an error of the link
    out = f.poll(3600000)
    while out != b"AT-MSSTM\r":  # the signal and the mailbox are due too
        assert out in (b"AT+CSQ\r", b"AT+SBDIX\r"), out
        out = f.answer(b"+CSQ:4\r\nOK\r\n" if out == b"AT+CSQ\r" else b"+SBDIX: 0, 1, 0, 0, 0, 0\r\nOK\r\n")
    assert f.answer(b"ERROR\r\n") in (b"", b"AT+CSQ\r") and not d.take_times()
    assert [e for e in f.take() if e[0] != 2] == [] and d.ready(f.t)


def test_iridium_time_off_and_another_era():
    f = Fed(IridiumDriver(time_period_ms=0))
    f.poll()
    for a in (b"OK\r\n", b"OK\r\n", b"OK\r\n", b"0\r\nOK\r\n"):
        f.answer(a)
    assert f.answer(b"+CSQ:4\r\nOK\r\n") == b""  # never asked
    f = iridium_up(time_epoch_s=ERA2)
    f.answer(b"-MSSTM: d1c6dd38\r\nOK\r\n")
    assert f.d.take_times()[0][2] == iw.parse_msstm(b"-MSSTM: d1c6dd38", ERA2)[0]


def test_sms_asks_cclk_and_a_modem_clock_never_set_is_no_time():
    f = Fed(SmsDriver(1, NUMBERS))
    assert f.poll() == b"ATE0Q0V1\r"
    for ans, cmd in ((b"\r\nOK\r\n", b"AT+CMEE=1\r"), (b"\r\nOK\r\n", b"AT+CPIN?\r"),
                     (b"\r\n+CPIN: READY\r\n\r\nOK\r\n", b"AT+CMGF=0\r"), (b"\r\nOK\r\n", b"AT+CNMI=2,1,0,0,0\r"),
                     (b"\r\nOK\r\n", b"AT+CSQ\r"), (b"\r\n+CSQ: 17,99\r\n\r\nOK\r\n", b"AT+CMGL=4\r")):
        assert f.answer(ans) == cmd
    # the storage listed, then the clock
    assert f.answer(b"\r\nOK\r\n") == b"AT+CCLK?\r"
    t = f.t + 1
    assert f.answer(b'\r\n+CCLK: "26/11/27,23:10:05+04"\r\n\r\nOK\r\n') == b""
    assert list(f.d.take_times()) == [(EV_TIME, "gsm", T, 0, 2000, t)]
    # an hour later (after the storage's listing, its work comes first);
    # the network never set the clock this time: no time, asked a minute later
    assert f.poll(3600000) == b"AT+CMGL=4\r"
    assert f.answer(b"\r\nOK\r\n") == b"AT+CCLK?\r"
    assert f.answer(b'\r\n+CCLK: "80/01/06,00:10:00+00"\r\n\r\nOK\r\n') == b"AT+CSQ\r"
    assert f.answer(b"\r\n+CSQ: 17,99\r\n\r\nOK\r\n") == b""
    assert not f.d.take_times()
    assert f.poll(60000) == b"AT+CCLK?\r"


# -- the emulators -------------------------------------------------------------------------
def talk(emu, now, line):
    emu.feed(now, line + b"\r")
    emu.poll(now)
    return emu.take_output()


def test_the_iridium_emulator_answers_msstm_from_the_worlds_time():
    e = IridiumEmulator(IridiumNetwork(), 1, bars=0, wall0_s=T)
    assert talk(e, 0, b"ATE0") == b"ATE0\r\r\nOK\r\n"
    assert talk(e, 1000, b"AT-MSSTM") == b"\r\n-MSSTM: no network service\r\n\r\nOK\r\n"
    e.set_bars(3)
    assert talk(e, 2000, b"AT-MSSTM") == b"\r\n-MSSTM: " + msstm_of(T + 2) + b"\r\n\r\nOK\r\n"
    # registered once: the unit counts on without signal
    e.set_bars(0)
    assert talk(e, 2090, b"AT-MSSTM") == b"\r\n-MSSTM: " + msstm_of(T + 2, 90) + b"\r\n\r\nOK\r\n"
    # numeric mode: the count, then 0
    assert talk(e, 2090, b"ATV0") == b"0\r"
    assert talk(e, 2090, b"AT-MSSTM") == b"-MSSTM: " + msstm_of(T + 2, 90) + b"\r\n0\r"
    e2 = IridiumEmulator(IridiumNetwork(), 2, wall0_s=T, epoch_s=ERA2)
    assert talk(e2, 0, b"AT-MSSTM").split(b"\r\n")[1] == b"-MSSTM: " + msstm_of(T, 0, ERA2)


def test_the_gsm_emulator_answers_cclk_with_and_without_network_time():
    assert civil(days2020(2026, 11, 27)) == (2026, 11, 27)
    assert cclk_text(T, 4) == b'+CCLK: "26/11/27,23:10:05+04"'
    assert cclk_text(T, -20) == b'+CCLK: "26/11/27,17:10:05-20"'
    e = GsmEmulator(GsmNetwork(), 1, wall0_s=T, tz=4)
    talk(e, 0, b"ATE0")
    assert talk(e, 3000, b"AT+CCLK?") == b'\r\n+CCLK: "26/11/27,23:10:08+04"\r\n\r\nOK\r\n'
    assert sw.parse_cclk(cclk_text(T + 3, 4)) == (T + 3, 0)
    # no network time: the unit's own clock from its power-up date
    e = GsmEmulator(GsmNetwork(), 2, wall0_s=T, network_time=False)
    talk(e, 0, b"ATE0")
    assert talk(e, 61000, b"AT+CCLK?") == b'\r\n+CCLK: "80/01/06,00:01:01+00"\r\n\r\nOK\r\n'
    # set by the host, it runs from there; a power cycle forgets it
    assert talk(e, 62000, b'AT+CCLK="26/11/27,22:10:05+00"') == b"\r\nOK\r\n"
    assert talk(e, 65000, b"AT+CCLK?") == b'\r\n+CCLK: "26/11/27,22:10:08+00"\r\n\r\nOK\r\n'
    assert talk(e, 65000, b'AT+CCLK="26/13/27,22:10:05+00"') == b"\r\nERROR\r\n"
    # the network's time needs the network: no signal, the RTC until registered
    e = GsmEmulator(GsmNetwork(), 3, wall0_s=T, rssi=0)
    talk(e, 0, b"ATE0")
    assert talk(e, 0, b"AT+CCLK?").startswith(b'\r\n+CCLK: "80/01/06')
    e.set_rssi(20)
    assert talk(e, 5000, b"AT+CCLK?") == b'\r\n+CCLK: "26/11/27,22:10:10+00"\r\n\r\nOK\r\n'


# -- end to end -------------------------------------------------------------------------------
def test_a_node_takes_its_wall_clock_from_an_emulated_iridium_modem():
    clk = ManualClock(0)
    a, b = uart_pair(rxbuf=4096, clock=clk)
    wc = WallClock(lambda: 1000, clk, None, 0)  # a board's clock never set: 1000 s from its epoch
    node = Node("buoy", 1, clk, wallclock=wc)
    steps = []
    wc.on_step(steps.append)
    node.add_link("sat", IridiumDriver(1, csq_retry_ms=5000, retry_ms=1000), a)
    t = Transport.of(node, wall=wc.wall)
    assert t.wall() == 1000 and wc.source == "none"
    emu = IridiumEmulator(IridiumNetwork(), 1, wall0_s=T, session_ms=2000, boot_ms=500)
    for _ in range(1000):
        now = clk()
        node.step(now)
        data = b.read()
        if data:
            emu.feed(now, data)
        emu.poll(now)
        out = emu.take_output()
        if out:
            b.write(out)
        clk.advance(20)
        if wc.source != "none":
            break
    assert wc.source == "iridium" and wc.uncertainty_ms() == 500
    # the emulated world's time, within the 90 ms frame and the loop's steps
    assert T <= wc.wall() <= T + clk() // 1000 + 1
    assert t.wall() == wc.wall() and len(steps) == 1 and steps[0] == wc.wall() - 1000 - (clk() - 20) // 1000
    # the node kept the time to itself
    assert EV_TIME not in [e[0] for e in node.take_events()]


def test_a_boards_gps_sets_its_clock():
    cfg = {"name": "b", "node_id": 1, "arch": "armv6m", "storage": None, "watchdog_ms": 0,
           "links": [{"name": "sat", "modem": "iridium", "uart": 1, "baud": 19200, "options": {"time_period_ms": 0}}],
           "gps": {"uart": 0, "rx": 1}}
    c = check(cfg)
    assert c["gps"] == {"uart": 0, "baud": 9600, "tx": None, "rx": 1, "rxbuf": 256}
    clk = ManualClock(0)
    ends = {}

    def open_uart(lk):
        ends[lk["uart"]] = uart_pair(clock=clk)
        return ends[lk["uart"]][0]

    board = build(c, open_uart, clk, lambda: 500)
    wc = board.node.wallclock
    assert wc.wall() == 500 and board.transport.wall() == 500
    body = b"GPRMC,221005.00,A,4807.038,N,01131.000,E,0.4,84.4,271126,,,A"
    x = 0
    for ch in body:
        x ^= ch
    ends[0][1].write(b"$" + body + b"*%02X\r\n" % x)
    board.node.step(clk())
    assert wc.source == "gps" and wc.wall() == T and board.transport.wall() == T
    # the config names a wrong gps entry in one line
    for bad, why in (({"uart": 1}, "gps.uart"), ({"uart": 0, "baud": "x"}, "gps.baud"), ({"uart": 0, "pins": 3}, "gps"),
                     ("0", "gps")):
        cfg["gps"] = bad
        e = str(raises(ConfigError, check, cfg))
        assert e.startswith("board config: " + why) and "\n" not in e, e
