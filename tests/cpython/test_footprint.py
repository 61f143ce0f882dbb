# The footprint benchmark's lockstep run (acomm bench footprint): the buoy's
# node alone in the MicroPython unix port, from the .mpy files `acomm flash`
# stages, stepped with a simulated ocean in this process. A roomy heap
# completes the minute with frames both ways and the diver's packet in the
# buoy's custody; a heap far too small is reported as a failure, not hidden.
# From a ROMFS image the same minute runs with the bytecode in place: the
# imports take less heap than from .mpy files, and the image is not counted.
import os
import shutil
import tempfile

from acomm_cpython.bench.workloads import footprint_runners as fr


def test_the_lockstep_minute_runs_and_a_tiny_heap_fails():
    tmp = tempfile.mkdtemp(prefix="acomm-fp-test-")
    try:
        fl = fr.stage_flash(tmp)
        r = fr.run_once(fl, 256 * 1024)
        assert r is not None and r["relayed"] == 1 and r["tx_frames"] > 0 and r["rx_frames"] > 0
        assert r["after_build"] < r["peak"] < 2 * 256 * 1024
        assert fr.run_once(fl, 16 * 1024) is None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def test_from_a_romfs_image_the_imports_take_less_heap():
    tmp = tempfile.mkdtemp(prefix="acomm-fp-test-")
    try:
        fl = fr.stage_flash(tmp)
        rom = fr.build_romfs(os.path.join(fl, "lib"), os.path.join(tmp, "rom.img"))
        files = fr.run_once(fl, 256 * 1024)
        r = fr.run_once(fl, 256 * 1024, rom=rom)
        assert r is not None and r["relayed"] == 1 and r["rom"] == os.path.getsize(rom)
        code_rom = (r["code"] - r["rom"]) // 2
        # the bytecode stays in the image: well under what loading took
        assert 0 < code_rom < 0.7 * (files["code"] // 2)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def test_the_buoys_flash_writes_per_hour():
    # `acomm bench footprint --only flash_writes --json`: the buoy's node as
    # the board builds it, an hour of the demo's traffic, every file write
    # counted (footprint_flash); no firmware needed
    import json
    import subprocess
    import sys

    from consoleprocs import tree_env

    r = subprocess.run([sys.executable, "-m", "acomm_cpython.cli", "bench", "footprint", "--only", "flash_writes",
                        "--json"], env=tree_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    got = dict((d["name"], d) for d in map(json.loads, r.stdout.splitlines()))
    w, b = got["flash_writes_per_hour_buoy"], got["flash_bytes_per_hour_buoy"]
    assert w["unit"] == "writes/hour" and b["unit"] == "bytes/hour"
    # the store (the log's lines delivered, the alarm relayed) and the
    # counter file both wrote, each write a few to a few hundred bytes
    assert "store" in r.stderr and "auth" in r.stderr, r.stderr
    assert 50 < w["value"] < 5000 and 10 * w["value"] < b["value"] < 1000 * w["value"], (w, b)
