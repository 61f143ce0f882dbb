# The neighbour table of routing's first step (acomm.link.neighbours): ETX
# from acknowledged attempts and from adverts missed, ageing (and starting
# afresh when heard again past it), the bounded table's eviction rule,
# signal averages, across the 2**30 tick wrap.

from acomm.compat import TICKS_MAX, ticks_add
from acomm.errors import AcommError
from acomm.link.neighbours import RECENT_ATTEMPTS, Neighbours
from acomm.prng import Prng
from checks import raises

T0 = TICKS_MAX - 5000  # the wrap comes within the first adverts
P = 60000  # advert period


def _adverts(nb, node, n, lose_every=0, start=T0):
    # n advert periods from start; every lose_every-th advert is lost on the way
    t = start
    for i in range(1, n + 1):
        t = ticks_add(start, i * P)
        if lose_every and i % lose_every == 0:
            continue
        nb.heard(t, node, advert_period_ms=P)
    return t


def test_unknown_until_heard_and_perfect_adverts_give_one():
    nb = Neighbours()
    assert nb.etx(T0, 5) is None
    nb.heard(T0, 5)  # a data frame says nothing about the ratio
    assert nb.etx(T0, 5) is None
    t = _adverts(nb, 5, 10)
    assert nb.etx16(t, 5) == 16 and nb.etx(t, 5) == 1.0


def test_missed_adverts_raise_etx_as_the_square_of_the_loss():
    nb = Neighbours()
    t = _adverts(nb, 7, 200, lose_every=2)  # half the adverts lost: ratio 0.5, ETX about 4
    e = nb.etx(t, 7)
    assert 3.0 <= e <= 5.5, e
    nb2 = Neighbours()
    t = _adverts(nb2, 7, 200, lose_every=5)  # a fifth lost: ETX about 1.56
    assert 1.3 <= nb2.etx(t, 7) <= 1.9


def test_attempts_take_over_from_adverts():
    nb = Neighbours()
    t = _adverts(nb, 3, 20)
    rng = Prng(4)
    for i in range(RECENT_ATTEMPTS - 1):
        nb.attempt(t, 3, False)
    assert nb.etx(t, 3) == 1.0  # too few attempts yet: the adverts' figure
    for i in range(400):
        nb.attempt(t, 3, rng.below(3) != 0)  # two in three acknowledged: ETX 1.5
    assert 1.2 <= nb.etx(t, 3) <= 2.0, nb.etx(t, 3)
    for i in range(60):
        nb.attempt(t, 3, False)
    assert nb.etx16(t, 3) == 1600  # never acknowledged lately: the ceiling, ETX 100


def test_attempts_alone_give_a_figure():
    nb = Neighbours()
    nb.attempt(T0, 9, True)
    assert nb.etx(T0, 9) == 1.0
    nb.attempt(T0, 9, False)
    assert nb.etx(T0, 9) > 1.0


def test_a_neighbour_not_heard_ages_out():
    nb = Neighbours(max_age_ms=3 * P)
    t = _adverts(nb, 2, 5)
    assert nb.etx(ticks_add(t, 3 * P - 1), 2) == 1.0
    assert nb.etx(ticks_add(t, 3 * P), 2) is None
    assert nb.usable(ticks_add(t, 3 * P)) == []


def test_a_long_silence_then_an_advert_counts_a_bounded_loss():
    nb = Neighbours(max_age_ms=10 ** 8)
    t = _adverts(nb, 4, 10)
    t = ticks_add(t, 1000 * P)  # gone for a thousand periods, then back
    nb.heard(t, 4, advert_period_ms=P)
    e = nb.etx(t, 4)
    assert e is not None and e > 10  # poor: it was missing
    for i in range(1, 60):
        nb.heard(ticks_add(t, i * P), 4, advert_period_ms=P)
    assert nb.etx(ticks_add(t, 59 * P), 4) < 1.1  # and it recovers as adverts keep coming


def test_heard_again_after_the_age_limit_it_starts_afresh():
    # polls unanswered while it was away made it look dead; back after longer than max_age_ms,
    # that evidence is dropped: no figure until its first advert, then one
    nb = Neighbours(max_age_ms=3 * P)
    t = _adverts(nb, 5, 3)
    for _ in range(RECENT_ATTEMPTS):
        nb.attempt(t, 5, False)
    assert nb.etx(t, 5) > 10
    t = ticks_add(t, 3 * P)
    nb.heard(t, 5)  # a frame of its, not an advert
    assert nb.etx(t, 5) is None
    nb.heard(ticks_add(t, 1000), 5, advert_period_ms=P)
    assert nb.etx(ticks_add(t, 1000), 5) == 1.0
    # within the limit nothing is forgotten
    for _ in range(RECENT_ATTEMPTS):
        nb.attempt(t, 5, False)
    nb.heard(ticks_add(t, 3 * P - 1), 5)
    assert nb.etx(ticks_add(t, 3 * P - 1), 5) > 10


def test_the_table_is_bounded_and_keeps_recent_neighbours():
    nb = Neighbours(capacity=4, keep_ms=30000)
    for k in range(4):
        assert nb.heard(ticks_add(T0, k * 1000), k)
    # all heard within keep_ms: a newcomer is refused, nobody is evicted
    assert not nb.heard(ticks_add(T0, 5000), 99)
    assert nb.refused == 1 and 99 not in nb.table and len(nb.table) == 4
    nb.attempt(ticks_add(T0, 5000), 98, True)  # nor by an attempt
    assert nb.refused == 2
    # later: the one heard longest ago makes room
    t = ticks_add(T0, 40000)
    for k in (1, 2, 3):
        nb.heard(t, k)
    assert nb.heard(t, 99)
    assert 0 not in nb.table and 99 in nb.table and len(nb.table) == 4


def test_usable_orders_by_etx_then_recency():
    nb = Neighbours()
    t = _adverts(nb, 1, 100, lose_every=3)
    _adverts(nb, 2, 100)
    _adverts(nb, 3, 99)
    assert nb.usable(t) == [2, 3, 1]


def test_signal_averages_and_bad_ids():
    nb = Neighbours()
    nb.heard(T0, 6, rssi=-60.0, snr=12.0)
    nb.heard(T0, 6, rssi=-80.0)
    r, s = nb.signal(6)
    assert r == -65.0 and s == 12.0
    assert nb.signal(7) == (None, None)
    assert raises(AcommError, nb.heard, T0, 255)
    assert raises(AcommError, nb.attempt, T0, -1, True)
