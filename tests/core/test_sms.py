# The GSM SMS driver and its emulator: the reference's PDU vector byte for
# byte (ref/modem-protocols.md 6.2), SMS-DELIVER decoding and its bounds,
# the PDU- and text-mode exchanges of 6.2-6.5, then drivers against
# emulated modems through one emulated SMS centre over FakeUART: +CMTI and
# polling, unknown senders, full storage, +CMS errors, no signal, garbage,
# a modem that stops answering or restarts; and Links and Nodes end to end.
from acomm.drivers.caps import CAP_ADDRESSING
from acomm.drivers import sms_pdu as pdu
from acomm.drivers import sms_wire as w
from acomm.drivers.sms import SmsDriver
from acomm.errors import AcommError, DecodeError, EncodeError
from acomm.events import DELIVERED, EV_DRIVER_DOWN, EV_DRIVER_UP, EV_RX, EV_TX_DONE, EV_TX_FAILED
from acomm_sim.gsm import GsmEmulator, default_number
from acomm_sim.gsm_net import GsmNetwork
from checks import raises
import modemnet
from linkcheck import check_exactly_one_final
from surfacenet import Fed, Rig, soak

REF_PDU = b"0001000C9144770009103200040548656C6C6F"
REF_NUMBER = "+447700900123"
NUMBERS = {1: default_number(1), 2: default_number(2), 5: REF_NUMBER}
FAST = {"retry_ms": 1000, "csq_retry_ms": 5000, "list_period_ms": 60000}


# -- PDUs --------------------------------------------------------------------------------
def test_submit_pdu_of_the_reference_byte_for_byte():
    p, n = pdu.encode_submit(REF_NUMBER, b"Hello")
    assert pdu.to_hex(p) == REF_PDU and n == 18 and p == pdu.from_hex(REF_PDU)
    assert pdu.decode_submit(p) == (REF_NUMBER, 4, b"Hello", None, None)
    # a national number, a validity period, a stored-elsewhere SMSC
    p, n = pdu.encode_submit("07700900123", bytes(140), vp=167, smsc="+447785016005")
    assert p[:8] == pdu.from_hex(b"0791447758100650") and p[8] == 0x11 and n == len(p) - 8
    assert pdu.decode_submit(p) == ("07700900123", 4, bytes(140), 167, None)
    raises(EncodeError, pdu.encode_submit, REF_NUMBER, bytes(141))
    raises(EncodeError, pdu.encode_submit, "+44x", b"x")
    p, _ = pdu.encode_submit("+123", b"x")
    assert p[2:6] == b"\x00\x03\x91\x21" and p[6] == 0xF3  # odd digit count: F pads
    raises(EncodeError, pdu.encode_submit, REF_NUMBER, b"x", 4, 256)


def test_deliver_pdus_septets_and_bounds():
    assert pdu.to_hex(pdu.pack_septets(b"hello")) == b"E8329BFD06"
    assert pdu.unpack_septets(pdu.from_hex(b"E8329BFD06"), 5) == b"hello"
    d = pdu.encode_deliver(REF_NUMBER, b"\x00\xffbin")
    assert pdu.decode_deliver(d)[:3] == (REF_NUMBER, 4, b"\x00\xffbin")
    d7 = pdu.encode_deliver("12345", b"SGVsbG8=", pdu.DCS_7BIT)
    assert pdu.decode_deliver(d7)[:3] == ("12345", 0, b"SGVsbG8=")
    # an alphanumeric sender name (TON 0xD0)
    name = pdu.pack_septets(b"Acomm")
    alpha = b"\x00\x04" + bytes((len(name) * 2, 0xD0)) + name + b"\x00\x04" + bytes(7) + b"\x02hi"
    assert pdu.decode_deliver(alpha)[0] == "Acomm"
    # a user data header is handed back apart
    udh = b"\x00\x44" + pdu.encode_address(REF_NUMBER) + b"\x00\x04" + bytes(7) + b"\x08\x05\x00\x03\x01\x02\x01ab"
    assert pdu.decode_deliver(udh)[2:] == (b"ab", bytes(7), b"\x00\x03\x01\x02\x01")
    # every cut of a valid PDU is a DecodeError, never another exception
    for k in range(len(d)):
        raises(DecodeError, pdu.decode_deliver, d[:k])
    raises(DecodeError, pdu.decode_deliver, pdu.from_hex(REF_PDU))  # a SUBMIT
    raises(DecodeError, pdu.from_hex, b"0G")
    raises(DecodeError, pdu.from_hex, b"000")


def test_text_mode_coding_and_the_lines_of_the_modem():
    assert w.encode_text(bytes(120)) == b"A" * 160 and w.decode_text(b"A" * 160) == bytes(120)
    assert w.decode_text(b"aGVsbG8A/w==") == b"hello\x00\xff"
    for bad in (b"", b"abc", b"ab$=", b"aGVs bG8="):
        raises(DecodeError, w.decode_text, bad)
    assert w.parse_csq(b"+CSQ: 17,99") == 17 and w.parse_csq(b"+CSQ: 99,99") == 99
    raises(DecodeError, w.parse_csq, b"+CSQ: 40,0")
    assert w.parse_index(b'+CMTI: "SM",3', b"+CMTI:") == 3 and w.parse_index(b"+CMGL: 7,1,,24", b"+CMGL:") == 7
    assert w.parse_index(b'+CMTI: "SM",x', b"+CMTI:") is None
    assert w.cmgr_sender(b'+CMGR: "REC UNREAD","+447700900123",,"24/05/01,12:00:00+00"') == REF_NUMBER
    assert w.cmgr_pdu_length(b"+CMGR: 0,,24") == 24 and w.parse_mr(b"+CMGS: 12") == 12


# -- byte-exact --------------------------------------------------------------------------------
def up_fed(pdu_mode=True):
    f = Fed(SmsDriver(1, NUMBERS, pdu_mode=pdu_mode, time_period_ms=0))
    assert f.poll() == b"ATE0Q0V1\r"
    assert f.answer(b"ATE0Q0V1\r\r\nOK\r\n") == b"AT+CMEE=1\r"
    assert f.answer(b"\r\nOK\r\n") == b"AT+CPIN?\r"
    assert f.answer(b"\r\n+CPIN: READY\r\n\r\nOK\r\n") == (b"AT+CMGF=0\r" if pdu_mode else b"AT+CMGF=1\r")
    if not pdu_mode:
        assert f.answer(b"\r\nOK\r\n") == b'AT+CSCS="GSM"\r'
    assert f.answer(b"\r\nOK\r\n") == b"AT+CNMI=2,1,0,0,0\r"
    assert f.answer(b"\r\nOK\r\n") == b"AT+CSQ\r"
    # up: the storage is listed at once
    assert f.answer(b"\r\n+CSQ: 17,99\r\n\r\nOK\r\n") == (b"AT+CMGL=4\r" if pdu_mode else b'AT+CMGL="ALL"\r')
    assert f.take() == [(EV_DRIVER_UP,)]
    assert f.answer(b"\r\nOK\r\n") == b""
    assert f.d.ready(f.t) and f.d.signal == 17
    return f


def test_pdu_mode_exchange_byte_for_byte():
    f = up_fed()
    d = f.d
    assert d.caps.has(CAP_ADDRESSING) and d.caps.mtu_tx == 140 and d.broadcast_addr is None
    h = d.send(f.t, 5, b"Hello")
    assert d.take_output() == b"AT+CMGS=18\r"
    assert f.answer(b"\r\n> ") == REF_PDU + b"\x1a"
    assert f.answer(b"\r\n+CMGS: 12\r\n\r\nOK\r\n") == b""
    assert f.take() == [(EV_TX_DONE, h)]
    # a message arrives: read, handed up with the sender's node id, deleted
    deliver = pdu.encode_deliver(REF_NUMBER, b"frame")
    assert f.answer(b'\r\n+CMTI: "SM",3\r\n') == b"AT+CMGR=3\r"
    line = b"\r\n+CMGR: 0,,%d\r\n%s\r\n\r\nOK\r\n" % (len(deliver) - 8, pdu.to_hex(deliver))
    assert f.answer(line) == b"AT+CMGD=3\r"
    assert f.take() == [(EV_RX, 5, 1, b"frame")]
    assert f.answer(b"\r\nOK\r\n") == b""
    assert d.stats["received"] == 1 and d.stats["deleted"] == 1 and d.junk == {}


def test_text_mode_exchange_of_the_reference():
    f = up_fed(pdu_mode=False)
    d = f.d
    assert d.caps.mtu_tx == 120
    h = d.send(f.t, 5, b"Hello")
    assert d.take_output() == b'AT+CMGS="+447700900123"\r'
    assert f.answer(b"\r\n> ") == b"SGVsbG8=\x1a"
    f.answer(b"\r\n+CMGS: 12\r\n\r\nOK\r\n")
    assert f.take() == [(EV_TX_DONE, h)]
    assert f.answer(b'\r\n+CMTI: "SM",3\r\n') == b"AT+CMGR=3\r"
    out = f.answer(b'\r\n+CMGR: "REC UNREAD","+447700900123",,"24/05/01,12:00:00+00"\r\nSGVsbG8=\r\n\r\nOK\r\n')
    assert out == b"AT+CMGD=3\r" and f.take() == [(EV_RX, 5, 1, b"Hello")]


def test_refusals_errors_and_a_missing_prompt():
    f = up_fed()
    d = f.d
    raises(EncodeError, d.send, f.t, None, b"all")  # no broadcast
    raises(EncodeError, d.send, f.t, 9, b"who")  # no number
    raises(EncodeError, d.send, f.t, 2, bytes(141))
    raises(EncodeError, d.send, f.t, 2, b"")
    raises(AcommError, SmsDriver, 1, {2: "+44 77"})
    h = d.send(f.t, 2, b"x")
    raises(AcommError, d.send, f.t, 2, b"busy")
    d.take_output()
    f.answer(b"\r\n> ")
    f.answer(b"\r\n+CMS ERROR: 38\r\n")
    assert f.take() == [(EV_TX_FAILED, h, "+CMS ERROR: 38")] and d.last_error == "+CMS ERROR: 38"
    h = d.send(f.t, 2, b"y")
    assert d.take_output().startswith(b"AT+CMGS=")
    assert f.poll(5001) == b"\x1b\r"  # ESC leaves a prompt that may have come
    assert f.take() == [(EV_TX_FAILED, h, "no > prompt")]
    f.poll(1000)
    assert d.ready(f.t)
    # a damaged PDU line is read again, then given up and deleted
    f.answer(b'\r\n+CMTI: "SM",4\r\n')
    assert f.answer(b"\r\n+CMGR: 0,,20\r\n0791ZZ\r\n\r\nOK\r\n") == b"AT+CMGR=4\r"
    assert f.answer(b"\r\n+CMGR: 0,,20\r\n07914477\r\n\r\nOK\r\n") == b"AT+CMGD=4\r"
    assert d.stats["rx_bad"] == 2 and [e for e in f.take() if e[0] == EV_RX] == []
    f.answer(b"\r\nOK\r\n")
    # taken while the signal poll was out, which then says "no signal": the
    # message waits, and fails once give_up_ms have passed
    assert f.poll(60000) == b"AT+CSQ\r"
    h = d.send(f.t, 2, b"z")
    assert f.answer(b"\r\n+CSQ: 99,99\r\n\r\nOK\r\n") == b""
    assert f.take() == [(EV_DRIVER_DOWN, "no signal")]
    f.poll(599000)
    assert f.take() == []
    f.poll(1000)
    assert (EV_TX_FAILED, h, "no signal") in f.take()


# -- against the emulator -------------------------------------------------------------------
def rig(n=2, drv=None, emu=None, net=None):
    opts = dict(FAST)
    opts.update(drv or {})
    eo = {"send_ms": 1000, "boot_ms": 500}
    eo.update(emu or {})
    r = Rig([SmsDriver(i + 1, NUMBERS, **opts) for i in range(n)], lambda net, a: GsmEmulator(net, a, **eo),
            net or GsmNetwork(delay_ms=2000))
    assert r.run(5000, until=lambda: all(EV_DRIVER_UP in [e[0] for e in ev] for ev in r.of_all()))
    return r


def test_messages_both_ways_in_both_modes():
    for pdu_mode in (True, False):
        r = rig(drv={"pdu_mode": pdu_mode})
        a, b = r.drivers
        h = a.send(r.now(), 2, b"\x00binary\xff\r\n")
        assert r.run(20000, until=r.got(1, EV_RX))
        assert r.of(0, EV_TX_DONE) == [(EV_TX_DONE, h)]
        assert r.of(1, EV_RX) == [(EV_RX, 1, 2, b"\x00binary\xff\r\n")]
        b.send(r.now(), 1, bytes(range(b.caps.mtu_tx)))
        assert r.run(20000, until=r.got(0, EV_RX))
        assert r.of(0, EV_RX) == [(EV_RX, 2, 1, bytes(range(b.caps.mtu_tx)))]
        r.run(1000)
        for i in (0, 1):
            assert r.emus[i].store_ == {}  # read and deleted
            assert r.drivers[i].junk == {} and r.drivers[i].stats["unexpected"] == 0
        assert r.emus[0].sent[0][1] == (4 if pdu_mode else 0)


def test_polling_finds_messages_without_indications():
    r = rig(drv={"cnmi": False, "list_period_ms": 20000})
    r.drivers[0].send(r.now(), 2, b"poll me")
    assert r.run(30000, until=r.got(1, EV_RX))
    assert r.of(1, EV_RX) == [(EV_RX, 1, 2, b"poll me")]
    assert r.emus[1].commands.get(b"AT+CNMI") is None and r.emus[1].commands[b"AT+CMGL"] >= 2


def test_unknown_senders_and_text_messages_are_dropped_and_counted():
    r = rig(1)
    r.net.queue_sms(r.now(), r.emus[0].number, b"who am i", src="+19995550100")
    r.net.queue_sms(r.now(), r.emus[0].number, b"plain text", src=NUMBERS[2], dcs=0)
    r.run(5000)
    d = r.drivers[0]
    assert d.stats["rx_unknown_sender"] == 1 and d.stats["rx_not_binary"] == 1 and r.of(0, EV_RX) == []
    assert r.emus[0].store_ == {}  # deleted all the same


def test_a_full_storage_holds_messages_at_the_centre():
    r = rig(drv={"cnmi": False, "list_period_ms": 30000}, emu={"storage": 1})
    net = r.net
    net.retry_ms = 5000
    for k in range(3):
        r.drivers[0].send(r.now(), 2, b"m%d" % k)
        assert r.run(5000, until=lambda: r.drivers[0].ready(r.now()))
    assert r.run(120000, until=lambda: len(r.of(1, EV_RX)) == 3)
    # the centre's retries may change the order, as a real one's do
    assert sorted(e[3] for e in r.of(1, EV_RX)) == [b"m0", b"m1", b"m2"] and net.expired == 0


def test_network_errors_and_no_signal():
    r = rig(1, emu={"rssi": 99})
    d = r.drivers[0]
    assert r.of(0, EV_DRIVER_DOWN) == [(EV_DRIVER_DOWN, "no signal")]
    assert not d.ready(r.now()) and d.caps.bitrate == 0
    r.emus[0].set_rssi(12)
    assert r.run(10000, until=lambda: d.ready(r.now()))
    assert r.of(0, EV_DRIVER_UP)[-1] == (EV_DRIVER_UP,) and d.caps.bitrate == 200
    r.emus[0].fail_sends(38)
    h = d.send(r.now(), 2, b"x")
    assert r.run(5000, until=r.got(0, EV_TX_FAILED))
    assert r.of(0, EV_TX_FAILED) == [(EV_TX_FAILED, h, "+CMS ERROR: 38")]
    r.emus[0].set_rssi(0)  # gone between two signal polls: the modem refuses
    h = d.send(r.now(), 2, b"y")
    assert r.run(5000, until=lambda: len(r.of(0, EV_TX_FAILED)) == 2)
    assert r.of(0, EV_TX_FAILED)[1] == (EV_TX_FAILED, h, "+CMS ERROR: 331")


def test_survives_garbage_damaged_lines_silence_and_restarts():
    r = rig(drv={"list_period_ms": 20000})
    a, b = r.drivers
    eb = r.emus[1]
    eb.inject_noise(b"\xff\x00RUBBISH\r\n+CMT")
    eb.corrupt_next(b"+CMTI")  # the indication is lost: the next listing finds it
    a.send(r.now(), 2, b"one")
    assert r.run(40000, until=r.got(1, EV_RX))
    eb.corrupt_next(b"0791")  # a damaged PDU line: read again
    a.send(r.now(), 2, b"two")
    assert r.run(40000, until=lambda: len(r.of(1, EV_RX)) == 2)
    assert [e[3] for e in r.of(1, EV_RX)] == [b"one", b"two"]
    assert b.stats["rx_bad"] == 1 and b.junk.get("noise") == 1
    # a modem that stops answering goes down and comes back
    r.emus[0].swallow_next(None, count=6)
    r.run(150000, until=r.got(0, EV_DRIVER_DOWN))
    assert r.of(0, EV_DRIVER_DOWN)[0] == (EV_DRIVER_DOWN, "modem not answering")
    assert r.run(30000, until=lambda: a.ready(r.now()))
    # a restart while sending: that message fails, the next one goes
    h = a.send(r.now(), 2, b"three")
    assert r.run(2000, until=lambda: r.emus[0].pending_reply)
    r.emus[0].reboot(r.now())
    assert r.run(30000, until=r.got(0, EV_TX_FAILED))
    (ev,) = r.of(0, EV_TX_FAILED)
    assert ev[1] == h and "modem" in ev[2]
    assert r.run(30000, until=lambda: a.ready(r.now()))
    h = a.send(r.now(), 2, b"four")
    assert r.run(20000, until=lambda: len(r.of(1, EV_RX)) == 3)
    assert r.of(1, EV_RX)[-1][3] == b"four" and (EV_TX_DONE, h) in r.of(0, EV_TX_DONE)


# -- Links and Nodes --------------------------------------------------------------------------------
def test_link_frames_end_to_end_through_the_sms_centre():
    stations = (("buoy", 1, 1), ("diver", 2, 2))
    net = modemnet.Net(SmsDriver, GsmEmulator, stations=stations, broadcast=None,
                       drv_opts=dict(FAST, numbers=NUMBERS), emu_opts={"send_ms": 1000},
                       link_opts={"ack_timeout_ms": 60000})
    assert net.up(5000)
    link = net.nodes["buoy"].links["acoustic"]
    assert link.elided and link.mtu_for(2) == 140 - 2
    r = net.send("buoy", "diver", b"surface at 12:00", ack=True, life=300)
    assert net.run(60000, step=50, until=net.done("buoy", r))
    assert net.rec("buoy").final(r) == DELIVERED
    assert net.received("diver") == [("buoy", "diver", b"surface at 12:00")]
    r2 = net.send("diver", "buoy", bytes(range(138)), ack=True, life=300)
    assert net.run(60000, step=50, until=net.done("diver", r2))
    assert net.received("buoy") == [("diver", "buoy", bytes(range(138)))]
    check_exactly_one_final(net.rec("buoy"), [r])
    check_exactly_one_final(net.rec("diver"), [r2])


def test_world_nodes_with_sms_links():
    from acomm.events import EV_RECEIVED
    from acomm_sim.world import World

    w = World(seed=6)
    lo = {"advert_period_ms": 3600000, "ack_timeout_ms": 60000}
    a = w.add("buoy", 1, "gsm", link="gsm", link_opts=lo, driver_opts=FAST)
    b = w.add("boat", 2, "gsm", link="gsm", link_opts=lo, driver_opts=FAST)
    assert w.run(10000, until=lambda: a.driver.ready(w.now()) and b.driver.ready(w.now()))
    a.node.send("gsm", "boat", b"by sms", 300, 2, True)
    assert w.run(60000, until=lambda: any(e[0] == EV_RECEIVED for e in b.events))
    assert [bytes(e[4]) for e in b.events if e[0] == EV_RECEIVED] == [b"by sms"]


def test_soak_with_faults_every_request_ends_once():
    # requests both ways while the emulated modems damage, cut and swallow
    # lines, refuse sends, lose signal, fill up, make noise and restart:
    # every request ends exactly once and nothing stays behind
    stations = (("buoy", 1, 1), ("diver", 2, 2))
    net = modemnet.Net(SmsDriver, GsmEmulator, stations=stations, broadcast=None,
                       drv_opts=dict(FAST, numbers=NUMBERS, list_period_ms=30000),
                       emu_opts={"send_ms": 1000, "storage": 2}, link_opts={"ack_timeout_ms": 60000})
    assert net.up(5000)

    def fail(rng, emu):
        emu.fail_sends((38, 42, 331)[rng.below(3)])

    events = {11: lambda n: n.emus["diver"].reboot(n.clk()), 5: lambda n: n.emus["buoy"].set_rssi(99),
              8: lambda n: n.emus["buoy"].set_rssi(15)}
    soak(net, 12, 20, 8000, (30, 300), lambda rng, i: rng.bytes(rng.range(1, 138)), fail, events)
    assert net.drivers["diver"].stats["reboots"] >= 1
