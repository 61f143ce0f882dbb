# The SeaTrac reply queue (DAT_QUEUE_SET / CLR / STATUS) and passive
# listening: byte-exact commands and answers between the driver and the
# emulator, the queued packet riding in the automatic reply to the next DAT
# request (and making it longer), third beacons overhearing that reply, the
# link's set_reply / overhear on top, and the USBL fix's bearing noise.
from binascii import unhexlify

from acomm.drivers import seatrac_wire as w

from acomm.drivers import seatrac_codes as sc
from acomm.errors import AcommError, EncodeError
from acomm.events import DELIVERED, EV_DRIVER_UP, EV_RECEIVED, EV_REPLIED, EV_STATUS
from acomm_sim.medium import Medium
from acomm_sim.seatrac import SeatracEmulator
from acomm_sim.world import World
from checks import raises
import modemnet
from test_seatrac import SYS_INFO_EXAMPLE, settings_line, up_driver

QSET_ABC = b"#64000361626330F7\r\n"  # dest 0 (any asker), 3 bytes "abc"
QSET_OK = b"$64002AC0\r\n"
QCLR = b"#65C02B\r\n"
QCLR_OK = b"$65002B50\r\n"
QSTATUS = b"#66802A\r\n"

run_emulators = modemnet.run_emulators


def messages(out, cid):
    # the payloads of the '$' lines with this CID in an emulator's output
    got = []
    for ln in out.split(b"\r\n"):
        if ln.startswith(b"$"):
            m = unhexlify(ln[1:-4])
            if m[0] == cid:
                got.append(m[1:])
    return got


def dat_receive(payload):
    # (dest, src, msg_type, ack, data, local flag or None) of a DAT_RECEIVE
    k = w.fix_len(payload, 0, len(payload))
    n = payload[k + 1]
    rest = payload[k + 2 + n :]
    return (payload[0], payload[1], payload[3], payload[k], bytes(payload[k + 2 : k + 2 + n]),
            rest[0] if rest else None)


def three(**opts):
    m = Medium(default_distance=150.0)
    return m, [SeatracEmulator(m, i, **opts) for i in (1, 2, 3)]


def test_queue_commands_answer_like_the_manual():
    m, (a, b, c) = three()
    b.feed(0, QSTATUS)
    assert b.take_output() == b"$66002BA0\r\n"  # nothing queued
    b.feed(0, QSET_ABC)
    assert b.take_output() == QSET_OK
    b.feed(0, QSTATUS)
    assert b.take_output() == b"$66036BA1\r\n"  # PACKET_LEN 3
    b.feed(0, QCLR)
    assert b.take_output() == QCLR_OK and b.xcvr.queued is None
    st = {}
    for name, payload in (
        ("too long", b"\x00\x20" + bytes(32)),
        ("length lies", b"\x00\x05Hi"),
        ("too much", b"\x00\x01Hi"),
        ("bad dest", b"\x10\x01x"),
        ("no length", b"\x00"),
    ):
        b.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_DAT_QUEUE_SET, payload))
        st[name] = b.take_output()[3:5]
    assert st == {"too long": b"05", "length lies": b"04", "too much": b"05", "bad dest": b"05", "no length": b"04"}
    assert b.xcvr.queued is None


def test_queued_packet_rides_the_reply_and_third_parties_overhear_it():
    m, (a, b, c) = three(local_flag=True)
    b.feed(0, QSET_ABC)
    b.take_output()
    a.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, bytes((2, sc.MSG_REQU, 2)) + b"Hi"))
    assert a.take_output() == b"$60000281DF\r\n"
    # request 660 ms on the air + 100 ms of sound, 310 ms turnaround, reply
    # 500 + 3 * 80 = 740 ms (240 longer than an empty one), 100 ms back
    out = run_emulators((a, b, c), 0, 1900)
    assert messages(out[0], sc.CID_DAT_RECEIVE) == []
    out2 = run_emulators((a, b, c), 1910, 1920)
    out[2] += out2[2]
    out = [out2[0], out2[1], out[2]]
    got = [dat_receive(p) for p in messages(out[0], sc.CID_DAT_RECEIVE)]
    assert got == [(1, 2, sc.MSG_RESPU, 1, b"abc", 1)]  # the ack, with the data
    assert b.xcvr.queued is None  # used up
    # beacon 3 heard the request to 2 and the reply to 1: passive listening
    heard = [dat_receive(p) for p in messages(out[2] + run_emulators((a, b, c), 1930, 4000)[2], sc.CID_DAT_RECEIVE)]
    assert heard == [(2, 1, sc.MSG_REQU, 0, b"Hi", 0), (1, 2, sc.MSG_RESPU, 0, b"abc", 0)]
    # the next request gets an empty reply: the third beacon hears nothing of it
    a.feed(5000, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, bytes((2, sc.MSG_REQU, 2)) + b"Hi"))
    out = run_emulators((a, b, c), 5000, 9000)
    assert [dat_receive(p)[3:5] for p in messages(out[0], sc.CID_DAT_RECEIVE)] == [(1, b"")]
    assert [dat_receive(p)[:2] for p in messages(out[2], sc.CID_DAT_RECEIVE)] == [(2, 1)]


def test_queue_for_one_asker_and_never_for_pings():
    m, (a, b, c) = three()
    b.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_DAT_QUEUE_SET, b"\x03\x02ok"))  # for beacon 3 only
    assert b.take_output() == QSET_OK
    a.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_PING_SEND, bytes((2, sc.MSG_REQU))))
    run_emulators((a, b, c), 0, 3000)
    a.feed(3000, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, bytes((2, sc.MSG_REQU, 1)) + b"?"))
    out = run_emulators((a, b, c), 3000, 7000)
    assert [dat_receive(p)[3:5] for p in messages(out[0], sc.CID_DAT_RECEIVE)] == [(1, b"")]
    assert b.xcvr.queued == (3, b"ok")
    c.feed(8000, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, bytes((2, sc.MSG_REQ, 1)) + b"?"))
    out = run_emulators((a, b, c), 8000, 12000)
    assert [dat_receive(p)[2:5] for p in messages(out[2], sc.CID_DAT_RECEIVE)] == [(sc.MSG_RESP, 1, b"ok")]
    assert b.xcvr.queued is None


def test_a_long_reply_at_long_range_is_heard_out():
    # the range timeout covers the reply's return, not its data
    m, (a, b, c) = three()
    m.set_distance(1, 2, 990.0)
    b.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_DAT_QUEUE_SET, b"\x00\x1f" + bytes(range(31))))
    a.feed(0, sc.encode(sc.SYNC_CMD, sc.CID_DAT_SEND, bytes((2, sc.MSG_REQU, 1)) + b"?"))
    out = run_emulators((a, b, c), 0, 8000)
    got = [dat_receive(p) for p in messages(out[0], sc.CID_DAT_RECEIVE)]
    assert got and got[0][3:5] == (1, bytes(range(31))) and messages(out[0], sc.CID_DAT_ERROR) == []


def test_driver_queue_reply_goes_through_the_command_slot():
    d = up_driver()
    d.queue_reply(10, b"abc")
    assert d.take_output() == QSET_ABC
    h = d.send(20, 2, b"x", True)
    assert d.take_output() == b""  # behind the queue command
    d.feed(30, QSET_OK)
    assert d.queued_reply == b"abc" and d.take_output().startswith(b"#600204")
    d.feed(40, sc.encode(sc.SYNC_RSP, sc.CID_DAT_SEND, b"\x00\x02"))
    d.queue_reply(50, None)
    assert d.take_output() == QCLR
    d.feed(60, QCLR_OK)
    assert d.queued_reply is None
    # refused: the reason is kept; silent: written again
    d.queue_reply(100, b"abc")
    d.take_output()
    d.feed(110, sc.encode(sc.SYNC_RSP, sc.CID_DAT_QUEUE_SET, b"\x05"))
    assert d.queue_problem == "CMD_PARAM_INVALID" and d.stats["queue_refused"] == 1
    d.queue_reply(200, b"abc")
    assert d.take_output() == QSET_ABC
    d.poll(200 + 1500)
    assert d.take_output() == QSET_ABC  # no answer: written again
    assert h is not None
    raises(EncodeError, d.queue_reply, 300, bytes(32))
    raises(EncodeError, d.queue_reply, 300, b"x", 16)


def set_up_again(d, now):
    # a restart's configuration (SYS_INFO, SETTINGS_GET); what the driver
    # writes once it is up again
    d.lost(now, "modem rebooted")
    d.poll(now)
    assert d.take_output() == b"#0281C1\r\n"
    d.feed(now + 1, SYS_INFO_EXAMPLE)
    assert d.take_output() == b"#15C1CF\r\n"
    d.feed(now + 2, settings_line(1))
    assert d.take_events()[-1] == (EV_DRIVER_UP,)
    return d.take_output()


def test_driver_forgets_the_queue_when_interrogated_and_requeues_after_a_reboot():
    d = up_driver()
    d.queue_reply(10, b"abc")
    d.take_output()
    d.feed(20, QSET_OK)
    # beacon 2 asks us (MSG_REQU to 1): our beacon's reply takes the packet
    req = bytes((1, 2, 0, sc.MSG_REQU)) + bytes(12) + b"\x00\x01?"
    d.feed(100, sc.encode(sc.SYNC_RSP, sc.CID_DAT_RECEIVE, req))
    assert d.queued_reply is None and d.take_events()[-1] == (EV_REPLIED,)
    assert set_up_again(d, 150) == b""  # nothing to queue again: the reply took it
    d.queue_reply(200, b"new")
    d.take_output()
    d.feed(210, sc.encode(sc.SYNC_RSP, sc.CID_DAT_QUEUE_SET, b"\x00"))
    assert set_up_again(d, 300) == sc.encode(sc.SYNC_CMD, sc.CID_DAT_QUEUE_SET, b"\x00\x03new")
    assert d.queued_reply is None  # until the beacon confirms it


def world3(overhear=True, diver_part=sc.PART_X110, **emu):
    wd = World(seed=5)
    lo = {"advert_period_ms": 3600000, "overhear": overhear}
    wd.add("buoy", 1, "seatrac", position=(-30.0, 0.0, 0.5), link_opts=lo, emu_opts=dict(emu))
    wd.add("auv", 2, "seatrac", position=(20.0, 25.0, 10.0), link_opts=lo, emu_opts=dict(emu))
    opts = dict(emu)
    opts["part"] = diver_part
    wd.add("diver", 3, "seatrac", position=(15.0, -30.0, 12.0), link_opts=lo, emu_opts=opts)
    assert wd.run(20000, until=lambda: all(sn.driver.ready(wd.now()) for sn in wd.nodes.values()))
    return wd


def test_link_set_reply_and_overhear():
    for overhear in (True, False):
        wd = world3(overhear)
        buoy, auv, diver = (wd.nodes[n] for n in ("buoy", "auv", "diver"))
        diver.link.set_reply(wd.now(), b"depth 12")
        wd.run(200)
        assert diver.driver.queued_reply[1:] == b"depth 12"  # behind the elided header
        rid = buoy.node.send("acoustic", "diver", b"", 10, 2, True)
        assert wd.run(10000, until=lambda: any(e[0] == EV_STATUS and e[2] == rid and e[3] == DELIVERED
                                               for e in buoy.events))
        wd.run(200)
        got = [e[2:] for e in buoy.events if e[0] == EV_RECEIVED]
        assert got == [("diver", "buoy", b"depth 12")]
        assert [e[2:] for e in diver.events if e[0] == EV_RECEIVED] == [("buoy", "diver", b"")]
        heard = [e[2:] for e in auv.events if e[0] == EV_RECEIVED]
        if overhear:
            assert heard == [("buoy", "diver", b""), ("diver", "buoy", b"depth 12")]
        else:
            assert heard == [] and auv.link.stats["rx_not_for_us"] == 2
        assert auv.link.stats["acks_sent"] == 0
    # the reply frames carry fresh sequence numbers: not taken for copies
    diver.link.set_reply(wd.now(), b"second")
    wd.run(200)
    rid = buoy.node.send("acoustic", "diver", b"", 10, 2, True)
    wd.run(6000)
    assert [e[4] for e in buoy.events if e[0] == EV_RECEIVED][-1] == b"second"
    raises(AcommError, diver.link.set_reply, wd.now(), bytes(30))  # past the link MTU


def test_set_reply_is_refused_without_a_reply_queue():
    wd = World(seed=1)
    sn = wd.add("a", 1, "bpsk", position=(0.0, 0.0, 0.0))
    raises(AcommError, sn.link.set_reply, 0, b"x")


def test_usbl_bearing_noise_is_bounded_and_repeats():
    def fixes(seed):
        m = Medium()
        a = SeatracEmulator(m, 1, bearing_noise_deg=2.0, range_noise_m=0.5, seed=seed)
        b = SeatracEmulator(m, 2)
        m.set_position(1, 0.0, 0.0, 0.0)
        m.set_position(2, 30.0, 40.0, 0.0)  # 50 m, azimuth 36.87 degrees, level
        out = []
        for k in range(20):
            t = k * 5000
            a.feed(t, sc.encode(sc.SYNC_CMD, sc.CID_PING_SEND, bytes((2, sc.MSG_REQU))))
            o = run_emulators((a, b), t, t + 4000)[0]
            for p in messages(o, sc.CID_PING_RESP):
                out.append(w.fix_dict(p, 0))
        return out

    f1, f2 = fixes(7), fixes(7)
    assert len(f1) == 20 and [f["azimuth"] for f in f1] == [f["azimuth"] for f in f2]
    assert len(set(f["azimuth"] for f in f1)) > 5
    for f in f1:
        assert abs(f["azimuth"] - 36.9) <= 2.05 and abs(f["elevation"]) <= 2.05
        assert abs(f["range"] - 50.0) <= 0.55
        # the position follows the noisy range and angles
        east, north = f["easting"], f["northing"]
        assert abs((east * east + north * north) ** 0.5 - f["range"]) < 0.3
    assert fixes(8)[0]["azimuth"] != f1[0]["azimuth"] or fixes(8)[1]["azimuth"] != f1[1]["azimuth"]
