# The transport's persistence: packets on a real file store (acomm.transport.store)
# across restarts, lifespans that keep counting through a restart, packet
# ids never reused, duplicates suppressed when a restarted sender sends a
# delivered packet again, big packets in several records, and the store's
# overflow rule (acomm.transport.packetstore) at the sender and at a relay.
from acomm.transport import segment as sg
from acomm.transport.arq import Outgoing
from acomm.errors import StoreFull
from acomm.events import DELIVERED, EXPIRED, FAILED, QUEUED, TRANSMITTED
from acomm.transport.memorystore import MemoryStore
from acomm.transport.packetstore import PacketStore, key_of
from acomm.prng import Prng
from acomm.transport.store import Store
from acomm.transport import Transport
from checks import TempDir, raises
from transportnet import net, packets, statuses, wall_of


def _restart(sn, w, store, **kw):
    # the node comes back: a new transport on the same store
    sn.node.transport = None
    return Transport.of(sn.node, store=store, wall=wall_of(w), **kw)


def _key(pid, chunk=0):
    # the store key of a chunk of the diver's packet pid (_Pkt's origin, 2, is the diver's id)
    return (chunk << 24) | key_of(_Pkt(pid, b""))


def _saved(store):
    # what a power cut would leave of a store, as its public get/keys read it
    return dict((k, store.get(k)) for k in store.keys())


def _cut_back(store, saved):
    # the store as it was when saved: later puts and deletes never happened
    for k in store.keys():
        if k not in saved:
            store.delete(k)
    for k, v in saved.items():
        store.put(k, v)


def test_a_restart_on_a_file_store_resumes_the_transfer():
    with TempDir() as d:
        st = Store(d.file("diver"), capacity_bytes=32768, max_record=256)
        w, a, b, _, ta = net(loss=0.05, stores={"diver": st})
        data = Prng(11).bytes(700)  # random: 3 records, 27 fragments
        pid = ta.send(w.now(), "buoy", data, 3600, 5)
        w.run(600000, until=lambda: ta.stats["fragments"] >= 8)
        assert not packets(b)
        st.close()  # power cut; the file is all that is left
        st = Store(d.file("diver"), capacity_bytes=32768, max_record=256)
        t2 = _restart(a, w, st)
        assert t2.pending() == [pid]
        assert w.run(1200000, until=lambda: DELIVERED in statuses(a, pid))
        assert [e[1:] for e in packets(b)] == [("diver", "buoy", data)]
        w.run(5000)
        assert t2.pending() == [] and len(st) == 1  # only the packet id limit
        assert t2.send(w.now(), "buoy", b"after", 60, 5) != pid  # ids go on
        st.close()


def test_waiting_packets_keep_their_bodies_in_the_store_not_in_ram():
    # A buoy whose uplink is down holds packets for hours: RAM keeps their
    # headers, the store their bodies, read back when each is sent (also
    # after a restart, which reads back the headers only)
    with TempDir() as d:
        st = Store(d.file("diver"), capacity_bytes=32768, max_record=256)
        w, a, b, _, ta = net(stores={"diver": st})
        w.channel.loss = 1.0  # nothing gets through for now
        data = [Prng(20 + i).bytes(600) for i in range(3)]  # random: stored as they are
        pids = [ta.send(w.now(), "buoy", x, 3600, 5) for x in data]
        w.run(30000)
        assert all(p.body is None and p.size == 600 for p in ta._out)
        st.close()
        st = Store(d.file("diver"), capacity_bytes=32768, max_record=256)
        t2 = _restart(a, w, st)
        assert sorted(t2.pending()) == sorted(pids)
        assert all(p.body is None and p.size == 600 for p in t2._out)
        w.channel.loss = 0.0
        assert w.run(3600000, until=lambda: all(DELIVERED in statuses(a, pid) for pid in pids))
        assert sorted(e[3] for e in packets(b)) == sorted(data)
        st.close()


def test_a_packet_whose_body_the_store_lost_fails_with_a_reason():
    store = MemoryStore(max_record=256)
    w, a, b, _, ta = net(stores={"diver": store})
    pid = ta.send(w.now(), "buoy", Prng(5).bytes(300), 3600, 5)  # random: two records
    store.delete(_key(pid, 1))  # its second record rots away before it is sent
    assert w.run(600000, until=lambda: FAILED in statuses(a, pid))
    assert not packets(b) and ta.pending() == []


def test_a_stored_blob_reads_what_the_joined_packet_holds():
    # the transfer reads its fragments back from the records (StoredBlob)
    # instead of holding header + body in RAM: every window of it must be
    # the bytes the joined copy had, across record boundaries, with and
    # without a medium name in chunk 0
    for medium in (None, "satellite"):
        ps = PacketStore(MemoryStore(max_record=64))
        body = Prng(3).bytes(300)
        p = _stored_packet(ps, body, medium)
        head = b"HEADER!"
        blob = ps.blob(key_of(p), head)
        whole = head + body
        assert len(blob) == len(whole)
        for n in (1, 5, 27, 64, 100, 400):
            for off in range(0, len(whole) + 3, 7):
                assert blob.read(off, n) == whole[off : off + n], (medium, off, n)


def _stored_packet(ps, body, medium):
    from acomm.transport.packetstore import Stored

    p = Stored()
    p.origin, p.final, p.pid, p.prio, p.expiry, p.compressed, p.medium = 1, 2, 9, 5, 1000, False, medium
    p.body, p.size = body, len(body)
    ps.put(p)
    return p


def test_a_record_lost_mid_transfer_fails_the_packet_once():
    store = MemoryStore(max_record=64)
    w, a, b, _, ta = net(loss=1.0, stores={"diver": store})  # nothing arrives: the transfer goes on
    pid = ta.send(w.now(), "buoy", Prng(6).bytes(400), 3600, 5)  # random: 7 records
    w.run(600000, until=lambda: ta.stats["fragments"] >= 2)
    store.delete(_key(pid, 6))  # a record of its tail rots away while it is sent
    w.channel.loss = 0.0
    assert w.run(1200000, until=lambda: FAILED in statuses(a, pid))
    w.run(60000)
    assert [s for s in statuses(a, pid) if s in (DELIVERED, FAILED, EXPIRED)] == [FAILED]
    assert not packets(b) and ta.pending() == []


def test_a_lifespan_keeps_counting_through_a_restart():
    w, a, b, _, ta = net()
    w.channel.loss = 1.0  # nothing gets through
    store = ta.store
    t0 = w.now()
    pid = ta.send(t0, "buoy", b"never", 30, 5)
    w.run(20000)
    t2 = _restart(a, w, store)
    assert t2.pending() == [pid]
    assert w.run(60000, until=lambda: EXPIRED in statuses(a, pid))
    assert 29000 <= w.now() - t0 <= 32000  # 30 s from send(), not from the restart


def test_a_sender_restarted_before_the_ack_does_not_deliver_twice():
    store = MemoryStore()
    w, a, b, _, ta = net(stores={"diver": store})
    pid = ta.send(w.now(), "buoy", b"status: ok, depth 12 m", 3600, 5)
    before = _saved(store)  # the store as a cut just before the SACK left it
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    _cut_back(store, before)
    t2 = _restart(a, w, store)
    assert t2.pending() == [pid]
    assert w.run(600000, until=lambda: statuses(a, pid).count(DELIVERED) == 2)
    assert len(packets(b)) == 1  # the receiver's lane remembered the completion


def test_a_restarted_sender_is_not_confused_by_the_receivers_lane_memory():
    # the receiver's lane 0 remembers the last packet's completion under
    # generation 0; the restarted sender starts its lane at generation 0
    # again with another packet, and must not take that completion for its own
    w, a, b, _, ta = net()
    p1 = ta.send(w.now(), "buoy", b"first", 3600, 5)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, p1))
    t2 = _restart(a, w, ta.store)
    p2 = t2.send(w.now(), "buoy", b"second", 3600, 5)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, p2))
    assert [e[3] for e in packets(b)] == [b"first", b"second"]


def test_a_sender_restarted_mid_transfer_meets_the_receivers_half_packet():
    # Found by the soak: the sender loses power with half of a long packet
    # at the receiver (lane 0, generation 0). Restarted, it sends a short
    # packet on lane 0 at generation 0 again; the receiver's SACK for the
    # half packet acknowledged more than the short one has, and the sender
    # took the short one as delivered. Now the first transfer on a lane
    # after a start probes it first, and a plain SACK that covers a whole
    # packet is never taken as its completion.
    w, a, b, _, ta = net()
    long = Prng(9).bytes(300)
    p1 = ta.send(w.now(), "buoy", long, 3600, 5)
    heard = b.node.links["acoustic"].stats
    rx0 = heard["rx_frames"]
    assert w.run(600000, until=lambda: heard["rx_frames"] - rx0 >= 4)  # 4 fragments at the buoy
    q = a.node.links["acoustic"].queue
    for r in list(q):
        q.cancel(r.req_id)  # the power went, and the queue to the modem with it
    t2 = _restart(a, w, ta.store)
    # the restarted sender has the long packet back from its store, and an
    # urgent short one that goes first: on lane 0, generation 0
    p2 = t2.send(w.now(), "buoy", b"short status", 3600, 1)
    assert w.run(900000, until=lambda: DELIVERED in statuses(a, p2) and DELIVERED in statuses(a, p1))
    assert sorted(e[3] for e in packets(b)) == sorted([long, b"short status"])


def test_a_plain_sack_never_completes_a_packet():
    o = Outgoing(b"x" * 50, 28, 0, 0, 7)  # 2 fragments
    o.new_round()
    assert not o.on_sack(sg.decode(*sg.sack(0, 0, 5)))  # 5 fragments "arrived": another transfer's
    assert not o.on_sack(sg.decode(*sg.sack(0, 0, 2)))  # all of it, but not as a completion
    assert not o.complete
    assert o.on_sack(sg.decode(*sg.sack_complete(0, 0, 2, 7))) and o.complete
    # probing: a SACK of nothing clears the lane; anything else is stale
    for seg, clear in ((sg.sack(0, 0, 0), True), (sg.sack(0, 0, 1), False), (sg.sack(0, 0, 0, b"\x01"), False),
                       (sg.sack_refused(0, 0, sg.REFUSE_FULL), False), (sg.sack_complete(0, 0, 3, 6), False)):
        o = Outgoing(b"x" * 50, 28, 0, 0, 7)
        o.probe()
        assert o.next_fragment() == (0,) + sg.frag_header(True, 0, 0, 0)  # a bare poll
        assert o.on_sack(sg.decode(*seg)) == clear and not o.complete and o.refused is None
    o = Outgoing(b"x" * 50, 28, 0, 0, 7)
    o.probe()
    assert o.on_sack(sg.decode(*sg.sack_complete(0, 0, 2, 7))) and o.complete  # ours, from before the restart


def test_packet_ids_survive_a_restart_without_a_write_per_packet():
    st = MemoryStore()
    ps = PacketStore(st)
    ids = [ps.next_pid() for _ in range(40)]
    assert ids == list(range(1, 41))
    ps2 = PacketStore(st)
    ps2.recover()
    assert ps2.next_pid() > 40  # never an id that may have been used
    writes = []
    st.put = lambda k, v: writes.append(k)
    for _ in range(64):
        ps2.next_pid()
    assert len(writes) == 2  # one limit record per 32 ids


def test_a_cut_put_leaves_no_half_packet():
    st = MemoryStore(max_record=64)
    w, a, b, _, ta = net(stores={"diver": st})
    pid = ta.send(w.now(), "buoy", Prng(2).bytes(300), 3600, 5)  # 5 records
    keys = st.keys()
    assert len(keys) == 6 and _key(pid) in keys  # 5 chunks and the packet id limit
    st.delete(_key(pid))  # chunk 0 is written last: cut before it
    t2 = _restart(a, w, st)
    assert t2.pending() == [] and st.keys() == [0xFFFFFF]


def test_the_overflow_rule_refuses_new_low_priority_packets_only():
    st = MemoryStore(capacity_bytes=2000)
    w, a, b, _, ta = net(stores={"diver": st})
    w.channel.loss = 1.0
    got = [ta.send(w.now(), "buoy", Prng(k).bytes(500), 3600, 10) for k in range(3)]
    assert [statuses(a, p) for p in got] == [[QUEUED], [QUEUED], [FAILED]]  # past 3/4 of 2000
    urgent = ta.send(w.now(), "buoy", Prng(9).bytes(500), 3600, 2)
    assert statuses(a, urgent) == [QUEUED]  # the last quarter is for urgent packets
    more = ta.send(w.now(), "buoy", Prng(8).bytes(500), 3600, 1)
    assert statuses(a, more) == [FAILED] and ta.stats["store_full"] == 2
    w.run(60000)
    assert sorted(ta.pending()) == sorted(got[:2] + [urgent])  # nothing accepted was dropped
    raises(StoreFull, st.put, 1, bytes(2000))


def test_a_full_relay_refuses_and_the_sender_keeps_the_packet():
    relay_store = MemoryStore(capacity_bytes=300)
    w, a, b, c, ta = net(relay=True, stores={"auv": relay_store})
    data = Prng(4).bytes(400)
    pid = ta.send(w.now(), "buoy", data, 7200, 5)
    assert w.run(600000, until=lambda: ta.stats["refused"] >= 1)
    assert statuses(a, pid) == [QUEUED] and not packets(b)
    assert c.node.transport.stats["store_full"] >= 1
    relay_store.capacity_bytes = 4000  # packets left the relay: room again
    assert w.run(1200000, until=lambda: packets(b))
    assert packets(b)[0][1:] == ("diver", "buoy", data)
    assert statuses(a, pid) == [QUEUED, TRANSMITTED]


class _Pkt:
    # what PacketStore needs of a transport packet
    def __init__(self, pid, body, prio=5):
        self.origin, self.final, self.pid, self.prio, self.expiry = 2, 1, pid, prio, 2000000000
        self.key = (2 << 16) | pid
        self.body, self.compressed, self.medium, self.chunks = body, False, None, 0
        self.size = len(body)


def test_a_full_store_can_still_move_the_packet_id_limit():
    # The id limit is rewritten every 32 packets, while its old copy is
    # still live: packets are refused before they take that room, so a full
    # store (also one recovered after a restart) still hands out safe ids.
    with TempDir() as d:
        st = Store(d.file("ids"), capacity_bytes=4096, max_record=256)
        ps = PacketStore(st)
        kept = 0
        for i in range(200):
            pid = ps.next_pid()  # never StoreFull
            try:
                ps.put(_Pkt(pid, Prng(i).bytes(90), prio=1))
                kept += 1
            except StoreFull:
                pass
        assert 20 < kept < 200 and ps.pid == 200
        st.close()
        st = Store(d.file("ids"), capacity_bytes=4096, max_record=256)
        ps = PacketStore(st)
        assert len(ps.recover()) == kept
        assert ps.next_pid() > 200  # above every id used before the restart
        st.close()


def test_a_restarted_receiver_does_not_deliver_a_resent_packet_twice():
    # the buoy delivered the packet, the diver never heard the SACK, then
    # the buoy lost power: its memory of what it delivered must come back
    # from its store, or the resent packet is delivered a second time
    sd, sb = MemoryStore(), MemoryStore()
    w, a, b, _, ta = net(stores={"diver": sd, "buoy": sb})
    pid = ta.send(w.now(), "buoy", b"alarm: low air", 3600, 2)
    before, live = _saved(sd), sd.live_bytes
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
    _cut_back(sd, before)  # the diver never saw the SACK
    assert sd.live_bytes == live
    _restart(b, w, sb)  # the buoy restarts: a new transport on its store
    t2 = _restart(a, w, sd)
    assert t2.pending() == [pid]
    assert w.run(600000, until=lambda: statuses(a, pid).count(DELIVERED) == 2)
    assert len(packets(b)) == 1
    assert b.node.transport.stats["rx_dup"] == 1


def test_the_delivered_pairs_are_kept_as_the_store_keeps_them():
    # 5 bytes an entry (origin, pid, the minute until which a copy can
    # come), at most 32: an entry is found only on its boundary (bytes
    # 1..3 of 01 01 02 xx xx | 03 ... are not an entry)
    w, a, b, _, ta = net()
    ta._remember(1, 0x0102, 600, False)
    ta._remember(3, 0x0405, 600, False)
    assert ta._is_done(1, 0x0102) and ta._is_done(3, 0x0405)
    assert not ta._is_done(1, 0x0203) and not ta._is_done(2, 0x0304)
    for k in range(40):
        ta._remember(9, k, 7200, False)
    # full: the entries whose lifespan ends soonest went first (the two of
    # 10 minutes, then the earliest of 2 hours), each one still alive counted
    assert len(ta._done) == 5 * 32 and not ta._is_done(1, 0x0102) and not ta._is_done(3, 0x0405)
    assert ta._is_done(9, 39) and ta._is_done(9, 8) and not ta._is_done(9, 7)
    assert ta.stats["done_forgotten"] == 10


def test_a_copy_that_comes_after_an_hour_in_a_relays_store_is_not_delivered_again():
    # the memory keeps a packet whose copies can still come over newer
    # packets with short lifespans: a long-lived packet is delivered, then
    # 40 short-lived ones (more than the memory holds) arrive an hour
    # later; the long one's copy is still known as done
    w, a, b, _, ta = net()
    ta._remember(4, 77, 86400, False)
    wall0 = ta.wall
    ta.wall = lambda: wall0() + 3600
    for k in range(40):
        ta._remember(5, k, 300, False)
    assert ta._is_done(4, 77) and ta.stats["done_forgotten"] > 0
    # once its day is over it goes like the others: forgetting it then is
    # not counted (no copy of it can come any more)
    forgotten = ta.stats["done_forgotten"]
    ta.wall = lambda: wall0() + 2 * 86400
    for k in range(32):
        ta._remember(6, k, 300, False)
    assert not ta._is_done(4, 77) and ta.stats["done_forgotten"] == forgotten


def test_an_older_stores_pairs_are_read_and_kept_for_an_hour():
    # a store written before the entries had lifespans: its 3-byte pairs
    # come back, with an hour to run, and are written in the new form
    from acomm.transport.memorystore import MemoryStore
    from acomm.transport.packetstore import PacketStore

    st = MemoryStore()
    st.put(0xFFFFFE, bytes((7, 1, 2, 8, 3, 4)))
    ps = PacketStore(st)
    assert ps.recover() == [] and len(ps.done) == 10 and 0xFFFFFE not in st.keys()
    assert ps.done[3:5] == b"\xff\xff"


def test_a_lifespan_longer_than_a_link_keeps_a_request_is_still_sent():
    # a link queues a request for 3 days at most; a packet with 10 days to
    # live (or an expiry from another wall-clock epoch) sends its fragments
    # with the link's longest, and keeps its own expiry
    w, a, b, _, ta = net()
    pid = ta.send(w.now(), "buoy", Prng(7).bytes(100), 10 * 86400, 5)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid)), statuses(a, pid)
    assert [e[3] for e in packets(b)] == [Prng(7).bytes(100)]


def test_a_wall_clock_step_forward_leaves_every_packet_the_time_it_had_left():
    # the node's clock (acomm.wallclock) starts behind, as a board without a battery clock does,
    # and a first fix steps it forward by a day: the packet queued before with 10 minutes to
    # live still has them, and goes when its receiver comes into range
    from acomm.wallclock import WallClock
    from acomm_sim.channel import Channel
    from acomm_sim.world import World

    w = World(seed=3, channel=Channel(seed=3, loss_curve=((0.0, 0.0), (200.0, 0.0), (201.0, 1.0))))
    a = w.add("diver", 2, "seatrac", position=(0, 0, 10), link_opts={"advert_period_ms": 600000})
    b = w.add("buoy", 1, "seatrac", position=(5000, 0, 0), link_opts={"advert_period_ms": 600000})
    base = [1000000]
    wc = WallClock(lambda: base[0] + w.now() // 1000, w.clock)
    a.node.wallclock = wc
    ta = Transport.of(a.node, wall=wc.wall)
    Transport.of(b.node, wall=lambda: w.now() // 1000)
    pid = ta.send(w.now(), "buoy", b"position 43.1N 5.9E", 600, 5)
    w.run(60000)
    now = w.now()
    before = wc.wall()
    assert wc.fix(now, "iridium", 126230400 + 86400, 0, 500)  # 2024-01-02: years ahead of the port's clock
    assert wc.wall() - before > 86400
    w.run(120000)
    assert EXPIRED not in statuses(a, pid)
    w.channel.set_position(1, 150.0, 0.0, 0.0)
    assert w.run(600000, until=lambda: DELIVERED in statuses(a, pid))
