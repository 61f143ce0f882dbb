# The store and `acomm node --store DIR` on a disk that fills up and on one
# that is read-only, for real where this machine lets a test mount a small
# tmpfs of its own (tests/cpython/smallfs.py: `unshare -m` as root, `unshare
# -rm` as a user), and on fault-injecting files where it does not
# (tests/core/faultfs.py). Each test prints which path it took; none skips:
# the fault path runs everywhere (ACOMM_TEST_NO_MOUNT=1 forces it).
#
# What must hold (issue 37, point 3): a full disk is StoreFull, never an
# OSError, and every record put() acknowledged is still there, also after
# a reopen; once there is room put() works again. The node keeps running,
# refuses new packets with "store full", says once that the store is full
# and once that there is room again. A store DIR it cannot write stops it
# at the start with one line and exit status 2.

import json
import os
import signal
import subprocess
import sys

from consoleprocs import Proc, acomm_cmd, tree_env
from smallfs import filler_path, in_tmpfs, way

HERE = os.path.dirname(os.path.abspath(__file__))
FULLDISK = os.path.join(HERE, "fulldisk_worker.py")
FAULTNODE = os.path.join(HERE, "faultnode.py")


def _worker(argv):
    r = subprocess.run(argv, env=tree_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def _check_worker(out, path):
    assert out["acked"] > 10, out  # the store took records until the disk was full
    assert out["why"] == "store %s: filesystem full" % path, out
    assert out["second"] == out["why"], out  # refused again, not an OSError
    assert out["reads"] and out["reopened"] and out["after"], out
    assert out["torn"] == 0, out  # the refused records' partial writes were cut off


def test_the_store_on_a_disk_that_fills_up(tmp_path):
    pre = way()
    mnt = str(tmp_path / "mnt")
    os.mkdir(mnt)
    if pre is not None:
        print("full disk: a real 64 KiB tmpfs, mounted with %s" % " ".join(pre))
        out = _worker(in_tmpfs(pre, mnt, 64, [sys.executable, FULLDISK, mnt, "real"], filler=40 * 1024))
        assert out["how"] == "real"
        _check_worker(out, os.path.join(mnt, "store"))
    else:
        print("full disk: no tmpfs can be mounted here; fault-injecting files only")
    # the fault path, everywhere: what CI without mounts runs
    fdir = str(tmp_path / "fault")
    os.mkdir(fdir)
    out = _worker([sys.executable, FULLDISK, fdir, "fault"])
    _check_worker(out, os.path.join(fdir, "store"))


def _node_args(store):
    return ["node", "--name", "buoy", "--id", "1", "--known", "far=9", "--udp", "127.0.0.1:0", "--no-multicast",
            "--broadcast", "none", "--store", store]


def test_acomm_node_on_a_full_disk_keeps_running_and_says_so_once(tmp_path):
    pre = way()
    mnt = str(tmp_path / "mnt")
    os.mkdir(mnt)
    store = os.path.join(mnt, "store")
    flag = str(tmp_path / "full")
    if pre is not None:
        print("acomm node: its store on a real 64 KiB tmpfs, 40 KiB taken by a filler file")
        node = Proc(_node_args(store), cmd=in_tmpfs(pre, mnt, 64, acomm_cmd(), filler=40 * 1024))
    else:
        print("acomm node: its store on fault-injecting files (no tmpfs can be mounted here)")
        node = Proc(_node_args(store), cmd=[sys.executable, FAULTNODE, flag])
    files = []
    for i in range(16):
        p = str(tmp_path / ("f%d" % i))
        with open(p, "wb") as f:
            f.write(os.urandom(3000))  # not compressible: about 3 KiB on disk each
        files.append(p)
    try:
        node.expect("ready: node buoy (1)")
        for i in range(12):
            if pre is None and i == 4:
                open(flag, "w").close()  # the disk is full from here
            node.send("file far %s --lifespan 600" % files[i])
            node.expect("packet %d to far" % (i + 1))
        full = [ln for ln in node.lines if ln.startswith("store ")]
        failed = [ln for ln in node.lines if ln.endswith(" failed: store full")]
        assert full == ["store %s/acomm.store: filesystem full; new packets are refused until there is room"
                        % store], node.lines
        assert 2 <= len(failed) <= 9, node.lines  # the first ones were taken, the rest refused, each with its status
        # room again: the next file is taken, and the node says so once
        if pre is not None:
            os.remove(filler_path(node.p.pid, mnt))
        else:
            os.remove(flag)
        node.send("file far %s --lifespan 600" % files[12])
        assert node.expect("store ") == "store %s/acomm.store: room again" % store
        node.expect("packet 13 to far")
        node.send("file far %s --lifespan 600" % files[13])
        node.expect("packet 14 to far")
        node.send("status")
        node.expect("last errors")
        assert not [ln for ln in node.lines if ln.startswith(("packet 13 failed", "packet 14 failed"))], node.lines
        assert len([ln for ln in node.lines if ln.startswith("store ")]) == 2, node.lines
    finally:
        rc, err = node.finish(signal.SIGINT)
    assert rc == 0 and "Traceback" not in err, err


def test_acomm_node_with_a_store_it_cannot_write_stops_with_one_line(tmp_path):
    pre = way()
    mnt = str(tmp_path / "mnt")
    os.mkdir(mnt)
    store = os.path.join(mnt, "store")
    flag = str(tmp_path / "disk.ro")
    if pre is not None:
        print("acomm node: its store on a real tmpfs mounted read-only")
        # DIR is there (made before the remount): the store file cannot be
        cmd = in_tmpfs(pre, mnt, 64, ["sh", "-c", 'mkdir "$0" && mount -o remount,ro "$1" && shift && exec "$@"',
                                      store, mnt] + acomm_cmd())
    else:
        print("acomm node: its store on fault-injecting files that refuse writing (no tmpfs can be mounted here)")
        open(flag, "w").close()
        cmd = [sys.executable, FAULTNODE, flag]
    r = subprocess.run(cmd + _node_args(store), env=tree_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       text=True, timeout=60)
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert r.stderr.strip() == "acomm node: store %s/acomm.store: read-only file system" % store, r.stderr
