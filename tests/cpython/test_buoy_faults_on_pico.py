# Faults on the buoy's own chip: boards/buoy_pico running from its firmware
# (build/firmware/buoy_pico.uf2, acomm frozen in, main.py and config.py
# copied by `acomm flash --frozen` as a user does) in the emulated Raspberry
# Pi Pico (acomm_cpython.board.picoboard), with its SeaTrac on UART0 and Iridium
# on UART1 played by the modem emulators in this process
# (acomm_cpython.emulate.picoocean: the World's clock follows the board's).
#
# What a buoy at sea meets, and what must hold each time: it keeps running
# (no reboot it did not ask for, no traceback on its console), it never
# loses a packet it acknowledged, and its watchdog is fed only while its
# loop runs.
#   1. Ctrl-C stops main.py: the watchdog resets the board, main.py starts
#      again; while the loop runs, no watchdog reset.
#   2. A modem that sends garbage on UART0 and on UART1; then the real
#      modems: both links come up and packets flow on both.
#   3. Iridium unplugged for minutes, and 5. power cuts while the buoy
#      writes its store, in one run (each costs minutes of the board's
#      time): every packet it acknowledged waits in its store and leaves
#      over Iridium once it is plugged in.
#   4. A full filesystem: what cannot be stored is refused ("receiver
#      full"), never acknowledged; what was stored before still leaves; and
#      a flash full before the first boot leaves a buoy that runs and
#      relays nothing.
#
# One flashed flash image is shared (copied per test); the emulator runs
# with speed_cap=0, so the board's idle time costs no wall time. Every
# limit below is in the board's simulated time, with a wall-clock guard.
import contextlib
import os
import random
import shutil
import subprocess
import sys
import time

import pytest

from acomm.events import DELIVERED, EV_PACKET, EV_PACKET_STATUS, TRANSMITTED
from acomm_cpython.board.picoboard import PicoBoard, firmware, runner_available

ACOMM = os.path.join(os.path.dirname(sys.executable), "acomm")
FIRMWARE = firmware("buoy_pico")
_missing = runner_available() or (None if FIRMWARE else
                                  "no build/firmware/buoy_pico.uf2: build it with `make firmware`")
needs_pico = pytest.mark.skipif(_missing is not None, reason=_missing or "")

READY = b"acomm buoy: node 1"
DIVER, SHORE = 2, 3  # boards/buoy_pico's peers


def _cfg():
    from acomm_cpython.board import boardfiles
    from acomm_mp.boardconfig import check

    return check(boardfiles.load_config(boardfiles.board_path("buoy_pico")))


# The full-filesystem images. "bare": the buoy flashed, then the flash filled
# (a log that grew) before it ever ran, so it has no store. "full": a buoy
# that has been at work, then filled: its store keeps one packet it took
# custody of earlier (the diver's, for shore) and the dead records of the
# lists of delivered packets it rewrote since; at 600 bytes it is past what
# littlefs keeps inline in its directory (about 500 bytes on this flash), so
# a new record needs a new block, and there is none. Made by the board's own
# acomm (frozen) from the raw REPL, before main.py ever runs.
HELD_PID = 0x7000
HELD_BODY = bytes(range(200))
FILL = """
import os, time
def fill(name, size):
    f = open(name, 'wb')
    b = bytes(size)
    n = 0
    try:
        while True:
            f.write(b)
            f.flush()
            n += size
    except OSError:
        pass
    f.close()
    return n
def fill_all(tag):
    return sum(fill('/%s%d.bin' % (tag, size), size) for size in (65536, 4096, 256, 16))
"""
FILL_BARE = """
f = open('/reserve.bin', 'wb')
f.write(bytes(16384))
f.close()
print('FILLED', fill_all('log'), os.listdir('/'))
"""
FILL_STORE = """
from acomm.transport.store import Store
from acomm.transport.packetstore import PacketStore
os.remove('/reserve.bin')  # room for the store
try:
    os.mkdir(%(dir)r)
except OSError:
    pass
st = Store(%(path)r, capacity_bytes=%(capacity)d, max_record=%(max_record)d)
ps = PacketStore(st)
class P:
    pass
p = P()
p.origin, p.final, p.pid, p.prio, p.compressed, p.medium = %(diver)d, %(shore)d, %(pid)d, 6, False, None
p.expiry = int(time.time()) + 86400
p.body = %(body)r
p.size = len(p.body)
ps.put(p)
for k in range(4):
    # 96 bytes a record, as before the entries had lifespans (19 of 5 bytes and one spare, which
    # recover() drops): the store file, and so how full the filesystem is around it, stay as they were
    ps.save_done(b"".join(bytes((%(auv)d, (100 * k + j) >> 8, (100 * k + j) & 0xFF, 0xFF, 0xFF)) for j in range(19)) + b"\x00")
print('STORE', st.used_bytes, st.dead_bytes, len(st))
st.close()
print('FILLED', fill_all('more'))
"""


def _raw(t, code):
    out, err = t.exec_raw(code, timeout=240)
    assert not err and b"FILLED" in out, (out, err)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    """Flash images: "base" the buoy flashed; "bare" and "full" with the filesystem full (above)."""
    d = tmp_path_factory.mktemp("buoy-pico")
    paths = dict((k, str(d / (k + ".img"))) for k in ("work", "base", "bare", "full"))
    cfg = _cfg()
    st = cfg["storage"]
    with PicoBoard(FIRMWARE, flash=paths["work"]) as b:
        r = subprocess.run([ACOMM, "flash", "--board", "buoy_pico", "--port", b.usb, "--frozen"],
                           stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=180)
        assert r.returncode == 0, r.stdout + r.stderr
        b.save()
        shutil.copy(paths["work"], paths["base"])
        # main.py has not run yet (no reset since the copy): no watchdog is
        # started, the raw REPL has the board to itself
        t = b.transport()
        t.enter_raw_repl(soft_reset=False)
        _raw(t, FILL + FILL_BARE)
        b.save()
        shutil.copy(paths["work"], paths["bare"])
        _raw(t, FILL + FILL_STORE % {
            "dir": st["path"].rsplit("/", 1)[0], "path": st["path"], "capacity": st["capacity"],
            "max_record": st["max_record"], "diver": DIVER, "shore": SHORE, "auv": cfg["peers"]["auv"],
            "pid": HELD_PID, "body": HELD_BODY})
        b.close_transport()
    shutil.move(paths["work"], paths["full"])  # stop() saved the filesystem there
    return paths


@contextlib.contextmanager
def _buoy(image, tmp_path, unplugged=()):
    """The buoy booting from a copy of `image`, its ocean around it: (board, ocean)."""
    from acomm_cpython.emulate.picoocean import PicoOcean

    flash = str(tmp_path / "flash.img")
    shutil.copy(image, flash)
    board = PicoBoard(FIRMWARE, flash=flash, ptys=False, speed_cap=0)
    ocean = None
    try:
        ocean = PicoOcean(board, _cfg(), peers={"diver": "seatrac", "shore": "iridium"}, via={"diver": "shore"},
                          unplugged=unplugged)
        _fast_gateway(ocean)
        assert ocean.run_until(lambda: ocean.console.count(READY) >= 1, sim_ms=10000, wall_s=60), ocean.console.text
        yield board, ocean
    finally:
        if ocean is not None:
            ocean.close()
        board.stop()


def _fast_gateway(ocean):
    # the emulated Iridium gateway hands a message on after 1-3 s instead of
    # the real 5-20 s: each packet over Iridium waits for shore's SACK to come
    # back through it, and these tests are about the buoy, not the network
    from acomm_sim.iridium_net import network_of

    net = network_of(ocean.w.channel)
    net.min_latency_ms, net.max_latency_ms = 1000, 3000


def _statuses(ocean, peer, status):
    return {e[1] for e in ocean.events(peer) if e[0] == EV_PACKET_STATUS and e[2] == status}


def _received(ocean, peer):
    return [e[1:] for e in ocean.events(peer) if e[0] == EV_PACKET]


def _healthy(board, ocean, resets=0):
    # the buoy kept running: no reset but the ones the test caused, nothing
    # escaped its loop, no error reported by Board.tick
    s = board.stats()
    assert s["watchdog_resets"] == 0 and s["machine_resets"] == 0, s
    assert s["ctl_resets"] == resets, s
    text = ocean.console.text
    assert "Traceback" not in text and "error during a step" not in text, text
    assert ocean.console.count(READY) == resets + 1, text
    return s


# -- 1. the watchdog ------------------------------------------------------------------------

@needs_pico
def test_the_watchdog_is_fed_while_the_loop_runs_and_resets_the_board_when_it_stops(images, tmp_path):
    wd = _cfg()["watchdog_ms"]
    with _buoy(images["base"], tmp_path) as (board, ocean):
        # the loop runs, with its modems answering: twice the watchdog's
        # timeout passes without a reset
        assert ocean.run_for(2 * wd)
        _healthy(board, ocean)
        # Ctrl-C stops main.py at the REPL; the RP2040's watchdog cannot be
        # stopped once started, and nothing feeds it now
        stopped = ocean.now
        ocean.console.send(b"\x03")
        assert ocean.run_until(lambda: b"KeyboardInterrupt" in ocean.console.raw, sim_ms=2000), ocean.console.text
        assert ocean.run_until(lambda: board.stats()["watchdog_resets"] == 1, sim_ms=3 * wd), board.stats()
        s = board.stats()
        assert s["resets"] == 1 and s["ctl_resets"] == 0 and s["machine_resets"] == 0, s
        # the watchdog's own timeout on the board's clock, not some other
        # reset: the loop fed it up to the Ctrl-C (typed at `stopped`, read
        # by the board a little later), and never after
        after = s["last_reset_ms"] - (stopped + ocean.sim0)
        print("watchdog reset %d ms after the Ctrl-C (watchdog_ms %d)" % (after, wd))
        assert wd - 1000 <= after <= wd + 1000, (s, stopped)
        # and the buoy starts again from main.py
        assert ocean.run_until(lambda: ocean.console.count(READY) == 2, sim_ms=10000), ocean.console.text


# -- 2. garbage on a UART ------------------------------------------------------------------

class Garbage:
    """What a broken modem or a bad cable sends, as a source for Cable.noise: runs of
    every kind, in a shuffled order each round, from a seeded PRNG. frames() gives
    the line protocol's own well-formed lines, which are then damaged."""

    def __init__(self, frames, seed):
        self.rng = random.Random(seed)
        self.frames = frames
        self.buf = bytearray()
        self.kinds = [self.random_bytes, self.line_noise, self.truncated, self.bad_checksum, self.nonsense,
                      self.long_line]
        self.counts = dict((k.__name__, 0) for k in self.kinds)
        self.round = []

    def __call__(self, n):
        while len(self.buf) < n:
            if not self.round:
                self.round = list(self.kinds)
                self.rng.shuffle(self.round)
            kind = self.round.pop()
            self.counts[kind.__name__] += 1
            self.buf += kind()
        out = bytes(self.buf[:n])
        del self.buf[:n]
        return out

    def random_bytes(self):
        return bytes(self.rng.getrandbits(8) for _ in range(self.rng.randint(1, 300)))

    def line_noise(self):
        # a floating line, a break, a wrong baud rate: runs of one value, or of CR/LF
        b = self.rng.choice([b"\x00", b"\xff", b"\x7f", b"\r", b"\n", b"\r\n", b"\xfe\xfc"])
        return b * self.rng.randint(5, 400)

    def truncated(self):
        # a line cut anywhere, with or without its end
        f = self.rng.choice(self.frames(self.rng))
        cut = f[: self.rng.randint(1, max(1, len(f) - 3))]
        return cut + (b"\r\n" if self.rng.random() < 0.5 else b"")

    def bad_checksum(self):
        f = bytearray(self.rng.choice(self.frames(self.rng)))
        body = len(f.rstrip(b"\r\n"))
        i = self.rng.randrange(max(1, body - 6), body)  # in the checksum, or what it covers
        f[i] = self.rng.choice(b"0123456789ABCDEF") if f[i] != ord("0") else ord("1")
        return bytes(f)

    def nonsense(self):
        # well formed and checked, but saying nothing a modem would
        return self.rng.choice(self.frames(self.rng))

    def long_line(self):
        return self.rng.choice([b"$", b"+", b"A", b""]) + bytes(self.rng.choice(b"0123456789ABCDEF")
                                                                 for _ in range(self.rng.randint(500, 3000)))


def _seatrac_frames(rng):
    # '$' lines with a correct CRC: the CIDs the driver reads, with payloads of
    # any length and content
    from acomm.drivers import seatrac_codes as sc
    from acomm.drivers import seatrac_wire as w

    out = []
    for cid in (sc.CID_STATUS, sc.CID_DAT_RECEIVE, sc.CID_DAT_SEND, sc.CID_DAT_ERROR, sc.CID_SYS_INFO, sc.CID_SYS_ALIVE,
                sc.CID_SETTINGS_GET, sc.CID_XCVR_STATUS, sc.CID_PING_RESP, sc.CID_PING_ERROR, sc.CID_DAT_QUEUE_STATUS,
                rng.randrange(256)):
        msg = bytes([cid]) + bytes(rng.getrandbits(8) for _ in range(rng.choice([0, 1, 2, 5, 12, 30, 60, 120])))
        line = bytearray(2 * len(msg) + 8)
        k = w.encode_into(line, sc.SYNC_RSP, msg, len(msg))
        out.append(bytes(line[:k]))
    return out


def _iridium_lines(rng):
    # what a 9603 says, with values no 9603 would
    n = lambda: str(rng.choice([0, 1, 2, 13, 32, 65535, -1, 99999999999])).encode()  # noqa: E731
    return [
        b"\r\nOK\r\n", b"\r\nERROR\r\n", b"\r\nREADY\r\n", b"\r\nSBDRING\r\n", b"\r\n0\r\n", b"\r\n2\r\n",
        b"\r\n+CSQ:" + n() + b"\r\n", b"\r\n+CSQF:" + n() + b"\r\n",
        b"\r\n+SBDIX: " + b", ".join(n() for _ in range(rng.randint(1, 8))) + b"\r\n",
        b"\r\n+CIEV:" + n() + b"," + n() + b"\r\n", b"\r\n+AREG:" + n() + b"\r\n",
        b"ATE0Q0V1\r\r\nOK\r\n",  # an echo: a modem that restarted
        rng.randbytes(2) + rng.randbytes(rng.randint(0, 80)) + rng.randbytes(2) + b"\r\nOK\r\n",  # an SBDRB block
    ]


@needs_pico
def test_garbage_on_both_uarts_then_the_real_modems_bring_the_links_up(images, tmp_path):
    with _buoy(images["base"], tmp_path) as (board, ocean):
        sea, sky = ocean.cable("acoustic"), ocean.cable("satellite")
        noise = {"acoustic": Garbage(_seatrac_frames, 1), "satellite": Garbage(_iridium_lines, 2)}
        # a flood, back to back at the line's baud: more than the buoy's
        # parsers take in (the UART's FIFO overruns, as on a board), then a
        # trickle it reads whole, so that every kind reaches its parser intact
        before = board.stats()
        for rates, ms in (((1.0, 1.0), 3000), ((0.05, 0.3), 6000)):
            sea.noise(noise["acoustic"], rates[0])
            sky.noise(noise["satellite"], rates[1])
            assert ocean.run_for(ms)
            s = _healthy(board, ocean)
            print("garbage at %r x baud for %d ms: %d + %d bytes overran the UARTs' FIFOs" % (
                rates, ms, s["uart0_rx_overrun"] - before["uart0_rx_overrun"],
                s["uart1_rx_overrun"] - before["uart1_rx_overrun"]))
            before = s
        for g in noise.values():
            assert all(g.counts.values()), g.counts  # every kind went over each line
        assert sea.noise_sent > 30000 and sky.noise_sent > 5000, (sea.noise_sent, sky.noise_sent)
        # the real modems: each link comes up and carries a packet both ways,
        # the diver's to the buoy acoustically, shore's to the buoy over Iridium
        sea.plug()
        sky.plug()
        diver = ocean.peer("diver").send(ocean.w.now(), "buoy", b"diver to buoy after the garbage", 600, 6)
        shore = ocean.peer("shore").send(ocean.w.now(), "buoy", b"shore to buoy after the garbage", 600, 6)
        assert ocean.run_until(lambda: diver in _statuses(ocean, "diver", DELIVERED)
                               and shore in _statuses(ocean, "shore", DELIVERED), sim_ms=90000, wall_s=200), \
            (ocean.events("diver"), ocean.events("shore"), ocean.console.text)
        _healthy(board, ocean)


# -- 3 and 5. a UART unplugged for minutes, power cuts during store writes ----------------------

# Iridium's cable is out from power-on for this long of the board's time at
# least, and at least QUIET_MS after the last power cut: well past the
# driver's start-up retries and its "down" (three failed rounds, about 30 s)
# since the last boot, and past the acoustic path's stall for shore, so that
# the packets wait on the satellite link when it comes up. (Longer costs
# wall time: the emulated Pico runs at about 0.4-1x real time here.)
SILENT_MS = 75000
QUIET_MS = 40000

# Each power cut comes at the first flash write the buoy makes after a
# fragment that asks for a SACK (the last of a round) went to its UART0
# ("write"), or as soon as that fragment went ("fragment": before the buoy
# read it): as it stores the packet (its record, then its list of delivered
# packets) and acknowledges it. The runner acts between its ~15 ms slices,
# so where a cut lands varies from run to run; the test prints where each
# landed (seen so far: after both writes, with the SACK out or not yet, and
# between the two writes).
CUTS = ("write", "write")


def _segments(data, sync, cid):
    """(dest, src or None, segment head) of each SeaTrac line of `cid` in data that
    carries an acomm SEGMENT frame: the buoy's DAT_SEND commands ('#60', to a
    beacon) or its modem's DAT_RECEIVE answers ('$61', from one)."""
    from acomm.drivers import seatrac_wire as w
    from acomm.frame import decode_elided

    out = []
    for line in data.split(b"\r\n"):
        if line[:3] != b"%c%02X" % (sync, cid):
            continue
        try:
            msg = bytes.fromhex(line[1:].decode())[:-2]  # without the CRC
            if cid == 0x60:  # CID, dest, msg type, length, data
                dest, src, data_at = msg[1], None, 4
            else:  # CID, the fix (dest, src, ...), ack flag, length, data
                dest, src, data_at = msg[1], msg[2], 3 + w.fix_len(msg, 1, len(msg))
            fr = decode_elided(msg[data_at : data_at + msg[data_at - 1]], src, dest)
        except (ValueError, IndexError):
            continue
        if fr.ftype == 5:
            out.append((dest, src, fr.seq))
    return out


def _last_fragment(data):
    # a fragment that asks for a SACK: the last of its round
    from acomm.transport.segment import is_poll

    return any(is_poll(head) for _, _, head in _segments(data, ord("$"), 0x61))


def _completion_sacks(data):
    # the buoy's SACKs to the diver that say a packet is complete (K and P set)
    return [head for dest, _, head in _segments(data, ord("#"), 0x60) if dest == DIVER and head & 12 == 12]


@needs_pico
def test_uplink_unplugged_for_minutes_and_power_cuts_in_store_writes_lose_no_acknowledged_packet(images, tmp_path):
    with _buoy(images["base"], tmp_path, unplugged=("satellite",)) as (board, ocean):
        sea, sky = ocean.cable("acoustic"), ocean.cable("satellite")
        sea.logging = True
        diver = ocean.peer("diver")
        bodies = {}
        for i in range(2):
            body = b"diver packet %d for shore, while the uplink is out" % i
            bodies[diver.send(ocean.w.now(), "shore", body, 3600, 6)] = body
        cuts = []
        seen = 0
        armed = None
        deadline = time.monotonic() + 400
        while len(cuts) < len(CUTS):
            time.sleep(0.002)
            ocean.pump()
            assert ocean.now < 120000 and time.monotonic() < deadline, (cuts, ocean.events("diver"))
            new, seen = sea.log[seen:], len(sea.log)
            if armed is None:
                if _last_fragment(b"".join(data for _, who, data in new if who == "modem")):
                    armed = (board.stats()["flash_programs"], seen)
                    if CUTS[len(cuts)] == "write":
                        continue
                else:
                    continue
            elif board.stats()["flash_programs"] == armed[0]:
                continue
            board.reset()
            writes = board.stats()["flash_programs"] - armed[0]
            acked = len(_statuses(ocean, "diver", TRANSMITTED))
            ocean.pump()  # what the board wrote before the cut
            sacked = bool(_completion_sacks(b"".join(data for _, who, data in sea.log[armed[1]:] if who == "board")))
            cuts.append((CUTS[len(cuts)], round(ocean.now), writes, sacked, acked))
            armed = None
            n = len(cuts)
            assert ocean.run_until(lambda: ocean.console.count(READY) == n + 1, sim_ms=10000), ocean.console.text
            seen = len(sea.log)
        # (trigger, the board's ms, flash writes of the old board since the fragment,
        # whether its completion SACK left UART0 since, packets the diver had seen acknowledged)
        print("power cuts:", cuts)
        # the diver sends until the buoy has acknowledged each; the uplink stays out
        assert ocean.run_until(lambda: _statuses(ocean, "diver", TRANSMITTED) == set(bodies), sim_ms=90000), \
            (cuts, ocean.events("diver"), ocean.console.text)
        quiet = max(SILENT_MS, cuts[-1][1] + QUIET_MS)
        written = sky.from_board
        assert ocean.run_until(lambda: ocean.now >= quiet, wall_s=400)
        # not a byte came back on UART1 all along; the driver kept asking, the
        # loop kept running (no reset but the test's), its watchdog fed
        s = _healthy(board, ocean, resets=len(cuts))
        assert s["uart1_rx_bytes"] == 0 and sky.from_board > written, (s, written, sky.from_board)
        assert not _received(ocean, "shore")
        # plugged in: the link comes up and every packet the buoy acknowledged
        # leaves its store for shore, once
        sky.plug()
        assert ocean.run_until(lambda: {p[2] for p in _received(ocean, "shore")} >= set(bodies.values()),
                               sim_ms=120000, wall_s=300), (cuts, _received(ocean, "shore"), ocean.console.text)
        _healthy(board, ocean, resets=len(cuts))
        got = _received(ocean, "shore")
        print("shore: %d packets, %d duplicates suppressed" % (len(got), ocean.peer("shore").stats["rx_dup"]))
        assert sorted(p[2] for p in got) == sorted(bodies.values()), got
        assert all(p[:2] == ("diver", "shore") for p in got), got


# -- 4. a full filesystem --------------------------------------------------------------------

@needs_pico
def test_a_full_filesystem_refuses_new_packets_and_keeps_the_ones_it_holds(images, tmp_path):
    with _buoy(images["full"], tmp_path) as (board, ocean):
        diver = ocean.peer("diver")
        new = diver.send(ocean.w.now(), "shore", b"for shore, with the buoy's flash full", 3600, 6)
        # what it held before the flash filled leaves over Iridium
        assert ocean.run_until(lambda: any(p[2] == HELD_BODY for p in _received(ocean, "shore")), sim_ms=150000,
                               wall_s=300), (_received(ocean, "shore"), ocean.console.text)
        assert [p for p in _received(ocean, "shore") if p[2] == HELD_BODY] == [("diver", "shore", HELD_BODY)]
        # what it could not store it never acknowledged, though the diver sent
        # it: the store's ENOSPC is a full store, so the buoy answered
        # "receiver full" and the diver keeps the packet to offer it later
        assert diver.stats["fragments"] > 0 and diver.stats["refused"] >= 1, diver.stats
        assert new not in _statuses(ocean, "diver", TRANSMITTED) | _statuses(ocean, "diver", DELIVERED), \
            ocean.events("diver")
        assert not [p for p in _received(ocean, "shore") if p[2] != HELD_BODY]
        # a refusal, not an error: it kept running with nothing to report
        s = board.stats()
        assert s["resets"] == 0, s
        text = ocean.console.text
        assert "Traceback" not in text and ocean.console.count(READY) == 1, text
        assert "Error" not in text, text


@needs_pico
def test_a_flash_full_before_the_first_boot_leaves_the_buoy_running_and_relaying_nothing(images, tmp_path):
    # no room for the store at all: the node runs on a store that takes
    # nothing (acomm_mp.boot.open_store), says so, and refuses to relay
    with _buoy(images["bare"], tmp_path) as (board, ocean):
        diver = ocean.peer("diver")
        relay = diver.send(ocean.w.now(), "shore", b"for shore, with no store at the buoy", 3600, 6)
        own = diver.send(ocean.w.now(), "buoy", b"for the buoy itself", 600, 6)
        assert ocean.run_until(lambda: own in _statuses(ocean, "diver", DELIVERED) and diver.stats["refused"],
                               sim_ms=60000), (diver.stats, ocean.events("diver"), ocean.console.text)
        assert relay not in _statuses(ocean, "diver", TRANSMITTED)
        text = ocean.console.text
        assert "acomm: no store at /data/acomm.store (OSError 28)" in text, text  # ENOSPC
        s = board.stats()
        assert s["resets"] == 0 and "Traceback" not in text and ocean.console.count(READY) == 1, (s, text)


def test_open_store_on_a_flash_that_cannot_hold_it_gives_a_store_that_takes_nothing(tmp_path):
    # the board port's side of the test above, on CPython: where the store's
    # folder cannot be made, the board says so and gets a store with no room
    from acomm.errors import StoreFull
    from acomm.transport.packetstore import PacketStore
    from acomm.transport.store import Store
    from acomm_mp.boot import open_store

    (tmp_path / "data").write_text("a file where the store's folder goes")
    said = []
    st = open_store({"path": str(tmp_path / "data" / "acomm.store"), "capacity": 65536, "max_record": 256},
                    said.append)
    assert len(said) == 1 and said[0].startswith("acomm: no store at ") and "relaying nothing" in said[0], said
    with pytest.raises(StoreFull):
        st.put(1, b"x")

    class P:
        size, prio, medium, origin, final = 10, 1, None, 2, 1

    assert not PacketStore(st).room(P())  # not even an urgent packet
    ok = open_store({"path": str(tmp_path / "ok" / "acomm.store"), "capacity": 65536, "max_record": 256},
                    said.append)
    assert isinstance(ok, Store) and len(said) == 1
    ok.close()


def test_open_store_where_the_store_itself_refuses_gives_a_store_that_takes_nothing(tmp_path):
    # the folder is there but the store cannot be opened (here a folder sits where its file goes;
    # on a board, a flash gone read-only or failing): Store says so with a StoreError, which must
    # not stop the board at boot any more than an OSError from the folder does
    from acomm.errors import StoreFull
    from acomm_mp.boot import open_store

    (tmp_path / "data" / "acomm.store").mkdir(parents=True)
    said = []
    st = open_store({"path": str(tmp_path / "data" / "acomm.store"), "capacity": 65536, "max_record": 256},
                    said.append)
    assert len(said) == 1 and "StoreError" in said[0] and "relaying nothing" in said[0], said
    with pytest.raises(StoreFull):
        st.put(1, b"x")
