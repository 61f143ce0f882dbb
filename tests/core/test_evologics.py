# The EvoLogics S2C driver and its emulator: byte-exact against the example
# exchange of ref/modem-protocols.md section 2.6, the line reader on binary
# payloads, then two Nodes whose Links drive EvologicsDrivers over FakeUART
# lines to emulated modems on one acoustic medium, through every fault mode.
from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST, CAP_DELIVERY, CAP_RANGING, CAP_RELIABLE
from acomm.compat import TICKS_MAX
from acomm.drivers import evologics_wire as w
from acomm.drivers.evologics import EvologicsDriver
from acomm.errors import EncodeError
from acomm.events import (
    DELIVERED,
    EV_DELIVERED,
    EV_DRIVER_DOWN,
    EV_DRIVER_UP,
    EV_RANGE,
    EV_RANGE_RECEIVED,
    EV_RX,
    EV_TX_DONE,
    EV_TX_FAILED,
    FAILED,
    QUEUED,
    TRANSMITTED,
    TRANSMITTING,
    WAITING,
)
from acomm.link import BROADCAST
from acomm_sim.evologics import EvologicsEmulator
from acomm_sim.medium import Medium
from checks import raises
import modemnet
from linkcheck import check_exactly_one_final

# section 2.6, command/NET mode
SENDIM = b"AT*SENDIM,5,2,ack,hello\n"
OK = b"OK\r\n"
DELIVEREDIM = b"DELIVEREDIM,2\r\n"
PTIME = b"AT?T\n"
PTIME_100M = b"66667\r\n"
RECVIM = b"RECVIM,5,1,2,ack,191000,-45,180,0.00,hello\r\n"


# -- the line reader ------------------------------------------------------------
class Sink:
    def __init__(self):
        self.lines = []
        self.junk = []

    def on_line(self, r):
        self.lines.append((r.text() if r.data_at < 0 else bytes(r.buf[: r.data_at]), r.data()))

    def on_junk(self, kind):
        self.junk.append(kind)


def test_reader_cuts_text_and_length_delimited_payloads():
    s = Sink()
    r = w.LineReader(s, w.RX_SPECS)
    r.feed(b"OK\r\nDELIVEREDIM,2\nFAILEDIM,3\r\r\n")
    # a payload holding CR LF and commas, fed a byte at a time
    for b in b"RECVIM,6,1,2,noack,1,-45,180,0.00,a\r\n,b\x00\r\nRECV,p7,2,3,4,9,-50,170,66667,0.10,zz\r\n":
        r.feed(bytes((b,)))
    assert s.lines == [
        (b"OK", None),
        (b"DELIVEREDIM,2", None),
        (b"FAILEDIM,3", None),
        (b"RECVIM,6,1,2,noack,1,-45,180,0.00,", b"a\r\n,b\x00"),
        (b"RECV,p7,2,3,4,9,-50,170,66667,0.10,", b"zz"),
    ]
    assert s.junk == [] and r.lines == 5
    # an empty payload, and the 1.6 layout (one more field before the data)
    s16 = Sink()
    r16 = w.LineReader(s16, w.RX_SPECS_16)
    r16.feed(b"RECVIM,2,1,2,ack,976,-45,180,66667,0.00,hi\r\nRECVPBM,0,1,2,1,-45,180,0.00,\r\n")
    assert s16.lines == [(b"RECVIM,2,1,2,ack,976,-45,180,66667,0.00,", b"hi"), (b"RECVPBM,0,1,2,1,-45,180,0.00,", b"")]


def test_reader_drops_damage_and_resynchronises():
    s = Sink()
    r = w.LineReader(s, w.RX_SPECS, max_data=64)
    # the declared length is too long: the lines inside the "payload" are
    # read again after the first terminator in it
    r.feed(b"RECVIM,9,1,2,ack,1,-45,180,0.00,abc\r\nOK\r\nDELIVEREDIM,2\r\n")
    assert s.lines == [(b"OK", None), (b"DELIVEREDIM,2", None)] and s.junk == [w.JUNK_LENGTH]
    s.lines[:] = []
    r.feed(b"RECVIM,xx,1,2,ack,1,2,3,4,data\r\nOK\r\n")  # not a length
    r.feed(b"RECV,65,1,2,3,4,5,6,7," + bytes(65) + b"\r\nOK\r\n")  # over max_data
    r.feed(b"X" * 200 + b"\r\nOK\r\n")  # longer than any text line
    r.feed(b"RECVIM,4,1,2,a\r\nOK\r\n")  # header cut short: a text line
    assert s.junk == [w.JUNK_LENGTH, w.JUNK_BAD_LEN, w.JUNK_BAD_LEN, w.JUNK_OVERLONG]
    assert s.lines == [(b"OK", None)] * 3 + [(b"RECVIM,4,1,2,a", None), (b"OK", None)]
    # a payload cut off by silence: the owner flushes it after a gap
    s.lines[:] = []
    r.feed(b"RECVIM,20,1,2,ack,1,-45,180,0.00,short\r\nOK\r\n")
    assert s.lines == [] and r.partial()
    r.flush()
    assert s.lines == [(b"OK", None)] and s.junk[-1] == w.JUNK_CUT and not r.partial()


# -- byte-exact: the driver -----------------------------------------------------
def up_driver(address=None, **opts):
    d = EvologicsDriver(address, **opts)
    d.poll(0)
    assert d.take_output() == b"AT@CTRL\n"
    d.feed(1, OK)
    assert d.take_output() == b"AT?MODE\n"
    d.feed(2, b"NET\r\n")
    assert d.take_output() == b"AT?AL\n"
    d.feed(3, b"1\r\n")
    if address is not None and address != 1:
        assert d.take_output() == b"AT!AL%d\n" % address
        d.feed(4, OK)
        assert d.take_output() == b"AT?AL\n"
        d.feed(5, b"%d\r\n" % address)
    assert d.take_output() == b"AT?CA\n"
    d.feed(6, b"1500\r\n")
    assert d.take_output() == b"AT@ZX1\n"
    d.feed(7, OK)
    assert d.take_output() == b""
    assert d.take_events() == [(EV_DRIVER_UP,)]
    assert d.ready(7) and d.address == (address if address is not None else 1)
    return d


def test_driver_start_sets_the_modem_up():
    d = up_driver()
    c = d.caps
    assert (c.manufacturer, c.model, c.mtu_tx, c.bitrate) == ("EvoLogics", "S2C", 1024, 5000)
    # burst data reports its delivery by itself; without burst (MTU 64) nothing does
    assert c.flags == CAP_ADDRESSING | CAP_BROADCAST | CAP_RELIABLE | CAP_RANGING | CAP_DELIVERY
    assert c.flag_names() == ["addressing", "reliable", "broadcast", "ranging", "delivery"]
    assert d.broadcast_addr == 255 and d.config.zx and d.sound_speed == 1500
    d = up_driver(7)
    assert d.address == 7
    d = EvologicsDriver(burst_mtu=0, take_control=False, check_mode=False, extra_commands=(b"AT!L2",))
    assert d.caps.mtu_tx == 64 and d.caps.bitrate == 976 and not d.caps.has(CAP_DELIVERY)
    d.poll(0)
    assert d.take_output() == b"AT?AL\n"
    d.feed(1, b"3\r\n")
    d.feed(2, b"1450\r\n")
    d.feed(3, b"ERROR WRONG FORMAT\r\n")  # no @ZX: the airtime model ends sends
    assert d.take_output() == b"AT?CA\nAT@ZX1\nAT!L2\n"
    d.feed(4, OK)
    assert d.take_events() == [(EV_DRIVER_UP,)] and not d.config.zx and d.sound_speed == 1450
    # a modem in AT mode is refused
    d = EvologicsDriver(take_control=False)
    d.poll(0)
    d.feed(1, b"AT\r\n")
    assert not d.ready(1) and "NET" in d.config.problem


def test_driver_im_with_ack_matches_reference():
    d = up_driver()
    h = d.send(10, 2, b"hello", True)
    assert d.take_output() == SENDIM
    assert not d.ready(10)
    d.feed(20, OK + b"SENDSTART,2,im,191000,0\r\n")
    d.feed(220, b"SENDEND,2,im,220000,191000\r\n")
    assert d.take_events() == [(EV_TX_DONE, h)]
    d.feed(600, DELIVEREDIM)
    assert d.take_events() == [(EV_DELIVERED, h)]
    assert d.take_output() == PTIME  # the propagation time after every ack
    d.feed(610, PTIME_100M)
    assert d.last_ptime_us == 66667 and d.ready(610)
    # FAILEDIM: the packet went out, nobody confirmed it
    h = d.send(700, 2, b"hello", True)
    d.feed(710, OK)
    d.feed(3000, b"FAILEDIM,2\r\n")
    assert d.take_events() == [(EV_TX_DONE, h), (EV_TX_FAILED, h, "FAILEDIM")]
    # a broadcast never asks for an ack
    d.take_output()
    d.send(3100, 255, b"all", True)
    assert d.take_output() == b"AT*SENDIM,3,255,noack,all\n"


def test_driver_ping_ranges_with_the_propagation_time():
    d = up_driver()
    h = d.ping(10, 2)
    assert d.take_output() == b"AT*SENDIM,1,2,ack,0\n"
    d.feed(20, OK + b"SENDEND,2,im,1,1\r\n")
    d.feed(600, DELIVEREDIM)
    assert d.take_output() == PTIME and d.take_events() == []
    d.feed(610, PTIME_100M)
    assert d.take_events() == [(EV_RANGE, h, 2, 100.0, {"ptime_us": 66667, "sound_speed": 1500})]
    h = d.ping(700, 2)
    d.feed(710, OK)
    d.feed(3000, b"FAILEDIM,2\r\n")
    assert d.take_events() == [(EV_RANGE, h, None, None, {"reason": "FAILEDIM"})]
    # bad addresses come back as failures, never exceptions
    h = d.ping(3100, 255)
    assert d.take_events() == [(EV_TX_FAILED, h, "cannot range to address 255")]


def test_driver_receives_every_layout():
    d = up_driver()
    d.feed(10, RECVIM)
    d.feed(11, b"RECVIM,p3,4,2,1,noack,1,-60,150,0.50,a\r\nb\r\n")
    d.feed(12, b"RECV,70,3,1," + b"976,-50,170,66667,0.10," + bytes(range(70)) + b"\r\n")
    d.feed(13, b"RECVIMS,2,4,255,123456,1,-45,180,0.00,hi\r\nRECVPBM,2,5,1,1,-45,180,0.00,pb\r\n")
    assert d.take_events() == [
        (EV_RX, 1, 2, b"hello"),
        (EV_RX, 2, 1, b"a\r\nb"),
        (EV_RX, 3, 1, bytes(range(70))),
        (EV_RX, 4, 255, b"hi"),
        (EV_RX, 5, 1, b"pb"),
    ]
    assert d.last_rx == {"src": 5, "rssi": -45, "integrity": 180, "velocity": 0.0}
    d16 = EvologicsDriver(firmware16=True)
    d16.feed(0, b"RECVIM,2,1,2,noack,976,-47,181,66667,0.25,hi\r\n")
    assert d16.take_events() == [(EV_RX, 1, 2, b"hi")]
    assert d16.last_rx == {"src": 1, "rssi": -47, "integrity": 181, "velocity": 0.25}
    # notifications we only count, USBL fixes, junk
    d.feed(20, b"RECVSTART\r\nRECVEND,1,2,3,4\r\nBITRATE,local,976\r\nPHYON\r\nSTATUS,a,b\r\n")
    d.feed(21, b"USBLLONG,1.0,2.0,2,3.0,4.0,5.0,6.0,7.0,8.0,0.1,0.2,0.3,66667,-45,180,0.5\r\n")
    d.feed(22, b"USBLANGLES,1.0,2.0,2,0.1,0.2,0.3,0.4,0.5,0.6,0.7,-45,180,0.5\r\nHELLO?\r\nOK\r\n")
    assert d.stats["notes"] == 5 and d.stats["unknown"] == 1 and d.stats["stale"] == 1
    assert d.last_fix["east"] == 6.0 and d.last_fix["addr"] == 2 and d.last_angles["bearing"] == 0.3
    assert d.take_events() == []


def test_driver_noack_burst_and_refusals():
    d = up_driver()
    h = d.send(10, 2, b"x", False)
    assert d.take_output() == b"AT*SENDIM,1,2,noack,x\n"
    d.feed(20, OK)
    assert d.take_events() == [] and not d.ready(20)
    d.feed(200, b"SENDEND,2,im,1,1\r\n")
    assert d.take_events() == [(EV_TX_DONE, h)] and d.ready(200)
    # burst data: always acknowledged by the modem
    h = d.send(300, 3, bytes(100), False)
    assert d.take_output() == b"AT*SEND,100,3," + bytes(100) + b"\n"
    d.feed(310, OK + b"SENDEND,3,burst,1,1\r\nDELIVERED,100,3\r\n")
    assert d.take_events() == [(EV_TX_DONE, h), (EV_DELIVERED, h)]
    h = d.send(400, 3, bytes(100), False)
    d.feed(410, OK + b"FAILED,100,3\r\n")
    assert d.take_events() == [(EV_TX_DONE, h), (EV_TX_FAILED, h, "FAILED")]
    # refusals carry the modem's words; BUSY holds the next command back
    d.take_output()
    h = d.send(500, 2, b"y", True)
    d.feed(510, b"BUSY BACKOFF STATE\r\n")
    assert d.take_events() == [(EV_TX_FAILED, h, "BUSY BACKOFF STATE")] and d.ready(510)
    d.take_output()
    h = d.send(520, 2, b"y", True)
    assert d.take_output() == b""
    d.poll(510 + 1000)
    assert d.take_output() == b"AT*SENDIM,1,2,ack,y\n"
    d.feed(1520, b"ERROR NO CONTROL\r\n")
    assert d.take_events() == [(EV_TX_FAILED, h, "ERROR NO CONTROL")]
    assert d.take_output() == b"AT@CTRL\n"  # take the modem back
    d.feed(1530, OK)
    # the link's MTU check has a twin here; the address must be a number
    raises(EncodeError, d.send, 1600, 2, bytes(1025), False)
    raises(EncodeError, d.send, 1600, 255, bytes(65), False)
    raises(EncodeError, d.send, 1600, "two", b"x", False)
    d2 = up_driver(burst_mtu=0)
    raises(EncodeError, d2.send, 10, 2, bytes(65), False)


def test_driver_without_notifications_uses_the_airtime_model():
    d = up_driver()
    d.config.zx = False
    h = d.send(10, 2, b"hello", False)
    d.feed(20, OK)
    air = d.airtime_ms(5)
    assert air == 150 + 41
    d.poll(20 + air - 1)
    assert d.take_events() == []
    d.poll(20 + air)
    assert d.take_events() == [(EV_TX_DONE, h)] and d.ready(20 + air)


def test_driver_timeouts_and_watchdog():
    d = up_driver()
    h = d.send(10, 2, b"lost", True)
    d.take_output()
    d.poll(10 + 4999)
    assert d.take_events() == []
    d.poll(10 + 5000)
    assert d.take_events() == [(EV_TX_FAILED, h, "no reply to AT*SENDIM")]
    assert d.ready(5010)
    assert d.take_output() == b"AT?AL\n"  # is it still there?
    d.feed(5100, b"1\r\nDELIVEREDIM,2\r\n")  # an outcome that comes after all
    assert d.stats["stale"] == 1 and d.take_events() == []
    # accepted, then silence: the watchdog ends it and sets the modem up again
    d.poll(20000)
    d.take_output()
    h = d.send(20000, 2, b"x", True)
    assert d.take_output() == b"AT*SENDIM,1,2,ack,x\n"
    d.feed(20010, OK)
    limit = 20010 + d.airtime_ms(1) + d.reply_window_ms() + d.margin_ms
    d.poll(limit - 1)
    assert d.take_events() == []
    d.poll(limit)
    assert d.take_events() == [(EV_TX_FAILED, h, "no final word from the modem")]
    assert d.take_output() == b"AT@CTRL\n" and not d.ready(limit)


def test_driver_sends_bursts_while_their_reports_wait():
    d = up_driver()
    h1 = d.send(300, 3, bytes(100))
    assert d.take_output() == b"AT*SEND,100,3," + bytes(100) + b"\n"
    d.feed(310, OK)
    assert not d.ready(310)
    d.feed(2000, b"SENDEND,3,burst,1,1\r\n")
    # it has left: the modem takes the next burst before the first's report
    assert d.take_events() == [(EV_TX_DONE, h1)] and d.ready(2000) and len(d.awaiting) == 1
    h2 = d.send(2010, 3, bytes(80))
    assert d.take_output() == b"AT*SEND,80,3," + bytes(80) + b"\n"
    d.feed(2020, OK + b"SENDEND,3,burst,1,1\r\n")
    # an instant message waits until every burst is reported (the modem
    # would say BUSY DELIVERING)
    h3 = d.send(2030, 3, b"hi")
    assert d.take_output() == b"" and not d.ready(2030)
    # the reports come in order, per address
    d.feed(3000, b"FAILED,100,3\r\n")
    assert d.take_events() == [(EV_TX_DONE, h2), (EV_TX_FAILED, h1, "FAILED")] and d.take_output() == b""
    d.feed(3010, b"DELIVERED,80,3\r\n")
    assert d.take_events() == [(EV_DELIVERED, h2)]
    assert d.take_output() == b"AT*SENDIM,2,3,noack,hi\n"
    d.feed(3020, OK + b"SENDEND,3,im,1,1\r\n")
    assert d.take_events() == [(EV_TX_DONE, h3)] and d.ready(3020)
    # burst data received for us: our modem acknowledges it, so the next
    # command waits until it is done
    d.feed(4000, b"RECV,3,2,1,5000,-48,197,100222,0.00,abc\r\n")
    assert d.take_events() == [(EV_RX, 2, 1, b"abc")]
    h5 = d.send(4000, 2, b"ok")
    assert d.take_output() == b""
    d.poll(4000 + d.turnaround_ms + d.airtime_ms(0))
    assert d.take_output() == b"AT*SENDIM,2,2,noack,ok\n"
    d.feed(4300, OK + b"SENDEND,2,im,1,1\r\n")
    assert d.take_events() == [(EV_TX_DONE, h5)]
    # a burst the modem never reports on: the watchdog fails it and sets
    # the modem up again
    h4 = d.send(5000, 3, bytes(100))
    d.take_output()
    d.feed(5010, OK + b"SENDEND,3,burst,1,1\r\n")
    assert d.take_events() == [(EV_TX_DONE, h4)]
    limit = d.awaiting[0][2]
    d.poll(limit - 1)
    assert d.take_events() == []
    d.poll(limit)
    assert d.take_events() == [(EV_TX_FAILED, h4, "no final word from the modem")] and not d.awaiting
    assert d.take_output() == b"AT@CTRL\n"


def test_driver_detects_reboots_and_silence():
    d = up_driver()
    h = d.send(10, 2, b"x", True)
    d.take_output()
    d.feed(20, OK)
    d.feed(300, b"EvoLogics S2C modem (acomm emulator)\r\n")
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem rebooted"), (EV_TX_FAILED, h, "modem rebooted")]
    assert d.take_output() == b"AT@CTRL\n" and not d.ready(300)
    for t, line in enumerate((OK, b"NET\r\n", b"1\r\n", b"1500\r\n", OK)):
        d.feed(400 + t, line)
    assert d.take_events() == [(EV_DRIVER_UP,)]
    # the periodic probe finds the address the modem had before we set it
    d = up_driver(7)
    d.poll(60007)
    assert d.take_output() == b"AT?AL\n"
    d.feed(60010, b"1\r\n")
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem rebooted")]
    # a modem that stops answering goes down after three commands
    d = up_driver()
    d.poll(60007)
    for k in range(3):
        assert d.take_output() == b"AT?AL\n"
        d.poll(60007 + 5000 * (k + 1))
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem not answering")]
    assert d.take_output() == b"AT@CTRL\n"


# -- byte-exact: the emulator -----------------------------------------------------
run_emulators = modemnet.run_emulators


def test_emulator_answers_like_the_reference():
    m = Medium(default_distance=100.0)
    a = EvologicsEmulator(m, 1)
    b = EvologicsEmulator(m, 2)
    a.feed(0, b"AT@ZX1\n")
    assert a.take_output() == OK
    a.feed(0, SENDIM)
    assert a.take_output() == OK + b"SENDSTART,2,im,191000,0\r\n"  # no echo
    out_a, out_b = run_emulators((a, b), 0, 1000)
    assert out_a == b"SENDEND,2,im,191000,191000\r\n" + DELIVEREDIM
    assert out_b == RECVIM.replace(b",180,", b",198,")  # integrity from the distance
    a.feed(1000, PTIME)
    assert a.take_output() == PTIME_100M
    # noack: SENDEND ends it; nobody acknowledges
    a.feed(2000, b"AT*SENDIM,2,2,noack,hi\r\n")
    assert a.take_output() == OK + b"SENDSTART,2,im,167000,0\r\n"
    out_a, out_b = run_emulators((a, b), 2000, 3000)
    assert a.take_output() == b""
    assert out_a == b"SENDEND,2,im,2167000,167000\r\n"
    assert out_b == b"RECVIM,2,1,2,noack,167000,-45,198,0.00,hi\r\n"


def test_emulator_refuses_and_times_out():
    m = Medium()
    a = EvologicsEmulator(m, 1)
    for cmd, ans in (
        (b"AT?MODE\r", b"NET"),
        (b"AT?AL\r\n", b"1"),
        (b"AT?CA\n", b"1500"),
        (b"ATI1\n", b"phy:1.7 mac:1.7"),
        (b"AT!CA1480\n", b"OK"),
        (b"AT?CA\n", b"1480"),
        (b"ATX\n", b"ERROR WRONG FORMAT"),
        (b"hello\n", b"ERROR WRONG FORMAT"),
        (b"AT*SENDIM,65,2,noack," + bytes(65) + b"\n", b"ERROR BUFFER OVERFLOW"),
        (b"AT*SENDIM,2,2,maybe,hi\n", b"ERROR WRONG FORMAT"),
        (b"AT*SENDIM,2,2,ack,hi\n", b"OK"),  # nobody is 2
        (b"AT*SENDIM,2,2,ack,hi\n", b"BUSY BACKOFF STATE"),
    ):
        a.feed(0, cmd)
        assert a.take_output() == ans + b"\r\n", (cmd, ans)
    a.feed(400, b"AT*SEND,3,2,abc\n")
    assert a.take_output() == b"BUSY DELIVERING\r\n"
    assert run_emulators((a,), 0, 5000)[0] == b"FAILEDIM,2\r\n"
    a.feed(6000, b"AT*SEND,3,2,abc\n")
    assert a.take_output() == OK
    assert run_emulators((a,), 6000, 10000)[0] == b"FAILED,3,2\r\n"
    # another client took control
    a.steal_control()
    a.feed(11000, b"AT?AL\n")
    assert a.take_output() == b"ERROR NO CONTROL\r\n"
    a.feed(11000, b"AT@CTRL\nAT!AL9\nAT?AL\n")
    assert a.take_output() == b"OK\r\nOK\r\n9\r\n"
    # ATZ0 restarts: the unsaved address is gone, the banner comes
    a.feed(11000, b"ATZ0\n")
    assert a.take_output() == OK
    out = run_emulators((a,), 11000, 12100)[0]
    assert out.startswith(b"EvoLogics S2C") and a.address == 1
    a.feed(12100, b"AT!AL4\nAT&W\n")
    a.reboot(12100)
    run_emulators((a,), 12100, 13200)
    assert a.address == 4


def test_emulator_sends_buffered_bursts_as_a_train_acknowledged_once():
    m = Medium(default_distance=150.0)
    a = EvologicsEmulator(m, 1)
    b = EvologicsEmulator(m, 2)
    a.feed(0, b"AT*SEND,100,2," + bytes(100) + b"\n")
    assert a.take_output() == OK
    # on the air: one more is buffered, a third is not taken
    a.feed(10, b"AT*SEND,80,2," + bytes(80) + b"\n")
    assert a.take_output() == OK
    a.feed(20, b"AT*SEND,80,2," + bytes(80) + b"\n")
    assert a.take_output() == b"BUSY BACKOFF STATE\r\n"
    # the second follows the first (310 ms of air) at once; the remote
    # acknowledges both with one packet once nothing more arrives
    out_a, out_b = run_emulators((a, b), 20, 700)
    assert out_a == b"" and out_b.count(b"RECV,") == 2 and m.in_flight() == 0
    a.feed(700, b"AT*SENDIM,2,2,noack,hi\n")  # waiting for the train's ack
    assert a.take_output() == b"BUSY DELIVERING\r\n"
    b.feed(700, b"AT*SENDIM,2,1,noack,hi\n")  # about to acknowledge
    assert b.take_output() == b"BUSY BACKOFF STATE\r\n"
    out_a, out_b = run_emulators((a, b), 700, 3000)
    assert out_a == b"DELIVERED,100,2\r\nDELIVERED,80,2\r\n" and out_b == b""
    assert a.xcvr.sent == 2 and b.xcvr.sent == 1 and a.ptime_us == 100000


def test_emulator_at_mode_envelope_and_data():
    m = Medium(default_distance=150.0)
    a = EvologicsEmulator(m, 1, mode="AT", remote_addr=2)
    b = EvologicsEmulator(m, 2, mode="AT", remote_addr=1)
    a.feed(0, b"+++AT?MODE\r\n+++AT?T\n+++AT:junk\n")
    assert a.take_output() == b"+++AT?MODE:2:AT\r\n+++AT?T:1:0\r\n+++AT:18:ERROR WRONG FORMAT\r\n"
    a.feed(10, b"raw ++ bytes+")  # data mode: raw bytes go out as burst data
    a.feed(11, b"+\n")
    out_a, out_b = run_emulators((a, b), 10, 3000)
    assert out_b == b"raw ++ bytes++\n"  # received burst data comes out raw
    assert out_a == b"+++AT:14:DELIVERED,15,2\r\n"
    a.feed(3000, b"+++AT*SENDIM,2,2,ack,hi\n")
    assert a.take_output() == b"+++AT*SENDIM:2:OK\r\n"
    out_a, out_b = run_emulators((a, b), 3000, 5000)
    assert out_b == b"+++AT:39:RECVIM,2,1,2,ack,167000,-48,197,0.00,hi\r\n"
    assert out_a == b"+++AT:13:DELIVEREDIM,2\r\n"
    a.feed(5000, b"+++ATC\n")
    a.feed(5000, b"AT?T\n")
    assert a.take_output() == b"+++ATC:2:OK\r\n100000\r\n"


# -- two nodes over FakeUART, emulated modems on one medium ---------------------------
BUOY, DIVER = modemnet.BUOY, modemnet.DIVER
check_recovered = modemnet.check_recovered


class Net(modemnet.Net):
    # Each node's Link drives an EvologicsDriver over a FakeUART line whose
    # other end the test pumps into that node's emulated modem.
    def __init__(self, **kw):
        modemnet.Net.__init__(self, EvologicsDriver, EvologicsEmulator, broadcast=255, uart_opts={"rxbuf": 4096}, **kw)


def test_unicast_with_ack_broadcast_and_names():
    net = Net(start=TICKS_MAX - 1000)  # crosses the tick wrap on the way
    net.run(1000)  # set-up
    assert net.drivers["buoy"].ready(net.clk()) and net.drivers["diver"].ready(net.clk())
    r1 = net.send("buoy", "diver", b"depth 12.5 m", ack=True)
    assert net.run(10000, until=net.done("buoy", r1))
    assert net.rec("buoy").statuses(r1) == [QUEUED, TRANSMITTING, WAITING, DELIVERED]
    assert net.received("diver") == [("buoy", "diver", b"depth 12.5 m")]
    net.run(200)
    assert net.drivers["buoy"].last_ptime_us == 66667
    r2 = net.send("diver", BROADCAST, b"all surface")
    assert net.run(10000, until=lambda: net.done("diver", r2)() and net.received("buoy"))
    assert net.rec("diver").statuses(r2) == [QUEUED, TRANSMITTING, TRANSMITTED]
    assert net.received("buoy") == [("diver", BROADCAST, b"all surface")]
    # a frame too large for an IM goes as burst data, still acknowledged
    big = bytes(range(256)) * 2
    r3 = net.send("buoy", "diver", big, ack=True)
    assert net.run(10000, until=net.done("buoy", r3))
    assert net.rec("buoy").final(r3) == DELIVERED
    assert net.received("diver")[-1] == ("buoy", "diver", big)
    for name in ("buoy", "diver"):
        assert net.drivers[name].junk == {} and net.emus[name].ignored == 0


def test_ranging_reports_the_distance():
    net = Net(distance=150.0)
    net.run(1000)
    link = net.nodes["buoy"].links["acoustic"]
    assert link.range(net.clk(), 77, ["diver", "ghost"], 60)
    assert net.run(20000, until=net.done("buoy", 77))
    r = net.rec("buoy").of(EV_RANGE_RECEIVED)[-1]
    assert r[3] == ["diver", "ghost"] and r[4] == [150.0, None]  # nobody is modem 5
    assert net.rec("buoy").final(77) == DELIVERED
    # the ping is an elided RANGE frame: the diver hears it but receives nothing
    assert net.received("diver") == []
    check_exactly_one_final(net.rec("buoy"), [77])


def test_mtu_violation_is_refused_by_the_link():
    net = Net(drv_opts={"burst_mtu": 0})
    net.run(1000)
    modemnet.check_mtu(net, 63)


def test_absent_destination_fails_with_the_modem_reason():
    net = Net(link_opts={"max_retries": 1})
    net.run(1000)
    modemnet.check_absent(net, "FAILEDIM")


def faulted(fault, prefix=b"OK", where="buoy", **kw):
    # One acknowledged request from buoy to diver with `fault` armed on
    # `where`'s emulator; returns the net and the request id.
    net = Net()
    net.run(1000)
    return net, modemnet.faulted(net, fault, prefix, where, **kw)


def test_noise_bytes_on_the_line():
    net = Net()
    net.run(1000)
    net.emus["buoy"].inject_noise(b"\x00\xff\x13garbage\r\nRECVIM,zz,1,2,ack,1,2,3,4,data\r\n" + b"A" * 300 + b"\r\nRECVIM,40,2,1,ack,1,2,3,4,ab\r\n")
    r = net.send("buoy", "diver", b"through faults", ack=True)
    assert net.run(12000, until=net.done("buoy", r))
    drv = net.drivers["buoy"]
    for kind in (w.JUNK_BAD_LEN, w.JUNK_OVERLONG):
        assert drv.junk.get(kind), (kind, drv.junk)
    assert drv.stats["unknown"] + drv.stats["malformed"] >= 1
    check_recovered(net, r)


def test_damaged_reply():
    net, r = faulted("corrupt_next")
    assert net.drivers["buoy"].stats["malformed"] == 1
    check_recovered(net, r, "garbled reply to AT*SENDIM")


def test_damaged_delivery_notification():
    net, r = faulted("corrupt_next", b"DELIVEREDIM")
    check_recovered(net, r, "no final word from the modem")


def test_damaged_reception_on_the_far_side():
    net, r = faulted("corrupt_next", b"RECVIM", where="diver")
    rec = net.rec("buoy")
    # the modem acknowledged, so the link counts it delivered; the diver's
    # host never saw it
    assert rec.final(r) == DELIVERED and net.received("diver") == []


def test_truncated_lines():
    net, r = faulted("truncate_next")
    check_recovered(net, r)
    net, r = faulted("truncate_next", b"DELIVEREDIM", terminate=False)
    check_recovered(net, r, "no final word from the modem")
    net, r = faulted("truncate_next", b"RECVIM", where="diver", terminate=False)
    assert net.drivers["diver"].junk.get(w.JUNK_CUT) or net.drivers["diver"].junk.get(w.JUNK_LENGTH)
    r2 = net.send("buoy", "diver", b"and after", ack=True)
    assert net.run(12000, until=net.done("buoy", r2))
    assert net.received("diver")[-1] == ("buoy", "diver", b"and after")


def test_reply_that_never_comes():
    net, r = faulted("swallow_next", b"AT*SENDIM")
    check_recovered(net, r, "no reply to AT*SENDIM")
    # carried out, only the answer lost: the retry waits until the modem is
    # free instead of running into BUSY
    net, r = faulted("swallow_next", b"AT*SENDIM", execute=True)
    check_recovered(net, r, "no reply to AT*SENDIM")
    assert not [x for x in net.rec("buoy").reasons(r) if x and "BUSY" in x]


def reboot_mid_transfer(emu_opts=None):
    net = Net(emu_opts=emu_opts)
    net.run(1000)
    return net, modemnet.reboot_mid_transfer(net, 100)  # on the air by then


def test_reboot_banner_mid_transfer():
    net, r = reboot_mid_transfer()
    assert net.drivers["buoy"].stats["reboots"] == 1
    check_recovered(net, r, "modem rebooted")
    assert net.drivers["buoy"].ready(net.clk())


def test_silent_reboot_is_found_by_the_watchdog():
    net, r = reboot_mid_transfer({"banner": ()})
    check_recovered(net, r, "no final word from the modem")
    assert net.emus["buoy"].zx  # set up again


def test_a_modem_that_stops_answering_goes_down_and_comes_back():
    net = Net(link_opts={"max_retries": 0})
    net.run(1000)
    modemnet.check_down_and_up(net, 40000, 40000)


def test_address_is_set_at_start_and_control_taken():
    # a spare modem set to 3: the driver wants 7
    net = Net(stations=(("buoy", 10, 7), DIVER), emu_opts={"need_control": True}, emu_ids={"buoy": 3})
    emu = net.emus["buoy"]
    assert net.run(3000, until=lambda: net.drivers["buoy"].ready(net.clk()))
    assert emu.address == 7 and emu.commands[b"!AL"] >= 1 and emu.commands[b"@CTRL"] == 1
    r = net.send("diver", "buoy", b"hello seven", ack=True)
    assert net.run(12000, until=net.done("diver", r))
    assert net.rec("diver").final(r) == DELIVERED
    # someone else takes the modem: the request fails with the modem's words,
    # the driver takes control back and the retry goes through
    emu.steal_control()
    r = net.send("buoy", "diver", b"mine again", ack=True)
    assert net.run(12000, until=net.done("buoy", r))
    assert net.rec("buoy").final(r) == DELIVERED
    assert "ERROR NO CONTROL" in net.rec("buoy").reasons(r)[2]


def sized(rng, i):
    # mostly instant messages, some large enough to go as burst data
    return bytes(rng.range(1, 200) if rng.chance(0.2) else rng.range(1, 40))


def test_every_request_ends_once_under_mixed_faults():
    net = Net(start=TICKS_MAX - 20000, link_opts={"queue_capacity": 6})
    net.run(1000)
    finals = modemnet.mixed_faults(net, 60, 2000, 30, payload=sized)
    assert finals.get(DELIVERED, 0) >= 15 and finals.get(TRANSMITTED) and finals.get(FAILED), finals
    modemnet.check_still_works(net)


CONFIG_ANSWERS = {1: OK, 2: b"NET\r\n", 3: None, 4: OK, 5: b"1500\r\n", 6: OK}


def test_driver_never_raises_on_random_lines():
    # Well-formed lines of every kind with random fields, cut or lengthened
    # at random, and plain noise, in every driver state.
    from acomm.prng import Prng

    rng = Prng(11)
    seen = {}
    words = (b"OK", b"ERROR X", b"BUSY Y", b"DELIVEREDIM", b"FAILEDIM", b"CANCELEDIM", b"DELIVERED", b"FAILED",
             b"SENDEND", b"SENDSTART", b"RECVIM", b"RECV", b"RECVIMS", b"RECVPBM", b"USBLLONG", b"66667", b"NET",
             b"1500", b"EvoLogics")
    for trial in range(30):
        now = 10
        d = up_driver(rng.range(1, 3)) if trial % 3 else EvologicsDriver(rng.range(1, 3))
        d.poll(now)
        for i in range(60):
            now += rng.range(0, 3000)
            if d.ready(now) and rng.chance(0.4):
                if rng.chance(0.5):
                    try:
                        d.send(now, rng.range(0, 255), rng.bytes(rng.range(1, 100)), rng.chance(0.5))
                    except EncodeError:
                        pass
                else:
                    d.ping(now, rng.range(0, 5))
            elif d.cmd in CONFIG_ANSWERS and rng.chance(0.6):
                ans = CONFIG_ANSWERS[d.cmd]
                d.feed(now, ans if ans else b"%d\r\n" % d.config.want_addr)
            elif d.slot.state in (2, 3, 4) and rng.chance(0.5):  # aimed at what is in flight
                a = d.slot.addr
                lines = {
                    2: (OK, b"BUSY X\r\n"),
                    3: (b"DELIVEREDIM,%d\r\n" % a, b"DELIVERED,9,%d\r\n" % a, b"FAILEDIM,%d\r\n" % a, b"SENDEND,%d,im,1,1\r\n" % a),
                    4: (PTIME_100M, b"-1\r\n"),
                }[d.slot.state]
                d.feed(now, lines[rng.below(len(lines))])
            elif rng.chance(0.7):
                word = words[rng.below(len(words))]
                fields = [b"%d" % (d.slot.addr if rng.chance(0.5) else rng.range(-5, 300)) for _ in range(rng.below(10))]
                line = b",".join((word,) + tuple(fields))
                if word.startswith(b"RECV") and rng.chance(0.7):
                    data = rng.bytes(rng.range(0, 70))
                    line = word + b",%d,%d,%d,ack,1,-45,180,0.00," % (len(data), rng.range(1, 3), rng.range(0, 3)) + data
                if rng.chance(0.3):
                    line = line[: rng.below(len(line) + 1)] + rng.bytes(rng.below(3))
                d.feed(now, line + (b"\r\n", b"\n", b"\r")[rng.below(3)])
            else:
                d.feed(now, rng.bytes(rng.range(1, 50)))
            d.poll(now)
            d.take_output()
            for ev in d.take_events():
                seen[ev[0]] = seen.get(ev[0], 0) + 1
    for code in (EV_RX, EV_TX_DONE, EV_DELIVERED, EV_TX_FAILED, EV_RANGE, EV_DRIVER_UP, EV_DRIVER_DOWN):
        assert seen.get(code), (code, seen)
