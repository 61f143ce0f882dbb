# The acomm command refuses bad arguments with a message that names the
# problem and exit status 2, before doing any work.
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _acomm(*args):
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([ROOT, os.path.join(ROOT, "ports", "cpython"), os.path.join(ROOT, "ports", "sim"),
                                         os.path.join(ROOT, "ports", "micropython")])
    p = subprocess.run([sys.executable, "-m", "acomm_cpython.cli"] + list(args), capture_output=True, text=True,
                       env=env, timeout=60)
    return p.returncode, p.stdout + p.stderr


def test_bad_arguments_are_named():
    for args, want in (
        (("fuzz", "--seconds", "-5"), "--seconds must be positive"),
        (("fuzz", "--cases", "0"), "--cases must be positive"),
        (("fuzz", "--case", "3"), "--case needs"),
        (("fuzz", "--target", "nope", "--seconds", "1"), "no such target: nope"),
        (("node", "--name", "x", "--id", "70000", "--udp", "0", "--seconds", "1"), "node id 70000 is not 0..254 or 256..65534"),
        (("node", "--name", "x", "--id", "255", "--udp", "0", "--seconds", "1"), "node id 255 is not 0..254 or 256..65534"),
        (("flash", "--board", "nosuch", "--dry-run"), "no board 'nosuch'"),
        (("demo", "--minutes", "-3"), "--minutes must be positive"),
        (("bench", "nosuch"), "unknown benchmark 'nosuch'"),
    ):
        rc, out = _acomm(*args)
        assert rc == 2 and want in out, (args, rc, out)
