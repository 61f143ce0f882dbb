# `acomm node` as two child processes on loopback TCP: the server prints
# where it listens, the client connects, waits until the server is heard,
# sends, and the server prints what it received.
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _node(*args):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT, os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "sim")])
    cmd = [sys.executable, "-m", "acomm_cpython.cli", "node"] + list(args)
    return subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)


def test_node_command_over_tcp():
    srv = _node("--name", "topside", "--id", "1", "--tcp-listen", "127.0.0.1:0", "--seconds", "4")
    cli = None
    try:
        banner = srv.stdout.readline()
        assert banner.startswith("tcp listening on 127.0.0.1:"), (banner, srv.stderr.read())
        port = banner.strip().rsplit(":", 1)[1]
        t0 = time.monotonic()
        cli = _node("--name", "buoy", "--id", "2", "--known", "topside=1", "--tcp-connect", "127.0.0.1:" + port,
                    "--send", "topside=hello over tcp", "--seconds", "1.5")
        out, err = cli.communicate(timeout=10)
        assert cli.returncode == 0, err
        assert "available topside on tcp" in out and "status tcp 1 delivered" in out, out
        srv.terminate()
        sout, serr = srv.communicate(timeout=10)
        assert "received tcp node-2 -> topside: hello over tcp" in sout, (sout, serr)
        assert time.monotonic() - t0 < 8
    finally:
        for p in (srv, cli):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()


def test_node_command_needs_a_link():
    p = _node("--name", "x", "--id", "1")
    _, err = p.communicate(timeout=10)
    assert p.returncode == 2 and "--udp" in err


def test_two_nodes_with_the_same_key_file_talk_and_a_bad_key_file_is_named(tmp_path):
    key = tmp_path / "net.key"
    key.write_text("00112233445566778899aabbccddeeff\n")
    key.chmod(0o600)
    srv = _node("--name", "topside", "--id", "1", "--tcp-listen", "127.0.0.1:0", "--seconds", "4",
                "--key-file", str(key), "--auth-counters", str(tmp_path / "topside.ctr"))
    cli = None
    try:
        port = srv.stdout.readline().strip().rsplit(":", 1)[1]
        cli = _node("--name", "buoy", "--id", "2", "--known", "topside=1", "--tcp-connect", "127.0.0.1:" + port,
                    "--send", "topside=sealed hello", "--seconds", "1.5", "--key-file", str(key))
        out, err = cli.communicate(timeout=10)
        assert cli.returncode == 0 and "status tcp 1 delivered" in out, (out, err)
        srv.terminate()
        sout, _ = srv.communicate(timeout=10)
        assert "received tcp node-2 -> topside: sealed hello" in sout, sout
        assert (tmp_path / "topside.ctr").exists()  # the counters were written
    finally:
        for p in (srv, cli):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()
    for text, want in (("0011", "2 bytes"), ("not hex at all", "not hex"), (None, "No such file")):
        path = tmp_path / ("k%d" % len(want))
        if text is not None:
            path.write_text(text)
            path.chmod(0o600)
        p = _node("--name", "x", "--id", "1", "--udp", "127.0.0.1:0", "--key-file", str(path), "--seconds", "1")
        _, err = p.communicate(timeout=10)
        assert p.returncode == 2 and str(path) in err and want in err, err
        assert text is None or text not in err or text == "not hex at all"


def test_a_key_file_others_can_read_is_refused_as_ssh_does(tmp_path):
    path = tmp_path / "open.key"
    path.write_text("00112233445566778899aabbccddeeff\n")
    for mode in (0o644, 0o640, 0o604, 0o620):
        path.chmod(mode)
        p = _node("--name", "x", "--id", "1", "--udp", "127.0.0.1:0", "--key-file", str(path), "--seconds", "1")
        _, err = p.communicate(timeout=10)
        assert p.returncode == 2 and "too open" in err and "%04o" % mode in err and "chmod 600" in err, err
        assert "0011223344" not in err
