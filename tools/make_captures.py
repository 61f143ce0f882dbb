# Rewrites the capture fixtures that `acomm replay` is tested on
# (tests/cpython/fixtures/captures/<modem>.jsonl) from the sessions of
# acomm_cpython.emulate.capture_sessions. Run after a change to a driver or an
# emulator that changes what goes over the line, and look at the diff.
#
#   .venv/bin/python tools/make_captures.py [modem ...]

import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
for p in ("ports/sim", "ports/cpython", "."):
    sys.path.insert(0, os.path.join(ROOT, p))

from acomm_cpython.emulate.capture_sessions import MODEMS, write_fixture  # noqa: E402

DIR = os.path.join(ROOT, "tests", "cpython", "fixtures", "captures")


def main(argv):
    for modem in argv or MODEMS:
        path = os.path.join(DIR, modem + ".jsonl")
        events = write_fixture(modem, path)
        print("%s: %d events -> %s" % (modem, len(events), os.path.relpath(path, ROOT)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
