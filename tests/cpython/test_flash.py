# `acomm flash`: the module plan of each board (the import closure plus its
# modems' drivers), .mpy compiled for the board's arch, the x64 build
# importing on the unix port laid out as on a device, errors with status 2
# for a wrong board or config, and a device that is not there. No device and
# no fake board: the device side is checked through a stand-in for mpremote.

import os
import re
import shutil
import subprocess
import sys
import time

import pytest

from acomm_cpython import cli
from acomm_cpython.board import boardfiles, flash

ROOT = boardfiles.repo_root()
BOARDS = os.path.join(ROOT, "boards")
from acomm.drivers.registry import names as modem_names  # noqa: E402

# mpy header byte 2 is (arch << 2) | 3 for a module with native code
_ARCH_CODE = {"x64": 2, "armv6m": 4, "xtensawin": 10}
_ALL_DRIVERS = set("acomm.drivers." + m for m in modem_names())


def _board_drivers(board):
    cfg = boardfiles.load_config(os.path.join(BOARDS, board))
    return set("acomm.drivers." + lk["modem"] for lk in cfg["links"])


def _dry_run(capsys, *args):
    rc = cli.main(["flash", "--dry-run"] + list(args))
    out = capsys.readouterr()
    return rc, out.out, out.err


@pytest.mark.parametrize("board,want,not_want", [
    ("buoy_pico", ["seatrac", "iridium"], ["evologics", "micromodem", "benthos", "sms"]),
    ("diver_esp32s3", ["seatrac"], ["iridium", "evologics", "micromodem", "benthos", "sms"]),
])
def test_dry_run_lists_the_board_and_only_its_drivers(capsys, board, want, not_want):
    rc, out, err = _dry_run(capsys, "--board", board, "--no-compile")
    assert rc == 0, err
    lines = out.splitlines()
    paths = [ln.split()[0] for ln in lines[:-1]]
    assert paths[:2] == ["/main.py", "/config.py"]
    assert "/lib/acomm_mp/start.py" in paths
    assert "/lib/acomm_mp/__init__.py" in paths and "/lib/acomm/__init__.py" in paths
    assert "/lib/acomm/drivers/__init__.py" in paths
    for d in want:
        assert "/lib/acomm/drivers/%s.py" % d in paths
    for d in not_want:
        assert "/lib/acomm/drivers/%s.py" % d not in paths
    assert not any(p.startswith("/lib/acomm/imc/") for p in paths)
    # sizes add up to the total line
    sizes = [int(ln.split()[-1]) for ln in lines[:-1]]
    assert lines[-1].startswith("total (%d files" % len(paths))
    assert int(lines[-1].split()[-1]) == sum(sizes)
    # the drivers come from the config's modems
    assert set(want) == set(d.rsplit(".", 1)[1] for d in _board_drivers(board))


@pytest.mark.parametrize("board", ["buoy_pico", "diver_esp32s3"])
def test_native_code_goes_to_the_frozen_manifest_and_not_to_the_flash(board):
    # relocated into RAM from a filesystem or ROMFS, in place from flash
    board_dir = os.path.join(BOARDS, board)
    assert "acomm.codec._crc16_viper" in boardfiles.FROZEN_ONLY
    assert "acomm.codec._crc16_viper" in boardfiles.modules(board_dir)
    devices = [e.device for e in boardfiles.plan(board_dir, compile=False)]
    assert "/lib/acomm/codec/crc.py" in devices
    assert not any("_crc16_viper" in d for d in devices)
    with open(os.path.join(ROOT, "ports", "micropython", "manifests", board + ".py")) as f:
        assert "codec/_crc16_viper.py" in f.read()


@pytest.mark.parametrize("board", ["buoy_pico", "diver_esp32s3"])
def test_every_planned_module_exists_where_the_device_path_says(board):
    dirs = boardfiles.package_dirs()
    entries = boardfiles.plan(os.path.join(BOARDS, board), compile=False)
    assert len(set(e.device for e in entries)) == len(entries)
    for e in entries:
        assert os.path.isfile(e.host), e
        assert e.size == os.path.getsize(e.host)
        if e.device.startswith("/lib/"):
            top, rest = e.device[len("/lib/"):].split("/", 1)
            assert os.path.samefile(e.host, os.path.join(dirs[top], rest))
    # every package on the way has its __init__
    for e in entries:
        parts = e.device.split("/")[2:-1]
        for i in range(1, len(parts) + 1):
            assert "/lib/" + "/".join(parts[:i]) + "/__init__.py" in [x.device for x in entries]


@pytest.mark.parametrize("board,arch", [("buoy_pico", "armv6m"), ("diver_esp32s3", "xtensawin")])
def test_compiles_mpy_for_the_board_arch(tmp_path, board, arch):
    bd = os.path.join(BOARDS, board)
    assert boardfiles.load_config(bd)["arch"] == arch
    entries = boardfiles.plan(bd, stage_dir=str(tmp_path))
    mods = [e for e in entries if e.device.startswith("/lib/")]
    assert mods and all(e.device.endswith(".mpy") for e in mods)
    assert [e.device for e in entries[:2]] == ["/main.py", "/config.py"]
    for e in mods:
        with open(e.host, "rb") as f:
            head = f.read(4)
        assert head[:2] == b"M\x06", e
        assert os.path.commonpath([str(tmp_path), e.host]) == str(tmp_path)
    viper = [e for e in mods if e.device == "/lib/acomm/_crc16_viper.mpy"]
    if viper:  # native code carries the arch in its header
        with open(viper[0].host, "rb") as f:
            assert f.read(3)[2] >> 2 == _ARCH_CODE[arch]
    total = boardfiles.mpy_total_bytes(bd, stage_dir=str(tmp_path / "again"))
    assert total == sum(e.size for e in mods)
    fp = boardfiles.footprint(bd, stage_dir=str(tmp_path / "fp"))
    assert fp["mpy_total_bytes"] == total and fp["arch"] == arch and fp["modules"] == len(mods)


def _micropython():
    exe = os.path.join(os.path.dirname(sys.executable), "micropython")
    return exe if os.access(exe, os.X_OK) else shutil.which("micropython")


@pytest.mark.parametrize("board", ["buoy_pico", "diver_esp32s3"])
def test_x64_mpy_imports_on_the_unix_port(tmp_path, board):
    mp = _micropython()
    if mp is None:
        pytest.skip("no micropython command")
    entries = boardfiles.plan(os.path.join(BOARDS, board), arch="x64", stage_dir=str(tmp_path / "stage"))
    dev = tmp_path / "device"
    for e in entries:
        dst = dev / e.device.lstrip("/")
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(e.host, dst)
    assert not list((dev / "lib").rglob("*.py"))  # only .mpy: the imports below use them
    drivers = sorted(_board_drivers(board))
    code = ("import acomm_mp.assemble, acomm_mp.start\n"
            "for m in %r:\n"
            "    __import__(m)\n"
            "import sys\n"
            "assert sys.modules['acomm_mp.assemble'].__file__.endswith('.mpy')\n"
            "from acomm.drivers.registry import driver_class\n"
            "for modem in %r:\n"
            "    driver_class(modem)\n"
            # the viper CRC stays behind (FROZEN_ONLY): the table one runs
            "from acomm.codec import crc\n"
            "assert crc.crc16 is crc.crc16_pure and crc.crc16(b'123456789') == 0xBB3D\n"
            # a traceback names the module; its line only where the config keeps lines
            "import io\n"
            "try:\n"
            "    crc.crc16(None)\n"
            "except TypeError as e:\n"
            "    s = io.StringIO()\n"
            "    sys.print_exception(e, s)\n"
            "    print(s.getvalue())\n"
            "print('IMPORTED')\n") % (drivers, sorted(set(d.rpartition(".")[2] for d in drivers)))
    env = dict(os.environ, MICROPYPATH=str(dev / "lib") + ":.frozen")
    r = subprocess.run([mp, "-c", code], cwd=str(tmp_path), env=env, capture_output=True, text=True, timeout=30)
    assert r.returncode == 0 and "IMPORTED" in r.stdout, r.stdout + r.stderr
    # each .mpy is named by its module (no qstr of its own); lines as configured
    line = int(re.search(r'File "acomm\.codec\.crc", line (\d+), in crc16_pure', r.stdout).group(1))
    lines = boardfiles.load_config(os.path.join(BOARDS, board)).get("mpy_lines", True)
    assert (line > 1) == lines, (board, r.stdout)
    # a driver the board does not have is not there
    other = sorted(_ALL_DRIVERS - set(drivers))[0]
    r = subprocess.run([mp, "-c", "import " + other], cwd=str(tmp_path), env=env, capture_output=True, text=True,
                       timeout=30)
    assert r.returncode != 0


def test_unknown_board_exits_2_naming_it(capsys):
    rc, out, err = _dry_run(capsys, "--board", "no_such_board")
    assert rc == 2
    assert "no_such_board" in err and "no board" in err


def test_bad_config_field_exits_2_naming_it(tmp_path, capsys):
    shutil.copytree(os.path.join(BOARDS, "diver_esp32s3"), str(tmp_path / "bad"))
    cfg = tmp_path / "bad" / "config.py"
    text = cfg.read_text()
    assert '"baud": 115200' in text
    cfg.write_text(text.replace('"baud": 115200', '"baud": "fast"', 1))
    rc, out, err = _dry_run(capsys, "--board", "bad", "--boards", str(tmp_path))
    assert rc == 2
    assert "links[0].baud" in err and "fast" in err


def test_bad_arch_exits_2(capsys):
    rc, out, err = _dry_run(capsys, "--board", "buoy_pico", "--arch", "z80")
    assert rc == 2 and "z80" in err


def test_closure_follows_relative_function_and_try_imports(tmp_path):
    a = tmp_path / "acomm"
    (a / "sub").mkdir(parents=True)
    mp = tmp_path / "ports" / "micropython" / "acomm_mp"
    mp.mkdir(parents=True)
    files = {
        a / "__init__.py": "",
        a / "one.py": "from . import two\nfrom .sub.deep import X\n",
        a / "two.py": "def f():\n    import acomm.three\n",
        a / "three.py": "try:\n    from acomm import four\nexcept ImportError:\n    pass\nimport gc, time\n",
        a / "four.py": "x = __import__('acomm.five')\n",
        a / "five.py": "",
        a / "unused.py": "",
        a / "sub" / "__init__.py": "",
        a / "sub" / "deep.py": "from .. import six\nX = 1\n",
        a / "six.py": "import asyncio, machine, micropython\n",
        mp / "__init__.py": "",
        mp / "start.py": "from .helper import h\nfrom acomm.one import two\n",
        mp / "helper.py": "import os\nh = 1\n",
    }
    for p, text in files.items():
        p.write_text(text)
    main = tmp_path / "main.py"
    main.write_text("from config import CONFIG\nfrom acomm_mp.start import start\n")
    got = boardfiles.closure([str(main)], root=str(tmp_path))
    assert sorted(got) == ["acomm", "acomm.five", "acomm.four", "acomm.one", "acomm.six", "acomm.sub",
                           "acomm.sub.deep", "acomm.three", "acomm.two", "acomm_mp", "acomm_mp.helper",
                           "acomm_mp.start"]
    (a / "five.py").unlink()
    with pytest.raises(flash.FlashError) as e:
        boardfiles.closure([str(main)], root=str(tmp_path))
    assert "acomm.five" in str(e.value)


class _FakeMpremote:
    # stands in for flash._mpremote: answers statvfs, records the rest
    def __init__(self, free, bs=4096, replaced=0):
        self.free, self.bs, self.replaced = free, bs, replaced
        self.calls = []

    def __call__(self, device, args, what, timeout=flash.TIMEOUT_S):
        self.calls.append(args)
        if args[0] == "exec" and "statvfs" in args[1]:
            return "ACOMM-DF %d %d %d\nACOMM-FROZEN - - -\n" % (self.bs, self.free, self.replaced)
        if args[0] == "exec":
            return "ACOMM-READY\n"
        return ""


def test_flash_refuses_when_it_does_not_fit(monkeypatch):
    entries = boardfiles.plan(os.path.join(BOARDS, "buoy_pico"), compile=False)
    fake = _FakeMpremote(free=8192, replaced=4096)
    monkeypatch.setattr(flash, "_mpremote", fake)
    with pytest.raises(flash.FlashError) as e:
        flash.flash("/dev/ttyFAKE", entries, log=lambda s: None)
    msg = str(e.value)
    assert "not enough space" in msg and "/dev/ttyFAKE" in msg and "12288 free" in msg
    assert len(fake.calls) == 1  # nothing written


def test_flash_makes_folders_and_copies_in_batches(monkeypatch):
    entries = boardfiles.plan(os.path.join(BOARDS, "buoy_pico"), compile=False)
    fake = _FakeMpremote(free=10 << 20)
    monkeypatch.setattr(flash, "_mpremote", fake)
    n, b = flash.flash("/dev/ttyFAKE", entries, log=lambda s: None)
    assert (n, b) == (len(entries), sum(e.size for e in entries))
    prepare = fake.calls[1][1]
    for d in ("/lib", "/lib/acomm", "/lib/acomm/drivers", "/lib/acomm_mp"):
        assert repr(d) in prepare
    copies = []
    for args in fake.calls[2:]:
        groups = " ".join(args).split(" + ")
        assert len(groups) <= flash._BATCH_FILES
        for g in groups:
            w = g.split()
            assert w[:2] == ["fs", "cp"] and w[3].startswith(":")
            copies.append((w[2], w[3][1:]))
    assert len(fake.calls) >= 3
    assert copies == [(e.host, e.device) for e in entries]


def test_missing_device_fails_with_no_answer():
    t = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "acomm_cpython.cli", "flash", "--board", "buoy_pico", "--no-compile",
                        "--port", "/dev/acomm-no-such-device"], capture_output=True, text=True, timeout=45)
    assert time.monotonic() - t < 40
    assert r.returncode != 0
    assert "no answer from /dev/acomm-no-such-device" in r.stderr


@pytest.mark.parametrize("reset", [False, True])
def test_reset_after_the_copy_only_when_asked(monkeypatch, capsys, reset):
    # --reset: mpremote's `reset` once every file is on the board, as the
    # last call; without it the board is left at its REPL (the Cortex-M3
    # tests go on to use it there)
    fake = _FakeMpremote(free=10 << 20)
    monkeypatch.setattr(flash, "_mpremote", fake)
    rc = cli.main(["flash", "--board", "buoy_pico", "--port", "/dev/ttyFAKE", "--no-compile"]
                  + (["--reset"] if reset else []))
    out = capsys.readouterr().out
    assert rc == 0
    assert fake.calls[-2][:2] == ["fs", "cp"]
    assert (fake.calls[-1] == ["reset"]) == reset
    assert sum(1 for c in fake.calls if c[0] == "reset") == (1 if reset else 0)
    assert ("reset /dev/ttyFAKE: main.py starts" in out) == reset
    assert ("reset the board to start it" in out) == (not reset)


def test_reset_that_fails_is_reported(monkeypatch, capsys):
    fake = _FakeMpremote(free=10 << 20)

    def failing(device, args, what, timeout=flash.TIMEOUT_S):
        if args == ["reset"]:
            raise flash.FlashError("%s: could not enter raw repl" % what)
        return fake(device, args, what, timeout)

    monkeypatch.setattr(flash, "_mpremote", failing)
    rc = cli.main(["flash", "--board", "buoy_pico", "--port", "/dev/ttyFAKE", "--no-compile", "--reset"])
    err = capsys.readouterr().err
    assert rc == 1 and "resetting /dev/ttyFAKE: could not enter raw repl" in err, err
