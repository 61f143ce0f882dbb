# The boards, proven without hardware: each board definition is flashed with
# `acomm flash` (modules compiled by mpy-cross, for x64 so the unix port can
# load them) to the fake board (tools/fakeboard.py: the MicroPython unix
# port behind a pty, driven by mpremote as a real board is), and then the
# board's node, built from the flashed config and .mpy modules, runs for a
# simulated minute against emulated modems on the board itself; frames must
# flow. The emulators are test scaffolding copied next to the flashed files
# (acomm_sim, and the few core modules only they import), never over them.
import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

from test_fakeboard import Board

ROOT = Path(__file__).resolve().parents[2]
ACOMM = Path(sys.executable).parent / "acomm"

RUN = ("import sys; sys.path.append('/'); from config import CONFIG; import acomm.link, acomm_mp.assemble; "
       "print('FROM', acomm.link.__file__, acomm_mp.assemble.__file__); "
       "from acomm_sim.boardsim import run_board; r = run_board(CONFIG, %r, via=%r); "
       "print('RESULT', repr((r['links'], r['relayed'], r['board'], r['peer_packets'], len(r['board_packets']))))")


def _scaffold(flash):
    lib = flash / "lib"
    shutil.copytree(ROOT / "ports" / "sim" / "acomm_sim", lib / "acomm_sim",
                    ignore=shutil.ignore_patterns("__pycache__"))
    for src in (ROOT / "acomm").rglob("*.py"):
        rel = src.relative_to(ROOT)
        dst = lib / rel
        if not dst.exists() and not dst.with_suffix(".mpy").exists():
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, dst)


def _flash_and_run(tmp_path, name, peers, via):
    b = Board(tmp_path, heap="4M")
    try:
        r = subprocess.run([str(ACOMM), "flash", "--board", name, "--port", b.link, "--arch", "x64"],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stdout + r.stderr
        flash = b.flash
        assert (flash / "main.py").exists() and (flash / "config.py").exists()
        assert (flash / "lib" / "acomm" / "link" / "__init__.mpy").exists()
        _scaffold(flash)
        out = b.mp("exec", RUN % (peers, via))
    finally:
        b.stop()
    # a marker may follow a stray byte of the raw REPL on a loaded machine
    # (a CI run failed on a RESULT line that did not start the line)
    line = [x[x.index("FROM "):] for x in out.splitlines() if "FROM " in x][0]
    assert "link/__init__.mpy" in line and "assemble.mpy" in line  # the flashed, compiled modules ran
    res = [x[x.index("RESULT ") + len("RESULT "):] for x in out.splitlines() if "RESULT " in x]
    assert res, out
    return ast.literal_eval(res[0])


def test_the_buoy_flashed_to_the_fake_board_relays(tmp_path):
    links, relayed, stats, peer_packets, board_packets = _flash_and_run(
        tmp_path, "buoy_pico", {"diver": "seatrac", "shore": "iridium"}, {"diver": "shore"})
    for name in ("acoustic", "satellite"):
        assert links[name]["tx_frames"] > 0 and links[name]["rx_frames"] > 0, links
    assert relayed == 1 and board_packets == 2
    assert stats["errors"] == 0 and stats["oom"] == 0


def test_the_diver_tablet_flashed_to_the_fake_board_talks_to_the_buoy(tmp_path):
    links, relayed, stats, peer_packets, board_packets = _flash_and_run(
        tmp_path, "diver_esp32s3", {"buoy": "seatrac"}, None)
    assert links["acoustic"]["tx_frames"] > 0 and links["acoustic"]["rx_frames"] > 0
    assert len(peer_packets["buoy"]) == 1 and board_packets == 1  # the alarm out, the buoy's chat in
    assert stats["errors"] == 0 and stats["oom"] == 0
