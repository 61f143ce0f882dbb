# Modules on a board's path keep the codes of a few source modules as
# private constants (`_EV_RX = const(1)`, `_CID_DAT_SEND = const(0x60)`):
# MicroPython inlines them and they cost no RAM, where a public name took a
# slot in a module's dict and an entry in the string pool on the board's
# heap. The values are copies, so this checks every copy against its one
# source: a renumbered code cannot drift.
#   acomm.events                  its copies anywhere in acomm/ (but where a
#                                 file copies the same name from a module below)
#   acomm.drivers.seatrac_codes   its copies in the SeaTrac driver's modules
#   the modules in SCOPED         their copies in the files named there
import importlib
import os
import re

import acomm.drivers.seatrac_codes as seatrac_codes
import acomm.events as events

ROOT = os.path.join(os.path.dirname(__file__), "..", "..", "acomm")
PRIVATE = re.compile(r"^_([A-Z][A-Z0-9_]*) = const\((.+?)\)", re.M)
# source module -> (the files that copy from it, the public names they copy)
SCOPED = {
    "acomm.drivers.base": (("drivers/seatrac.py", "drivers/seatrac_sequences.py", "drivers/iridium.py",
                            "drivers/atdriver.py"), ("IDLE", "QUEUED", "S_START", "S_CONFIG", "S_UP")),
    "acomm.drivers.caps": (("drivers/seatrac.py", "link/__init__.py", "link/ranging.py", "transport/__init__.py"),
                           ("CAP_ADDRESSING", "CAP_BROADCAST", "CAP_DISCOVERY", "CAP_RANGING", "CAP_RELIABLE",
                            "CAP_DELIVERY")),
    "acomm.drivers.atcommand": (("drivers/iridium.py", "drivers/atdriver.py"), ("R_OK", "R_END", "R_TIMEOUT")),
    "acomm.drivers.seatrac_sequences": (("drivers/seatrac.py",), ("CMD", "K_DAT", "K_PING")),
    "acomm.link.txqueue": (("link/__init__.py", "link/ranging.py", "transport/__init__.py"), ("MAX_LIFESPAN_MS",)),
    "acomm.frame": (("transport/__init__.py",), ("SEGMENT",)),
    "acomm.transport.packetstore": (("transport/__init__.py",), ("DONE_MEMORY",)),
    "acomm.transport.delivery": (("transport/__init__.py",), ("REPORTS_ACK", "REPORT_COMPLETE", "REPORT_NEW_ROUND",
                                                          "REPORT_REPOLL")),
    "acomm.drivers.evologics": (("link/__init__.py",), ("MAX_AWAITING",)),
}
# the same for copies of a module's private constants (attributes on CPython)
PRIVATE_SCOPED = {
    "acomm.link": (("link/ranging.py",), ("IDLE", "SENDING", "K_PING")),  # the Link's slot
    "acomm.transport.packetstore": (("transport/memorystore.py",), ("REC_OVERHEAD",)),  # a record's overhead
    "acomm.transport.segment": (("transport/__init__.py",), ("K_SACK",)),  # the SACK bit of an overheard header
}
_CLAIMED = {(f, n) for files, names in SCOPED.values() for f in files for n in names}
SOURCES = (
    (events, "events.py", lambda rel: True),
    (seatrac_codes, os.path.join("drivers", "seatrac_codes.py"),
     lambda rel: os.path.basename(rel).startswith("seatrac")),
)


def _copies(source, own, scope):
    for folder, _, files in os.walk(ROOT):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                rel = os.path.relpath(path, ROOT)
                if rel == own or not scope(rel):
                    continue
                with open(path) as fh:
                    for name, value in PRIVATE.findall(fh.read()):
                        if hasattr(source, name) and not (source is events and (rel, name) in _CLAIMED):
                            yield rel, name, value


def _wrong(source, found):
    return ["%s: _%s = %s, %s has %r" % (p, n, v, source.__name__, getattr(source, n))
            for p, n, v in found if int(v, 0) != getattr(source, n)]


def test_every_private_copy_of_an_event_code_is_the_events_value():
    found = list(_copies(*SOURCES[0]))
    assert len(found) > 40  # the link alone keeps 24
    wrong = _wrong(events, found)
    assert not wrong, "\n".join(wrong)


def test_every_private_copy_of_a_seatrac_code_is_seatrac_codes_value():
    found = list(_copies(*SOURCES[1]))
    assert len(found) > 40  # the driver, its sequences and its wire module
    assert {p for p, _, _ in found} == {os.path.join("drivers", f) for f in
                                       ("seatrac.py", "seatrac_sequences.py", "seatrac_wire.py")}
    wrong = _wrong(seatrac_codes, found)
    assert not wrong, "\n".join(wrong)


def _scoped(table, prefix=""):
    # -> ({(file, name) copied}, [what is wrong]) for a SCOPED-like table;
    # prefix: "_" when the source's own constants are private
    seen, wrong = set(), []
    for modname, (files, names) in table.items():
        source = importlib.import_module(modname)
        for f in files:
            with open(os.path.join(ROOT, f)) as fh:
                copies = dict(PRIVATE.findall(fh.read()))
            for n in names:
                if n in copies:
                    seen.add((f, n))
                    if int(copies[n], 0) != getattr(source, prefix + n):
                        wrong.append("%s: _%s = %s, %s has %r" % (f, n, copies[n], modname, getattr(source, prefix + n)))
    return seen, wrong


def test_every_private_copy_of_a_lower_modules_code_is_its_value():
    seen, wrong = _scoped(SCOPED)
    assert not wrong, "\n".join(wrong)
    assert len(seen) >= 25  # the drivers', the link's and the transport's copies


def test_copies_of_another_modules_private_constants_are_its_values():
    # acomm.link.ranging works on the Link's transmission slot: its states
    # and kinds are the Link's private constants; the RAM store counts a
    # record as packetstore does
    seen, wrong = _scoped(PRIVATE_SCOPED, "_")
    assert {n for f, n in seen if f == "link/ranging.py"} >= {"IDLE", "SENDING", "K_PING"}
    assert ("transport/memorystore.py", "REC_OVERHEAD") in seen
    assert ("transport/__init__.py", "K_SACK") in seen
    assert not wrong, wrong


def test_no_module_of_the_seatrac_driver_keeps_a_public_copy():
    # a public `CID_X = const(...)` in the driver's modules would put the
    # name back on a board's heap (and be a second source)
    for f in ("seatrac.py", "seatrac_sequences.py", "seatrac_wire.py"):
        with open(os.path.join(ROOT, "drivers", f)) as fh:
            text = fh.read()
        public = [n for n in re.findall(r"^([A-Z][A-Z0-9_]*) = const", text, re.M) if hasattr(seatrac_codes, n)]
        assert not public, (f, public)


def test_the_check_sees_a_wrong_copy(tmp_path):
    # the pattern must catch a copy that drifted, as it is written
    src = "_EV_RX = const(%d)\n" % (events.EV_RX + 1)
    (name, value), = PRIVATE.findall(src)
    assert name == "EV_RX" and int(value, 0) != events.EV_RX
    assert _wrong(events, [("x.py", name, value)])
