# The link API with a hand-driven modem driver: every primitive and status.
from acomm import frame as fr
from acomm.drivers.caps import CAP_DISCOVERY, CAP_RANGING, CAP_RELIABLE
from acomm_sim.clock import ManualClock
from acomm.compat import TICKS_MAX
from acomm.events import (
    AVAILABLE,
    CANCELED,
    DELIVERED,
    EV_AVAILABILITY,
    EV_CAPS,
    EV_RANGE_RECEIVED,
    EV_RECEIVED,
    EXPIRED,
    FAILED,
    QUEUED,
    TRANSMITTED,
    TRANSMITTING,
    UNAVAILABLE,
    UNKNOWN,
    WAITING,
)
from acomm.errors import EncodeError
from acomm.link import BROADCAST, Link
from acomm.link.names import NameTable
from linkcheck import Recorder, check_exactly_one_final
from scripted_driver import MODEM_FLAGS, ScriptedDriver


def make(flags=MODEM_FLAGS, start=1000, **opts):
    clk = ManualClock(start)
    names = NameTable()
    names.add("me", 1)
    names.add("diver", 2)
    names.add("auv", 3)
    drv = ScriptedDriver(flags)
    rec = Recorder()
    opts.setdefault("advert_period_ms", 600000)
    link = Link("acoustic", drv, 1, names, rec, **opts)
    return clk, drv, rec, link


def elided(ftype, seq, payload=b""):
    return fr.encode_elided(fr.Frame(ftype, 0, 0, seq, payload))


def test_capabilities_reflect_framing_and_services():
    clk, drv, rec, link = make()
    c = link.advertise_caps()
    assert c.mtu_tx == 32 - fr.ELIDED_OVERHEAD
    assert c.has(CAP_RANGING) and c.has(CAP_DISCOVERY) and c.has(CAP_RELIABLE)
    assert rec.of(EV_CAPS)[-1][2] == c
    # a modem reconfigured after a reboot announces its new figures
    drv.caps.mtu_tx = 16
    drv.reboot()
    link.poll(clk())
    assert rec.of(EV_CAPS)[-1][2].mtu_tx == 16 - fr.ELIDED_OVERHEAD
    n = len(rec.of(EV_CAPS))
    drv.reboot()
    link.poll(clk())
    assert len(rec.of(EV_CAPS)) == n  # unchanged: no new advertisement


def test_refusals_say_why():
    clk, drv, rec, link = make()
    now = clk()
    assert not link.request(now, 1, "nobody", b"x", 10)
    assert not link.request(now, 2, "diver", bytes(40), 10)
    assert not link.request(now, 3, "diver", b"x", 0)
    assert not link.request(now, 4, "diver", b"x", -5)
    assert not link.request(now, 5, "diver", b"x", 10, priority=0)
    assert not link.request(now, 6, "diver", b"x", 10, priority=17)
    assert not link.request(now, 7, "me", b"x", 10)
    assert not link.request(now, 8, "diver", b"x", 400000)
    assert link.request(now, 9, "diver", b"x", 10)
    assert not link.request(now, 9, "diver", b"y", 10)
    for rid in range(1, 9):
        assert rec.statuses(rid) == [FAILED], rid
    assert "unknown destination" in rec.reasons(1)[0]
    assert "MTU" in rec.reasons(2)[0]
    assert "lifespan" in rec.reasons(3)[0]
    assert "in use" in rec.reasons(9)[-1]
    assert rec.statuses(9) == [QUEUED, FAILED]  # the second use of id 9 was refused
    assert drv.sent == []


def test_unacknowledged_send_ends_transmitted():
    clk, drv, rec, link = make()
    assert link.request(clk(), 1, "diver", b"hello", 10, priority=2)
    link.poll(clk())
    h, addr, data, ack = drv.sent[0]
    assert addr == 2 and not ack
    f = fr.decode_elided(data, 1, 2)
    assert f.ftype == fr.DATA and f.payload == b"hello"
    assert len(data) == 6  # one byte of acomm overhead
    clk.advance(500)
    drv.finish(h)
    link.poll(clk())
    assert rec.statuses(1) == [QUEUED, TRANSMITTING, TRANSMITTED]


def test_modem_ack_gives_delivered():
    clk, drv, rec, link = make()
    link.request(clk(), 1, "diver", b"hi", 10, ack=True)
    link.poll(clk())
    h = drv.sent[0][0]
    assert drv.sent[0][3] is True
    drv.finish(h)
    link.poll(clk())
    assert rec.statuses(1) == [QUEUED, TRANSMITTING, WAITING]
    drv.deliver(h)
    link.poll(clk())
    assert rec.statuses(1)[-1] == DELIVERED
    check_exactly_one_final(rec, [1])


def test_addressing_modem_without_acks_gets_link_acks():
    # A modem that addresses frames but never reports delivery (Benthos):
    # the elided frame asks for an ack in its flags byte, and the peer's
    # link answers with an elided ACK frame.
    from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST

    clk, drv, rec, link = make(CAP_ADDRESSING | CAP_BROADCAST)
    assert link.mtu_for(2) == 30  # one header byte and the flags byte
    link.request(clk(), 1, "diver", b"hi", 10, ack=True)
    link.poll(clk())
    h, addr, data, ack = drv.sent[0]
    assert addr == 2 and ack is False
    f = fr.decode_elided(data, 1, 2)
    assert f.flags == fr.F_ACK_REQ and f.payload == b"hi"
    drv.finish(h)
    link.poll(clk())
    assert rec.statuses(1) == [QUEUED, TRANSMITTING, WAITING]
    drv.receive(2, 1, elided(fr.ACK, f.seq))
    link.poll(clk())
    assert rec.statuses(1)[-1] == DELIVERED
    # and it acknowledges what it receives
    drv.receive(2, 1, fr.encode_elided(fr.Frame(fr.DATA, 0, 0, 5, b"yo", fr.F_ACK_REQ)))
    link.poll(clk())
    h2, addr2, data2, _ = drv.sent[-1]
    assert addr2 == 2 and fr.decode_elided(data2, 1, 2).ftype == fr.ACK
    check_exactly_one_final(rec, [1])


def test_modem_failure_retries_then_fails():
    clk, drv, rec, link = make(max_retries=1)
    link.request(clk(), 1, "diver", b"hi", 60, ack=True)
    link.poll(clk())
    drv.fail(drv.sent[-1][0], "no ack from remote")
    link.poll(clk())
    link.poll(clk())
    assert len(drv.sent) == 2  # retried once
    # the retry carries the same sequence number, so a copy can be dropped
    assert drv.sent[0][2] == drv.sent[1][2]
    drv.fail(drv.sent[-1][0], "no ack from remote")
    link.poll(clk())
    assert rec.final(1) == FAILED
    assert "no ack from remote" in rec.reasons(1)[-1]
    check_exactly_one_final(rec, [1])


def test_ack_timeout_retries_then_fails():
    clk, drv, rec, link = make(max_retries=2, ack_timeout_ms=1000)
    link.request(clk(), 1, "diver", b"hi", 60, ack=True)
    for _ in range(3):
        link.poll(clk())
        drv.finish()
        link.poll(clk())
        clk.advance(1000)
        link.poll(clk())
    assert len(drv.sent) == 3
    assert rec.final(1) == FAILED
    assert "no acknowledgement" in rec.reasons(1)[-1]
    check_exactly_one_final(rec, [1])


def test_expiry_in_queue_across_tick_wrap():
    clk, drv, rec, link = make(start=TICKS_MAX - 300)
    link.request(clk(), 1, "diver", b"long", 60)
    link.poll(clk())  # request 1 on the air, link busy
    link.request(clk(), 2, "diver", b"stale", 1)  # 1 s lifespan, crosses the wrap
    clk.advance(999)
    link.poll(clk())
    assert rec.final(2) is None
    clk.advance(1)
    link.poll(clk())
    assert rec.final(2) == EXPIRED
    drv.finish()
    link.poll(clk())
    assert len(drv.sent) == 1  # the expired request never wasted airtime
    check_exactly_one_final(rec, [1, 2])


def test_expiry_while_waiting_for_ack():
    clk, drv, rec, link = make(ack_timeout_ms=60000)
    link.request(clk(), 1, "diver", b"x", 5, ack=True)
    link.poll(clk())
    drv.finish()
    link.poll(clk())
    clk.advance(5000)
    link.poll(clk())
    assert rec.final(1) == EXPIRED
    check_exactly_one_final(rec, [1])


def test_cancel_in_every_state():
    clk, drv, rec, link = make()
    now = clk()
    # queued
    link.request(now, 1, "diver", b"a", 60)
    link.request(now, 2, "diver", b"b", 60, ack=True)
    link.request(now, 3, "diver", b"c", 60)
    link.poll(now)  # 1 transmitting
    assert link.cancel(now, 3, "operator")
    assert rec.statuses(3) == [QUEUED, CANCELED]
    assert rec.reasons(3)[-1] == "operator"
    # transmitting: canceled at once; the end of that transmission is ignored
    assert link.cancel(now, 1)
    assert rec.final(1) == CANCELED
    h1 = drv.finish()
    link.poll(now)
    assert rec.final(1) == CANCELED and rec.statuses(1).count(CANCELED) == 1
    # waiting for ack
    h2 = drv.sent[-1][0]
    assert h2 != h1
    drv.finish(h2)
    link.poll(now)
    assert rec.statuses(2)[-1] == WAITING
    assert link.cancel(now, 2)
    drv.deliver(h2)  # the late ack changes nothing
    link.poll(now)
    assert rec.final(2) == CANCELED
    # finished or unknown requests cannot be canceled
    assert not link.cancel(now, 2)
    assert not link.cancel(now, 99)
    check_exactly_one_final(rec, [1, 2, 3])
    # the link carries on
    link.request(now, 4, "diver", b"d", 60)
    link.poll(now)
    drv.finish()
    link.poll(now)
    assert rec.final(4) == TRANSMITTED


def test_alarm_waits_only_for_the_frame_on_the_air():
    clk, drv, rec, link = make(queue_capacity=64)
    now = clk()
    for i in range(40):
        link.request(now, 100 + i, "diver", b"log line", 600, priority=16)
    link.poll(now)
    assert len(drv.sent) == 1
    link.request(now, 1, "diver", b"ALARM", 60, priority=1)
    link.request(now, 2, "diver", b"telemetry", 60, priority=2)
    drv.finish()
    link.poll(now)
    assert drv.sent[1][2][1:] == b"ALARM"
    drv.finish()
    link.poll(now)
    assert drv.sent[2][2][1:] == b"telemetry"


def test_full_queue_evicts_lowest_priority_with_status():
    clk, drv, rec, link = make(queue_capacity=2)
    now = clk()
    link.request(now, 1, "diver", b"a", 60, priority=10)
    link.request(now, 2, "diver", b"b", 60, priority=16)
    assert not link.request(now, 3, "diver", b"c", 60, priority=16)
    assert "queue full" in rec.reasons(3)[0]
    assert link.request(now, 4, "diver", b"d", 60, priority=1)
    assert rec.final(2) == FAILED and "evicted" in rec.reasons(2)[-1]
    check_exactly_one_final(rec, [2, 3])


def test_receive_translates_names_and_drops_copies_and_strangers():
    clk, drv, rec, link = make()
    drv.receive(2, 1, elided(fr.DATA, 5, b"status"))
    drv.receive(2, 1, elided(fr.DATA, 5, b"status"))  # a copy
    drv.receive(3, 0, elided(fr.DATA, 1, b"to all"))  # broadcast
    drv.receive(3, 2, elided(fr.DATA, 2, b"not mine"))
    drv.receive(3, 1, b"")  # damaged
    link.poll(clk())
    got = rec.of(EV_RECEIVED)
    assert [(e[2], e[3], bytes(e[4])) for e in got] == [("diver", "me", b"status"), ("auv", BROADCAST, b"to all")]
    assert link.stats["rx_duplicates"] == 1
    assert link.stats["rx_not_for_us"] == 1
    assert link.stats["rx_bad"] == 1
    # after the duplicate window the same sequence number is new data again
    clk.advance(link.dup_window_ms)
    drv.receive(2, 1, elided(fr.DATA, 5, b"status"))
    link.poll(clk())
    assert len(rec.of(EV_RECEIVED)) == 3


def test_ranging():
    clk, drv, rec, link = make()
    assert link.range(clk(), 7, ["diver", "auv"], 30)
    link.poll(clk())
    assert drv.sent[-1][1:] == ("ping", 2)
    drv.range_reply(drv.sent[-1][0], 2, 123.4)
    link.poll(clk())
    link.poll(clk())
    assert drv.sent[-1][1:] == ("ping", 3)
    drv.range_reply(drv.sent[-1][0], None, None)  # the AUV did not answer
    link.poll(clk())
    r = rec.of(EV_RANGE_RECEIVED)[-1]
    assert r[2] == 7 and r[3] == ["diver", "auv"] and r[4] == [123.4, None]
    assert rec.final(7) == DELIVERED
    # nobody answers
    link.range(clk(), 8, ["auv"], 30)
    link.poll(clk())
    drv.range_reply(drv.sent[-1][0], None, None)
    link.poll(clk())
    assert rec.final(8) == FAILED
    # refusals
    assert not link.range(clk(), 9, [BROADCAST], 30)
    assert not link.range(clk(), 10, [], 30)
    check_exactly_one_final(rec, [7, 8, 9, 10])


def test_ranging_refused_without_capability():
    clk, drv, rec, link = make(flags=MODEM_FLAGS & ~CAP_RANGING)
    assert not link.range(clk(), 1, ["diver"], 30)
    assert "cannot measure range" in rec.reasons(1)[0]


def test_availability_from_traffic_and_loss():
    clk, drv, rec, link = make(advert_period_ms=10000, lost_after=3)
    assert link.availability("diver") == UNKNOWN
    drv.receive(2, 1, elided(fr.DATA, 0, b"x"))
    link.poll(clk())
    assert link.availability("diver") == AVAILABLE
    assert rec.of(EV_AVAILABILITY)[-1][2:] == ("diver", AVAILABLE)
    clk.advance(29999)
    link.poll(clk())
    assert link.availability("diver") == AVAILABLE
    clk.advance(1)
    link.poll(clk())
    assert link.availability("diver") == UNAVAILABLE
    assert rec.of(EV_AVAILABILITY)[-1][2:] == ("diver", UNAVAILABLE)
    drv.receive(2, 1, elided(fr.DATA, 1, b"back"))
    link.poll(clk())
    assert rec.of(EV_AVAILABILITY)[-1][2:] == ("diver", AVAILABLE)


def _advert_wait(link, since):
    # how long after a transmission at `since` the next advert is due (Discovery.advert_due)
    d = link.discovery
    return [w for w in range(d.period_ms + 1) if d.advert_due(since + w, since)][0]


def test_idle_node_advertises_and_adverts_teach_addresses():
    clk, drv, rec, link = make(advert_period_ms=10000)
    link.poll(clk())  # nothing sent yet: advertise at once
    sent_at = clk()
    h, addr, data, ack = drv.sent[-1]
    assert addr == 0  # the modem's broadcast address
    f = fr.decode_elided(data, 1, 0)
    assert f.ftype == fr.ADVERT and len(data) == 3
    drv.finish(h)
    link.poll(clk())
    # the next one after the period less a random tenth of it at most
    wait = _advert_wait(link, sent_at)
    assert 9000 <= wait <= 10000
    clk.advance(wait - 1)
    link.poll(clk())
    assert len(drv.sent) == 1
    clk.advance(1)
    link.poll(clk())
    assert len(drv.sent) == 2
    drv.finish()
    # traffic postpones the next advert
    wait = _advert_wait(link, clk())
    link.request(clk(), 1, "diver", b"x", 60)
    link.poll(clk())
    drv.finish()
    clk.advance(wait - 1)
    link.poll(clk())
    assert len(drv.sent) == 3
    clk.advance(1)
    link.poll(clk())
    assert len(drv.sent) == 4 and fr.decode_elided(drv.sent[-1][2], 1, 0).ftype == fr.ADVERT
    drv.finish()
    # an advert from node 9 at modem address 9 with a 40 s period
    drv.receive(9, 0, elided(fr.ADVERT, 3, bytes((9, 10))))
    link.poll(clk())
    assert rec.of(EV_AVAILABILITY)[-1][2:] == ("node-9", AVAILABLE)
    clk.advance(3 * 40000 - 1)
    link.poll(clk())
    assert link.discovery.state(9) == AVAILABLE
    clk.advance(1)
    link.poll(clk())
    assert link.discovery.state(9) == UNAVAILABLE


def test_channel_is_free_while_waiting_for_acks():
    # an acknowledged request waits off the air: an alarm goes meanwhile
    clk, drv, rec, link = make(flags=MODEM_FLAGS, ack_window=2, ack_timeout_ms=5000)
    now = clk()
    link.request(now, 1, "diver", b"t1", 60, priority=2, ack=True)
    link.request(now, 2, "diver", b"t2", 60, priority=2, ack=True)
    link.request(now, 3, "diver", b"t3", 60, priority=2, ack=True)
    for _ in range(2):
        link.poll(now)
        drv.finish()
        link.poll(now)
    assert rec.statuses(1)[-1] == WAITING and rec.statuses(2)[-1] == WAITING
    # the ack window is full: request 3 waits, but an unacknowledged alarm goes
    link.poll(now)
    assert len(drv.sent) == 2
    link.request(now, 4, "auv", b"ALARM", 60, priority=1)
    link.poll(now)
    assert drv.sent[-1][2][1:] == b"ALARM"
    drv.finish()
    link.poll(now)
    assert rec.final(4) == TRANSMITTED
    # acks arrive out of order; each frees a slot
    drv.deliver(drv.sent[1][0])
    link.poll(now)
    assert rec.final(2) == DELIVERED
    assert drv.sent[-1][2][1:] == b"t3"
    drv.deliver(drv.sent[0][0])
    link.poll(now)
    assert rec.final(1) == DELIVERED
    check_exactly_one_final(rec, [1, 2, 4])


def test_ranging_waits_for_a_busy_driver_between_pings():
    # the driver is not ready right after the first reply: the job must keep
    # its place and not be overwritten by the next queued request
    clk, drv, rec, link = make()
    link.range(clk(), 7, ["diver", "auv"], 30)
    link.request(clk(), 8, "diver", b"data", 30)
    link.poll(clk())
    h = drv.sent[-1][0]
    drv.range_reply(h, 2, 50.0)
    drv.busy = 99  # still busy with something of its own
    link.poll(clk())
    assert drv.sent[-1][0] == h  # nothing new yet
    drv.busy = None
    link.poll(clk())
    assert drv.sent[-1][1:] == ("ping", 3)
    drv.range_reply(drv.sent[-1][0], 3, 75.0)
    link.poll(clk())
    assert rec.final(7) == DELIVERED
    assert rec.of(EV_RANGE_RECEIVED)[-1][4] == [50.0, 75.0]
    link.poll(clk())
    assert drv.sent[-1][2][1:] == b"data"
    # cancel between pings, and a ping the driver refuses
    link.range(clk(), 9, ["diver", "auv"], 30)
    drv.finish()
    link.poll(clk())
    drv.range_reply(drv.sent[-1][0], 2, 1.0)
    drv.busy = 99
    link.poll(clk())
    assert link.cancel(clk(), 9)
    drv.busy = None
    link.poll(clk())
    assert rec.final(9) == CANCELED

    def refuse(now, addr):
        raise EncodeError("no")

    drv.ping = refuse
    link.range(clk(), 10, ["diver"], 30)
    link.poll(clk())
    assert rec.final(10) == FAILED
    check_exactly_one_final(rec, [7, 8, 9, 10])
