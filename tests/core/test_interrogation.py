# acomm.apps.interrogation: one node's view of a scripted interrogation cycle.
# Each role (interrogator, responder, listener) moves on by what it
# observes, a timeout moves anyone on, and a node that missed a step
# catches up on the next frame it hears.
from acomm.compat import TICKS_MAX, ticks_add
from acomm.errors import AcommError
from acomm.apps.interrogation import Interrogation
from checks import raises

STEPS = (("p", "d"), ("b", "p"), ("b", "d"), ("p", "b"))


def test_interrogator_asks_once_and_moves_on_at_its_status():
    s = Interrogation("p", STEPS, 3000)
    assert s.turn(0) is None  # not started
    s.start(0)
    assert s.turn(0) == "d" and s.turn(5) is None  # once per step
    s.heard(1800, "d", "p")  # the reply (it may come before the status)
    assert s.step == 1
    s.done(1810, True)  # a status for a step we left changes nothing
    assert s.step == 1 and s.turn(1810) is None
    s.heard(2000, "b", "p")  # asked by b: our modem answers; next step
    assert s.step == 2 and s.turn(2000) is None
    s.heard(4500, "d", "b")  # overheard b's reply from d
    assert s.step == 3 and s.turn(4500) == "b"
    s.done(6000, False)  # failed: the cycle goes on
    assert s.step == 0 and s.cycles == 1 and s.turn(6000) == "d"


def test_responder_and_listener_follow_what_they_hear():
    d = Interrogation("d", STEPS, 3000)
    b = Interrogation("b", STEPS, 3000)
    d.start(0)
    b.start(0)
    assert d.heard(600, "p", "d") == 0 and d.step == 1  # asked
    assert b.heard(600, "p", "d") == 0 and b.step == 0  # overheard request: step 0 began
    assert b.poll(1799) == 3600 and b.step == 0  # its timeout counts from there
    assert b.heard(1800, "d", "p") == 0 and b.step == 1 and b.turn(1800) == "p"
    # a frame of the step before is late news: nothing moves
    assert d.heard(1900, "p", "d") == 0 and d.step == 1


def test_timeout_moves_everyone_on_and_is_counted():
    s = Interrogation("b", STEPS, 3000)
    s.start(ticks_add(TICKS_MAX, -1000))  # across the tick wrap
    t = ticks_add(TICKS_MAX, -1000)
    assert s.poll(ticks_add(t, 2999)) == ticks_add(t, 3000) and s.step == 0
    s.poll(ticks_add(t, 3000))
    assert s.step == 1 and s.timeouts == [1, 0, 0, 0]
    assert s.turn(ticks_add(t, 3000)) == "p"


def test_catches_up_on_a_later_step_and_resolves_repeated_pairs():
    s = Interrogation("d", STEPS, 3000)
    s.start(0)
    # d missed steps 0 and 1; it hears b ask it (step 2): asked, so step 3
    s.heard(5000, "b", "d")
    assert s.step == 3
    # p -> b is step 3's request (nearer) and not step 1's reply
    assert s.heard(7000, "p", "b") == 3 and s.step == 3
    assert s.heard(8800, "b", "p") == 3 and s.step == 0 and s.cycles == 1
    # at step 1 (b asks p), p -> b is step 1's reply
    s.heard(9000, "p", "d")
    assert s.step == 1
    assert s.heard(10000, "p", "b") == 1 and s.step == 2


def test_per_step_timeouts_and_refusals():
    s = Interrogation("x", (("x", "y", 1000), ("y", "x")), 5000)
    assert [s.timeout_ms(k) for k in (0, 1)] == [1000, 5000]
    s.start(0)
    assert s.turn(0) == "y"
    s.poll(1000)
    assert s.step == 1 and s.turn(1000) is None
    s.stop()
    assert s.poll(99999) is None and not s.running()
    raises(AcommError, Interrogation, "x", (), 1000)
    raises(AcommError, Interrogation, "x", (("x", "x"),), 1000)
