# The footprint bench on the buoy's own chip (acomm bench footprint, the
# *_rp2040 groups): the buoy's node on MicroPython's rp2 firmware for the
# Pico in the rp2040js emulator (build/firmware/rp2040-full.uf2, acomm and
# the lockstep harness frozen in), stepped over the USB REPL in lock with
# the simulated ocean for one minute. In a roomy heap the minute completes
# with frames both ways and the diver's packet relayed; a heap far too
# small (the GC's pool cut down from Python, as run_pico does) fails with a
# MemoryError and is never a pass. The cheap group runs through the real
# CLI. About a minute: a Pico minute is most of it.
import json
import os
import subprocess
import sys

import pytest

from acomm_cpython.board.picoboard import firmware, runner_available
from acomm_cpython.bench.workloads import footprint_pico as fp

ACOMM = os.path.join(os.path.dirname(sys.executable), "acomm")


def _need(name):
    why = runner_available()
    if why:
        pytest.skip(why)
    fw = firmware(name)
    if fw is None:
        pytest.skip("build/firmware/%s.uf2 not built (python3 tools/firmware.py build)" % name)
    return fw


def test_a_region_and_its_pool_as_py_gc_c_lays_them_out():
    # the whole rp2 heap: a 251,652-byte region gives the 245,888-byte pool
    # the Pico reports (gc.mem_alloc() + gc.mem_free())
    assert fp.pool_of(251652) == 245888 and fp.region_of(245888) == 251652
    for region in range(20000, 140000, 4099):
        pool = fp.pool_of(region)
        assert pool % 64 == 0 and fp.region_of(pool) <= region < fp.region_of(pool + 64)


def test_heap_min_is_the_first_of_three_sizes_in_a_row_that_passed():
    # near the edge the outcome depends on where fragments fall: a size that
    # fails above one that passed restarts the count, and the size above the
    # failure must pass itself (here 8,704 fails too)
    from acomm_cpython.bench.workloads.footprint_workload import bisect

    tried = {}

    def trial(h):
        tried[h] = h >= 8192 and h not in (8448, 8704)
        return {"fail": None if tried[h] else "MemoryError"}

    for first in (None, 6000, 12000):  # a first guess narrows either side, same answer
        tried.clear()
        got = bisect(trial, 4096, 20480, first=first)
        assert got == 8960 and all(tried.get(got + 256 * k) for k in range(3)), sorted(tried.items())
        assert first is None or first // 256 * 256 in tried


def test_one_lockstep_minute_on_the_emulated_pico():
    full = _need("rp2040-full")
    r = fp.run_pico(full, fp.ROOMY, peak=False)
    assert r["fail"] is None, r["text"][-2000:]
    assert r["relayed"] == 1 and r["tx_frames"] > 0 and r["rx_frames"] > 0 and r["oom"] == 0
    # the pool is a 128 KiB region's (less what of the stand-in's heap
    # does not fill 64 bytes), and the figures are the buoy's (imports, then
    # the node on top) within it
    assert fp.pool_of(fp.ROOMY) - 64 < r["pool"] <= fp.pool_of(fp.ROOMY)
    assert 8 * 1024 < r["code"] < r["after_build"] < r["pool"]
    assert 0 < r["harness"] < 2048 and r["peak"] is None  # not sampled: peak=False


def test_a_heap_too_small_for_the_node_is_a_memory_error_not_a_pass():
    # 40 KiB: the imports fit (30 KB), the node built on them does not
    r = fp.run_pico(_need("rp2040-full"), 40 * 1024, peak=False)
    assert r["fail"] is not None and "MemoryError" in r["fail"], r["text"][-2000:]


def test_the_boot_group_through_acomm_bench():
    _need("rp2040-stock")
    _need("buoy_pico")
    p = subprocess.run([ACOMM, "bench", "footprint", "--only", "boot_rp2040", "--json"],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    got = {}
    for line in p.stdout.splitlines():
        rec = json.loads(line)
        assert rec["unit"] == "bytes"
        got[rec["name"]] = rec["value"]
    assert set(got) == {"flash_image_rp2040_stock_bytes", "flash_image_buoy_pico_bytes",
                        "heap_free_boot_rp2040_stock_bytes", "heap_pool_rp2040_bytes"}
    # acomm frozen in makes the image larger; the stock firmware boots with
    # most of its heap free
    assert 200000 < got["flash_image_rp2040_stock_bytes"] < got["flash_image_buoy_pico_bytes"] < 640 * 1024
    assert 200000 < got["heap_free_boot_rp2040_stock_bytes"] < got["heap_pool_rp2040_bytes"]


def test_the_buoy_flashed_to_a_stock_pico_reports_its_free_heap_at_boot(tmp_path):
    # acomm flash onto the stock firmware, then the buoy's own ready line at
    # power-up: empty, then holding 8 packets of 1 KiB (seeded on its flash
    # at its config's store path), which cost it heap
    from acomm_cpython.board.picoflash import PICO_WALL0, boot_free, flash_image
    from acomm_cpython.bench.workloads.footprint_minute import seed_store

    stock = _need("rp2040-stock")
    img = str(tmp_path / "flash.img")
    flash_image(stock, img, harness=False)
    empty = boot_free(stock, img)
    with open(seed_store(str(tmp_path / "store"), wall0=PICO_WALL0), "rb") as f:
        loaded = boot_free(stock, img, f.read())
    assert 100000 < loaded < empty < fp.pool_of(251652), (empty, loaded)
