# The WHOI Micro-Modem driver and its emulator: byte-exact against the
# example exchanges of ref/modem-protocols.md section 3.7 (checksums
# included), then two Nodes whose Links drive MicroModemDrivers over FakeUART
# lines to emulated modems on one acoustic medium, through every fault mode.
from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST, CAP_RANGING, CAP_RELIABLE
from acomm.compat import TICKS_MAX
from acomm.drivers import micromodem_wire as nm
from acomm.drivers.micromodem import MicroModemDriver
from acomm.drivers.micromodem_wire import Airtime, advert_to_mini, mini_to_advert
from acomm.errors import AcommError, EncodeError
from acomm.events import (
    AVAILABLE,
    DELIVERED,
    EV_AVAILABILITY,
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
from acomm_sim.medium import Medium
from acomm_sim.micromodem import MicroModemEmulator
from checks import raises
import modemnet
from linkcheck import check_exactly_one_final

# section 3.7, every line with its checksum
CYC = b"$CCCYC,0,1,2,1,1,1*5B\r\n"
CACYC = b"$CACYC,0,1,2,1,1,1*59\r\n"
DRQ = b"$CADRQ,120000,1,2,1,64,1*47\r\n"
TXD = b"$CCTXD,1,2,1,48656C6C6F*05\r\n"
CATXD = b"$CATXD,1,2,1,5*4D\r\n"
RXD = b"$CARXD,1,2,1,1,48656C6C6F*1C\r\n"
ACK = b"$CAACK,1,2,1,1*48\r\n"
MPC = b"$CCMPC,1,2*5D\r\n"
CAMPC = b"$CAMPC,1,2*5F\r\n"
MPR = b"$CAMPR,2,1,0.2501*7A\r\n"
CFG = b"$CCCFG,SRC,1*31\r\n"
CACFG = b"$CACFG,SRC,1*33\r\n"


# -- byte-exact: sentences --------------------------------------------------------
def test_sentences_match_reference():
    s = nm.sentence
    assert s("CCCYC", 0, 1, 2, 1, 1, 1) == CYC and s("CACYC", 0, 1, 2, 1, 1, 1) == CACYC
    assert s("CADRQ", "120000", 1, 2, 1, 64, 1) == DRQ
    assert s("CCTXD", 1, 2, 1, nm.hexlify(b"Hello")) == TXD and s("CATXD", 1, 2, 1, 5) == CATXD
    assert s("CARXD", 1, 2, 1, 1, "48656C6C6F") == RXD and s("CAACK", 1, 2, 1, 1) == ACK
    assert s("CCMPC", 1, 2) == MPC and s("CAMPC", 1, 2) == CAMPC and s("CAMPR", 2, 1, "0.2501") == MPR
    assert s("CCCFG", "SRC", 1) == CFG and s("CACFG", "SRC", 1) == CACFG
    assert nm.unhex(b"48656c6C6F") == b"Hello" and nm.unhex(b"4G") is None and nm.unhex(b"486") is None
    assert nm.num(b"-12") == -12 and nm.num(b"1x") is None and nm.num(b"") is None and nm.num(b"7", 0, 5) is None
    assert nm.real(b"0.2501") == 0.2501 and nm.real(b"nan") is None
    assert nm.hhmmss(12 * 3600000 + 61000) == "120101"
    # the 8-digit checksum of acomms 3.1.0 (table of reflected 0xD663B05D)
    assert nm.crc32(b"") == 0 and nm.crc32(b"123456789") == 0x78C32C47
    assert nm.sentence32("CAACK", 1, 2, 1, 1) == b"$CAACK,1,2,1,1*%08X\r\n" % nm.crc32(b"CAACK,1,2,1,1")


class Sink:
    def __init__(self):
        self.got = []
        self.junk = []

    def on_sentence(self, buf, n):
        self.got.append(bytes(buf[:n]))

    def on_junk(self, kind):
        self.junk.append(kind)


def test_line_reader_takes_every_terminator_and_drops_damage():
    s = Sink()
    rd = nm.LineReader(s)
    rd.feed(CACYC + ACK.replace(b"\r\n", b"\r") + CACFG.replace(b"\r\n", b"\n") + b"$CAACK,1,2,1,1*48\n\r")
    assert s.got == [b"CACYC,0,1,2,1,1,1", b"CAACK,1,2,1,1", b"CACFG,SRC,1", b"CAACK,1,2,1,1"]
    rd.feed(nm.sentence32("CAACK", 1, 2, 1, 1) + b"$CCCYC,0,1,2,1,1,1*5b\r")  # lower-case digits too
    assert len(s.got) == 6 and s.junk == []
    bad = [
        b"boot text\r\n",
        b"$CAACK,1,2,1,1*49\r\n",  # wrong checksum
        b"$CAACK,1,2,1,1\r\n",  # none
        b"$CAACK,1,2,1,1*4\r\n",  # one digit
        b"$CAACK,1,2,1,1*ZZ\r\n",
        b"$CAACK,1,2,1,1*00000000\r\n",  # wrong 8-digit checksum
        b"$CAA",  # cut short: the next '$' starts a new line
        b"$" + b"A" * 700 + b"\r\n",
        b"$*00\r\n",  # no name
    ]
    rd.feed(b"".join(bad))
    J = nm
    assert s.junk == [J.JUNK_TEXT, J.JUNK_CHECKSUM, J.JUNK_FORMAT, J.JUNK_FORMAT, J.JUNK_FORMAT, J.JUNK_CHECKSUM,
                      J.JUNK_TRUNCATED, J.JUNK_OVERLONG, J.JUNK_FORMAT]
    rd.feed(ACK)
    assert len(s.got) == 7 and rd.junk[nm.JUNK_CHECKSUM] == 2
    # 8-digit checksums unchecked, or refused
    s2 = Sink()
    nm.LineReader(s2, csum32=nm.CSUM32_ACCEPT).feed(b"$CAACK,1,2,1,1*00000000\r\n")
    assert s2.got == [b"CAACK,1,2,1,1"]
    nm.LineReader(s2, csum32=nm.CSUM32_REJECT).feed(nm.sentence32("CAACK", 1, 2, 1, 1))
    assert len(s2.got) == 1 and s2.junk == [nm.JUNK_FORMAT]


# -- byte-exact: the driver ---------------------------------------------------------
def up_driver(address=1, **opts):
    d = MicroModemDriver(address, **opts)
    d.poll(0)
    assert d.take_output() == nm.sentence("CCCFG", "SRC", address)
    d.feed(1, nm.sentence("CACFG", "SRC", address))
    assert d.take_events() == [(EV_DRIVER_UP,)] and d.ready(1) and d.address == address
    return d


def test_driver_caps_follow_the_rate():
    d = up_driver()
    c = d.caps
    assert (c.manufacturer, c.model, c.mtu_tx, c.bitrate) == ("WHOI", "Micro-Modem", 64, 250)
    assert c.flags == CAP_ADDRESSING | CAP_BROADCAST | CAP_RELIABLE | CAP_RANGING and d.broadcast_addr == 0
    assert c.latency_ms == 1000 + 64 * 32 + 1333
    figures = [(MicroModemDriver(1, rate=r).caps.mtu_tx, MicroModemDriver(1, rate=r).caps.bitrate) for r in range(6)]
    assert figures == [(32, 80), (64, 250), (64, 500), (256, 1200), (256, 1300), (256, 5300)]
    air = Airtime()
    assert air.mini_ms() == 700 and air.packet_ms(0, 32) == 700 + 4000  # seed 000
    for bad in (6, -1, "1"):
        raises(AcommError, MicroModemDriver, 1, bad)
    raises(AcommError, MicroModemDriver, 16)
    raises(AcommError, MicroModemDriver, 0)  # the broadcast address


def test_driver_cycle_matches_reference():
    d = up_driver()
    h = d.send(10, 2, b"Hello", True)
    assert d.take_output() == CYC and not d.ready(10)
    d.feed(20, CACYC + DRQ)
    assert d.take_output() == TXD
    d.feed(30, CATXD + b"$CATXP,5*47\r\n")
    assert d.take_events() == []
    d.feed(1200, b"$CATXF,5*51\r\n")
    assert d.take_events() == [(EV_TX_DONE, h)] and not d.ready(1200)
    d.feed(2600, ACK)
    assert d.take_events() == [(EV_DELIVERED, h)] and d.ready(2600)
    # what modem 1 hears
    d.feed(3000, b"$CARXP,1*45\r\n$CACYC,0,2,1,1,1,1*59\r\n" + nm.sentence("CARXD", 2, 1, 1, 1, "48656C6C6F"))
    assert d.take_events() == [(EV_RX, 2, 1, b"Hello")]
    d.feed(3000, nm.sentence("CAMSG", "BAD_CRC", 1) + nm.sentence("CAMSG", "PACKET_TIMEOUT", 2))
    assert d.stats["bad_crc"] == 1 and d.stats["packet_timeout"] == 1
    # nobody acknowledges: the round trip at 2000 m has passed
    h = d.send(4000, 3, b"x", True)
    assert d.take_output() == nm.sentence("CCCYC", 0, 1, 3, 1, 1, 1)
    d.feed(4010, nm.sentence("CACYC", 0, 1, 3, 1, 1, 1) + nm.sentence("CADRQ", "120004", 1, 3, 1, 64, 1))
    assert d.take_output() == nm.sentence("CCTXD", 1, 3, 1, "78")
    d.feed(4020, nm.sentence("CATXD", 1, 3, 1, 1) + nm.sentence("CATXF", 1))
    assert d.take_events() == [(EV_TX_DONE, h)]
    d.poll(4020 + d.ack_window_ms() - 1)
    assert d.take_events() == []
    d.poll(4020 + d.ack_window_ms())
    assert d.take_events() == [(EV_TX_FAILED, h, "no acknowledgement")] and d.ready(9000)
    # a broadcast is never acknowledged, and ends at $CATXF
    h = d.send(20000, 0, b"all", True)
    assert d.take_output() == nm.sentence("CCCYC", 0, 1, 0, 1, 0, 1)
    d.feed(20010, nm.sentence("CACYC", 0, 1, 0, 1, 0, 1) + nm.sentence("CADRQ", "120020", 1, 0, 0, 64, 1))
    assert d.take_output() == nm.sentence("CCTXD", 1, 0, 0, "616C6C")
    d.feed(20020, nm.sentence("CATXD", 1, 0, 0, 3) + nm.sentence("CATXP", 3) + nm.sentence("CATXF", 3))
    assert d.take_events() == [(EV_TX_DONE, h)] and d.ready(20020)


def test_driver_ping_matches_reference():
    d = up_driver()
    h = d.ping(10, 2)
    assert d.take_output() == MPC
    d.feed(20, CAMPC + b"$CATXP,0*42\r\n")
    d.feed(1500, MPR)
    ev = d.take_events()
    assert ev == [(EV_RANGE, h, 2, 0.2501 * 1500.0, {"travel_s": 0.2501})] and abs(ev[0][3] - 375.15) < 1e-9
    h = d.ping(2000, 2)
    d.feed(2010, CAMPC)
    d.poll(2010 + d.ping_window_ms())
    assert d.take_events() == [(EV_RANGE, h, None, None, {"reason": "no ping reply"})]
    # the window grows with the maximum range (pyacomms waits 30 s)
    assert MicroModemDriver(1, max_range_m=10000).ping_window_ms() > d.ping_window_ms() + 10000
    for bad in (0, 1, 16, None):
        h = d.ping(3000, bad)
        assert d.take_events() == [(EV_TX_FAILED, h, "cannot ping address %r" % (bad,))]


def test_driver_refusals_errors_and_retries():
    d = up_driver()
    raises(EncodeError, d.send, 10, 2, bytes(65), True)
    raises(EncodeError, d.send, 10, 16, b"x", True)
    raises(EncodeError, d.send, 10, 2, b"", True)
    h = d.send(10, 2, b"Hello", True)
    raises(AcommError, d.send, 10, 2, b"x", True)  # busy
    d.take_output()
    d.feed(20, CACYC + DRQ)
    d.take_output()
    d.feed(3020, nm.sentence("CAERR", "120003", "DATA_TIMEOUT", 1, "no data from the host"))
    assert d.take_events() == [(EV_TX_FAILED, h, "modem error DATA_TIMEOUT: no data from the host")]
    # an unanswered $CCCYC is sent again after 5 s, three times (goby3)
    h = d.send(4000, 2, b"Hello", True)
    assert d.take_output() == CYC
    for k in range(3):
        d.poll(4000 + 5000 * (k + 1) - 1)
        assert d.take_output() == b""
        d.poll(4000 + 5000 * (k + 1))
        assert d.take_output() == CYC
    d.poll(24000)
    assert d.take_events() == [(EV_TX_FAILED, h, "no answer to $CCCYC"), (EV_DRIVER_DOWN, "modem not answering")]
    assert d.take_output() == CFG and not d.ready(24000)
    d.feed(24100, CACFG)
    assert d.take_events() == [(EV_DRIVER_UP,)]
    # the echo of a resent sentence that was only slow: late echoes are stale
    d.feed(24200, CACYC + ACK + b"$CATXF,5*51\r\n")
    assert d.take_events() == [] and d.stats["stale"] == 2


def test_driver_restarts_after_the_modem_rebooted():
    d = up_driver()
    h = d.send(10, 2, b"Hello", True)
    d.feed(20, CACYC + DRQ)
    d.take_output()
    d.feed(500, b"$CAREV,120000,INIT,0.94.0.00*55\r\n$CAREV,120000,AUV,0.94.0.00*0D\r\n")
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem rebooted"), (EV_TX_FAILED, h, "modem rebooted")]
    assert d.info == {"AUV": "0.94.0.00"} and d.stats["reboots"] == 1
    d.poll(500 + 1999)
    assert d.take_output() == b""  # goby3 waits 2 s after INIT
    d.poll(2500)
    assert d.take_output() == CFG
    d.feed(2510, CACFG)
    assert d.take_events() == [(EV_DRIVER_UP,)] and d.ready(2510)


def test_driver_asks_the_modem_its_address_and_sets_the_clock():
    d = MicroModemDriver(clock=lambda: (2024, 5, 1, 12, 0, 0))
    d.poll(0)
    assert d.take_output() == nm.sentence("CCCFQ", "SRC")
    d.feed(5, nm.sentence("CACFG", "SRC", 7))
    assert d.take_output() == nm.sentence("CCCLK", 2024, 5, 1, 12, 0, 0)
    d.feed(10, nm.sentence("CACLK", 2024, 5, 1, 12, 0, 0))
    assert d.take_events() == [(EV_DRIVER_UP,)] and d.address == 7
    d.send(20, 2, b"x")
    assert d.take_output() == nm.sentence("CCCYC", 0, 7, 2, 1, 0, 1)
    # a modem answering with 8-digit checksums
    d = MicroModemDriver(3)
    d.poll(0)
    d.feed(1, nm.sentence32("CACFG", "SRC", 3))
    assert d.take_events() == [(EV_DRIVER_UP,)]


# -- adverts as mini-packets ---------------------------------------------------------
def test_advert_mini_packet_mapping():
    from acomm import frame as fr
    from acomm.link.discovery import encode_advert

    for seq in (0, 5, 15):
        for period_ms in (4000, 60000, 1020000):
            f = fr.encode_elided(fr.Frame(fr.ADVERT, 3, 0, seq, encode_advert(3, period_ms)))
            v = advert_to_mini(f, 3)
            assert v is not None and v <= 0x1FFF and mini_to_advert(v, 3) == f
    adv = fr.encode_elided(fr.Frame(fr.ADVERT, 3, 0, 4, encode_advert(3, 60000)))
    assert advert_to_mini(adv, 4) is None and advert_to_mini(adv, None) is None  # not our address
    assert advert_to_mini(fr.encode_elided(fr.Frame(fr.DATA, 3, 0, 4, b"ab")), 3) is None
    assert mini_to_advert(0x0123, 3) is None and mini_to_advert(0x1100, 3) is None
    d = up_driver(3)
    h = d.send(10, 0, adv, False)
    assert d.take_output() == nm.sentence("CCMUC", 3, 0, "140F")
    d.feed(20, nm.sentence("CAMUC", 3, 0, "140F") + nm.sentence("CATXP", 0))
    assert d.take_events() == []
    d.feed(720, nm.sentence("CATXF", 0))
    assert d.take_events() == [(EV_TX_DONE, h)] and d.ready(720)
    d.feed(800, nm.sentence("CAMUA", 5, 0, "1A0F") + nm.sentence("CAMUA", 5, 0, "0042"))
    assert d.take_events() == [(EV_RX, 5, 0, bytes((0x2A, 5, 15)))] and d.stats["mini_ignored"] == 1
    d2 = up_driver(3, mini_adverts=False)
    d2.send(10, 0, adv, False)
    assert d2.take_output().startswith(b"$CCCYC")


# -- byte-exact: the emulator ----------------------------------------------------------
run_emulators = modemnet.run_emulators


def test_emulator_answers_like_the_reference():
    m = Medium(default_distance=375.15)
    a = MicroModemEmulator(m, 1)
    b = MicroModemEmulator(m, 2)
    assert a.take_output() == b"$CAREV,120000,INIT,0.94.0.00*55\r\n$CAREV,120000,AUV,0.94.0.00*0D\r\n"
    b.take_output()
    a.feed(0, CFG)
    assert a.take_output() == CACFG
    a.feed(0, CYC)
    assert a.take_output() == CACYC + DRQ
    a.feed(0, TXD)
    assert a.take_output() == CATXD + b"$CATXP,5*47\r\n"
    out_a, out_b = run_emulators((a, b), 0, 5000)
    assert out_b == b"$CARXP,1*45\r\n" + CACYC + RXD  # the remote side
    assert out_a == b"$CATXF,5*51\r\n" + ACK  # the automatic acknowledgement
    a.feed(6000, MPC)
    assert a.take_output() == CAMPC
    out_a, out_b = run_emulators((a, b), 6000, 9000)
    assert out_a == MPR and out_b == b"$CAMPA,1,2*5D\r\n"
    a.feed(9000, nm.sentence("CCMUC", 1, 0, "1234"))
    assert a.take_output() == nm.sentence("CAMUC", 1, 0, "1234") + nm.sentence("CATXP", 0)
    out_a, out_b = run_emulators((a, b), 9000, 10000)
    assert out_a == nm.sentence("CATXF", 0) and out_b == nm.sentence("CAMUA", 1, 0, "1234")


def test_emulator_errors_queries_and_timeouts():
    m = Medium()
    a = MicroModemEmulator(m, 1, banner=False)
    assert a.take_output() == b""
    a.feed(0, nm.sentence("CCXYZ", 1) + b"$CCCFQ,SRC*5C\r\n")
    assert a.take_output() == nm.sentence("CAERR", "120000", "NMEA", 1, "unknown sentence CCXYZ") + nm.sentence(
        "CAERR", "120000", "NMEA", 2, "bad sentence (checksum)")
    a.feed(0, b"$CCCFQ,SRC\r\n")  # no checksum at all: accepted
    assert a.take_output() == CACFG
    a.feed(0, nm.sentence("CCCFQ", "ALL"))
    assert a.take_output().count(b"$CACFG") == 5
    # the host leaves the data request unanswered
    # (rate 0: the cycle-init mini-packet first, test_micromodem_rate0)
    a.feed(1000, nm.sentence("CCCYC", 0, 1, 2, 0, 0, 1))
    assert a.take_output() == nm.sentence("CACYC", 0, 1, 2, 0, 0, 1) + nm.sentence("CATXP", 0)
    a.feed(1010, CYC)
    assert a.take_output() == nm.sentence("CAERR", "120001", "CYC", 3, "BUSY")
    assert run_emulators((a,), 1010, 4710)[0] == nm.sentence("CATXF", 0) + nm.sentence(
        "CADRQ", "120001", 1, 2, 0, 32, 1) + nm.sentence("CAERR", "120004", "DATA_TIMEOUT", 1, "no data from the host")
    # a standalone modem completes its own transmissions with nobody listening
    a.feed(5000, CYC)
    a.feed(5000, TXD)
    a.take_output()
    assert run_emulators((a,), 5000, 12000)[0] == b"$CATXF,5*51\r\n"
    # the clock, a too-long frame, a restart by $CCMSC
    a.feed(13000, nm.sentence("CCCLK", 2024, 5, 1, 23, 59, 59))
    assert a.take_output() == nm.sentence("CACLK", 2024, 5, 1, 23, 59, 59)
    a.feed(14000, CYC + nm.sentence("CCTXD", 1, 2, 1, "00" * 65))
    assert a.take_output().endswith(nm.sentence("CAERR", "000000", "TXD", 3, "bad CCTXD data"))
    a.feed(15000, nm.sentence("CCMSC", 1, 1, 0))
    assert a.take_output() == nm.sentence("CAMSC", 1, 1, 0)
    a.feed(15100, CFG)  # nobody listens while it restarts
    assert run_emulators((a,), 15100, 16100)[0] == nm.sentence("CAREV", "000002", "INIT", "0.94.0.00") + nm.sentence(
        "CAREV", "000002", "AUV", "0.94.0.00")


# -- two nodes over FakeUART, emulated modems on one medium -----------------------------
BUOY, DIVER = ("buoy", 1), ("diver", 2)


class Net(modemnet.Net):
    # Each node's Link drives a MicroModemDriver over a FakeUART line whose
    # other end the test pumps into that node's emulated modem. Node ids are
    # the modem addresses (the Link's default identity address map) unless
    # addr_offset moves the node ids away from them.
    def __init__(self, addr_offset=0, **kw):
        stations = tuple((name, addr + addr_offset, addr) for name, addr in (BUOY, DIVER))
        broadcast = 0 if addr_offset else None
        ghost = ("ghost", 5 + addr_offset, 5)
        modemnet.Net.__init__(self, MicroModemDriver, MicroModemEmulator, stations, broadcast=broadcast, ghost=ghost, **kw)


def test_unicast_with_ack_broadcast_and_names():
    net = Net(start=TICKS_MAX - 3000)  # crosses the tick wrap on the way
    net.run(5000)  # start-up (2 s after the power-up banner), the first adverts
    r1 = net.send("buoy", "diver", b"depth 12.5 m", ack=True)
    assert net.run(15000, until=net.done("buoy", r1))
    assert net.rec("buoy").statuses(r1) == [QUEUED, TRANSMITTING, WAITING, DELIVERED]
    assert net.received("diver") == [("buoy", "diver", b"depth 12.5 m")]
    r2 = net.send("diver", BROADCAST, b"all surface")
    assert net.run(15000, until=lambda: net.done("diver", r2)() and net.received("buoy"))
    assert net.rec("diver").statuses(r2) == [QUEUED, TRANSMITTING, TRANSMITTED]
    assert net.received("buoy") == [("diver", BROADCAST, b"all surface")]
    assert net.emus["buoy"].sentences["CCCFG"] >= 1 and net.drivers["buoy"].junk == {}


def desync(net):
    # both nodes advertise at start-up, at the same moment, and a half-duplex
    # modem does not hear while it transmits: different periods part them
    net.nodes["diver"].links["acoustic"].discovery.period_ms = 28000
    return net


def test_nodes_discover_each_other_through_mini_packets():
    net = desync(Net(link_opts={"advert_period_ms": 20000}))
    assert net.run(45000, until=lambda: net.rec("buoy").of(EV_AVAILABILITY) and net.rec("diver").of(EV_AVAILABILITY))
    for name, other in (("buoy", "diver"), ("diver", "buoy")):
        assert [e[2:] for e in net.rec(name).of(EV_AVAILABILITY)] == [(other, AVAILABLE)]
        emu = net.emus[name]
        assert emu.sentences.get("CCMUC", 0) >= 1 and "CCCYC" not in emu.sentences
        assert net.nodes[name].links["acoustic"].stats["adverts_sent"] >= 1
    # node ids that are not the modem addresses: adverts go as full frames
    net = desync(Net(link_opts={"advert_period_ms": 20000}, addr_offset=10))
    assert net.run(60000, until=lambda: net.rec("buoy").of(EV_AVAILABILITY) and net.rec("diver").of(EV_AVAILABILITY))
    assert "CCMUC" not in net.emus["buoy"].sentences and net.emus["buoy"].sentences["CCCYC"] >= 1


def test_ranging_reports_the_distance():
    net = Net(distance=375.15)
    net.run(5000)
    link = net.nodes["buoy"].links["acoustic"]
    assert link.range(net.clk(), 77, ["diver", "ghost"], 60)
    assert net.run(30000, until=net.done("buoy", 77))
    r = net.rec("buoy").of(EV_RANGE_RECEIVED)[-1]
    assert r[3] == ["diver", "ghost"] and abs(r[4][0] - 375.15) < 0.01 and r[4][1] is None
    assert net.rec("buoy").final(77) == DELIVERED
    assert sorted(net.emus["diver"].sentences) == ["CCCFG", "CCMUC"]  # the diver's host never helped
    check_exactly_one_final(net.rec("buoy"), [77])


def test_mtu_violation_is_refused_by_the_link():
    net = Net(drv_opts={"rate": 0}, emu_opts={"rate": 0})
    net.run(5000)
    modemnet.check_mtu(net, 31, within_ms=20000)  # the largest that fits at rate 0


def test_absent_destination_fails_with_the_modem_reason():
    net = Net(link_opts={"max_retries": 1})
    net.run(5000)
    modemnet.check_absent(net, "no acknowledgement")


def faulted(fault, name=None, where="buoy", **kw):
    net = Net()
    net.run(5000)
    return net, modemnet.faulted(net, fault, name, where, within_ms=60000, **kw)


def check_recovered(net, r, reason=None):
    modemnet.check_recovered(net, r, reason, within_ms=15000)


def test_noise_on_the_line():
    net = Net()
    net.run(5000)
    net.emus["buoy"].inject_noise(b"\x00\xff garbage\r\n$CAACK,1*00\r\n$CAA" + b"$" + b"9" * 700 + b"\r\n$CAR")
    r = net.send("buoy", "diver", b"through faults", ack=True)
    assert net.run(15000, until=net.done("buoy", r))
    junk = net.drivers["buoy"].junk
    for kind in (nm.JUNK_TEXT, nm.JUNK_CHECKSUM, nm.JUNK_TRUNCATED, nm.JUNK_OVERLONG):
        assert junk.get(kind), (kind, junk)
    check_recovered(net, r)


def test_wrong_checksums():
    net, r = faulted("corrupt_next", "CACYC")  # the data request still comes
    assert net.drivers["buoy"].junk[nm.JUNK_CHECKSUM] == 1
    check_recovered(net, r)
    net, r = faulted("corrupt_next", "CAACK")
    check_recovered(net, r, "no acknowledgement")


def test_truncated_lines():
    net, r = faulted("truncate_next", "CADRQ")  # the modem gives up waiting for data
    check_recovered(net, r, "DATA_TIMEOUT")
    net, r = faulted("truncate_next", "CATXF", terminate=False)  # the ack ends it anyway
    assert net.drivers["buoy"].junk[nm.JUNK_TRUNCATED] >= 1
    check_recovered(net, r)


def test_reply_that_never_comes():
    net, r = faulted("swallow_next", "CCCYC")  # resent after 5 s
    check_recovered(net, r)
    assert net.emus["buoy"].sentences["CCCYC"] == 3  # twice, then the later request
    net, r = faulted("swallow_next", "CCCYC", execute=True)  # only its echo is lost
    check_recovered(net, r)
    net, r = faulted("swallow_next", "CCTXD")
    check_recovered(net, r, "DATA_TIMEOUT")


def test_reboot_banner_mid_transfer():
    net = Net()
    net.run(5000)
    r = modemnet.reboot_mid_transfer(net, 800)  # on the air by then
    assert net.drivers["buoy"].stats["reboots"] == 2  # the power-up banner, then the fault
    check_recovered(net, r, "modem rebooted")


def test_a_modem_that_stops_answering_goes_down_and_comes_back():
    net = Net(link_opts={"max_retries": 0})
    net.run(5000)
    r = modemnet.check_down_and_up(net, 40000, 30000, within_ms=15000)
    assert net.rec("buoy").reasons(r)[-1] == "no answer to $CCCYC"


def test_every_request_ends_once_under_mixed_faults():
    net = Net(start=TICKS_MAX - 20000, link_opts={"queue_capacity": 6})
    net.run(5000)
    finals = modemnet.mixed_faults(net, 40, 4000, 20, life=(10, 60))
    assert finals.get(DELIVERED, 0) >= 10 and finals.get(TRANSMITTED) and finals.get(FAILED), finals
    modemnet.check_still_works(net)


def test_driver_never_raises_on_random_input():
    # Well-formed sentences with random fields (aimed at whatever the driver
    # waits for), damaged ones and plain noise, in every driver state.
    from acomm.prng import Prng

    rng = Prng(11)
    seen = {}
    names = ("CACYC", "CADRQ", "CATXD", "CATXP", "CATXF", "CAACK", "CARXD", "CAMUA", "CAMUC", "CAMPC",
             "CAMPR", "CAERR", "CAREV", "CACFG", "CAMSG", "CAXYZ")
    for trial in range(30):
        now = 2
        if trial % 3:
            d = up_driver(rng.range(1, 15))
        else:
            d = MicroModemDriver(rng.range(1, 15))
            d.poll(now)
        for i in range(60):
            now += rng.range(0, 3000)
            if d.ready(now) and rng.chance(0.4):
                if rng.chance(0.6):
                    try:
                        d.send(now, rng.range(0, 16), rng.bytes(rng.range(0, 66)), rng.chance(0.5))
                    except EncodeError:
                        pass
                else:
                    d.ping(now, rng.range(0, 16))
            elif rng.chance(0.7):
                name = names[rng.below(len(names))]
                st = d.slot.state
                if rng.chance(0.6) and st:  # what the slot waits for
                    name = ("CACYC", "CADRQ", "CADRQ", "CATXD", "CATXF", "CAACK", "CAMUC", "CAMPC", "CAMPR")[st]
                elif rng.chance(0.5) and not d.ready(now):
                    name = "CACFG"
                elif rng.chance(0.02):
                    name = "INIT"
                addr = d.slot.addr if rng.chance(0.6) else rng.below(16)
                own = d.address or 0
                pick = (own, addr, rng.below(300), "120000", "AUV", "SRC", "1", "BAD_CRC", "0.1234", "", "ZZ")
                fields = [pick[rng.below(len(pick))] for _ in range(rng.below(7))]
                if rng.chance(0.5) and name in ("CACYC", "CADRQ", "CAACK", "CAMPR", "CAMUA", "CARXD", "CACFG", "INIT"):
                    fields = {
                        "CACFG": ["SRC", own],
                        "INIT": ["120000", "INIT", "0.94"],
                        "CACYC": [0, own, addr, 1, 1, 1],
                        "CADRQ": ["120000", own, addr, 1, 64, 1],
                        "CAACK": [own, addr, 1, 1],
                        "CAMPR": [addr, own, "0.1"],
                        "CAMUA": [addr, 0, "%04X" % rng.below(0x2000)],
                        "CARXD": [addr, own, 0, 1, nm.hexlify(rng.bytes(rng.range(0, 8)))],
                    }[name]
                line = nm.sentence("CAREV" if name == "INIT" else name, *fields)
                if rng.chance(0.2):
                    line = line[: rng.below(len(line))]
                d.feed(now, line)
            else:
                d.feed(now, rng.bytes(rng.range(1, 50)))
            d.poll(now)
            d.take_output()
            for ev in d.take_events():
                seen[ev[0]] = seen.get(ev[0], 0) + 1
    for code in (EV_RX, EV_TX_DONE, EV_DELIVERED, EV_TX_FAILED, EV_RANGE, EV_DRIVER_UP, EV_DRIVER_DOWN):
        assert seen.get(code), (code, seen)


def test_sentences_with_bytes_that_are_not_utf8():
    # found by `acomm fuzz` (drv.micromodem, seed 1, case 1149): a sentence
    # whose checksum matches may still carry non-UTF-8 bytes; $CAREV and
    # $CAERR decoded their text fields and let a UnicodeError out
    d = up_driver()
    d.feed(10, b"$CAREV,120000,AUV,\xb4.9*%02X\r\n" % _xor(b"CAREV,120000,AUV,\xb4.9"))
    d.feed(11, b"$CAERR,120000,\xff\xfe,1,\xb4*%02X\r\n" % _xor(b"CAERR,120000,\xff\xfe,1,\xb4"))
    assert d.info["AUV"] == "?.9" and d.stats["errors"] == 1
    d.feed(12, RXD)
    assert d.take_events()[-1] == (EV_RX, 1, 2, b"Hello")  # still takes valid input


def _xor(body):
    x = 0
    for b in body:
        x ^= b
    return x
