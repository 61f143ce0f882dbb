# The MicroPython port's board layer (ports/micropython/acomm_mp) and the two
# board definitions (boards/*/config.py), on both runtimes: configurations
# are checked with messages that name the field, a board's node is
# assembled from its config and runs for a simulated minute against
# emulated modems with frames flowing, the main loop's tick survives
# MemoryError and garbage, and machine.UART is normalised.
from acomm.catalog import caddy
from acomm_sim.fakeuart import FakeUART
from acomm.prng import Prng
from acomm_mp import boot as mpboot
from acomm_mp.assemble import build
from acomm_mp.boardconfig import ConfigError, check
from acomm_mp.uartstream import UartStream
from acomm_sim.boardsim import run_board
from checks import raises

# the repository from this file's path (tests/core/), not from acomm's:
# acomm frozen into a firmware has no path in the repository
ROOT = (__file__.rsplit("/", 1)[0] if "/" in __file__ else ".") + "/../.."


def _config(board):
    g = {}
    with open(ROOT + "/boards/" + board + "/config.py") as f:
        exec(f.read(), g)
    return g["CONFIG"]


def _copy(d):
    # a deep enough copy of a config to spoil one field
    out = {}
    for k in d:
        v = d[k]
        if isinstance(v, dict):
            v = dict(v)
        elif isinstance(v, list):
            v = [dict(x) if isinstance(x, dict) else x for x in v]
        out[k] = v
    return out


def _error(cfg):
    return str(raises(ConfigError, check, cfg))


def test_both_boards_check_and_fill_defaults():
    for board in ("buoy_pico", "diver_esp32s3"):
        cfg = check(_config(board))
        assert cfg["links"] and cfg["step_ms"] == 10 and cfg["gc_ms"] == 1000
        for lk in cfg["links"]:
            assert lk["address"] == cfg["node_id"] and isinstance(lk["options"], dict)
    buoy = check(_config("buoy_pico"))
    assert [lk["modem"] for lk in buoy["links"]] == ["seatrac", "iridium"]
    assert buoy["arch"] == "armv6m" and buoy["station"] is None
    # mpy_lines (acomm flash's choice) stays in the checked copy only when False
    c = _config("buoy_pico")
    c["mpy_lines"] = True
    assert "mpy_lines" not in check(c)
    c["mpy_lines"] = False
    assert check(c)["mpy_lines"] is False


def test_a_wrong_field_is_named():
    base = _config("buoy_pico")
    c = _copy(base)
    del c["node_id"]
    assert "node_id: missing" in _error(c)
    c = _copy(base)
    c["links"][1]["baud"] = "fast"
    assert "links[1].baud" in _error(c) and "fast" in _error(c)
    c = _copy(base)
    c["links"][0]["modem"] = "tin_can"
    assert "links[0].modem" in _error(c)
    c = _copy(base)
    c["links"][1]["name"] = "acoustic"
    assert "links[1].name" in _error(c)
    c = _copy(base)
    c["routes"] = {"shore": "nobody"}
    assert "routes.shore" in _error(c)
    c = _copy(base)
    c["storage"]["capacity"] = 10
    assert "storage.capacity" in _error(c)
    c = _copy(base)
    c["nodeid"] = 1
    assert "nodeid" in _error(c)
    c = _copy(base)
    c["arch"] = "z80"
    assert "arch" in _error(c)
    c = _copy(base)
    c["mpy_lines"] = 0
    assert "mpy_lines" in _error(c)
    c = _copy(base)
    c["peers"] = {"diver": 1}  # the board's own id
    assert "peers.diver" in _error(c)
    c = _copy(base)
    c["links"][0]["link"] = {"advert_period": 5}
    assert "links[0].link" in _error(c)
    c = _copy(base)
    c["watchdog_ms"] = 100
    assert "watchdog_ms" in _error(c)
    c = _copy(base)
    c["links"] = []
    assert "links" in _error(c)
    # a driver option the driver does not take: found when the node is built
    c = _copy(base)
    c["links"][1]["options"] = {"no_such_option": 1}
    e = raises(ConfigError, build, check(c), lambda lk: FakeUART())
    assert "links[1].options" in str(e)


def test_routing_is_a_board_option_off_by_default():
    base = _config("buoy_pico")
    c = check(base)
    assert "routing" not in c  # off: the checked config is as it was
    t = build(c, lambda lk: FakeUART()).transport
    assert t.router.routing is None
    c = _copy(base)
    c["routing"] = True
    assert check(c)["routing"] is True
    rt = build(check(c), lambda lk: FakeUART()).transport.router.routing
    assert rt is not None and rt.finder.search_ms == 60000
    c["routing"] = {"search_ms": 30000, "media": ["acoustic"], "capacity": 8}
    rt = build(check(c), lambda lk: FakeUART()).transport.router.routing
    assert rt.finder.search_ms == 30000 and rt.table.capacity == 8 and rt.media == ("acoustic",)
    for bad, field in (("yes", "routing"), ({"search": 1}, "routing"), ({"search_ms": 5}, "routing.search_ms"),
                       ({"media": []}, "routing.media")):
        c["routing"] = bad
        assert field in _error(c), bad


def test_the_buoy_relays_for_a_simulated_minute():
    r = run_board(_config("buoy_pico"), {"diver": "seatrac", "shore": "iridium"}, via={"diver": "shore"})
    assert r["sim_ms"] >= 60000
    ac, sat = r["links"]["acoustic"], r["links"]["satellite"]
    assert ac["tx_frames"] > 0 and ac["rx_frames"] > 0  # frames flowed both ways acoustically
    assert sat["tx_frames"] > 0 and sat["rx_frames"] > 0  # and over Iridium
    srcs = sorted(p[0] for p in r["board_packets"])
    assert srcs == ["diver", "shore"]  # each peer's chat line reached the board
    assert r["relayed"] == 1  # the diver's packet for shore is in the buoy's custody
    assert r["board"]["errors"] == 0 and r["board"]["oom"] == 0 and r["board"]["gc"] >= 59


def test_the_diver_tablet_sends_its_alarm_and_hears_the_buoy():
    r = run_board(_config("diver_esp32s3"), {"buoy": "seatrac"})
    got = r["peer_packets"]["buoy"]
    assert len(got) == 1 and got[0][0] == "diver"
    m = caddy.CATALOG.unpack(got[0][2])
    assert m[0][0] is caddy.ALARM and m[0][1]["alarm"] == "low_air"
    assert r["inbox"] == [("buoy", "chat", {"text": "hello buoy"})]
    assert r["station"]["alarms"] == 1 and r["board"]["errors"] == 0


class _Wdt:
    def __init__(self):
        self.fed = 0

    def feed(self):
        self.fed += 1


class _Garbage:
    # a UART that hands up noise, or nothing at all (read() -> None). The noise
    # is drawn once and handed up 8 bytes at a time, round: drawing each 8 in
    # Python was the test's own cost, not the node's (on the emulated Pico too)
    def __init__(self, seed, silent=False):
        self.noise = Prng(seed).bytes(1024)
        self.at = 0
        self.silent = silent

    def any(self):
        return 0 if self.silent else 8

    def read(self, n=-1):
        if self.silent:
            return None
        at = self.at
        self.at = (at + 8) % len(self.noise)
        return self.noise[at:at + 8]

    def write(self, b):
        return None  # a UART timeout


def test_errors_and_out_of_memory_in_a_step_do_not_stop_the_loop():
    said = []
    cfg = check(_config("buoy_pico"))
    board = build(cfg, lambda lk: FakeUART(), say=said.append)
    board.wdt = _Wdt()
    real = board.node.step
    faults = [MemoryError("heap"), ValueError("bug"), MemoryError("again")]

    def flaky(now):
        if faults:
            raise faults.pop(0)
        return real(now)

    board.node.step = flaky
    for k in range(10):
        board.tick(k * 10)
    assert board.stats["oom"] == 2 and board.stats["errors"] == 1 and board.stats["ticks"] == 10, board.stats
    assert board.wdt.fed == 10  # fed on every tick, faulty or not
    assert len(said) == 2  # each kind reported once, not once per tick
    assert "out of memory" in said[0] and "ValueError" in said[1]


def test_a_uart_of_garbage_or_silence_never_stops_the_node():
    cfg = check(_config("buoy_pico"))
    uarts = [_Garbage(3), _Garbage(4, silent=True)]
    said = []
    board = build(cfg, lambda lk: uarts.pop(0), say=said.append)
    # 20 s of the board's time (every second's collection, the drivers'
    # timers), ticked every 40 ms: 64 KiB of noise. At every 10 ms it was
    # four times the noise for no other path, and four minutes of the
    # emulated Pico's CI time
    for k in range(500):
        board.tick(k * 40)
    assert board.stats["ticks"] == 500 and board.stats["gc"] >= 19, board.stats
    assert board.stats["errors"] == 0 and board.stats["oom"] == 0, (board.stats, said)
    assert board.node.links["acoustic"].stats is not None


class _Pin:
    def __init__(self, n):
        self.n = n


class _Uart:
    # machine.UART as on a port whose constructor has no rxbuf
    def __init__(self, uid, **kw):
        if "rxbuf" in kw:
            raise TypeError("unexpected keyword argument 'rxbuf'")
        self.uid, self.kw = uid, kw
        self.rx = b"\x01\x02\x03"

    def any(self):
        return len(self.rx)

    def read(self, n):
        # timeout=0: what is waiting, up to n; None when nothing is
        got, self.rx = self.rx[:n], self.rx[n:]
        return got or None

    def write(self, b):
        return 2 if len(b) > 2 else None


class _Machine:
    Pin = _Pin
    UART = _Uart


def test_machine_uart_is_normalised():
    lk = check(_config("buoy_pico"))["links"][1]
    s = mpboot.open_uart(_Machine, lk)
    assert s.uart.uid == 1 and s.uart.kw["baudrate"] == 19200 and s.uart.kw["tx"].n == 4
    assert lk["rxbuf"] == 256  # 100 ms at 19200 baud is less: the floor
    assert check(_config("buoy_pico"))["links"][0]["rxbuf"] == 1152  # SeaTrac, 115200 baud
    assert s.read(2) == b"\x01\x02" and s.read(64) == b"\x03"
    assert s.read(64) is None  # nothing waiting: None, never a blocking read
    assert s.write(b"abcdef") == 2 and s.write(b"a") == 0  # a timeout counts as nothing written
    assert s.bytes_in == 3 and s.bytes_out == 2


def test_a_module_released_after_boot_leaves_and_loads_again():
    import sys

    import acomm_mp
    from acomm_mp import release

    import acomm_mp.uartstream  # noqa: F401

    release("acomm_mp.uartstream")
    assert "acomm_mp.uartstream" not in sys.modules and "uartstream" not in acomm_mp.__dict__
    from acomm_mp.uartstream import UartStream

    assert UartStream is not None and "acomm_mp.uartstream" in sys.modules


def test_the_config_module_is_released_once_checked():
    # start("config") on a board: the checked copy stays, the module and
    # its raw CONFIG go (two copies would both stay on the heap for ever)
    import sys

    from acomm_mp.runloop import run_blocking
    from acomm_mp.boot import load_config

    class _Module:
        CONFIG = _config("buoy_pico")

    sys.modules["acomm_test_config"] = _Module
    try:
        cfg = load_config("acomm_test_config")
    finally:
        gone = "acomm_test_config" not in sys.modules
        sys.modules.pop("acomm_test_config", None)
    assert gone and cfg["links"][0]["rxbuf"] == 1152 and "acomm_mp.boardconfig" not in sys.modules
    assert load_config(_config("diver_esp32s3"))["name"] == "diver"  # a dict is taken as it is
    assert run_blocking is not None


def test_the_plain_loop_polls_each_step_and_sleeps_what_is_left():
    from acomm_mp.runloop import run_blocking

    class _Board:
        cfg = {"step_ms": 10}
        ticks = []

        def poll(self, now):
            self.tick(now)

        def tick(self, now):
            self.ticks.append(now)
            t[0] += 3  # the step itself takes 3 ms

    t = [0]
    slept = []

    def sleep(ms):
        slept.append(ms)
        t[0] += ms

    b = _Board()
    run_blocking(b, clock=lambda: t[0], sleep_ms=sleep, stop=lambda: len(b.ticks) >= 4)
    assert b.ticks == [0, 10, 20, 30] and slept == [7, 7, 7, 7]
    # a step longer than step_ms is not followed by a sleep
    b.ticks = []
    slept = []

    def slow(now):
        b.ticks.append(now)
        t[0] += 25

    b.tick = slow
    run_blocking(b, clock=lambda: t[0], sleep_ms=sleep, stop=lambda: len(b.ticks) >= 2)
    assert slept == [] and b.ticks[1] - b.ticks[0] == 25


def test_an_idle_node_steps_every_idle_ms_and_bytes_wake_it_within_a_step():
    cfg = check(_config("buoy_pico"))
    assert cfg["idle_ms"] == 100  # the default
    uarts = [FakeUART(), FakeUART()]
    given = list(uarts)
    board = build(cfg, lambda lk: given.pop(0))
    board.wdt = _Wdt()
    for k in range(300):  # 30 s: the drivers' start-up is over, the links quiet
        board.tick(k * 100)
    ticked = []
    real = board.tick

    def tick(now):
        ticked.append(now)
        real(now)

    board.tick = tick
    # quiet: one step per idle_ms, the watchdog fed on every poll all the same
    t0 = 30000
    for k in range(100):
        board.poll(t0 + k * 10)
    # (a step at which a driver wrote a command is followed by one more)
    gaps = [b - a for a, b in zip(ticked, ticked[1:])]
    assert 9 <= len(ticked) <= 13 and max(gaps) <= 100 and gaps.count(100) >= 7, ticked
    assert board.wdt.fed >= 300 + 100 and board.stats["rests"] >= 87, (board.wdt.fed, board.stats)
    # a byte on a UART: the next poll steps the node though idle_ms has not
    # passed, and so does the one after (that step moved the byte)
    t1 = t0 + 1000
    board.tick(t1)
    del ticked[:]
    uarts[0].inject(b"\x00")
    board.poll(t1 + 10)
    board.poll(t1 + 20)
    assert ticked == [t1 + 10, t1 + 20], ticked
    # bad idle_ms values are named
    c = _copy(_config("buoy_pico"))
    for bad in (0, 5, 10001, "100"):
        c["idle_ms"] = bad
        c["step_ms"] = 10
        assert "idle_ms" in _error(c), bad


def test_the_loop_steps_after_a_step_that_moved_bytes_until_one_moves_none():
    from acomm_mp.runloop import Board

    class _Node:
        moved = 0
        steps = []

        def step(self, now):
            self.steps.append(now)
            if now in io:
                self.moved += 1

    io = (0, 10, 20)  # three steps that read or wrote, then quiet
    n = _Node()
    b = Board({"idle_ms": 100, "gc_ms": 1000, "name": "t"}, n, None, None, print, ())
    for t in range(0, 400, 10):
        b.poll(t)
    # 0, 10, 20 moved bytes: each was followed by a step; 30 moved none, so
    # the next is at 130, then 230, 330
    assert n.steps == [0, 10, 20, 30, 130, 230, 330], n.steps
    assert b.stats["ticks"] == 7 and b.stats["rests"] == 33
    # a stream that cannot say whether bytes wait makes every poll a step
    n.steps = []
    b = Board({"idle_ms": 100, "gc_ms": 1000, "name": "t"}, n, None, None, print, (object(),))
    for t in range(1000, 1050, 10):
        b.poll(t)
    assert n.steps == [1000, 1010, 1020, 1030, 1040], n.steps


def test_a_network_key_in_the_config_secures_every_link_and_a_bad_one_is_refused():
    key = "00112233445566778899aabbccddeeff"
    c = _copy(_config("buoy_pico"))
    c["auth"] = {"key": key, "tag_len": 6}
    cfg = check(c)
    board = build(cfg, lambda lk: FakeUART())
    assert board.node.auth is not None and board.node.auth.overhead == 9
    for name in board.node.links:
        assert board.node.links[name].framing.auth is board.node.auth and board.node.links[name].guard is not None
    assert check(_config("buoy_pico"))["auth"] is None  # no key: no auth
    for bad in (key[:30], key + "00" * 49, "zz" * 16, 1234, None):
        c["auth"] = {"key": bad}
        e = _error(c)
        assert "auth.key" in e and (not isinstance(bad, str) or bad not in e)  # named, never echoed
    c["auth"] = {"key": key, "tag_len": 2}
    assert "auth.tag_len" in _error(c)
    c["auth"] = {"key": key, "tagl": 4}
    assert "tagl" in _error(c)


def test_the_boards_wall_clock_counts_from_2020_in_small_integers():
    # expiries from time.time() (1970) are past 2**30, a big integer on a
    # 32-bit board; from 2020 they stay small until 2054, and a clock never
    # set gives its own small count, never a negative one
    import time

    from acomm_mp.start import wall

    t = int(time.time())
    w = wall()
    if t >= 1577836800:
        assert abs(w + 1577836800 - t) <= 1 and (1 << 30) - w > 20 * 365 * 86400
    else:  # a board whose clock was never set (the qemu board counts from boot)
        assert abs(w - t) <= 1
    assert 0 <= w < (1 << 30)
