# docs/quickstart.md runs as written: its ```sh and ```python blocks are
# taken from the page in order; /tmp/acomm-quickstart is replaced by a
# fresh folder of this test; sh lines run with this tree's `acomm` first on
# PATH (a line ending in "&" is started in the background, and the paths
# it names are awaited, then it is stopped at the end); python blocks run
# in one shared namespace, as one session. ```text blocks show output and
# are not run. The page's own asserts and printed lines are checked.
# CPython only (pseudo-terminals); every wait is bounded.

import contextlib
import io
import os
import re
import shlex
import signal
import subprocess
import sys
import time

import pytest

serial = pytest.importorskip("serial")
if not sys.platform.startswith("linux"):
    pytest.skip("needs Linux pseudo-terminals", allow_module_level=True)

from consoleprocs import ROOT, tree_env  # noqa: E402

PAGE = os.path.join(ROOT, "docs", "quickstart.md")
PLACE = "/tmp/acomm-quickstart"


def blocks(text):
    """[(language, code)] of the page's fenced blocks, in order."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.S | re.M)]


def _env():
    env = tree_env()
    env["PATH"] = os.path.dirname(sys.executable) + os.pathsep + env.get("PATH", "")
    return env


def _acomm_on_path(tmp_path):
    # `acomm` as this tree runs it (an editable install has one beside python)
    exe = os.path.join(os.path.dirname(sys.executable), "acomm")
    if os.path.exists(exe):
        return
    bindir = tmp_path / "bin"
    bindir.mkdir()
    (bindir / "acomm").write_text("#!/bin/sh\nexec %s -m acomm_cpython.cli \"$@\"\n" % sys.executable)
    (bindir / "acomm").chmod(0o755)
    os.environ["PATH"] = str(bindir) + os.pathsep + os.environ["PATH"]


def test_the_page_has_the_sections_the_issue_asks_for():
    text = open(PAGE).read()
    langs = [lang for lang, _ in blocks(text)]
    assert langs.count("python") >= 7 and "sh" in langs, langs
    for words in ("Open a serial modem", "lifespan and a priority", "Receive", "Range", "file through the transport",
                  "CADDY diver status", "acomm emulate", "simulated ocean"):
        assert words in text, words


def test_every_block_of_the_quickstart_runs(tmp_path):
    _acomm_on_path(tmp_path)
    place = str(tmp_path / "qs")
    text = open(PAGE).read().replace(PLACE, place)
    background = []
    ns = {"__name__": "quickstart"}
    out = io.StringIO()
    try:
        for i, (lang, code) in enumerate(blocks(text)):
            if lang == "sh":
                for line in code.strip().splitlines():
                    _sh(line, background, place)
            elif lang == "python":
                with contextlib.redirect_stdout(out):
                    exec(compile(code, "%s block %d" % (PAGE, i + 1), "exec"), ns)
            else:
                assert lang == "text", "block %d: %r is neither sh, python nor text" % (i + 1, lang)
    finally:
        for p in background:
            p.send_signal(signal.SIGTERM)
            p.wait(10)
            p.stdout.close()
    printed = out.getvalue().splitlines()
    # what the page's comments say is printed
    assert printed[0] == "acoustic is up", printed
    for want in ("delivered", "('acoustic', 'buoy', b'surface in 5 min')", "{'diver': 150.0}", "delivered True",
                 "4 bytes", "diver_status 72 14 36.6", "['delivered']", "[b'hello from the sim']"):
        assert want in printed, (want, printed)


def _sh(line, background, place):
    if line.endswith("&"):
        args = shlex.split(line[:-1])
        p = subprocess.Popen(args, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        background.append(p)
        # the ports it makes are there before the next block opens them
        paths = [re.search(re.escape(place) + r"[^:\s]*", a).group(0) for a in args if place in a]
        end = time.monotonic() + 15
        while not all(os.path.exists(pth) for pth in paths):
            assert p.poll() is None and time.monotonic() < end, (line, p.stdout.read() if p.poll() is not None else "")
            time.sleep(0.05)
        return
    r = subprocess.run(line, shell=True, env=_env(), capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, (line, r.stdout, r.stderr)
    if "acomm node" in line:
        # the console answered what the pipe asked
        assert "range acoustic" in r.stdout and " diver 150.0 m" in r.stdout, r.stdout
        assert "link acoustic: seatrac on" in r.stdout, r.stdout
