# The footprint bench on the 32-bit Cortex-M3 board (acomm bench footprint):
# the buoy's node on MicroPython's qemu MPS2-AN385 firmware with acomm and
# the lockstep harness frozen in (build/firmware/cm3-full.elf, made by
# tools/firmware.py build), stepped over its UART in lock with the simulated
# ocean for one minute. At a roomy heap the minute completes with frames
# both ways, the diver's packet relayed and sane heap figures; at a heap far
# too small the MemoryError is a failed run, never a pass.
import pytest

from acomm_cpython.board.qemuboard import firmware
from acomm_cpython.bench.workloads import footprint_runners as fr

ELF = firmware("cm3-full")
pytestmark = pytest.mark.skipif(ELF is None, reason="build/firmware/cm3-full.elf not built (python3 tools/firmware.py build)")


def test_one_lockstep_minute_on_the_cortex_m3_board():
    r = fr.run_qemu(ELF, 128 * 1024)
    assert r["fail"] is None, r["text"][-2000:]
    assert r["relayed"] == 1 and r["tx_frames"] > 0 and r["rx_frames"] > 0 and r["oom"] == 0
    # the imports (frozen: objects only), then the node on top, then the
    # garbage of a minute, all within the heap
    assert 8 * 1024 < r["code"] < r["after_build"] < r["peak"] < 128 * 1024


def test_a_heap_too_small_is_a_failure_not_a_pass():
    r = fr.run_qemu(ELF, 24 * 1024)
    assert r["fail"] is not None and "MemoryError" in r["fail"]


def test_a_minute_from_a_romfs_image_at_the_boards_partition(tmp_path):
    # the buoy's .mpy files in a ROMFS image loaded at the board's ROMFS
    # partition and mounted by its _boot.py (v1.28's qemu port has no
    # vfs.rom_ioctl: the partition is mounted from memory): its imports take
    # far less heap than the same files from littlefs, which copy their code
    harness = firmware("cm3-harness")
    if harness is None:
        pytest.skip("build/firmware/cm3-harness.elf not built")
    st = fr.Staged(str(tmp_path), "armv7m")
    rom = fr.run_qemu(harness, 128 * 1024, rom=st.rom())
    assert rom["fail"] is None, rom["text"][-2000:]
    lfs = fr.run_qemu(harness, 192 * 1024, flash=st.lfs())
    assert lfs["fail"] is None, lfs["text"][-2000:]
    assert rom["code"] + 32 * 1024 < lfs["code"], (rom["code"], lfs["code"])


def test_a_firmware_that_knows_the_buoys_names_imports_its_romfs_modules_in_less_heap(tmp_path):
    # cm3-names freezes the names the buoy's modules use (tools/qstrnames.py): the same
    # ROMFS image imports without adding them to the heap's qstr pools (about 1,700 names:
    # 8 KiB in the bench), and the minute runs as on the stock firmware
    harness, names = firmware("cm3-harness"), firmware("cm3-names")
    if harness is None or names is None:
        pytest.skip("build/firmware/cm3-harness.elf or cm3-names.elf not built")
    st = fr.Staged(str(tmp_path), "armv7m")
    stock = fr.run_qemu(harness, 128 * 1024, rom=st.rom())
    known = fr.run_qemu(names, 128 * 1024, rom=st.rom())
    assert stock["fail"] is None and known["fail"] is None, known["text"][-2000:]
    assert known["relayed"] == 1 and known["tx_frames"] > 0 and known["rx_frames"] > 0
    assert known["code"] + 4096 < stock["code"], (known["code"], stock["code"])


def test_the_routing_minute_exercises_the_buoys_router_and_its_figure_runs():
    # the buoy's config with routing on: the diver's route requests reach
    # the buoy's finder, which answers or rebroadcasts them and learns the
    # route back; the plain minute loads none of it. The routing figure's
    # code path (bisection and the difference) runs on a narrow bracket
    r = fr.run_qemu(ELF, 128 * 1024, routing=True)
    assert r["fail"] is None, r["text"][-2000:]
    assert r["relayed"] == 1 and r["oom"] == 0
    assert r["route_requests"] >= 1 and r["routes"] >= 1 and r["control_sent"] >= 1
    plain = fr.run_qemu(ELF, 128 * 1024)
    assert plain["routes"] == -1 and plain["route_requests"] == -1
    assert plain["after_build"] < r["after_build"]


def test_the_routing_group_emits_its_figure_and_the_difference(monkeypatch):
    from acomm_cpython.bench.workloads import footprint_workload as fw

    calls = []

    def fake(elf, heap, routing=False, **kw):
        # a board whose minute needs 40 KiB, 2 KiB more with routing
        calls.append(routing)
        need = 40960 + (2048 if routing else 0)
        return {"fail": None if heap >= need else "MemoryError", "after_build": 30000, "code": 20000, "peak": 60000}

    monkeypatch.setattr(fw, "run_qemu", fake)
    got = {}
    fw._group("routing_cortex_m", lambda n, v, u: got.__setitem__(n, v), {"tmp": None})
    assert got["heap_min_frozen_cortex_m_routing_bytes"] == 43008
    assert got["heap_routing_extra_frozen_cortex_m_bytes"] == 2048
    assert True in calls and False in calls


def test_the_names_group_emits_both_figures_on_the_names_firmware(monkeypatch):
    from acomm_cpython.bench.workloads import footprint_workload as fw

    seen = []

    def fake(elf, heap, routing=False, rom=None, **kw):
        # a ROMFS board whose minute needs 56 KiB, 5 KiB more with routing
        seen.append((elf, rom, routing))
        need = 57344 + (5120 if routing else 0)
        return {"fail": None if heap >= need else "MemoryError", "after_build": 50000, "code": 40000, "peak": 90000}

    class FakeStaged:
        def __init__(self, tmp, arch):
            pass

        def rom(self):
            return "rom.img"

    monkeypatch.setattr(fw, "run_qemu", fake)
    monkeypatch.setattr(fw, "Staged", FakeStaged)
    monkeypatch.setattr(fw, "_fw", lambda name: name + ".elf")
    got = {}
    fw._group("romfs_names_cortex_m", lambda n, v, u: got.__setitem__(n, v), {"tmp": None})
    assert got["heap_min_romfs_names_cortex_m_bytes"] == 57344
    assert got["heap_min_romfs_names_cortex_m_routing_bytes"] == 62464
    assert got["heap_after_build_romfs_names_cortex_m_routing_bytes"] == 50000
    assert set(e for e, _, _ in seen) == {"cm3-names.elf"} and set(r for _, r, _ in seen) == {"rom.img"}
    assert {False, True} == set(x for _, _, x in seen)
