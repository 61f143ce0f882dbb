# The buoy on its own chip, as `acomm bench board --json` runs it
# (acomm_cpython.bench.picobuoy): boards/buoy_pico flashed with `acomm flash
# --reset` onto an emulated Raspberry Pi Pico, the diver's tablet program on
# a second one, `acomm emulate seatrac` between them, `acomm emulate iridium`
# and an `acomm node` as shore behind the buoy. The diver's report must reach
# shore through the buoy's flash store and leave over Iridium exactly once,
# although the buoy is power-cycled during the Iridium session carrying it.
# One run of the real CLI (about 3 minutes here) serves every test below.
import json
import os
import subprocess
import sys
import time

import pytest

from acomm_cpython.bench import picobuoy

ACOMM = os.path.join(os.path.dirname(sys.executable), "acomm")
_missing = picobuoy.missing()
FIGURES = ("rp2040_buoy_relayed_packets", "rp2040_buoy_lost_packets", "rp2040_buoy_duplicate_packets",
           "rp2040_buoy_resets", "rp2040_flash_seconds", "rp2040_boot_to_ready_ms",
           "rp2040_first_boot_to_ready_ms", "rp2040_buoy_heap_free_bytes", "rp2040_buoy_heap_free_after_reset_bytes",
           "rp2040_buoy_idle_cpu_percent")


@pytest.fixture(scope="module")
def board(tmp_path_factory):
    if _missing:
        pytest.skip(_missing)
    out = tmp_path_factory.mktemp("board") / "run.json"
    t = time.monotonic()
    r = subprocess.run([ACOMM, "bench", "board", "--json"], capture_output=True, text=True, timeout=900,
                       env=dict(os.environ, ACOMM_BOARD_RUN=str(out)))
    wall = time.monotonic() - t
    assert r.returncode == 0, r.stdout + r.stderr[-3000:]
    lines = [json.loads(ln) for ln in r.stdout.splitlines()]
    with open(out) as f:
        run = json.load(f)
    return {d["name"]: d for d in lines}, lines, run, wall


def test_the_figures(board):
    figures, lines, run, wall = board
    for d in lines:
        assert set(d) == {"name", "value", "unit"}, d
    assert sorted(figures) == sorted(FIGURES)
    v = dict((k, d["value"]) for k, d in figures.items())
    assert v["rp2040_buoy_relayed_packets"] >= 1, run
    assert v["rp2040_buoy_lost_packets"] == 0, run
    assert v["rp2040_buoy_duplicate_packets"] == 0, run
    assert v["rp2040_buoy_resets"] >= 1
    assert 0 < v["rp2040_flash_seconds"] < wall
    # a boot is imports and the node's build: well under the watchdog's 8 s
    for k in ("rp2040_boot_to_ready_ms", "rp2040_first_boot_to_ready_ms"):
        assert 0 < v[k] < 8000, v
    assert figures["rp2040_boot_to_ready_ms"]["unit"] == "ms"
    assert figures["rp2040_flash_seconds"]["unit"] == "s"
    # the Pico's GC pool is 245,888 bytes: the buoy from .mpy files leaves
    # about half of it
    for k in ("rp2040_buoy_heap_free_bytes", "rp2040_buoy_heap_free_after_reset_bytes"):
        assert 100000 < v[k] < 245888, v
    # an idle buoy steps its node every idle_ms (100), not every loop pass
    # (10 ms): that kept its core busy 37 % of the time
    assert 0 < v["rp2040_buoy_idle_cpu_percent"] < 15, v


def test_the_diver_report_reached_shore_once(board):
    _, _, run, _ = board
    got = run["shore_packets"]
    assert len(got) == len(run["custody"]) == run["relayed"], run
    for p in got:
        # an empty DIVER_STATUS: the diver's tablet has no sensor wired
        assert p["dst"] == "shore" and p["bytes"] == 1, p
        assert p["caddy"][0][0] == "diver_status", p
    # the bytes shore saved are what the diver's tablet program makes (main.py:
    # diver_report with no sensor)
    from acomm.apps.station import diver_report

    want = bytes(diver_report(lambda: {})(0)).hex()
    assert [(name.split("-")[0], data) for name, data in run["inbox"]] == [("diver", want)] * len(got)


def test_it_left_once_and_the_rebooted_buoy_finished_it_from_its_store(board):
    from acomm_cpython.emulate import modemtaps as mt

    _, _, run, _ = board
    # the power cycle fell inside the Iridium session that carried the packet:
    # the gateway got it, the buoy never saw the session's result
    assert run["reset_in_session"] is True and run["buoy_stats"]["ctl_resets"] == run["resets"] == 1
    pid = run["custody"][0]
    assert run["mo_copies"] == {"%d/0" % pid: 1}, run["sessions"]
    # after it, the rebooted buoy asked (a bare poll: no fragment bytes) and
    # read shore's completion instead of sending the packet again
    segs = [mt.frame_segment(bytes.fromhex(h))[1] for h in run["mo_segments"]]
    first = [i for i, s in enumerate(segs) if not s.is_sack and s.payload]
    assert len(first) == 1 and any(s.poll and not s.payload for s in segs[first[0] + 1:]), segs
    assert pid in run["completions_read"], run
    # its store on the Pico's flash: the packet put there by the relay, and
    # deleted by the rebooted buoy once shore's completion came
    recs = run["store"]
    assert ["P", 2, pid, 0] in recs and ["D", 2, pid, 0] in recs, recs
    live = set()
    for r in recs:
        if r[1] != "meta":
            (live.add if r[0] == "P" else live.discard)(tuple(r[1:]))
    assert not live, recs


def test_the_lines_ran_clean(board):
    _, _, run, _ = board
    stats = run["buoy_stats"]
    for k in ("uart0_rx_overrun", "uart1_rx_overrun", "uart0_rx_dropped", "uart1_rx_dropped", "usb_in_dropped",
              "watchdog_resets", "emulator_errors"):
        assert stats[k] == 0, (k, stats)
    assert stats["uart1_fw_baud"] == 19200 and abs(stats["uart0_fw_baud"] - 115200) < 200
    # nothing but its ready line at each boot: an error in a step would be said here
    for con, name in ((run["buoy_console"], "buoy"), (run["diver_console"], "diver")):
        assert con and all(ln.startswith("acomm %s: node" % name) for ln in con if ln.strip()), con


def test_without_the_runner_it_fails_with_one_line(tmp_path):
    r = subprocess.run([ACOMM, "bench", "board", "--json"], capture_output=True, text=True, timeout=60,
                       env=dict(os.environ, ACOMM_RP2040_BOOTROM=str(tmp_path / "no-bootrom.bin")))
    assert r.returncode == 1 and r.stdout == "", r
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("acomm bench board: "), r.stderr
    assert "no-bootrom.bin" in err[0] or "not installed" in err[0], err
