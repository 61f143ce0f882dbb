#!/usr/bin/env python3
# The browser of the console's browser test (tests/cpython/
# test_console_browser.py): Debian's chromium, installed with apt-get when
# it is missing and this runs as root (as CI does `make test`); never a
# browser downloaded at run time (no `playwright install`).
#
#   python tools/browser.py      prints "browser: /usr/bin/chromium" and
#                                exits 0, or says what is missing, exit 3
import os
import shutil
import subprocess
import sys

PACKAGE = "chromium"
NAMES = ("chromium", "chromium-browser")


def find():
    """The path of the system's Chromium, or None."""
    for n in NAMES:
        p = shutil.which(n)
        if p:
            return p
    return None


def ensure():
    """-> the browser's path, installing Debian's chromium when root can; None (and why, printed) otherwise."""
    p = find()
    if p:
        return p
    if not (hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get")):
        print("browser: chromium missing: run 'apt-get install chromium' as root for the console's browser test")
        return None
    print("browser: installing %s" % PACKAGE, flush=True)
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    cmd = ["apt-get", "install", "-y", "-q", "--no-install-recommends", PACKAGE]
    if subprocess.run(cmd, env=env, capture_output=True).returncode != 0:
        subprocess.run(["apt-get", "update", "-q"], env=env, capture_output=True)
        r = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if r.returncode != 0:
            print("browser: apt-get install %s failed: %s" % (PACKAGE, (r.stderr.strip().splitlines() or ["?"])[-1]))
            return None
    return find()


if __name__ == "__main__":
    path = ensure()
    if path:
        print("browser: %s" % path)
    sys.exit(0 if path else 3)
