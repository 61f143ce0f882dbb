# Exactly once across resends, restarts and long delays (issue 37): a link
# command resent because its acknowledgement was lost is carried out at its
# destination at most once, however late a copy of it comes and whether the
# receiver restarted in between. The hole this closes, as the attack bench
# found it: the buoy's link resent an acknowledged command sealed afresh
# (counters 24 and 25); the AUV restarted, accepted 25, and 183 s later the
# attacker's recording of 24 was inside the counter window and past the
# link's 60 s duplicate filter: the command was carried out twice.
from acomm import frame as fr
from acomm.apps.policy import commands
from acomm.catalog import teleop
from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST
from acomm.events import DELIVERED, EV_RECEIVED
from acomm.frame.auth import Auth
from acomm.link import Link
from acomm.link.names import NameTable
from checks import TempDir
from linkcheck import Recorder, check_exactly_one_final
from scripted_driver import ScriptedDriver

KEY = b"0123456789abcdef0123456789abcdef"
THRUST = teleop.CATALOG.pack([(teleop.THRUST, teleop.thrust_values((0.5, 0, 0, 0, 0, 0), 3))])


def _link(node_id, auth, flags=None):
    names = NameTable()
    names.add("buoy", 1)
    names.add("auv", 2)
    drv = ScriptedDriver() if flags is None else ScriptedDriver(flags)
    rec = Recorder()
    link = Link("acoustic", drv, node_id, names, rec, advert_period_ms=60000000)
    link._last_tx = 0  # no advert in these tests' hours
    if auth is not None:
        link.framing.set_auth(auth)
        link.guard = commands()
    return drv, rec, link


def _received(rec):
    return [e[4] for e in rec.of(EV_RECEIVED)]


def _resent_command(d, flags=None):
    # the buoy sends one acknowledged command; the first copy gets no
    # acknowledgement and is sent again: -> (both copies, the buoy's parts)
    t = 1000
    drv, rec, buoy = _link(1, Auth(KEY, path=d.file("buoy")), flags)
    buoy.request(t, 1, "auv", THRUST, 600, ack=True)
    buoy.poll(t)
    first = drv.sent[-1]
    drv.fail(first[0], "no reply")
    buoy.poll(t + 5000)
    buoy.poll(t + 5000)
    second = drv.sent[-1]
    assert second[0] != first[0]
    return first[2], second[2], drv, rec, buoy


def test_a_resent_command_replayed_after_the_receivers_restart_is_refused():
    with TempDir() as d:
        first, second, _, _, _ = _resent_command(d)
        # the AUV had taken frames before, and saved its counters; it restarts
        path = d.file("auv")
        Auth(KEY, path=path)
        drv, rec, auv = _link(2, Auth(KEY, path=path))
        t = 10000
        # the first copy was lost on the way; the second arrives and is carried out
        drv.receive(1, 2, second)
        auv.poll(t)
        assert _received(rec) == [THRUST]
        # 183 s later (past the duplicate filter) the attacker plays its recording of the first copy
        drv.receive(1, 2, first)
        auv.poll(t + 183000)
        assert _received(rec) == [THRUST]
        # and after another restart, the second copy too
        drv, rec, auv = _link(2, Auth(KEY, path=path))
        drv.receive(1, 2, first)
        drv.receive(1, 2, second)
        auv.poll(t + 7200000)
        assert _received(rec) == []


def test_every_copy_of_a_resent_request_carries_the_same_counter_and_tag():
    with TempDir() as d:
        first, second, drv, rec, buoy = _resent_command(d)
        assert first == second  # sealed once: the receiver's window makes any copy at most once
        assert buoy.framing.auth.stats["sealed"] == 1
        drv.deliver(drv.sent[-1][0])
        buoy.poll(7000)
        assert rec.final(1) == DELIVERED
        check_exactly_one_final(rec, [1])


# -- the sealed ACK: no counter of its own, a tag bound to the acknowledged frame's counter --
LINK_ACKS = CAP_ADDRESSING | CAP_BROADCAST  # a modem that leaves acknowledgements to acomm


def _pair(d, reserve=64):
    # the buoy (1) and the AUV (2) on a modem without acks of its own, both keyed
    b = _link(1, Auth(KEY, path=d.file("buoy"), reserve=reserve), LINK_ACKS)
    a = _link(2, Auth(KEY, path=d.file("auv"), reserve=reserve), LINK_ACKS)
    return b, a


def _cross(t, frm, to):
    # what frm's driver sent last reaches to: -> the bytes
    drv, _, link = frm
    h, addr, data, _ = drv.sent[-1]
    drv.finish(h)
    link.poll(t)
    to[0].receive(frm[2].node_id, to[2].node_id, data)
    to[2].poll(t)
    return data


def test_a_sealed_ack_is_six_bytes_elided_and_delivers():
    with TempDir() as d:
        b, a = _pair(d)
        b[2].request(1000, 1, "auv", b"status", 600, ack=True)
        b[2].poll(1000)
        _cross(1000, b, a)
        assert _received(a[1]) == [b"status"]
        ack = _cross(1100, a, b)
        assert len(ack) == 6  # header, flags (F_AUTH), 4-byte tag
        f = fr.decode_elided(ack, 2, 1)
        assert f.ftype == fr.ACK and f.flags == fr.F_AUTH
        assert b[1].final(1) == DELIVERED
        check_exactly_one_final(b[1], [1])


def test_forged_replayed_and_wrong_counter_acks_are_refused():
    with TempDir() as d:
        b, a = _pair(d)
        drv, rec, buoy = b
        buoy.request(1000, 1, "auv", b"one", 600, ack=True)
        buoy.poll(1000)
        _cross(1000, b, a)
        old_ack = _cross(1100, a, b)
        assert rec.final(1) == DELIVERED
        # 15 more, acknowledged; the next reuses the first one's sequence number, and a recorded
        # ACK of the first does not fit it
        auth = buoy.framing.auth
        for rid in range(2, 17):
            buoy.request(1000 * rid, rid, "auv", b"x", 600, ack=True)
            buoy.poll(1000 * rid)
            _cross(1000 * rid, b, a)
            _cross(1000 * rid + 100, a, b)
            assert rec.final(rid) == DELIVERED
        rid = 17
        buoy.request(2000, rid, "auv", b"x", 600, ack=True)
        buoy.poll(2000)
        drv.finish()
        buoy.poll(2000)
        seq = fr.decode_elided(drv.sent[-1][2], 1, 2).seq
        assert seq == fr.decode_elided(old_ack, 2, 1).seq
        bad = auth.stats["bad_tag"]
        drv.receive(2, 1, old_ack)  # replayed: bound to the first request's counter
        drv.receive(2, 1, fr.encode_elided(fr.Frame(fr.ACK, 0, 0, seq, b"\x01\x02\x03\x04", fr.F_AUTH)))
        drv.receive(2, 1, fr.encode_elided(fr.Frame(fr.ACK, 0, 0, seq)))  # unsealed
        # sealed by a node with the key, for another counter than the request's
        other = a[2].framing.encode(fr.ACK, 1, seq, b"", 0, auth.last - 1)[1]
        drv.receive(2, 1, other)
        buoy.poll(2100)
        assert rec.final(rid) is None
        assert auth.stats["bad_tag"] == bad + 3 and buoy.guard.refused["ack"] == 4
        # the genuine one
        drv.receive(2, 1, a[2].framing.encode(fr.ACK, 1, seq, b"", 0, auth.last)[1])
        buoy.poll(2200)
        assert rec.final(rid) == DELIVERED


def test_the_ack_to_a_resend_is_sent_again_and_the_copy_is_not_delivered_again():
    with TempDir() as d:
        b, a = _pair(d)
        drv, rec, buoy = b
        buoy.request(1000, 1, "auv", THRUST, 600, ack=True, retries=3)
        buoy.poll(1000)
        first = _cross(1000, b, a)
        assert _received(a[1]) == [THRUST]
        # the AUV's ack is lost on the way: the buoy resends the same frame after its ack timeout
        a[0].finish()
        a[2].poll(1300)
        t = 1000 + buoy.ack_timeout_ms + 10
        buoy.poll(t)
        buoy.poll(t)
        again = _cross(t, b, a)
        assert again == first
        # 2 hours later too (past the duplicate filter): acknowledged, not carried out again
        drv.receive(1, 2, first)
        acked = a[2].stats["acks_sent"]
        ack = _cross(t + 100, a, b)
        assert _received(a[1]) == [THRUST] and a[2].framing.auth.stats["again"] == 1
        assert len(ack) == 6 and rec.final(1) == DELIVERED
        check_exactly_one_final(rec, [1])
        a[0].receive(1, 2, first)
        a[2].poll(t + 7200000)
        assert _received(a[1]) == [THRUST] and a[2].stats["acks_sent"] == acked + 1
        assert a[2].framing.auth.stats["again"] == 2


def test_acks_during_a_key_rotation_verify_under_the_requests_phase():
    from acomm.frame.auth import OP_INSTALL, OP_USE, key_command

    with TempDir() as d:
        b, a = _pair(d)
        drv, rec, buoy = b
        for auth in (buoy.framing.auth, a[2].framing.auth):
            auth.key_command(key_command(OP_INSTALL, 1, b"12345678"))
        buoy.request(1000, 1, "auv", b"old key", 600, ack=True)
        buoy.poll(1000)
        _cross(1000, b, a)
        # both switch to phase 1 before the ack comes: it is bound to the request's phase 0 counter
        for auth in (buoy.framing.auth, a[2].framing.auth):
            auth.key_command(key_command(OP_USE, 1))
        _cross(1100, a, b)
        assert rec.final(1) == DELIVERED
        buoy.request(2000, 2, "auv", b"new key", 600, ack=True)
        buoy.poll(2000)
        _cross(2000, b, a)
        _cross(2100, a, b)
        assert rec.final(2) == DELIVERED and buoy.framing.auth.last & 0x800000
        assert _received(a[1]) == [b"old key", b"new key"]


def test_a_delivered_sealed_frame_is_on_file_before_the_application_has_it():
    # after a restart, no recording of a plain DATA frame already handed up is fresh again
    with TempDir() as d:
        b, a = _pair(d)
        sent = []
        for rid in range(1, 6):
            b[2].request(1000 * rid, rid, "auv", b"status %d" % rid, 600)
            b[2].poll(1000 * rid)
            sent.append(_cross(1000 * rid, b, a))
        assert len(_received(a[1])) == 5
        drv, rec, auv = _link(2, Auth(KEY, path=d.file("auv")), LINK_ACKS)
        for data in sent:
            drv.receive(1, 2, data)
        auv.poll(9000000)
        assert _received(rec) == []
