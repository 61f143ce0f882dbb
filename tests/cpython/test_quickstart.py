# docs/quickstart.md (the asyncio library), docs/quickstart-blocking.md
# (its blocking form) and docs/core-loop.md (the core's own loop, as on a
# board) run as written: their ```sh and ```python blocks are taken from
# each page in order; /tmp/acomm-quickstart is replaced by a
# fresh folder of this test; sh lines run with this tree's `acomm` first on
# PATH (a line ending in "&" is started in the background, and the paths
# it names are awaited, then it is stopped at the end); python blocks run
# in one shared namespace, as one session. ```text blocks show output and
# are not run. The page's own asserts are checked, and every line a
# `print(...)  # TEXT` says it prints is printed, in the page's order.
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

PAGES = [os.path.join(ROOT, "docs", p) for p in ("quickstart.md", "quickstart-blocking.md", "core-loop.md")]
PLACE = "/tmp/acomm-quickstart"


def blocks(text):
    """[(language, code)] of the page's fenced blocks, in order."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.S | re.M)]


def promised(text):
    """The lines the page's python blocks say they print (`print(...)  # TEXT`), in order."""
    out = []
    for lang, code in blocks(text):
        if lang == "python":
            out += [m.group(1).strip() for m in re.finditer(r"^\s*print\(.*\)\s+# (.+)$", code, re.M)]
    return out


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


def test_the_pages_have_the_sections_the_issue_asks_for():
    qs, blocking, core = (open(p).read() for p in PAGES)
    assert [lang for lang, _ in blocks(qs)].count("python") >= 6 and "sh" in [lang for lang, _ in blocks(qs)]
    for words in ("Open a node on a modem", "lifespan and a priority", "receive", "Range", "file through the transport",
                  "CADDY diver status", "acomm emulate", "from the command line", "asyncio.run"):
        assert words in qs, words
    for words in ("Node.open", "send_and_wait", "receive(timeout_s)", "close()"):
        assert words in blocking, words
    for words in ("node.step()", "listen", "simulated ocean", "board"):
        assert words in core, words
    # each page names the others, so a reader finds the form they need
    assert "quickstart-blocking.md" in qs and "core-loop.md" in qs and "quickstart.md" in blocking


@pytest.mark.parametrize("page", PAGES, ids=[os.path.basename(p) for p in PAGES])
def test_every_block_of_the_page_runs(tmp_path, page):
    _acomm_on_path(tmp_path)
    place = str(tmp_path / "qs")
    text = open(page).read().replace(PLACE, place)
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
                    exec(compile(code, "%s block %d" % (page, i + 1), "exec"), ns)
            else:
                assert lang == "text", "block %d: %r is neither sh, python nor text" % (i + 1, lang)
    finally:
        for p in background:
            p.send_signal(signal.SIGTERM)
            p.wait(10)
            p.stdout.close()
    printed = out.getvalue().splitlines()
    want = promised(text)
    assert len(want) >= 5, want
    at = 0
    for w in want:
        assert w in printed[at:], (w, printed)
        at = printed.index(w, at) + 1


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
