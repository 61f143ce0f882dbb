# `acomm node --web`: two nodes on loopback TCP, the topside one serving
# the operator console with a password. A chat line sent from the console's
# API reaches the other node; the command is printed in the topside's
# event log with who sent it; --web errors are usage errors.
import json
import os
import signal
import time
import urllib.error
import urllib.request

from consoleprocs import Proc, free_port



def call(url, body=None, cookie=None):
    req = urllib.request.Request(url, data=None if body is None else json.dumps(body).encode(),
                                 headers=dict({"Content-Type": "application/json"}, **({"Cookie": cookie} if cookie
                                                                                       else {})))
    try:
        with urllib.request.urlopen(req, timeout=5) as r:
            return r.status, json.loads(r.read()), r.headers.get("Set-Cookie", "")
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read()), ""


def test_node_serves_the_console_and_its_commands_go_out(tmp_path):
    pw = tmp_path / "pw"
    pw.write_text("reef\n")
    os.chmod(pw, 0o600)
    port = free_port()
    top = Proc(["node", "--name", "topside", "--id", "1", "--known", "diver=2", "--tcp-listen", "127.0.0.1:0",
                "--web", "127.0.0.1:%d" % port, "--web-password-file", str(pw), "--seconds", "20"])
    diver = None
    try:
        where = top.expect("tcp listening on 127.0.0.1:")
        top.expect("console: http://127.0.0.1:%d/" % port)
        diver = Proc(["node", "--name", "diver", "--id", "2", "--known", "topside=1", "--tcp-connect",
                      "127.0.0.1:" + where.rsplit(":", 1)[1], "--seconds", "15"])
        top.expect("available diver on tcp")
        url = "http://127.0.0.1:%d" % port
        assert call(url + "/api/state")[0] == 401
        code, ans, cookie = call(url + "/api/login", {"user": "dana", "password": "reef"})
        assert code == 200, ans
        cookie = cookie.split(";")[0]
        code, ans, _ = call(url + "/api/command", {"op": "chat", "dst": "diver", "text": "surface now"}, cookie)
        assert code == 202, ans
        diver.expect("received tcp topside -> diver")
        top.expect("web: dana@127.0.0.1")
        code, ans, _ = call(url + "/api/command", {"op": "chat", "dst": "shore", "text": "x"}, cookie)
        assert code == 404 and "unknown node" in ans["error"], ans
        end = time.monotonic() + 10
        while True:
            code, v, _ = call(url + "/api/view/log", cookie=cookie)
            e = [x for x in v["data"]["entries"] if x["cls"] == "chat"]
            if e and e[0]["status"] == "delivered" or time.monotonic() > end:
                break
            time.sleep(0.2)
        assert e[0]["status"] == "delivered" and e[0]["by"] == "dana@127.0.0.1", e
        code, v, _ = call(url + "/api/view/nodes", cookie=cookie)
        assert "diver" in [n["name"] for n in v["data"]["nodes"]]
    finally:
        top.finish(signal.SIGTERM)
        if diver is not None:
            diver.finish(signal.SIGTERM)


def test_web_usage_errors(tmp_path):
    p = Proc(["node", "--name", "a", "--id", "1", "--tcp-listen", "127.0.0.1:0", "--web", "nowhere"])
    rc, err = p.finish()
    assert rc == 2 and "--web" in err, err
    p = Proc(["node", "--name", "a", "--id", "1", "--tcp-listen", "127.0.0.1:0", "--web-password-file", "x"])
    rc, err = p.finish()
    assert rc == 2 and "goes with --web" in err, err
