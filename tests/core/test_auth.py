# Authenticated frames (acomm.frame.auth, acomm.link.guard): the tag and the replay
# window on their own, the counter file across restarts, and on the real
# stack (SeaTrac nodes in a World): genuine commands are carried out, and
# forged, tampered and replayed ones are refused and reported, never passed
# on, while status from a node without the key still gets through.
import os

from acomm import frame as fr
from acomm.apps.policy import commands
from acomm.frame.auth import Auth
from acomm.catalog import caddy, seaware, teleop
from acomm.errors import AcommError, AuthError
from acomm.events import EV_RECEIVED, EV_REFUSED
from acomm_sim.world import World
from checks import TempDir, raises

KEY = b"0123456789abcdef0123456789abcdef"
QUIET = {"advert_period_ms": 600000}


def test_a_sealed_payload_opens_and_any_change_is_refused():
    a, b = Auth(KEY), Auth(KEY)
    body = a.seal(fr.DATA, 2, 1, b"start")
    assert len(body) == 5 + 3 + 4 and a.overhead == 7
    assert b.open(fr.DATA, 2, 1, body)[0] == b"start"
    body = a.seal(fr.DATA, 2, 1, b"start")
    for i in range(len(body)):
        bad = bytearray(body)
        bad[i] ^= 0x10
        raises(AuthError, b.open, fr.DATA, 2, 1, bytes(bad))
    raises(AuthError, b.open, fr.DATA, 2, 3, body)  # heard towards another node
    raises(AuthError, b.open, fr.DATA, 4, 1, body)  # claimed by another sender
    raises(AuthError, b.open, fr.SEGMENT, 2, 1, body)
    raises(AuthError, b.open, fr.DATA, 2, 1, body, 1)  # another sequence number
    raises(AuthError, Auth(b"another key of 16+ bytes").open, fr.DATA, 2, 1, body)
    raises(AuthError, b.open, fr.DATA, 2, 1, body[:6])
    assert b.open(fr.DATA, 2, 1, body)[0] == b"start"  # the genuine one still passes after all that
    assert b.stats["bad_tag"] == len(body) + 5 and b.stats["opened"] == 2


def test_replays_are_refused_and_late_frames_inside_the_window_pass():
    a, b = Auth(KEY), Auth(KEY)
    bodies = [a.seal(fr.DATA, 2, 1, b"m%d" % i) for i in range(40)]
    assert b.open(fr.DATA, 2, 1, bodies[5])[1] == 6  # counters start at 1
    raises(AuthError, b.open, fr.DATA, 2, 1, bodies[5])  # replayed
    assert b.open(fr.DATA, 2, 1, bodies[3])[0] == b"m3"  # late, inside the window
    raises(AuthError, b.open, fr.DATA, 2, 1, bodies[3])
    assert b.open(fr.DATA, 2, 1, bodies[39])[1] == 40
    raises(AuthError, b.open, fr.DATA, 2, 1, bodies[4])  # 35 behind: older than the window
    assert b.open(fr.DATA, 2, 1, bodies[20])[1] == 21  # 19 behind: inside it
    assert b.stats["replayed"] == 3
    assert Auth(KEY).open(fr.DATA, 2, 1, bodies[5])[0] == b"m5"  # a receiver per node: its own window


def test_keys_and_tags_of_the_wrong_size_are_refused_at_start():
    for key in (b"short", b"x" * 15, b"x" * 65, "a text key of 16+ chars", None):
        raises(AcommError, Auth, key)
    raises(AcommError, Auth, KEY, 3)
    raises(AcommError, Auth, KEY, 17)
    assert Auth(KEY, 8).overhead == 11


def test_counters_survive_a_restart_without_a_write_per_frame():
    with TempDir() as d:
        _restarts(d.file("counters"))


def _restarts(path):
    a = Auth(KEY, path=path + ".a", reserve=16, wall=lambda: 1000)
    b = Auth(KEY, path=path + ".b", reserve=16, wall=lambda: 2000)
    assert a.epoch == 1000 and b.epoch == 2000  # no file yet: an epoch from the wall clock
    # b learns a's epoch from what a's adverts carry
    b.open(fr.ADVERT, 2, None, a.seal(fr.ADVERT, 2, None, b"\x02\x01", 0, True))
    sent = [a.seal(fr.DATA, 2, 1, b"s%d" % i) for i in range(40)]
    for body in sent[:20]:
        b.open(fr.DATA, 2, 1, body)
    assert a.stats["saves"] == 4  # the new file, then counters 1, 17, 33: one write per 16 frames
    assert b.stats["saves"] == 2  # the new file, then after 16 accepted frames
    # the sender restarts: it resumes after its reservation, never reusing
    a2 = Auth(KEY, path=path + ".a", reserve=16)
    assert a2.epoch == 1000
    assert b.open(fr.DATA, 2, 1, a2.seal(fr.DATA, 2, 1, b"after"))[1] == 49
    # a command was accepted (counter 49): the receiver writes at once, so
    # after its own restart no recording up to it is fresh again
    b.commit()
    b2 = Auth(KEY, path=path + ".b", reserve=16)
    for body in sent:
        raises(AuthError, b2.open, fr.DATA, 2, 1, body)
    assert b2.open(fr.DATA, 2, 1, a2.seal(fr.DATA, 2, 1, b"next"))[1] == 50
    # the power went between the new file and the rename: the new one counts
    os.remove(path + ".a")
    with open(path + ".a.new", "wb") as f:
        f.write(b"AK2\x00\x00\x00\x03\xe8\x00\x00\x40\x00\x00\x00")
    assert Auth(KEY, path=path + ".a").seal(fr.DATA, 2, 1, b"")[-7:-4] == b"\x00\x00\x41"


def _net(key_for=("topside", "auv")):
    w = World(seed=3)
    nodes = {}
    for name, nid, x in (("auv", 1, 0), ("topside", 2, 100), ("stranger", 3, 150)):
        nodes[name] = w.add(name, nid, "seatrac", position=(x, 0, 5), link_opts=QUIET)
    for name in key_for:
        nodes[name].node.set_auth(Auth(KEY), commands())
    w.run(5000)
    return w, nodes


def _got(sn, code):
    return [e for e in sn.events if e[0] == code]


def _send(w, sn, data):
    sn.node.send("acoustic", "auv", data, 60, 5)
    w.run(20000)


def test_genuine_commands_pass_and_forged_ones_are_refused_on_the_stack():
    w, n = _net()
    auv = n["auv"]
    start = seaware.encode(2, "start_mission")
    _send(w, n["topside"], start)
    assert [e[4] for e in _got(auv, EV_RECEIVED)] == [start]
    # the stranger has no key: its commands of every guarded kind are
    # refused and reported, its chat passes
    thrust = teleop.CATALOG.pack([(teleop.THRUST, teleop.thrust_values((0.5, 0, 0, 0, 0, 0), 1))])
    go_up = caddy.CATALOG.pack([(caddy.COMMAND, {"command": "go_up"})])
    chat = caddy.CATALOG.pack([(caddy.CHAT, {"text": "hello"})])
    for data in (seaware.encode(3, "stop_mission"), thrust, go_up, chat):
        _send(w, n["stranger"], data)
    refused = _got(auv, EV_REFUSED)
    assert len(refused) == 3 and all(e[2] == "stranger" for e in refused)
    assert [e[4] for e in _got(auv, EV_RECEIVED)] == [start, chat]
    assert auv.node.links["acoustic"].stats["refused"] == 3


def _frame_to_auv(n, data):
    # what the topside's link puts on the air for the auv: (address, bytes)
    return n["topside"].node.links["acoustic"].framing.encode(fr.DATA, 1, 7, data)


def _on_air(w, eve, data):
    # a transceiver near the auv puts data on the water as the topside's (2) frame to the auv (1)
    eve.send(w.now(), 2, 1, data)
    w.run(5000)


def test_tampered_and_replayed_frames_never_reach_the_application():
    from acomm_sim.attacker import Attacker

    w, n = _net()
    eve = Attacker(w.channel, 9, (20, 0, 5))
    auth = n["auv"].node.auth
    stop = seaware.encode(2, "stop_mission")
    _, genuine = _frame_to_auv(n, stop)
    _on_air(w, eve, genuine)
    assert [e[4] for e in _got(n["auv"], EV_RECEIVED)] == [stop]
    # a recording played back later, past the link's duplicate filter
    w.run(120000)
    _on_air(w, eve, genuine)
    assert auth.stats["replayed"] == 1
    # and with a fresh sequence number, which the tag covers
    replay = bytearray(genuine)
    replay[0] = (replay[0] & 0xF0) | 9
    _on_air(w, eve, bytes(replay))
    assert auth.stats["bad_tag"] == 1
    # tampered: one bit of the command changed
    _, other = _frame_to_auv(n, seaware.encode(2, "rendezvous_on"))
    bad = bytearray(other)
    bad[3] ^= 1
    _on_air(w, eve, bytes(bad))
    assert auth.stats["bad_tag"] == 2
    # an unauthenticated copy of the same command: no tag at all
    plain = fr.encode_elided(fr.Frame(fr.DATA, 2, 1, 5, seaware.encode(2, "rendezvous_on")))
    _on_air(w, eve, plain)
    assert len(_got(n["auv"], EV_REFUSED)) == 1
    assert [e[4] for e in _got(n["auv"], EV_RECEIVED)] == [stop]
    # and the genuine one still goes through after all that
    _, ok = _frame_to_auv(n, seaware.encode(2, "rendezvous_on"))
    _on_air(w, eve, ok)
    assert len(_got(n["auv"], EV_RECEIVED)) == 2


def test_without_a_key_a_node_takes_unauthenticated_commands():
    # the guard exists only with a key: a network without one works as before
    w, n = _net(key_for=())
    _send(w, n["stranger"], seaware.encode(3, "start_mission"))
    assert len(_got(n["auv"], EV_RECEIVED)) == 1 and not _got(n["auv"], EV_REFUSED)


def test_a_command_in_a_transport_packet_needs_every_fragment_authenticated():
    from acomm.events import EV_PACKET
    from acomm.transport import Transport

    w, n = _net()
    wall = lambda: w.now() // 1000  # noqa: E731
    for name in n:
        Transport.of(n[name].node, wall=wall)
    # the stranger's transfer starts with its fragments, as an attacker's
    # would: a fresh transport (nothing resumed from its store) sends no
    # lane probe first (acomm.transport.arq.Outgoing.probe), whose answer
    # the stranger could not hear anyway
    assert n["stranger"].node.transport.pending() == []
    start = seaware.encode(2, "start_mission")
    n["topside"].node.transport.send(w.now(), "auv", start, 600, 5)
    w.run(60000)
    # one at a time: the stranger cannot hear the auv's acknowledgements
    # (sealed; a node without the key drops sealed frames), so a fragment
    # of its lost in a collision would never be asked for again
    n["stranger"].node.transport.send(w.now(), "auv", seaware.encode(3, "start_mission"), 600, 5)
    w.run(60000)
    auv = n["auv"]
    assert [e[3] for e in _got(auv, EV_PACKET)] == [start]
    refused = _got(auv, EV_REFUSED)
    assert len(refused) == 1 and refused[0][1] is None and refused[0][2] == "stranger"
    assert auv.node.transport.stats["refused_unauthed"] == 1
