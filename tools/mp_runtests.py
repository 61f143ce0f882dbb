# Runs acomm's core tests on the MicroPython unix port (and on CPython, for a
# sanity check): imports every tests/core/test_*.py, calls each test_*
# function, and prints "micropython: N passed, N failed". Exit status 1 when
# anything failed. MicroPython's unix build from PyPI has no unittest, and
# the tests use plain asserts, so this is all the runner it needs.
#
#   micropython tools/mp_runtests.py [tests/core] [-k substring]

import gc
import os
import sys

try:
    import time

    _ms = time.ticks_ms
    _diff = time.ticks_diff
except AttributeError:
    _ms = lambda: int(time.monotonic() * 1000)  # noqa: E731
    _diff = lambda a, b: a - b  # noqa: E731


def _here():
    f = __file__
    i = f.rfind("/")
    return f[:i] if i >= 0 else "."


def _print_exc(e):
    if hasattr(sys, "print_exception"):
        sys.print_exception(e)
    else:
        import traceback

        traceback.print_exception(type(e), e, e.__traceback__)


def main(argv):
    root = _here() + "/.."
    dirs = []
    pattern = None
    frozen = False
    impl = sys.implementation.name
    i = 0
    while i < len(argv):
        if argv[i] == "-k":
            pattern = argv[i + 1]
            i += 2
            continue
        if argv[i] == "--name":
            impl = argv[i + 1]
            i += 2
            continue
        if argv[i] == "--frozen":
            frozen = True
            i += 1
            continue
        dirs.append(argv[i])
        i += 1
    if not dirs:
        dirs = [root + "/tests/core"]
    if frozen:
        # after the frozen modules: acomm and acomm_mp are the firmware's
        at = sys.path.index(".frozen") + 1 if ".frozen" in sys.path else len(sys.path)
        sys.path.insert(at, root + "/ports/sim")
        import acomm
        import acomm_mp

        where = (acomm.__file__, acomm_mp.__file__)
        if where != ("acomm/__init__.py", "acomm_mp/__init__.py"):
            print("%s: acomm is not frozen here: %s %s" % (impl, where[0], where[1]))
            print("%s: 0 passed, 1 failed" % impl)
            return 1
        del acomm, acomm_mp
        sys.modules.pop("acomm", None)
        sys.modules.pop("acomm_mp", None)
    else:
        # the core, the simulator's portable emulators (driver tests use
        # them) and the MicroPython port (its board assembly runs in the
        # simulator)
        for p in (root + "/ports/micropython", root + "/ports/sim", root):
            if p not in sys.path:
                sys.path.insert(0, p)
        at = 0
    passed = failed = skipped = 0
    failures = []
    for d in dirs:
        sys.path.insert(at, d)
        names = sorted(n for n in os.listdir(d) if n.startswith("test_") and n.endswith(".py"))
        for fname in names:
            modname = fname[:-3]
            before = set(sys.modules)
            try:
                mod = __import__(modname)
            except Exception as e:
                print("ERROR importing", modname)
                _print_exc(e)
                failed += 1
                failures.append(modname)
                continue
            for name in sorted(dir(mod)):
                if not name.startswith("test_"):
                    continue
                if pattern and pattern not in modname + "." + name:
                    continue
                fn = getattr(mod, name)
                if not callable(fn):
                    continue
                t0 = _ms()
                try:
                    fn()
                except Exception as e:
                    if type(e).__name__ == "Skip":  # checks.skip: cannot run here
                        skipped += 1
                        print("skip", modname + "." + name + ":", e)
                        continue
                    failed += 1
                    failures.append(modname + "." + name)
                    print("FAIL", modname + "." + name)
                    _print_exc(e)
                    continue
                passed += 1
                dt = _diff(_ms(), t0)
                if dt > 2000:
                    print("slow", modname + "." + name, dt, "ms")
            # Drop each test module, and every module it imported, once it
            # has run, and collect: the unix port's heap is 2 MB, and tests
            # that need large blocks (the queue flood) must not depend on
            # how many modules (drivers, emulators) ran before.
            mod = fn = None
            for m in list(sys.modules):
                if m not in before:
                    sys.modules.pop(m, None)
            gc.collect()
        sys.path.pop(at)
    for f in failures:
        print("FAILED", f)
    print("%s: %d passed, %d failed%s" % (impl, passed, failed, ", %d skipped" % skipped if skipped else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
