# The transport on a file store whose filesystem fills up
# (tests/core/faultfs.py): a send that the disk cannot keep is refused
# with a final status that says why, what was accepted before is still
# delivered, and once there is room again sends go through; a receiver or
# a relay on a full disk goes on working (issue 37, point 3).
from acomm.events import DELIVERED, EV_PACKET_STATUS, FAILED, QUEUED, TRANSMITTED
from acomm.prng import Prng
from acomm.transport.store import Store
from checks import TempDir
from faultfs import FaultFS
from transportnet import net, packets, statuses


def _reason(sn, pid):
    return [e[3] for e in sn.events if e[0] == EV_PACKET_STATUS and e[1] == pid and e[2] == FAILED]


def test_a_send_on_a_full_disk_is_refused_and_the_next_one_after_goes_through():
    with TempDir() as d:
        fs = FaultFS()
        st = Store(d.file("diver"), capacity_bytes=32768, max_record=256, opener=fs.open)
        w, a, b, _, ta = net(stores={"diver": st})
        first = Prng(1).bytes(300)
        p1 = ta.send(w.now(), "buoy", first, 3600, 5)
        assert statuses(a, p1) == [QUEUED]
        fs.free = 0  # the disk is full from here
        p2 = ta.send(w.now(), "buoy", Prng(2).bytes(300), 3600, 5)
        assert statuses(a, p2) == [FAILED] and _reason(a, p2) == ["store full"]
        assert ta.stats["store_full"] == 1 and ta.pending() == [p1]
        # what was accepted before still goes, the disk still full
        assert w.run(600000, until=lambda: DELIVERED in statuses(a, p1))
        assert [e[1:] for e in packets(b)] == [("diver", "buoy", first)]
        assert st.stats["delete_deferred"] >= 1
        fs.free = None  # room again
        last = Prng(3).bytes(300)
        p3 = ta.send(w.now(), "buoy", last, 3600, 5)
        assert statuses(a, p3) == [QUEUED]
        assert w.run(600000, until=lambda: DELIVERED in statuses(a, p3))
        assert [e[1:] for e in packets(b)] == [("diver", "buoy", first), ("diver", "buoy", last)]
        assert statuses(a, p2) == [FAILED]  # one final status each
        st.close()


def test_a_receiver_on_a_full_disk_still_takes_packets():
    # its memory of what it delivered cannot be written: counted, not raised
    with TempDir() as d:
        fs = FaultFS()
        st = Store(d.file("buoy"), capacity_bytes=32768, max_record=256, opener=fs.open)
        w, a, b, _, ta = net(stores={"buoy": st})
        fs.free = 0
        data = Prng(4).bytes(200)
        pid = ta.send(w.now(), "buoy", data, 3600, 5)
        assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
        assert [e[1:] for e in packets(b)] == [("diver", "buoy", data)]
        assert b.node.transport.stats["store_full"] >= 1
        st.close()


def test_a_relay_on_a_full_disk_refuses_and_the_sender_keeps_the_packet():
    with TempDir() as d:
        fs = FaultFS()
        st = Store(d.file("auv"), capacity_bytes=32768, max_record=256, opener=fs.open)
        w, a, b, c, ta = net(relay=True, stores={"auv": st})
        fs.free = 0
        data = Prng(5).bytes(400)
        pid = ta.send(w.now(), "buoy", data, 7200, 5)
        assert w.run(600000, until=lambda: ta.stats["refused"] >= 1)
        assert statuses(a, pid) == [QUEUED] and not packets(b)
        assert c.node.transport.stats["store_full"] >= 1
        fs.free = None  # room on the relay again
        assert w.run(1200000, until=lambda: packets(b))
        assert packets(b)[0][1:] == ("diver", "buoy", data)
        assert statuses(a, pid) == [QUEUED, TRANSMITTED]
        st.close()


def test_a_send_the_store_cannot_write_for_another_reason_says_that_reason():
    # an I/O error (EIO) on the packet's record: the send ends failed with the store's own
    # words, the node goes on, and the next send goes through
    with TempDir() as d:
        fs = FaultFS()
        st = Store(d.file("diver"), capacity_bytes=32768, max_record=256, opener=fs.open)
        w, a, b, _, ta = net(stores={"diver": st})
        p0 = ta.send(w.now(), "buoy", Prng(3).bytes(100), 3600, 5)  # the packet ids' record is written
        fs.fail = 5
        p1 = ta.send(w.now(), "buoy", Prng(4).bytes(100), 3600, 5)
        why = _reason(a, p1)
        assert statuses(a, p1) == [FAILED] and len(why) == 1 and why[0] != "store full", why
        assert ta.pending() == [p0]
        p2 = ta.send(w.now(), "buoy", Prng(5).bytes(100), 3600, 5)
        assert w.run(600000, until=lambda: DELIVERED in statuses(a, p2) and DELIVERED in statuses(a, p0))
        assert len(packets(b)) == 2
        st.close()
