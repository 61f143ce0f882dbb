# The key lifecycle (acomm.frame.auth): a damaged or lost counter file starts a
# new counter epoch instead of stopping the node, which peers take only
# from a frame sealed under it, never from a recording; two keys (the
# counter's phase bit) during a rotation; rotation by sealed command, on
# the stack, and what a restart keeps of it.
from acomm import frame as fr
from acomm.apps.policy import commands
from acomm.frame.auth import OP_DROP, OP_INSTALL, OP_USE, Auth, key_command
from acomm.errors import AcommError, AuthError
from acomm.events import EV_RECEIVED, EV_REFUSED
from acomm_sim.world import World
from checks import TempDir, raises

KEY = b"0123456789abcdef0123456789abcdef"
KEY2 = b"fedcba9876543210fedcba9876543210"
NONCE = b"\x01\x02\x03\x04\x05\x06\x07\x08"


def _advert(a, src=2):
    return a.seal(fr.ADVERT, src, None, bytes((src, 1)), 0, True)


def _no_key(a, phase):
    # True when a holds no key for phase: a frame sealed under that phase
    # (by a peer of its own, source 250) is refused for want of one
    peer = Auth(KEY)
    if phase:
        peer.add_key(KEY2, 1)
        peer.key_command(key_command(OP_USE, 1))
    before = a.stats["no_key"]
    try:
        a.open(fr.DATA, 250, 1, peer.seal(fr.DATA, 250, 1, b"probe"))
    except AuthError:
        pass
    return a.stats["no_key"] == before + 1


def test_a_damaged_counter_file_starts_a_new_epoch_that_peers_take_only_sealed():
    with TempDir() as d:
        path = d.file("b.auth")
        b = Auth(KEY, path=path, wall=lambda: 5000)
        peer = Auth(KEY)
        peer.open(fr.ADVERT, 2, None, _advert(b))
        old = [b.seal(fr.DATA, 2, 1, b"m%d" % i) for i in range(3)]
        for body in old:
            peer.open(fr.DATA, 2, 1, body)
        old_advert = _advert(b)
        for damage in (b"AK2\x00\x00", b"garbage of some length", b""):
            with open(path, "wb") as f:
                f.write(damage)
            try:
                os_remove(path + ".new")
            except OSError:
                pass
            b2 = Auth(KEY, path=path, wall=lambda: 6000)  # the node starts: no error
            assert b2.epoch == 6000 and b2.stats["epochs"] == 1
        # its counters start over; under the new epoch they do not verify
        # at a peer that has not heard the announcement
        fresh = b2.seal(fr.DATA, 2, 1, b"new")
        raises(AuthError, peer.open, fr.DATA, 2, 1, fresh)
        # the announcement (an advert) sealed under the new epoch is taken,
        # and from then on the node's frames pass, the old ones still do not
        peer.open(fr.ADVERT, 2, None, _advert(b2))
        assert peer.stats["epochs"] == 1
        assert peer.open(fr.DATA, 2, 1, b2.seal(fr.DATA, 2, 1, b"ok"))[0] == b"ok"
        for body in old + [old_advert]:
            raises(AuthError, peer.open, fr.DATA if body is not old_advert else fr.ADVERT, 2,
                   1 if body is not old_advert else None, body)
        # an announcement forged without the key, claiming a later epoch
        forged = bytearray(_advert(b2))
        forged[-10] = 0x7F  # the epoch's first byte
        raises(AuthError, peer.open, fr.ADVERT, 2, None, bytes(forged))
        assert peer.stats["epochs"] == 1


def os_remove(p):
    import os

    os.remove(p)


def test_a_lost_counter_file_is_a_new_epoch_too_and_peers_keep_theirs():
    with TempDir() as d:
        path = d.file("a.auth")
        a = Auth(KEY, path=path, wall=lambda: 100)
        b = Auth(KEY, path=d.file("b.auth"), wall=lambda: 200)
        b.open(fr.ADVERT, 2, None, _advert(a))
        b.open(fr.DATA, 2, 1, a.seal(fr.DATA, 2, 1, b"x"))
        b.commit()
        os_remove(path)
        # the clock stood still (no RTC): the epoch still goes up by one
        a2 = Auth(KEY, path=path, wall=lambda: 0)
        assert a2.epoch == 1
        b2 = Auth(KEY, path=d.file("b.auth"))  # b restarts and keeps a's epoch 100
        raises(AuthError, b2.open, fr.ADVERT, 2, None, _advert(a2))  # epoch 1 < 100: refused
        a3 = Auth(KEY, wall=lambda: 300)
        a3.epoch = 300
        b2.open(fr.ADVERT, 2, None, _advert(a3))
        assert b2.stats["epochs"] == 1


def test_two_keys_during_a_rotation_and_a_dropped_one_is_refused():
    a, b = Auth(KEY), Auth(KEY)
    before = a.seal(fr.DATA, 2, 1, b"before")
    raises(AcommError, key_command, OP_INSTALL, 1)  # no nonce
    raises(AcommError, key_command, OP_USE, 2)
    for node in (a, b):
        assert node.key_command(key_command(OP_INSTALL, 1, NONCE))
    assert not a.key_command(b"\xa5 not a key command")
    assert a.key_command(key_command(OP_USE, 1)) and a.phase == 1
    after = a.seal(fr.DATA, 2, 1, b"after")
    assert after[-7] & 0x80  # the phase bit
    assert b.open(fr.DATA, 2, 1, after)[0] == b"after"
    assert b.open(fr.DATA, 2, 1, before)[0] == b"before"  # late, but the old key is still held
    c = Auth(KEY)  # missed the install
    raises(AuthError, c.open, fr.DATA, 2, 1, a.seal(fr.DATA, 2, 1, b"x"))
    assert c.stats["no_key"] == 1
    # a key delivered out of band works the same way
    c.add_key(KEY2, 1)
    d = Auth(KEY)
    d.add_key(KEY2, 1)
    d.key_command(key_command(OP_USE, 1))
    assert c.open(fr.DATA, 4, 1, d.seal(fr.DATA, 4, 1, b"oob"))[0] == b"oob"
    # the key in use is never dropped; once b sends with the new one, the
    # old phase goes, and a frame sealed with it is refused
    assert b.key_command(key_command(OP_DROP, 0)) and not _no_key(b, 0)
    b.key_command(key_command(OP_USE, 1))
    b.key_command(key_command(OP_DROP, 0))
    raises(AuthError, b.open, fr.DATA, 5, 1, Auth(KEY).seal(fr.DATA, 5, 1, b"old key"))
    assert b.stats["no_key"] == 1


def test_the_rotation_survives_a_restart():
    with TempDir() as d:
        a = Auth(KEY, path=d.file("a"), wall=lambda: 10)
        a.key_command(key_command(OP_INSTALL, 1, NONCE))
        a.key_command(key_command(OP_USE, 1))
        a.key_command(key_command(OP_DROP, 0))
        a2 = Auth(KEY, path=d.file("a"))
        assert a2.phase == 1 and a2.epoch == 10 and _no_key(a2, 0)
        b = Auth(KEY)
        b.key_command(key_command(OP_INSTALL, 1, NONCE))
        b.open(fr.ADVERT, 2, None, _advert(a2))
        assert b.open(fr.DATA, 2, 1, a2.seal(fr.DATA, 2, 1, b"still"))[0] == b"still"


def test_rotation_by_sealed_command_on_the_stack():
    w = World(seed=4)
    n = {}
    for name, nid, x in (("auv", 1, 0), ("topside", 2, 100), ("stranger", 3, 150)):
        n[name] = w.add(name, nid, "seatrac", position=(x, 0, 5), link_opts={"advert_period_ms": 600000})
    for name in ("auv", "topside"):
        n[name].node.set_auth(Auth(KEY), commands())
    w.run(5000)
    auv = n["auv"].node.auth
    # from a node without the key: refused, and the auv keeps one key
    n["stranger"].node.send("acoustic", "auv", key_command(OP_INSTALL, 1, NONCE), 60, 5)
    w.run(20000)
    assert [e[0] for e in n["auv"].events if e[0] == EV_REFUSED] == [EV_REFUSED] and _no_key(auv, 1)
    # sealed, from the topside: the auv installs the key
    top = n["topside"].node.auth
    cmd = key_command(OP_INSTALL, 1, NONCE)
    n["topside"].node.send("acoustic", "auv", cmd, 60, 5)
    w.run(20000)
    assert not _no_key(auv, 1)
    top.key_command(cmd)
    top.key_command(key_command(OP_USE, 1))
    n["topside"].node.send("acoustic", "auv", b"on the new key", 60, 5)
    w.run(20000)
    got = [e[4] for e in n["auv"].events if e[0] == EV_RECEIVED]
    assert got[-1] == b"on the new key" and auv.stats["opened"] >= 2


def test_a_file_naming_a_dropped_key_in_use_is_damaged_and_an_added_key_is_added_again():
    with TempDir() as d:
        path = d.file("c.auth")
        # phase 1 in use, phase 1 dropped: inconsistent, so a new epoch on the base key
        with open(path, "wb") as f:
            f.write(b"AK2\x01\x00\x00\x00\x05\x00\x00\x10\x00\x02\x00")
        a = Auth(KEY, path=path, wall=lambda: 900)
        assert a.epoch == 900 and a.phase == 0 and _no_key(a, 1)
        assert Auth(KEY).open(fr.ADVERT, 2, None, _advert(a))[0] == b"\x02\x01"
        # an out-of-band key in use (flag 0 for phase 1): the file loads, and
        # the node seals only once whoever loads it has added the key again
        b = Auth(KEY, path=d.file("b.auth"), wall=lambda: 50)
        b.add_key(KEY2, 1)
        b.key_command(key_command(OP_USE, 1))
        b2 = Auth(KEY, path=d.file("b.auth"))
        assert b2.phase == 1 and b2.epoch == 50
        raises(AcommError, b2.seal, fr.DATA, 2, 1, b"x")
        b2.add_key(KEY2, 1)
        peer = Auth(KEY)
        peer.add_key(KEY2, 1)
        peer.open(fr.ADVERT, 2, None, _advert(b2))
        assert peer.open(fr.DATA, 2, 1, b2.seal(fr.DATA, 2, 1, b"y"))[0] == b"y"
