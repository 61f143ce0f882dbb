# What the firmware builds froze (tools/firmware.py, `make firmware`): the
# full manifest freezes every module of acomm and acomm_mp, on the Cortex-M3
# on the i386 unix build and on the Pico (rp2040-full), the buoy's firmware
# (Cortex-M3 and Pico) freezes exactly its board's import closure, the
# modules `acomm flash` would copy, and the stock Pico image freezes none. Read from
# the frozen_content.c that MicroPython's mpy-tool wrote for each product,
# so a module that mpy-tool cannot freeze (as the float literal of
# acomm/imc/wire.py once was) fails the build, and one left out fails here.
import os
import re
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WORK = os.path.join(ROOT, "build", "firmware", "work")


def _frozen(product):
    path = os.path.join(WORK, product, "build", "frozen_content.c")
    if not os.path.exists(path):
        pytest.skip("%s is not built: run `make firmware` (tools/firmware.py build)" % product)
    with open(path) as f:
        text = f.read()
    names = text[text.index("mp_frozen_names[]") :]
    names = names[: names.index("};")]
    return set(re.findall(r'"([^"\\]+\.py)\\0"', names))


def _package_modules(pkg_dir, pkg):
    out = set()
    for dirpath, _dirs, files in os.walk(pkg_dir):
        for f in files:
            if f.endswith(".py"):
                rel = os.path.relpath(os.path.join(dirpath, f), os.path.dirname(pkg_dir))
                out.add(rel.replace(os.sep, "/"))
    assert out, pkg
    return out


def _every_module():
    return _package_modules(os.path.join(ROOT, "acomm"), "acomm") | _package_modules(
        os.path.join(ROOT, "ports", "micropython", "acomm_mp"), "acomm_mp"
    )


@pytest.mark.parametrize("product", ["cm3-full", "micropython-i386", "rp2040-full"])
def test_the_full_manifest_freezes_every_module(product):
    frozen = _frozen(product)
    missing = sorted(_every_module() - frozen)
    assert not missing, missing
    # and the harness the footprint figures run (tools/lockstep)
    assert "acomm_lockstep.py" in frozen


# the Pico's own modules, which a user's code may import: the rp2 images
# keep them under acomm (the buoy's manifest includes the board's own)
RP2_OWN = {"_boot.py", "rp2.py", "asyncio/__init__.py", "onewire.py", "neopixel.py"}


def test_the_stock_pico_firmware_freezes_only_the_boards_own_modules():
    frozen = _frozen("rp2040-stock")
    assert RP2_OWN <= frozen
    assert not any(n.split("/")[0] in ("acomm", "acomm_mp") for n in frozen)


@pytest.mark.parametrize("product", ["cm3-buoy", "buoy_pico"])
def test_the_buoy_firmware_freezes_its_import_closure_and_nothing_else_of_acomm(product):
    frozen = _frozen(product)
    if product == "buoy_pico":
        assert RP2_OWN <= frozen
    for p in (os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "micropython")):
        if p not in sys.path:
            sys.path.insert(0, p)
    from acomm_cpython.board import boardfiles

    closure = set()
    for name, path in boardfiles.modules(os.path.join(ROOT, "boards", "buoy_pico"), root=ROOT).items():
        pkg = name.split(".")[0]
        top = os.path.join(boardfiles.package_dirs(ROOT)[pkg], "..")
        closure.add(os.path.relpath(path, top).replace(os.sep, "/"))
    ours = set(n for n in frozen if n.split("/")[0] in ("acomm", "acomm_mp"))
    assert ours == closure, (sorted(ours - closure), sorted(closure - ours))
    # the buoy never imports the IMC gateway; the full image does
    assert not any(n.startswith("acomm/imc/") for n in ours)


def _pool_strings(product):
    # the strings of a product's frozen qstr pool (frozen_content.c) and of its own pool
    # (genhdr/qstrdefs.generated.h): every name its firmware knows without the heap
    import ast

    build = os.path.join(WORK, product, "build")
    with open(os.path.join(build, "frozen_content.c")) as f:
        text = f.read()
    pool = text[text.index("mp_qstr_frozen_const_pool = {") :]
    pool = pool[pool.index("{", pool.index("mp_qstr_frozen_const_lengths")) : pool.index("};")]
    known = set(ast.literal_eval("b" + m).decode() for m in re.findall(r'^\s*("(?:[^"\\]|\\.)*"),$', pool, re.M))
    with open(os.path.join(build, "genhdr", "qstrdefs.generated.h")) as f:
        for m in re.finditer(r'^QDEF\d?\(MP_QSTR_\w*, \d+, \d+, ("(?:[^"\\]|\\.)*")\)', f.read(), re.M):
            known.add(ast.literal_eval("b" + m.group(1)).decode())
    return known


def test_the_names_firmware_knows_every_name_of_the_buoys_romfs_modules(tmp_path):
    # cm3-names (tools/qstrnames.py): the buoy's .mpy files as `acomm flash` compiles them
    # for the ROMFS image use no name its firmware lacks, and it freezes no module of acomm
    frozen = _frozen("cm3-names")
    assert "acomm_names.py" in frozen and not any(n.split("/")[0] in ("acomm", "acomm_mp") for n in frozen)
    for p in (os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "tools")):
        if p not in sys.path:
            sys.path.insert(0, p)
    import qstrnames
    from acomm_cpython.board import boardfiles

    known = _pool_strings("cm3-names")
    used = set()
    for e in boardfiles.plan(boardfiles.board_path("buoy_pico"), arch="armv7m", stage_dir=str(tmp_path)):
        if e.device.endswith(".mpy"):
            with open(e.host, "rb") as f:
                used.update(qstrnames.mpy_qstrs(f.read()))
    assert len(used) > 1000
    assert not sorted(used - known), sorted(used - known)[:20]
    # the stock harness firmware lacks most of them: what the names save
    assert len(used - _pool_strings("cm3-harness")) > 1000


def test_the_names_module_names_what_it_can_and_leaves_out_what_it_cannot(tmp_path):
    for p in (os.path.join(ROOT, "tools"),):
        if p not in sys.path:
            sys.path.insert(0, p)
    import qstrnames

    mc = os.path.join(ROOT, "build", "firmware", "mpy-cross")
    if not os.path.exists(mc):
        pytest.skip("build/firmware/mpy-cross not built: run `make firmware`")
    names = ["depth_m", "x%d", "acomm.transport.routing", "lifespan over", "class", "_private"]
    src = tmp_path / "names.py"
    src.write_text(qstrnames.names_module(names, per_def=1))
    out = tmp_path / "names.mpy"
    import subprocess

    subprocess.run([mc, "-o", str(out), str(src)], check=True)
    got = set(qstrnames.mpy_qstrs(out.read_bytes()))
    # a keyword cannot be an argument: as a short string it is interned all the same
    assert {"depth_m", "x%d", "acomm.transport.routing", "_private", "class"} <= got
    # a long string is frozen as a string object, not a name
    assert "lifespan over" not in got
    # and a board's files come with the module names acomm flash gives them
    files = qstrnames.board_files("buoy_pico")
    assert (os.path.join(ROOT, "acomm", "transport", "routing.py"), "acomm.transport.routing") in [
        (os.path.normpath(p), n) for p, n in files]
    assert ("acomm.transport",) == tuple(n for p, n in files if p.endswith(os.path.join("transport", "__init__.py")))
    # the command line: the buoy's names module, which compiles and names the router's methods
    cli = tmp_path / "acomm_names.py"
    subprocess.run([sys.executable, os.path.join(ROOT, "tools", "qstrnames.py"), "buoy_pico", mc, str(cli)], check=True)
    subprocess.run([mc, "-o", str(out), str(cli)], check=True)
    got = set(qstrnames.mpy_qstrs(out.read_bytes()))
    assert {"hop_failed", "overheard", "acomm.transport.routing"} <= got and len(got) > 1000
