# `acomm flash` against a real bare-metal MicroPython: the Cortex-M3
# firmware (tools/firmware.py, `make firmware`) under qemu-system-arm, its
# UART on a pty that mpremote opens as it would a board's serial port.
#
# cm3-plain has no acomm: the buoy is flashed as modules compiled for its
# arch (armv6m, which the M3 runs, viper CRC included). cm3-buoy has the
# buoy's import closure frozen in, as a production buoy is built: the flash
# must copy only main.py and config.py and clear old copies from /lib.
# Then the buoy's node runs on the board from what was flashed (or frozen)
# for a simulated minute against emulated modems on the board, as
# test_board_on_fakeboard.py does: frames on both links, the diver's packet
# relayed, no error, no MemoryError. Every module the board needs is
# imported first and where it came from checked (/lib/....mpy; or frozen:
# its package's __path__ is .frozen/...). The simulator is test
# scaffolding under /sim, reached by pointing the board's packages'
# __path__ there only after that, so it never stands in for a board module.
import ast
import os
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import pytest

from acomm_cpython.board import boardfiles
from acomm_cpython.board.qemuboard import QemuBoard, QemuError, firmware

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ACOMM = os.path.join(os.path.dirname(sys.executable), "acomm")
MPREMOTE = os.path.join(os.path.dirname(sys.executable), "mpremote")
BOARD = os.path.join(ROOT, "boards", "buoy_pico")
HEAP = 2 * 1024 * 1024  # the World and the emulators run on the board too

RUN = """import sys, gc
sys.path.append('/')
_need = %r
for _m in _need:
    __import__(_m)
print('FROM', repr({_m: (sys.modules[_m].__file__, getattr(sys.modules[_m], '__path__', None)) for _m in _need}))
from acomm.codec import crc
print('CRC', repr(crc.crc16 is crc.crc16_pure))
for _m in _need:
    if hasattr(sys.modules[_m], '__path__'):
        sys.modules[_m].__path__ = '/sim/' + _m.replace('.', '/')
sys.path.append('/sim')
from config import CONFIG
from acomm_sim.boardsim import run_board
r = run_board(CONFIG, {'diver': 'seatrac', 'shore': 'iridium'}, via={'diver': 'shore'})
print('RESULT', repr((r['links'], r['relayed'], r['board'], len(r['board_packets']))))
gc.collect()
print('FREE', gc.mem_free())
"""


def _need(name):
    fw = firmware(name)
    if fw is None:
        pytest.skip("build/firmware/%s.elf is not built: run `make firmware` (tools/firmware.py build)" % name)
    if shutil.which("qemu-system-arm") is None:
        pytest.skip("qemu-system-arm is not installed: `make firmware` installs it")
    return fw


def _mp(port, *args, timeout=120):
    r = subprocess.run([MPREMOTE, "connect", port] + list(args), capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def _flash(port, *extra):
    return subprocess.run([ACOMM, "flash", "--board", "buoy_pico", "--port", port] + list(extra),
                          capture_output=True, text=True, timeout=180)


def _scaffold(tmp_path, needed):
    # the simulator and the core modules only it imports, compiled, for /sim
    stage = tmp_path / "sim"
    mc = boardfiles.mpy_cross_command()
    srcs = []
    for pkg, base in (("acomm", os.path.join(ROOT, "acomm")),
                      ("acomm_sim", os.path.join(ROOT, "ports", "sim", "acomm_sim"))):
        for d, dirs, files in os.walk(base):
            dirs[:] = [x for x in dirs if x not in ("__pycache__", "imc")]
            for f in files:
                if f.endswith(".py"):
                    rel = os.path.relpath(os.path.join(d, f), base)
                    mod = (pkg + "." + rel[:-3].replace(os.sep, ".")).replace(".__init__", "")
                    if mod not in needed:
                        srcs.append((os.path.join(d, f), stage / pkg / (rel[:-3] + ".mpy")))
    for src, dst in srcs:
        dst.parent.mkdir(parents=True, exist_ok=True)
    with ThreadPoolExecutor(max_workers=4) as ex:
        for f in [ex.submit(boardfiles.compile_mpy, src, str(dst), "armv6m", None, mc) for src, dst in srcs]:
            f.result()
    return stage


def _run_minute(tmp_path, port, needed):
    stage = _scaffold(tmp_path, needed)
    _mp(port, "fs", "mkdir", ":/sim", "+", "fs", "cp", "-r", str(stage / "acomm"), str(stage / "acomm_sim"), ":/sim/")
    out = _mp(port, "exec", RUN % (sorted(needed),), timeout=150)
    assert "MemoryError" not in out and "Traceback" not in out, out
    frm = [ln for ln in out.splitlines() if ln.startswith("FROM ")]
    res = [ln for ln in out.splitlines() if ln.startswith("RESULT ")]
    assert frm and res, out
    links, relayed, stats, board_packets = ast.literal_eval(res[0][len("RESULT "):])
    for name in ("acoustic", "satellite"):
        assert links[name]["tx_frames"] > 0 and links[name]["rx_frames"] > 0, links
    assert relayed == 1 and board_packets == 2
    assert stats["errors"] == 0 and stats["oom"] == 0, stats
    pure = [ln for ln in out.splitlines() if ln.startswith("CRC ")]
    return ast.literal_eval(frm[0][len("FROM "):]), pure == ["CRC True"]


def test_the_buoy_flashed_to_the_cortex_m3_runs_from_the_flashed_mpy(tmp_path):
    with QemuBoard(_need("cm3-plain"), heap=HEAP) as b:
        r = _flash(b.port, "--frozen")  # asserts a frozen acomm, which this firmware has not
        assert r.returncode == 2 and "has no acomm frozen in its firmware" in r.stderr, r.stdout + r.stderr
        r = _flash(b.port)
        assert r.returncode == 0, r.stdout + r.stderr
        assert "frozen" not in r.stdout and "flashed" in r.stdout, r.stdout
        # all but the native code (boardfiles.FROZEN_ONLY), which would
        # take RAM there: the table CRC runs instead of the viper one
        needed = dict((m, p) for m, p in boardfiles.modules(BOARD).items() if m not in boardfiles.FROZEN_ONLY)
        files, pure_crc = _run_minute(tmp_path, b.port, needed)
        assert b.alive(), b.stop()
    assert set(files) == set(needed) and "acomm.codec._crc16_viper" not in files
    for m, (f, path) in files.items():
        assert f.startswith("/lib/") and f.endswith(".mpy"), (m, f)  # the flashed, compiled module ran
    assert pure_crc
    assert files["acomm.drivers"][1] == "/lib/acomm/drivers"


def test_the_production_buoy_gets_only_its_config_and_runs_frozen_acomm(tmp_path):
    with QemuBoard(_need("cm3-buoy"), heap=HEAP) as b:
        # a stale copy of acomm from an earlier, unfrozen flash
        _mp(b.port, "exec", "import os\nfor d in ('/lib', '/lib/acomm', '/lib/acomm_mp'):\n    os.mkdir(d)\n"
                            "open('/lib/acomm/node.py', 'w').write('BROKEN = 1\\n')")
        r = _flash(b.port)  # found out on the board, no --frozen
        assert r.returncode == 0, r.stdout + r.stderr
        assert "frozen in its firmware" in r.stdout and "copying only main.py and config.py" in r.stdout, r.stdout
        assert "flashed 2 files" in r.stdout, r.stdout
        ls = _mp(b.port, "exec", "import os; print(sorted(os.listdir('/')), sorted(os.listdir('/lib')))")
        assert "'main.py'" in ls and "'config.py'" in ls and "acomm" not in ls, ls
        needed = boardfiles.modules(BOARD)
        files, pure_crc = _run_minute(tmp_path, b.port, needed)
        assert b.alive(), b.stop()
    assert set(files) == set(needed)
    assert not pure_crc  # the frozen viper CRC runs from flash
    # from the firmware, not from /lib: a frozen module's __file__ is its
    # name alone (acomm/link/__init__.py, no .mpy), its package's __path__ .frozen/...
    for m, (f, path) in files.items():
        assert not f.startswith("/") and f.endswith(".py"), (m, f)
        assert path is None or path.startswith(".frozen/"), (m, path)
    assert files["acomm"][1] == ".frozen/acomm"


def test_flash_refuses_a_version_other_than_the_frozen_one(tmp_path):
    fw = _need("cm3-buoy")
    with QemuBoard(fw, heap=HEAP) as b:
        # the board's firmware says 0.1.0; pretend the host moved on
        r = subprocess.run([sys.executable, "-c",
                            "import sys, acomm; acomm.__version__ = '9.9.9'; "
                            "from acomm_cpython.cli import main; sys.exit(main())",
                            "flash", "--board", "buoy_pico", "--port", b.port],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 2, r.stdout + r.stderr
        assert "version 0.1.0, this host's is 9.9.9" in r.stderr, r.stderr
        assert "main.py" not in _mp(b.port, "exec", "import os; print(os.listdir('/'))")


def test_flash_reports_a_board_that_does_not_answer(tmp_path):
    fw = _need("cm3-plain")
    b = QemuBoard(fw, heap=HEAP)
    port = b.port
    b.stop()
    r = _flash(port)
    assert r.returncode == 1 and ("no answer from %s" % port) in r.stderr, r.stdout + r.stderr


def test_a_qemu_that_does_not_start_is_reported_with_its_stderr(tmp_path):
    fw = _need("cm3-plain")
    with pytest.raises(QemuError) as e:
        QemuBoard(fw, heap=HEAP, rom=str(tmp_path / "no-such-romfs.img"))
    msg = str(e.value)
    assert "qemu did not start" in msg and "no-such-romfs.img" in msg and "qemu-system-arm:" in msg, msg
