# The SeaTrac driver and its emulator: byte-exact against the example
# exchanges of ref/modem-protocols.md section 1 (CRCs included), then two
# Nodes whose Links drive SeatracDrivers over FakeUART lines to emulated
# beacons on one acoustic medium, through every fault mode.
from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST, CAP_RANGING, CAP_RELIABLE
from acomm.compat import TICKS_MAX, ticks_add
from acomm.drivers import seatrac_wire as w
from acomm.drivers import seatrac_codes as sc
from acomm.drivers.seatrac import SeatracDriver
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
from acomm_sim.medium import Medium
from acomm_sim.seatrac import SeatracEmulator
import modemnet
from linkcheck import check_exactly_one_final

# The reference's lines (section 1.2 and 1.8), with their CRCs.
SYS_INFO_EXAMPLE = b"$0234000000011B0301690E000000000000FF900301006901B7FAC5BFFF910301007A07750463A973BA\r\n"
STATUS_EXAMPLE = b"$10078D48100000000000B930C2000800000000000000480DE3FD0DFD320303FF2B0400005EF273\r\n"
PING_SEND = b"#4002040177\r\n"
PING_STATUS = b"$4000028015\r\n"
PING_RESP = b"$4201020103D204F4FF19006900983A76FD800C000080841E00DC054AA8\r\n"
PING_ERROR = b"$43340266D5\r\n"
DAT_SEND = b"#6002000548656C6C6F7A7D\r\n"
DAT_STATUS = b"$60000281DF\r\n"
DAT_RECEIVE = b"$6101020000D204F4FF19006900983A76FD000548656C6C6F3EB2\r\n"
DAT_RECEIVE_LOCAL = b"$6101020000D204F4FF19006900983A76FD000548656C6C6F01F210\r\n"
DAT_ERROR = b"$633402671F\r\n"


# -- byte-exact: the wire format ----------------------------------------------
def test_wire_vectors():
    assert sc.encode(sc.SYNC_CMD, sc.CID_SYS_INFO) == b"#0281C1\r\n"
    assert sc.encode(sc.SYNC_CMD, sc.CID_SYS_ALIVE) == b"#01C1C0\r\n"
    assert sc.encode(sc.SYNC_CMD, sc.CID_STATUS, b"\x00") == b"#10000DC0\r\n"
    assert sc.encode(sc.SYNC_CMD, sc.CID_SETTINGS_GET) == b"#15C1CF\r\n"
    assert sc.encode(sc.SYNC_CMD, sc.CID_SYS_REBOOT, b"\x95\x6a") == b"#03956A1F7F\r\n"
    assert sc.encode(sc.SYNC_CMD, sc.CID_PING_SEND, b"\x02\x04") == PING_SEND
    assert sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, b"\x02\x00\x05Hello") == DAT_SEND
    assert sc.encode(sc.SYNC_RSP, sc.CID_DAT_ERROR, b"\x34\x02") == DAT_ERROR
    assert sc.encode(sc.SYNC_RSP, sc.CID_PING_ERROR, b"\x34\x02") == PING_ERROR


class Sink:
    def __init__(self):
        self.msgs = []
        self.junk = []

    def on_message(self, b, n):
        self.msgs.append(bytes(b[:n]))

    def on_junk(self, kind):
        self.junk.append(kind)


def test_line_decoder_takes_every_terminator_and_drops_damage():
    s = Sink()
    dec = w.LineReader(sc.SYNC_RSP, s)
    good = (PING_STATUS, DAT_ERROR.replace(b"\r\n", b"\n"), PING_ERROR.replace(b"\r\n", b"\r"), b"$4000028015\n\r")
    dec.feed(b"".join(good))
    assert s.msgs == [b"\x40\x00\x02", b"\x63\x34\x02", b"\x43\x34\x02", b"\x40\x00\x02"]
    bad = [
        b"boot text\r\n",  # no sync
        b"$4000028016\r\n",  # wrong CRC
        b"$40000280\r\n",  # CRC cut short (so the check fails)
        b"$4000028\r\n",  # odd length
        b"$633402671f\r\n",  # lowercase hex
        b"$6334",  # truncated: the next '$' starts a new line
        b"$" + b"00" * 200 + b"\r\n",  # longer than any message
        b"$C1\r\n",  # shorter than CID + CRC
    ]
    dec.feed(b"".join(bad))
    kinds = [sc.JUNK_TEXT, sc.JUNK_CRC, sc.JUNK_CRC, sc.JUNK_HEX, sc.JUNK_HEX, sc.JUNK_TRUNCATED, sc.JUNK_OVERLONG, sc.JUNK_SHORT]
    assert s.junk == kinds
    dec.feed(b"\r\n" + PING_STATUS)
    assert s.msgs[-1] == b"\x40\x00\x02" and len(s.msgs) == 5
    assert dec.messages == 5 and dec.junk[sc.JUNK_CRC] == 2


# -- byte-exact: the driver ---------------------------------------------------
def settings_line(beacon_id):
    from acomm_sim.seatrac import default_settings

    return sc.encode(sc.SYNC_RSP, sc.CID_SETTINGS_GET, default_settings(beacon_id))


def up_driver(beacon_id=1, **opts):
    d = SeatracDriver(beacon_id, **opts)
    d.poll(0)
    assert d.take_output() == b"#0281C1\r\n"
    d.feed(1, SYS_INFO_EXAMPLE)
    assert d.take_output() == b"#15C1CF\r\n"
    d.feed(2, settings_line(beacon_id))
    assert d.take_output() == b""
    assert d.take_events() == [(EV_DRIVER_UP,)]
    assert d.ready(2) and d.beacon_id == beacon_id
    return d


def test_driver_start_reads_the_beacon():
    d = up_driver()
    c = d.caps
    assert (c.manufacturer, c.model, c.serial) == ("Blueprint Subsea", "X150", "3689")
    assert c.mtu_tx == 30 and c.bitrate == 100 and c.latency_ms == 1300 + 80 * 30
    assert c.flags == CAP_ADDRESSING | CAP_BROADCAST | CAP_RELIABLE | CAP_RANGING
    assert d.broadcast_addr == 0
    assert d.config.info["firmware"] == "1.0.1914"
    assert d.range_tmo_m == 1000 and d.vos == 1500


def test_driver_ping_matches_reference():
    d = up_driver()
    h = d.ping(10, 2)
    assert d.take_output() == PING_SEND
    assert not d.ready(10)
    d.feed(20, PING_STATUS)
    d.feed(400, PING_RESP)
    ev = d.take_events()
    assert len(ev) == 1 and ev[0][:4] == (EV_RANGE, h, 2, 150.0)
    x = ev[0][4]
    got = (x["yaw"], x["pitch"], x["roll"], x["depth_local"], x["vos"], x["rssi"])
    assert got == (123.4, -1.2, 2.5, 10.5, 1500.0, -65.0)
    assert x["range_count"] == 3200 and abs(x["range_time"] - 0.2) < 1e-9
    assert "azimuth" not in x  # the fix carries no USBL group
    assert d.ready(400)
    h = d.ping(500, 2)
    d.feed(510, PING_STATUS + PING_ERROR)
    assert d.take_events() == [(EV_RANGE, h, None, None, {"status": "XCVR_RESP_TIMEOUT"})]


def test_driver_data_matches_reference():
    d = up_driver()
    h = d.send(10, 2, b"Hello", False)
    assert d.take_output() == DAT_SEND
    d.feed(20, DAT_STATUS)
    d.poll(20 + 500 + 80 * 5 - 1)
    assert d.take_events() == [] and not d.ready(919)
    d.poll(920)
    assert d.take_events() == [(EV_TX_DONE, h)] and d.ready(920)
    # what beacon 1 hears, in both firmware layouts
    d.feed(1000, DAT_RECEIVE + DAT_RECEIVE_LOCAL)
    assert d.take_events() == [(EV_RX, 2, 1, b"Hello"), (EV_RX, 2, 1, b"Hello")]
    # a REQ-type send that nobody answers
    h = d.send(2000, 2, b"Hello", True)
    assert d.take_output() == b"#6002040548656C6C6F3FBD\r\n"  # MSG_REQU
    d.feed(2010, DAT_STATUS)
    d.feed(3000, DAT_ERROR)
    assert d.take_events() == [(EV_TX_DONE, h), (EV_TX_FAILED, h, "XCVR_RESP_TIMEOUT")]
    assert d.ready(3000)


def test_driver_maps_refusals_and_acks():
    d = up_driver()
    h = d.send(10, 2, b"x", True)
    assert d.take_output() == b"#6002040178C1C3\r\n"
    d.feed(20, sc.encode(sc.SYNC_RSP, sc.CID_DAT_SEND, b"\x30\x02"))
    assert d.take_events() == [(EV_TX_FAILED, h, "XCVR_BUSY")]
    # busy: the next command waits for the back-off, the link is not blocked
    assert d.ready(20)
    h = d.send(30, 2, b"x", True)
    assert d.take_output() == b""
    d.poll(20 + 1000)
    assert d.take_output().startswith(b"#600204")
    d.feed(1030, sc.encode(sc.SYNC_RSP, sc.CID_DAT_SEND, b"\x00\x02"))
    # the remote's automatic reply: DAT_RECEIVE with ACK_FLAG set, from 2 to 1
    ack = bytes((1, 2, sc.FIX_RANGE, sc.MSG_RESPU)) + bytes(12) + bytes(8) + b"\xe8\x03" + b"\x01\x00"
    d.feed(2500, sc.encode(sc.SYNC_RSP, sc.CID_DAT_RECEIVE, ack))
    assert d.take_events() == [(EV_TX_DONE, h), (EV_DELIVERED, h)]
    assert d.last_fix["range"] == 100.0
    h = d.send(2600, 2, b"y", False)
    d.feed(2610, sc.encode(sc.SYNC_RSP, sc.CID_DAT_SEND, b"\x05\x02"))
    d.take_output()
    assert d.take_events() == [(EV_TX_FAILED, h, "CMD_PARAM_INVALID")]
    # a broadcast always goes one-way, whatever was asked
    d.send(2700, 0, b"z", True)
    assert d.take_output().startswith(b"#600000")
    # the link's MTU check has a twin here
    d2 = up_driver(mtu=16)
    err = None
    try:
        d2.send(10, 2, bytes(17), False)
    except Exception as e:  # noqa: BLE001
        err = e
    assert err is not None and "MTU" in str(err)
    # a bad address comes back as a failed ping, never an exception
    h = d2.ping(20, 0)
    assert d2.take_events() == [(EV_TX_FAILED, h, "cannot ping beacon id 0")]


def test_driver_command_timeout_frees_the_driver():
    d = up_driver()
    h = d.send(10, 2, b"lost", False)
    d.take_output()
    d.poll(10 + 1499)
    assert d.take_events() == []
    d.poll(10 + 1500)
    assert d.take_events() == [(EV_TX_FAILED, h, "no response to DAT_SEND")]
    assert d.ready(1510)
    # an answer that comes after all is ignored and counted
    d.feed(1600, DAT_STATUS)
    assert d.take_events() == [] and d.stats["stale"] >= 1


def test_driver_detects_reboot_from_uptime():
    d = up_driver()
    h = d.send(10, 2, b"x", True)
    d.take_output()
    d.feed(20, DAT_STATUS)
    d.feed(600, b"SeaTrac power-up text\r\n")  # a restart prints text
    assert d.take_output() == b"#01C1C0\r\n"  # how long have you been up?
    d.feed(610, sc.encode(sc.SYNC_RSP, sc.CID_SYS_ALIVE, b"\x00\x00\x00\x00"))
    ev = d.take_events()
    assert ev == [(EV_DRIVER_DOWN, "modem rebooted"), (EV_TX_FAILED, h, "modem rebooted")]
    assert not d.ready(610)
    assert d.take_output() == b"#0281C1\r\n"  # configuring again
    d.feed(620, SYS_INFO_EXAMPLE)
    assert d.take_output() == b"#15C1CF\r\n"
    d.feed(630, settings_line(1))
    assert d.take_events() == [(EV_DRIVER_UP,)] and d.ready(630)
    # noise that is not a restart: the probe finds the uptime has grown
    d.feed(5000, b"\x00\xff garbage\r\n")
    assert d.take_output() == b"#01C1C0\r\n"
    d.feed(5010, sc.encode(sc.SYNC_RSP, sc.CID_SYS_ALIVE, (57).to_bytes(4, "little")))
    assert d.take_events() == [] and d.ready(5010)
    # a beacon that announces itself with SYS_INFO after a restart
    info = bytes(int(SYS_INFO_EXAMPLE[i : i + 2], 16) for i in range(3, len(SYS_INFO_EXAMPLE) - 6, 2))
    d.feed(9000, sc.encode(sc.SYNC_RSP, sc.CID_SYS_INFO, b"\x01\x00\x00\x00" + info[4:]))  # up 1 s
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem rebooted")] and not d.ready(9000)
    assert d.take_output() == b"#0281C1\r\n"


# -- byte-exact: the emulator ---------------------------------------------------
def emulator_pair(part=sc.PART_X150, **opts):
    m = Medium(default_distance=150.0)
    a = SeatracEmulator(m, 1, part=part, **opts)
    b = SeatracEmulator(m, 2, part=part, **opts)
    for e in (a, b):
        e.attitude[:] = [1234, -12, 25]
        e.env[3] = 105
    return m, a, b


run_emulators = modemnet.run_emulators


def test_emulator_answers_like_the_reference():
    m = Medium()
    e = SeatracEmulator(m, 1, uptime_ms=52000)
    e.feed(0, b"#0281C1\r\n")
    assert e.take_output() == SYS_INFO_EXAMPLE
    e = SeatracEmulator(Medium(), 1, uptime_ms=1067149)
    e.env[:] = [12473, 194, 8, 0, 3400]
    e.attitude[:] = [-541, -755, 818]
    e.feed(0, b"#10000DC0\r\n")  # flags 0: the configured 0x07 come back
    assert e.take_output() == STATUS_EXAMPLE
    # the example exchanges of section 1.8 (beacon 1 asks beacon 2)
    m, a, b = emulator_pair(part=sc.PART_X110)
    a.feed(0, DAT_SEND)
    assert a.take_output() == DAT_STATUS
    out_a, out_b = run_emulators((a, b), 0, 1990)
    assert out_a == b"" and out_b.startswith(b"$61020100")  # heard by 2
    b.feed(2000, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, b"\x01\x00\x05Hello"))
    assert b.take_output() == sc.encode(sc.SYNC_RSP, sc.CID_DAT_SEND, b"\x00\x01")
    # the reference's DAT_RECEIVE bytes are what beacon 1 hears from 2
    assert run_emulators((a, b), 2000, 3990)[0] == DAT_RECEIVE
    a.feed(4000, PING_SEND)
    assert a.take_output() == PING_STATUS
    out_a, out_b = run_emulators((a, b), 4000, 5990)
    assert out_a.startswith(b"$4201020105D2")  # MSG_RESPU, range only (X110)
    assert out_b.startswith(b"$4102010004D2")  # PING_REQ: information only
    # the reference's PING_RESP carries type RESP and a range only: the
    # reply to a MSG_REQ ping at an X110, 150 m away
    a.feed(6000, sc.encode(sc.SYNC_CMD, sc.CID_PING_SEND, bytes((2, sc.MSG_REQ))))
    assert a.take_output() == PING_STATUS
    out_a, _ = run_emulators((a, b), 6000, 8000)
    assert out_a == PING_RESP
    # local flag (newer firmware)
    m, a, b = emulator_pair(part=sc.PART_X110, local_flag=True)
    b.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, b"\x01\x00\x05Hello"))
    b.take_output()
    assert run_emulators((a, b), 0, 2000)[0] == DAT_RECEIVE_LOCAL


def test_emulator_times_out_and_refuses():
    m = Medium()
    a = SeatracEmulator(m, 1)
    a.feed(0, PING_SEND)  # nobody is beacon 2
    assert a.take_output() == PING_STATUS
    a.feed(10, DAT_SEND)
    assert a.take_output() == sc.encode(sc.SYNC_RSP, sc.CID_DAT_SEND, b"\x30\x02")  # busy with the ping
    out = run_emulators((a,), 0, 5000)[0]
    assert out == PING_ERROR
    a.feed(6000, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, b"\x02\x04\x05Hello"))
    assert a.take_output() == DAT_STATUS
    assert run_emulators((a,), 6000, 11000)[0] == DAT_ERROR
    st = {}
    for name, payload in (
        ("too long", b"\x02\x00\x1f" + bytes(31)),
        ("length lies", b"\x02\x00\x05Hi"),
        ("broadcast REQ", b"\x00\x02\x01x"),
        ("to itself", b"\x01\x00\x01x"),
    ):
        a.feed(20000, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, payload))
        st[name] = a.take_output()[3:5]
    assert st == {"too long": b"05", "length lies": b"04", "broadcast REQ": b"05", "to itself": b"05"}
    # bad CRC, lowercase hex: no answer at all
    a.feed(20000, b"#0281C2\r\n#0281c1\r\n")
    assert a.take_output() == b"" and a.ignored == 2
    a.feed(20000, b"#03956A1F7F\n")  # SYS_REBOOT with its check word
    assert a.take_output() == sc.encode(sc.SYNC_RSP, sc.CID_SYS_REBOOT, b"\x00")
    a.feed(20100, b"#01C1C0\r")  # the port is closed while it restarts
    assert run_emulators((a,), 20100, 21100)[0].startswith(b"Blueprint Subsea")
    a.feed(21200, b"#01C1C0\r")
    assert a.take_output() == sc.encode(sc.SYNC_RSP, sc.CID_SYS_ALIVE, (1).to_bytes(4, "little"))


# -- two nodes over FakeUART, emulated beacons on one medium ---------------------
BUOY, DIVER = modemnet.BUOY, modemnet.DIVER
check_recovered = modemnet.check_recovered


class Net(modemnet.Net):
    # Each node's Link drives a SeatracDriver over a FakeUART line whose other
    # end the test pumps into that node's emulated beacon.
    def __init__(self, **kw):
        modemnet.Net.__init__(self, SeatracDriver, SeatracEmulator, **kw)


def test_unicast_with_ack_broadcast_and_names():
    net = Net(start=TICKS_MAX - 3000)  # crosses the tick wrap on the way
    net.run(4000)  # configuration, then the start-up adverts go by
    r1 = net.send("buoy", "diver", b"depth 12.5 m", ack=True)
    assert net.run(10000, until=net.done("buoy", r1))
    assert net.rec("buoy").statuses(r1) == [QUEUED, TRANSMITTING, WAITING, DELIVERED]
    assert net.received("diver") == [("buoy", "diver", b"depth 12.5 m")]
    r2 = net.send("diver", BROADCAST, b"all surface")
    assert net.run(10000, until=lambda: net.done("diver", r2)() and net.received("buoy"))
    assert net.rec("diver").statuses(r2) == [QUEUED, TRANSMITTING, TRANSMITTED]
    assert net.received("buoy") == [("diver", BROADCAST, b"all surface")]
    assert net.drivers["buoy"].caps.model == "X150"


def test_ranging_reports_the_distance_and_the_fix():
    net = Net(distance=150.0)
    net.medium.set_position(1, 0.0, 0.0, 0.0)
    net.medium.set_position(2, 90.0, 120.0, 0.0)
    net.run(4000)
    link = net.nodes["buoy"].links["acoustic"]
    assert link.range(net.clk(), 77, ["diver", "ghost"], 60)
    assert net.run(20000, until=net.done("buoy", 77))
    r = net.rec("buoy").of(EV_RANGE_RECEIVED)[-1]
    assert r[3] == ["diver", "ghost"] and r[4] == [150.0, None]  # nobody is beacon 5
    assert net.rec("buoy").final(77) == DELIVERED
    fix = net.drivers["buoy"].last_fix
    assert abs(fix["azimuth"] - 36.9) < 0.11 and fix["easting"] == 90.0 and fix["northing"] == 120.0
    check_exactly_one_final(net.rec("buoy"), [77])


def test_mtu_violation_is_refused_by_the_link():
    net = Net()
    net.run(4000)
    modemnet.check_mtu(net, 29)


def test_absent_destination_fails_with_the_modem_reason():
    net = Net(link_opts={"max_retries": 1})
    net.run(4000)
    modemnet.check_absent(net, "XCVR_RESP_TIMEOUT")


def faulted(fault, cid=sc.CID_DAT_SEND, where="buoy", **kw):
    # One acknowledged request from buoy to diver with `fault` armed on
    # `where`'s emulator; returns the net and the request id.
    net = Net()
    net.run(4000)
    return net, modemnet.faulted(net, fault, cid, where, **kw)


def test_noise_bytes_on_the_line():
    net = Net()
    net.run(4000)
    net.emus["buoy"].inject_noise(b"\x00\xff\x13garbage\r\n$12ZZ\r\n$633402671f\r\n$" + b"41" * 150 + b"\r\n$60")
    r = net.send("buoy", "diver", b"through faults", ack=True)
    assert net.run(12000, until=net.done("buoy", r))
    junk = net.drivers["buoy"].junk
    for kind in (sc.JUNK_TEXT, sc.JUNK_HEX, sc.JUNK_OVERLONG, sc.JUNK_TRUNCATED):
        assert junk.get(kind), (kind, junk)
    check_recovered(net, r)


def test_wrong_checksum_on_a_command_status():
    net, r = faulted("corrupt_next")
    assert net.drivers["buoy"].junk[sc.JUNK_CRC] == 1
    check_recovered(net, r, "no response to DAT_SEND")


def test_wrong_checksum_on_the_ack():
    net, r = faulted("corrupt_next", sc.CID_DAT_RECEIVE)
    check_recovered(net, r, "no reply from the modem")


def test_truncated_lines():
    net, r = faulted("truncate_next")
    check_recovered(net, r, "no response to DAT_SEND")
    net, r = faulted("truncate_next", sc.CID_DAT_RECEIVE, terminate=False)
    assert net.drivers["buoy"].junk[sc.JUNK_TRUNCATED] >= 1
    check_recovered(net, r, "no reply from the modem")


def test_reply_that_never_comes():
    net, r = faulted("swallow_next")
    check_recovered(net, r, "no response to DAT_SEND")
    # carried out, only the answer lost: the retry waits until the beacon
    # is free instead of running into XCVR_BUSY
    net, r = faulted("swallow_next", execute=True)
    check_recovered(net, r, "no response to DAT_SEND")
    assert "XCVR_BUSY" not in net.rec("buoy").reasons(r)


def reboot_mid_transfer(emu_opts=None):
    net = Net(emu_opts=emu_opts)
    net.run(4000)
    r = modemnet.reboot_mid_transfer(net, 1200)  # on the air by then
    assert net.drivers["buoy"].stats["reboots"] == 1
    return net, r


def test_reboot_banner_mid_transfer():
    net, r = reboot_mid_transfer()
    check_recovered(net, r, "modem rebooted")
    assert net.drivers["buoy"].ready(net.clk())


def test_reboot_announced_by_an_unsolicited_alive():
    net, r = reboot_mid_transfer({"banner": (), "boot_message": sc.CID_SYS_ALIVE})
    check_recovered(net, r, "modem rebooted")


def test_silent_reboot_is_found_by_the_watchdog():
    net, r = reboot_mid_transfer({"banner": ()})
    check_recovered(net, r, "no reply from the modem")


def test_a_beacon_that_stops_answering_goes_down_and_comes_back():
    net = Net(link_opts={"max_retries": 0})
    net.run(4000)
    modemnet.check_down_and_up(net, 20000, 20000)


def test_beacon_id_is_set_at_start_and_verified():
    net = Net(stations=(("buoy", 10, 7), DIVER), emu_ids={"buoy": 3})  # a spare beacon set to 3
    emu = net.emus["buoy"]
    # the buoy's driver wants 7: it writes the settings and restarts the beacon
    assert net.run(15000, until=lambda: net.drivers["buoy"].ready(net.clk()))
    assert emu.beacon_id == 7 and net.drivers["buoy"].beacon_id == 7
    for cid in (sc.CID_SETTINGS_SET, sc.CID_SETTINGS_SAVE, sc.CID_SYS_REBOOT):
        assert emu.commands[cid] == 1
    r = net.send("diver", "buoy", b"hello seven", ack=True)
    assert net.run(12000, until=net.done("diver", r))
    assert net.rec("diver").final(r) == DELIVERED
    # without permission to write, the driver stays down and says why
    d = SeatracDriver(9, set_beacon_id=False)
    d.poll(0)
    d.feed(1, SYS_INFO_EXAMPLE)
    d.take_output()
    d.feed(2, settings_line(1))
    assert not d.ready(2) and d.config.problem == "beacon id is 1, not 9"


def test_every_request_ends_once_under_mixed_faults():
    net = Net(start=TICKS_MAX - 20000, link_opts={"queue_capacity": 6})
    net.run(4000)
    finals = modemnet.mixed_faults(net, 60, 2500, 30)
    assert finals.get(DELIVERED, 0) >= 15 and finals.get(TRANSMITTED) and finals.get(FAILED), finals
    # and the network still works afterwards
    modemnet.check_still_works(net)


# -- the medium ------------------------------------------------------------------
class Station:
    def __init__(self):
        self.got = []

    def receive(self, t, src, packet, distance):
        self.got.append((t, src, packet, distance))


def test_medium_delay_loss_and_half_duplex():
    m = Medium(default_distance=150.0)
    a, b, c = Station(), Station(), Station()
    m.attach(1, a)
    m.attach(2, b)
    m.attach(3, c)
    m.set_distance(1, 3, 1500.0)
    # across the tick wrap (times stay in the ticks domain: a 32-bit board's
    # C ticks_diff reads only small ints)
    t0 = TICKS_MAX - 100
    m.transmit(t0, 1, "p", 500)
    m.poll(ticks_add(t0, 599))
    assert b.got == [] and a.got == []
    m.poll(ticks_add(t0, 600))
    assert b.got == [(ticks_add(t0, 600), 1, "p", 150.0)]
    m.poll(ticks_add(t0, 1500))
    assert len(c.got) == 1 and c.got[0][3] == 1500.0
    # half-duplex: 2 starts transmitting while 1's packet arrives
    m.transmit(5000, 1, "q", 500)
    m.transmit(5300, 2, "r", 500)
    m.poll(8000)
    assert [g[2] for g in b.got] == ["p"] and m.deaf == 2  # 1 also missed "r"
    assert [g[2] for g in c.got] == ["p", "r", "q"]  # 2 is nearer to 3 than 1 is
    assert m.transmitting(2, 5400) and not m.transmitting(2, 5800)
    # a sender that restarts mid-packet never finishes it
    m.transmit(9000, 1, "cut", 500)
    m.cancel(1, 9200)
    m.poll(12000)
    assert "cut" not in [g[2] for g in b.got + c.got]
    # geometry and loss
    m.set_position(2, 0.0, 0.0, 10.0)
    m.set_position(3, 30.0, 40.0, 10.0)
    assert m.distance(2, 3) == 50.0 and m.offset(2, 3) == (30.0, 40.0, 0.0)
    m2 = Medium(loss=1.0)
    m2.attach(1, a)
    m2.attach(2, b)
    m2.transmit(0, 1, "x", 10)
    m2.poll(1000)
    assert m2.lost == 1 and m2.in_flight() == 0


def test_emulator_settings_and_transceiver_state():
    m = Medium()
    e = SeatracEmulator(m, 4)
    e.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_SETTINGS_GET))
    line = e.take_output()
    s = Sink()
    w.LineReader(sc.SYNC_RSP, s).feed(line)
    rec = bytearray(s.msgs[0][1:])
    assert len(rec) == 110 and rec[96] == 4
    rec[96] = 9
    e.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_SETTINGS_SET, rec))
    assert e.take_output() == sc.encode(sc.SYNC_RSP, sc.CID_SETTINGS_SET, b"\x00")
    assert e.beacon_id == 4  # takes effect only after a restart
    e.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_SETTINGS_SET, rec[:50]))
    assert e.take_output()[3:5] == b"04"
    e.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_XCVR_STATUS))
    assert e.take_output() == sc.encode(sc.SYNC_RSP, sc.CID_XCVR_STATUS, b"\x3b")  # idle
    e.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, b"\x00\x00\x02hi"))  # broadcast
    e.take_output()
    e.feed(10, sc.encode(sc.SYNC_CMD, sc.CID_XCVR_STATUS))
    assert e.take_output() == sc.encode(sc.SYNC_RSP, sc.CID_XCVR_STATUS, b"\x3c")  # transmitting
    # saved, then restarted: the new id is live
    e.feed(1000, sc.encode(sc.SYNC_CMD, sc.CID_SETTINGS_SAVE) + sc.encode(sc.SYNC_CMD, sc.CID_SYS_REBOOT, b"\x95\x6a"))
    run_emulators((e,), 1000, 2100)
    assert e.beacon_id == 9 and e.xcvr.addr == 9
    e.feed(2200, sc.encode(sc.SYNC_CMD, sc.CID_SYS_REBOOT, b"\x00\x00"))
    assert e.take_output()[3:5] == b"05"  # wrong check word: no restart


def test_driver_never_raises_on_random_messages():
    # Well-framed messages with random CIDs and payloads (so past the CRC
    # check), and plain noise, in every driver state.
    from acomm.prng import Prng

    rng = Prng(11)
    seen = {}
    for trial in range(30):
        now = 2
        if trial % 3:
            d = up_driver(rng.range(1, 15))
        else:
            d = SeatracDriver(rng.range(1, 15))
            d.poll(now)
        for i in range(60):
            now += rng.range(0, 800)
            if d.ready(now) and rng.chance(0.4):
                if rng.chance(0.5):
                    d.send(now, rng.range(0, 15), rng.bytes(rng.range(0, 30)), rng.chance(0.5))
                else:
                    d.ping(now, rng.range(0, 16))
            elif rng.chance(0.6):
                cid, payload = plausible(rng, d)
                if rng.chance(0.3):  # cut or lengthened
                    payload = payload[: rng.below(len(payload) + 1)] + rng.bytes(rng.below(3))
                d.feed(now, sc.encode(sc.SYNC_RSP, cid, payload))
            else:
                d.feed(now, rng.bytes(rng.range(1, 50)))
            d.poll(now)
            d.take_output()
            for ev in d.take_events():
                seen[ev[0]] = seen.get(ev[0], 0) + 1
    # every kind of event came up, so the random input reached every path
    for code in (EV_RX, EV_TX_DONE, EV_DELIVERED, EV_TX_FAILED, EV_RANGE, EV_DRIVER_UP, EV_DRIVER_DOWN):
        assert seen.get(code), (code, seen)


def plausible(rng, d):
    # A message of a kind the driver handles, with random fields: aimed at
    # whatever the driver is waiting for about half of the time.
    cid = (1, 2, 0x10, 0x15, 0x40, 0x42, 0x43, 0x60, 0x61, 0x61, 0x63, 0x39)[rng.below(12)]
    slot = d.slot
    if d.cmd in (sc.CID_SYS_INFO, sc.CID_SETTINGS_GET) and rng.chance(0.6):  # configuring
        line = SYS_INFO_EXAMPLE if d.cmd == sc.CID_SYS_INFO else settings_line(d.config.want_id)
        return d.cmd, bytes(int(line[i : i + 2], 16) for i in range(3, len(line) - 6, 2))
    if slot.state == 2 and rng.chance(0.6):  # the status of our command
        cid = 0x40 if slot.kind else 0x60
    elif slot.state == 3 and rng.chance(0.6):  # the outcome on the air
        cid = (0x42, 0x43) if slot.kind else (0x61, 0x63)
        cid = cid[rng.below(2)]
    addr = d.slot.addr if rng.chance(0.5) else rng.below(16)
    own = d.beacon_id or 1
    if cid in (0x40, 0x60):
        return cid, bytes(((0, 0, 0, 0x30, 5)[rng.below(5)], addr))
    if cid in (0x43, 0x63):
        return cid, bytes((0x34, addr))
    if cid in (0x42, 0x61):
        flags = rng.below(8)
        fix = bytes((own, addr, flags, rng.below(8))) + rng.bytes(12)
        if flags & 1:
            fix += rng.bytes(10)
        if flags & 2:
            ch = rng.below(5)
            fix += bytes((ch,)) + rng.bytes(2 * ch + 6)
        if flags & 4:
            fix += rng.bytes(6)
        if cid == 0x61:
            n = rng.below(32)
            ack = 1 if slot.state == 3 and rng.chance(0.7) else rng.below(2)
            fix += bytes((ack, n)) + rng.bytes(n) + rng.bytes(rng.below(2))
        return cid, fix
    return cid, rng.bytes(rng.range(0, 60))


def test_every_status_code_has_its_name_and_an_unknown_one_its_number():
    from acomm.drivers.seatrac_wire import _CST_NAMES, status_name

    words = _CST_NAMES.split()
    for i in range(0, len(words), 2):
        assert status_name(int(words[i], 16)) == words[i + 1]
    assert status_name(0x02) == "CST_0x02" and status_name(0xFF) == "CST_0xFF"
    assert status_name(0x3F) == "XCVR_STATE_RESP"  # the last, with no space after it
