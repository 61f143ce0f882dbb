# Modules on a board's path keep acomm.events' codes as private constants
# (`_EV_RX = const(1)`): MicroPython inlines them and they cost no RAM,
# where `from .events import EV_RX` took a slot in the module's dict on the
# board's heap. The values are copies, so this checks every copy against
# acomm.events, the one source: a renumbered code cannot drift.
import os
import re

import acomm.events as events

ROOT = os.path.join(os.path.dirname(__file__), "..", "..", "acomm")
PRIVATE = re.compile(r"^_([A-Z][A-Z0-9_]*) = const\((.+?)\)", re.M)


def _copies():
    for folder, _, files in os.walk(ROOT):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                with open(path) as fh:
                    for name, value in PRIVATE.findall(fh.read()):
                        if hasattr(events, name) and not path.endswith("events.py"):
                            yield os.path.relpath(path, ROOT), name, value


def test_every_private_copy_of_an_event_code_is_the_events_value():
    found = list(_copies())
    assert len(found) > 40  # the link alone keeps 24
    wrong = ["%s: _%s = %s, acomm.events has %r" % (p, n, v, getattr(events, n))
             for p, n, v in found if int(v, 0) != getattr(events, n)]
    assert not wrong, "\n".join(wrong)


def test_the_check_sees_a_wrong_copy(tmp_path):
    # the pattern must catch a copy that drifted, as it is written
    src = "_EV_RX = const(%d)\n" % (events.EV_RX + 1)
    (name, value), = PRIVATE.findall(src)
    assert name == "EV_RX" and int(value, 0) != events.EV_RX
