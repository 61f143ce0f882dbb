# The node's wall clock (acomm.wallclock): the port's clock until a source
# speaks, the first fix taken, a big step only when confirmed, never
# backwards, steps told to listeners, and the last good time kept in a
# file so that a reboot never starts it earlier.
from acomm.wallclock import MIN_S, WallClock
from checks import TempDir

T = MIN_S + 90000000  # a time from 2020-01-01: late 2026


class Rig:
    # a clock on hand-moved ticks (ms) and a hand-set port clock (s)
    def __init__(self, port=100, path=None, host=False):
        self.t = 0
        self.port = port
        self.c = WallClock(lambda: self.port, lambda: self.t, path, 0, host)
        self.steps = []
        self.c.on_step(self.steps.append)

    def at(self, t):
        self.t = t
        self.c.poll(t)
        return self.c.wall()


def test_before_any_source_it_is_the_ports_clock():
    r = Rig(port=1000)
    assert r.c.wall() == 1000 and r.c.source == "none" and r.c.uncertainty_ms() is None
    r.port = 1005
    assert r.at(5000) == 1005 and r.steps == []
    # the port's clock set forward (a board's RTC set): a step, told
    r.port = 5000
    assert r.at(6000) == 5000 and r.steps == [3994]
    # set back: not followed, the clock goes on from where it was
    r.port = 10
    assert r.at(8000) == 5002


def test_the_first_fix_is_taken_and_steps_forward():
    r = Rig()
    assert r.c.fix(1000, "iridium", T, 500, 500)
    assert r.c.source == "iridium" and r.c.wall() == T and r.steps == [T - 101]
    assert r.at(3600) == T + 3  # 500 ms + 2600 ms
    assert r.c.uncertainty_ms(3600) == 500
    # once a source spoke the port's clock is not read again
    r.port = T + 10000
    assert r.at(5000) == T + 4
    # a fix before 2024 (a modem's power-up date) is no source
    assert not r.c.fix(5000, "gsm", 1000, 0, 2000)


def test_a_big_step_needs_a_confirmation():
    r = Rig()
    r.c.fix(0, "gps", T, 0, 1000)
    # one bad fix, a day ahead: kept aside, the clock does not move
    assert not r.c.fix(10000, "gps", T + 86400 + 10, 0, 1000)
    assert r.at(10000) == T + 10
    # the same glitch told again within 5 s by the same source: still not
    assert not r.c.fix(12000, "gps", T + 86400 + 12, 0, 1000)
    # a second fix that agrees with the first, 5 s later: taken, a step
    assert r.c.fix(16000, "gps", T + 86400 + 16, 0, 1000)
    assert r.at(16000) == T + 86400 + 16 and r.steps[-1] == 86400
    # a good fix (within the uncertainties) drops a waiting candidate
    assert not r.c.fix(16500, "gps", T + 16, 500, 1000)
    assert r.c.fix(17000, "gps", T + 86400 + 17, 0, 1000)
    assert r.c._cand is None
    # another source agreeing with a candidate confirms it at once
    assert not r.c.fix(17000, "gps", T + 2 * 86400 + 17, 0, 1000)
    assert r.c.fix(17500, "iridium", T + 2 * 86400 + 17, 500, 500)
    assert r.at(17500) == T + 2 * 86400 + 17
    assert r.c.source == "iridium"


def test_small_corrections_within_the_uncertainty_are_taken():
    r = Rig()
    r.c.fix(0, "gsm", T, 0, 2000)
    # 2.5 s ahead: within 2 s + 2 s + 1 s
    assert r.c.fix(10000, "gsm", T + 12, 500, 2000)
    assert r.c.wall() == T + 12 and r.steps[-1] == 2
    # the uncertainty grows with the time since the last fix (100 ppm)
    assert r.c.uncertainty_ms(10000 + 3600000) == 2000 + 360


def test_never_backwards_a_correction_back_is_held():
    r = Rig()
    r.c.fix(0, "gps", T, 0, 1000)
    assert r.at(10000) == T + 10
    n = len(r.steps)
    # 1.8 s back: taken, but wall() holds at T+10 until the time passes it
    assert r.c.fix(10000, "gps", T + 8, 200, 1000)
    assert r.c.wall() == T + 10 and len(r.steps) == n
    assert r.at(11000) == T + 10
    assert r.at(12700) == T + 10
    assert r.at(12800) == T + 11
    values = [r.at(13000 + 100 * i) for i in range(50)]
    assert values == sorted(values)


def test_host_mode_keeps_the_hosts_clock():
    r = Rig(port=T + 3, host=True)
    assert r.c.source == "host"
    assert not r.c.fix(0, "iridium", T + 500, 0, 500)
    assert r.c.wall() == T + 3 and r.c.source == "host"


def test_the_last_good_time_survives_a_reboot():
    with TempDir() as d:
        path = d.file("clock")
        r = Rig(path=path)
        r.c.fix(0, "iridium", T, 0, 500)  # a step of years: written a minute later
        assert r.c.saves == 0
        r.at(59000)
        assert r.c.saves == 0
        r.at(60000)
        with open(path) as f:
            assert int(f.read()) == T + 60
        # then at most one write an hour of uptime
        for i in range(2, 121):
            r.at(i * 60000)  # two hours, polled every minute
        assert r.c.saves == 2
        r.at(60000 + 2 * 3600000)
        assert r.c.saves == 3
        with open(path) as f:
            assert int(f.read()) == T + 60 + 7200
        # a board without a battery clock restarts at its power-up date:
        # the clock starts at the last good time, not before
        r2 = Rig(port=50, path=path)
        assert r2.c.wall() == T + 7260 and r2.c.source == "none"
        # a port clock ahead of the file wins
        r3 = Rig(port=T + 9000, path=path)
        assert r3.c.wall() == T + 9000
        # a damaged file: the port's clock, as without one
        with open(path, "w") as f:
            f.write("12x")
        assert Rig(port=77, path=path).c.wall() == 77
