# The Iridium SBD driver and its emulator: the reference's checksum vector
# and example exchange byte for byte (ref/modem-protocols.md 5.2, 5.5), the
# SBDRB block's damage and unsolicited lines, then drivers against emulated
# modems through one emulated gateway over FakeUART: ring alerts, mailbox
# checks, failed sessions retried with back-off and given up, no signal, a
# modem that stops answering or restarts, garbage; and Links and Nodes
# end to end, with the transport on top.
from acomm.drivers.caps import CAP_ADDRESSING
from acomm.drivers import iridium_wire as w
from acomm.drivers.iridium import IridiumDriver
from acomm.frame import RAW_OVERHEAD_WIDE, raw_overhead
from acomm.errors import AcommError, DecodeError, EncodeError
from acomm.events import (
    DELIVERED,
    EV_DRIVER_DOWN,
    EV_DRIVER_UP,
    EV_RX,
    EV_TX_DONE,
    EV_TX_FAILED,
)
from acomm_sim.iridium import IridiumEmulator
from acomm_sim.iridium_net import IridiumNetwork
from checks import raises
import modemnet
from linkcheck import check_exactly_one_final
from surfacenet import Fed, Rig, soak

HELLO_WB = b"\x68\x65\x6c\x6c\x6f\x02\x14"
SIX = b"\x01\x02\x03\x04\x05\x06"
FAST = {"retry_first_ms": 5000, "retry_max_ms": 20000, "give_up_ms": 60000, "sbdix_timeout_ms": 10000,
        "csq_retry_ms": 5000, "retry_ms": 1000}


def emu_maker(**opts):
    o = {"session_ms": 2000, "boot_ms": 500}
    o.update(opts)
    return lambda net, addr: IridiumEmulator(net, addr, **o)


def rig(n=2, drv=None, emu=None, net=None):
    # drivers started (ready, when the emulators have signal)
    opts = dict(FAST)
    opts.update(drv or {})
    r = Rig([IridiumDriver(i + 1, **opts) for i in range(n)], emu_maker(**(emu or {})),
            net or IridiumNetwork(min_latency_ms=5000, max_latency_ms=5000))
    assert r.run(5000, until=lambda: all(EV_DRIVER_UP in [e[0] for e in ev] for ev in r.of_all()))
    return r


def up_fed(**opts):
    # these transcripts leave out AT-MSSTM (test_iridium_time has it)
    opts.setdefault("time_period_ms", 0)
    f = Fed(IridiumDriver(**opts))
    # a unit in any mode (echo, numeric, quiet) comes out of this one in ours
    assert f.poll() == b"ATE0Q0V1\r"
    for cmd in (b"AT&K0\r", b"AT+SBDMTA=1\r", b"AT+SBDD0\r"):
        assert f.answer(b"OK\r\n") == cmd
    assert f.answer(b"0\r\nOK\r\n") == b"AT+CSQ\r"
    assert f.answer(b"+CSQ:4\r\nOK\r\n") == b""
    assert f.take() == [(EV_DRIVER_UP,)]
    assert f.d.ready(f.t) and f.d.signal == 4 and f.d.caps.bitrate == 100
    return f


# -- the wire --------------------------------------------------------------------------
def test_checksum_vectors_of_the_reference():
    assert w.sbdwb_data(b"hello") == HELLO_WB
    assert w.sbdrb_block(b"hello") == b"\x00\x05" + HELLO_WB
    assert w.sbdrb_block(b"") == b"\x00\x00\x00\x00"
    assert w.checksum(b"\xff" * 300) == (255 * 300) & 0xFFFF
    raises(EncodeError, w.sbdwb_data, b"")
    raises(EncodeError, w.sbdwb_data, bytes(341))
    assert len(w.sbdwb_data(bytes(340))) == 342


def test_sbdix_reports_and_mo_status_names():
    assert w.parse_sbdix(b"+SBDIX: 0, 23, 1, 5, 6, 0") == [0, 23, 1, 5, 6, 0]
    assert w.parse_sbdix(b"+SBDIX:32,1,2,0,0,0") == [32, 1, 2, 0, 0, 0]
    for bad in (b"+SBDIX: 0, 23, 1", b"+SBDIX: a, 1, 1, 1, 1, 1", b"+SBDIX: 0, 70000, 0, 0, 0, 0",
                b"+SBDIX: 0, 1, 3, 0, 0, 0", b"SBDIX: 0, 1, 0, 0, 0, 0", b"+SBDIX: 0, -1, 0, 0, 0, 0", b""):
        raises(DecodeError, w.parse_sbdix, bad)
    assert w.mo_status_name(32) == "no network service" and w.mo_status_name(18) == "RF drop"
    assert w.mo_status_name(40) == "reserved failure" and w.mo_status_name(7) == "reserved failure"
    assert w.parse_csq(b"+CSQ:5") == 5 and w.parse_csq(b"+CSQ: 0") == 0
    for bad in (b"+CSQ:6", b"+CSQ:", b"+CSQ:x", b"+CSQ: 17,99"):
        raises(DecodeError, w.parse_csq, bad)


# -- byte-exact --------------------------------------------------------------------------
def test_driver_speaks_the_reference_exchange():
    f = up_fed()
    d = f.d
    assert not d.caps.has(CAP_ADDRESSING) and d.broadcast_addr is None
    assert d.caps.mtu_tx == 340 and d.caps.mtu_rx == 270 and d.caps.cost_tx > 0 and d.caps.latency_ms >= 10000
    h = d.send(f.t, 7, b"hello")  # the address is ignored: all goes to the gateway
    assert not d.ready(f.t)
    raises(AcommError, d.send, f.t, None, b"again")
    assert d.take_output() == b"AT+SBDWB=5\r"
    assert f.answer(b"READY\r\n") == HELLO_WB
    assert f.answer(b"0\r\nOK\r\n") == b"AT+SBDIX\r"
    assert f.answer(b"+SBDIX: 0, 23, 1, 5, 6, 0\r\nOK\r\n") == b"AT+SBDRB\r"
    assert f.take() == [(EV_TX_DONE, h)]
    assert f.answer(b"\x00\x06" + SIX + b"\x00\x15" + b"OK\r\n") == b"AT+SBDD0\r"
    assert f.take() == [(EV_RX, None, None, SIX)]
    assert f.answer(b"0\r\nOK\r\n") == b""
    assert d.ready(f.t) and d.last_session == [0, 23, 1, 5, 6, 0]
    assert d.junk == {} and d.stats["unexpected"] == 0


def test_sbdrb_reads_past_unsolicited_lines_and_reads_damage_again():
    f = up_fed()
    d = f.d
    d.send(f.t, None, b"x")
    d.take_output()
    f.answer(b"READY\r\n")
    f.answer(b"0\r\nOK\r\n")
    # MT queued 0 here; one MT in the buffer
    assert f.answer(b"+SBDIX: 0, 1, 1, 1, 6, 0\r\nOK\r\n") == b"AT+SBDRB\r"
    # a ring alert arrives where the length is expected (DUNE's case),
    # then a block whose checksum is wrong: read again
    assert f.answer(b"SBDRING\r\n\x00\x06" + SIX + b"\x00\x16OK\r\n") == b"AT+SBDRB\r"
    assert d.stats["rings"] == 1 and d.stats["mt_bad"] == 1
    # a length over the MT maximum: junk, read again
    assert f.answer(b"\x01\x20" + bytes(20) + b"OK\r\n") == b"AT+SBDRB\r"
    assert d.junk.get("block too long") == 1
    # another unsolicited line before the block does not upset it either
    out = f.answer(b"\r\n+CIEV:0,3\r\n\x00\x06" + SIX + b"\x00\x15" + b"OK\r\n")
    assert [e for e in f.take() if e[0] == EV_RX] == [(EV_RX, None, None, SIX)]
    assert out == b"AT+SBDD0\r"
    # the ring alert asks for a session with SBDIXA
    assert f.answer(b"0\r\nOK\r\n") == b"AT+SBDIXA\r"


def test_mt_given_up_after_three_damaged_reads():
    f = up_fed(mailbox_check_ms=0)
    d = f.d
    d.send(f.t, None, b"x")
    d.take_output()
    f.answer(b"READY\r\n")
    f.answer(b"0\r\nOK\r\n")
    f.answer(b"+SBDIX: 0, 1, 1, 1, 6, 0\r\nOK\r\n")
    for _ in range(3):
        out = f.answer(b"\x00\x06" + SIX + b"\x00\x00OK\r\n")
    assert out == b"AT+SBDD0\r" and d.stats["mt_lost"] == 1 and d.stats["mt_bad"] == 3
    assert [e for e in f.take() if e[0] == EV_RX] == []


def test_sbdwb_statuses_and_sizes():
    f = up_fed()
    d = f.d
    raises(EncodeError, d.send, f.t, None, b"")
    raises(EncodeError, d.send, f.t, None, bytes(341))
    h = d.send(f.t, None, bytes(340))
    assert d.take_output() == b"AT+SBDWB=340\r"
    assert len(f.answer(b"READY\r\n")) == 342
    # checksum mismatch: written again; the modem's own timeout (status 1,
    # no OK): again; a third failure is final
    assert f.answer(b"2\r\nOK\r\n") == b"AT+SBDWB=340\r"
    f.answer(b"READY\r\n")
    assert f.answer(b"1\r\n") == b"AT+SBDWB=340\r"
    f.answer(b"READY\r\n")
    assert f.answer(b"2\r\nOK\r\n") == b"AT+SBDD0\r"  # nothing sent: clear what is there
    assert f.take() == [(EV_TX_FAILED, h, "SBDWB status 2: checksum mismatch")]
    f.answer(b"0\r\nOK\r\n")
    assert d.ready(f.t)
    # a prefix for RockBLOCK relays costs its bytes
    g = up_fed(mo_prefix=b"RB0001234")
    assert g.d.caps.mtu_tx == 331
    g.d.send(g.t, None, b"hi")
    assert g.d.take_output() == b"AT+SBDWB=11\r"
    assert g.answer(b"READY\r\n") == w.sbdwb_data(b"RB0001234hi")


# -- against the emulator -------------------------------------------------------------------
def test_mo_reaches_the_other_modem_by_ring_alert():
    r = rig()
    h = r.drivers[0].send(r.now(), None, b"to the shore")
    assert r.run(40000, until=r.got(1, EV_RX))
    assert r.of(0, EV_TX_DONE) == [(EV_TX_DONE, h)]
    assert r.of(1, EV_RX) == [(EV_RX, None, None, b"to the shore")]
    # the receiver answered the ring alert; the sender cleared its MO buffer
    assert [s[1] for s in r.emus[1].sessions] == [b"+SBDIXA"]
    assert r.drivers[1].stats["rings"] == 1
    r.run(2000)
    assert r.emus[0].mo is None and r.net.mo_log[-1][2] == b"to the shore"
    # and back
    r.drivers[1].send(r.now(), None, b"ack")
    assert r.run(40000, until=r.got(0, EV_RX))
    assert r.of(0, EV_RX) == [(EV_RX, None, None, b"ack")]
    for d in r.drivers:
        assert d.junk == {} and d.stats["unexpected"] == 0 and d.stats["sessions_failed"] == 0


def test_the_gateways_shore_hook_gets_the_momsn_the_modem_reported():
    # a shore behind the gateway (DirectIP) files each MO message under the MOMSN the modem's own
    # +SBDIX gave: the emulator counts the session's MOMSN before it hands the message on
    r = rig()
    got = []
    r.net.shores.append(lambda now, imei, serial, momsn, mtmsn, data: got.append((momsn, data, r.emus[0].momsn)))
    for n, text in ((1, b"first"), (2, b"second")):
        assert r.run(40000, until=lambda: r.drivers[0].ready(r.now()))
        r.drivers[0].send(r.now(), None, text)
        assert r.run(40000, until=lambda: len(got) == n)
    assert [(g[0], g[1]) for g in got] == [(1, b"first"), (2, b"second")], got
    assert all(g[0] == g[2] for g in got), got  # the MOMSN +SBDIX reports, already counted


def test_failed_sessions_back_off_then_succeed():
    r = rig()
    r.emus[0].fail_sessions(18, 2)  # RF drop twice
    t0 = r.now()
    h = r.drivers[0].send(t0, None, b"persist")
    assert r.run(60000, until=r.got(0, EV_TX_DONE))
    s = r.emus[0].sessions
    assert [x[2] for x in s] == [18, 18, 0]
    gaps = [s[i + 1][0] - s[i][0] for i in range(2)]
    # session_ms (2 s) plus the back-off: 5 s, then 10 s; a CSQ in between
    assert 7000 <= gaps[0] <= 7200 and 12000 <= gaps[1] <= 12200, gaps
    assert r.of(0, EV_TX_DONE) == [(EV_TX_DONE, h)] and r.of(0, EV_TX_FAILED) == []
    assert r.drivers[0].last_failure == "MO status 18: RF drop"


def test_gives_up_with_the_reason_after_its_time():
    r = rig()
    r.emus[0].fail_sessions(32, 100)  # no network service, with bars
    h = r.drivers[0].send(r.now(), None, b"lost cause")
    assert r.run(90000, until=r.got(0, EV_TX_FAILED))
    (ev,) = r.of(0, EV_TX_FAILED)
    assert ev[1] == h and ev[2].startswith("MO status 32: no network service (gave up after")
    starts = [x[0] - 2000 for x in r.emus[0].sessions]
    gaps = [starts[i + 1] - starts[i] - 2000 for i in range(len(starts) - 1)]
    # doubling from 5 s, capped at 20 s (a CSQ may delay one by a step)
    assert [g // 1000 for g in gaps] == [5, 10, 20, 20][: len(gaps)] and len(gaps) >= 3, gaps
    assert r.of(0, EV_TX_DONE) == []
    r.run(3000)
    assert r.emus[0].mo is None and r.drivers[0].ready(r.now())  # the MO buffer was cleared
    assert r.drivers[0].stats["mo_failed"] == 1


def test_mailbox_check_fetches_mt_without_ring_alerts():
    r = rig(1, drv={"ring_alerts": False, "mailbox_check_ms": 30000})
    t0 = r.now()
    for k in range(3):
        r.net.queue_mt(r.now(), r.emus[0].imei, b"mt %d" % k)
    assert r.run(60000, until=lambda: len(r.of(0, EV_RX)) == 3)
    assert [e[3] for e in r.of(0, EV_RX)] == [b"mt 0", b"mt 1", b"mt 2"]
    first = r.when(0, EV_RX)[0] - t0
    assert 30000 <= first <= 34000, first  # nothing before the check was due
    d = r.drivers[0]
    # one mailbox check, then sessions while the gateway said more were queued
    assert d.stats["mailbox_checks"] == 1 and d.stats["sessions"] == 3 and d.stats["rings"] == 0
    assert [s[1] for s in r.emus[0].sessions] == [b"+SBDIX"] * 3


def test_no_signal_holds_sessions_and_says_so():
    r = rig(1, emu={"bars": 0})
    d = r.drivers[0]
    assert r.run(3000, until=r.got(0, EV_DRIVER_DOWN))
    assert r.of(0, EV_DRIVER_DOWN) == [(EV_DRIVER_DOWN, "no signal")]
    assert not d.ready(r.now()) and d.caps.bitrate == 0 and d.signal == 0
    r.emus[0].set_bars(2)
    assert r.run(10000, until=lambda: d.ready(r.now()))
    assert r.of(0, EV_DRIVER_UP)[-1] == (EV_DRIVER_UP,) and d.caps.bitrate == 100
    # the signal goes while a message waits: the session fails (32), the
    # driver reads the signal again and waits for it
    h = d.send(r.now(), None, b"patience")
    r.emus[0].set_bars(0)
    assert r.run(20000, until=lambda: len(r.of(0, EV_DRIVER_DOWN)) == 2)
    n = len(r.emus[0].sessions)
    r.run(30000)
    assert len(r.emus[0].sessions) == n  # no session without signal
    r.emus[0].set_bars(1)
    assert r.run(30000, until=r.got(0, EV_TX_DONE))
    assert r.of(0, EV_TX_DONE) == [(EV_TX_DONE, h)]


def test_message_waiting_without_signal_fails_when_its_time_is_up():
    r = rig(1, emu={"bars": 0})
    d = r.drivers[0]
    r.emus[0].set_bars(3)
    assert r.run(10000, until=lambda: d.ready(r.now()))
    h = d.send(r.now(), None, b"never")
    r.emus[0].set_bars(0)
    assert r.run(90000, until=r.got(0, EV_TX_FAILED))
    assert r.of(0, EV_TX_FAILED)[0][1] == h and "no signal" in r.of(0, EV_TX_FAILED)[0][2]


def test_survives_garbage_and_malformed_answers():
    r = rig()
    e = r.emus[0]
    e.inject_noise(b"\x00\xff\x13garbage\r\n" + b"X" * 500 + b"\r\n")
    e.corrupt_next(b"+SBDIX")  # an unreadable report: the session counts as failed
    e.truncate_next(b"+SBDIX", terminate=False)
    h = r.drivers[0].send(r.now(), None, b"through noise")
    assert r.run(90000, until=r.got(0, EV_TX_DONE))
    r.run(20000)
    assert r.of(0, EV_TX_DONE) == [(EV_TX_DONE, h)] and r.of(1, EV_RX)[0][3] == b"through noise"
    d = r.drivers[0]
    assert d.junk.get("noise") == 1 and d.junk.get("overlong") == 1
    assert d.stats["sessions_failed"] >= 1
    # the MO went out more than once (a session "failed" that had worked):
    # the receiver may get copies; the link drops them
    assert len(r.of(1, EV_RX)) >= 1


def test_modem_that_stops_answering_goes_down_and_comes_back():
    r = rig()
    d = r.drivers[0]
    r.emus[0].swallow_next(None, count=8)
    h = d.send(r.now(), None, b"after the silence")
    assert r.run(60000, until=r.got(0, EV_DRIVER_DOWN))
    assert r.of(0, EV_DRIVER_DOWN)[0] == (EV_DRIVER_DOWN, "modem not answering")
    assert r.run(60000, until=r.got(1, EV_RX))
    assert r.of(0, EV_TX_DONE) == [(EV_TX_DONE, h)] and r.of(0, EV_TX_FAILED) == []
    assert r.of(0, EV_DRIVER_UP)[-1] == (EV_DRIVER_UP,) and d.ready(r.now())


def test_restart_mid_session_is_noticed_and_the_message_still_goes():
    r = rig()
    d = r.drivers[0]
    h = d.send(r.now(), None, b"survivor")
    assert r.run(5000, until=lambda: d.slot.state == 4)  # in its session
    r.emus[0].reboot(r.now())
    assert r.run(60000, until=r.got(1, EV_RX))
    assert d.stats["reboots"] >= 1  # its echo came back
    assert r.of(0, EV_TX_DONE) == [(EV_TX_DONE, h)] and r.of(0, EV_TX_FAILED) == []
    assert r.of(1, EV_RX) == [(EV_RX, None, None, b"survivor")]
    assert r.emus[0].mta  # ring alerts on again after the restart


# -- Links and Nodes over the gateway ---------------------------------------------------------
def iridium_net(**link):
    lo = {"ack_timeout_ms": 120000}
    lo.update(link)
    net = modemnet.Net(IridiumDriver, IridiumEmulator, drv_opts=FAST, emu_opts={"session_ms": 2000},
                       link_opts=lo)
    assert net.up(5000)
    return net


def test_link_frames_end_to_end_through_the_gateway():
    net = iridium_net()
    link = net.nodes["buoy"].links["acoustic"]
    assert link.mtu_for(20) == 340 - raw_overhead(10, 20) and link.caps.mtu_tx == 340 - RAW_OVERHEAD_WIDE
    r = net.send("buoy", "diver", b"position report", ack=True, life=300)
    assert net.run(200000, step=50, until=net.done("buoy", r))
    assert net.rec("buoy").final(r) == DELIVERED
    assert net.received("diver") == [("buoy", "diver", b"position report")]
    # too big for one SBD message: refused at once with the MTU in the reason
    assert not link.request(net.clk(), 99, "diver", bytes(link.mtu_for(20) + 1), 60)
    assert "MTU" in net.rec("buoy").reasons(99)[0]
    check_exactly_one_final(net.rec("buoy"), [r, 99])


def test_world_nodes_with_iridium_beside_acoustic_ones():
    from acomm.events import EV_RECEIVED, EV_STATUS, is_final
    from acomm_sim.world import World

    w = World(seed=4)
    quiet = {"advert_period_ms": 3600000, "ack_timeout_ms": 120000}
    sat = {"session_ms": 2000}
    buoy = w.add("buoy", 1, "iridium", link="satellite", emu_opts=sat, driver_opts=FAST, link_opts=quiet)
    shore = w.add("shore", 2, "iridium", link="satellite", emu_opts=sat, driver_opts=FAST, link_opts=quiet)
    w.add("diver", 3, "seatrac", position=(0, 0, 10), link_opts={"advert_period_ms": 600000})
    assert w.run(10000, until=lambda: buoy.driver.ready(w.now()) and shore.driver.ready(w.now()))
    rid = buoy.node.send("satellite", "shore", b"from the buoy", 300, 2, True)
    assert w.run(200000, until=lambda: any(e[0] == EV_RECEIVED for e in shore.events))
    assert [bytes(e[4]) for e in shore.events if e[0] == EV_RECEIVED] == [b"from the buoy"]
    def final():
        got = [e[3] for e in buoy.events if e[0] == EV_STATUS and e[2] == rid and is_final(e[3])]
        return got[-1] if got else None

    assert w.run(100000, until=lambda: final() is not None)
    assert final() == DELIVERED


def test_transport_carries_a_packet_over_iridium_in_link_sized_fragments():
    # the transport's fragments are sized by link.mtu_for: a 1000-byte
    # packet that does not compress takes several SBD messages. Modem to
    # modem, an MO message must fit the receiver's MT buffer: mo_mtu=270
    from acomm.events import EV_PACKET
    from acomm.prng import Prng
    from acomm.transport import Transport
    from acomm_sim.world import World

    w = World(seed=5)
    quiet = {"advert_period_ms": 3600000, "ack_timeout_ms": 120000}
    sat = {"session_ms": 2000}
    drv = dict(FAST, mo_mtu=270)
    ends = [w.add(n, i, "iridium", link="satellite", emu_opts=sat, driver_opts=drv, link_opts=quiet)
            for n, i in (("buoy", 1), ("shore", 2))]
    for sn in ends:
        Transport.of(sn.node, wall=lambda: w.now() // 1000)
    assert w.run(10000, until=lambda: all(sn.driver.ready(w.now()) for sn in ends))
    data = Prng(9).bytes(1000)
    ends[0].node.transport.send(w.now(), "shore", data, 3600, 5)
    assert w.run(900000, until=lambda: any(e[0] == EV_PACKET for e in ends[1].events))
    assert [bytes(e[3]) for e in ends[1].events if e[0] == EV_PACKET] == [data]
    mo = [len(m[2]) for m in w.channel.iridium_network.mo_log if m[1] == ends[0].emu.imei]
    assert len(mo) >= 4 and max(mo) == 270, mo
    assert ends[1].emu.mt_too_big == 0


def test_soak_with_faults_every_request_ends_once():
    # requests both ways through the gateway while the emulators damage,
    # cut and swallow lines, fail sessions, lose signal, make noise and
    # restart: every request ends exactly once and nothing stays behind
    net = iridium_net()

    def fail(rng, emu):
        emu.fail_sessions((32, 18, 11)[rng.below(3)], rng.range(1, 3))

    events = {9: lambda n: n.emus["diver"].reboot(n.clk()), 5: lambda n: n.emus["buoy"].set_bars(0),
              7: lambda n: n.emus["buoy"].set_bars(4)}
    soak(net, 11, 16, 20000, (60, 400), lambda rng, i: b"soak %d" % i, fail, events)
    # both drivers saw the trouble
    assert net.drivers["diver"].stats["reboots"] >= 1 and net.drivers["buoy"].stats["sessions_failed"] >= 1
