# The device half of tools/board_runtests.py: uploaded to the firmware
# board's filesystem (the Cortex-M3 under qemu, the RP2040 in its emulator;
# as /t/board_device.mpy) and called over the raw REPL, once per test module:
#
#   import board_device; board_device.run("test_crc", 0[, "substring"[, ["test_a", ...]]])
#
# imports the module and calls its test_* functions in sorted order from
# the given index, printing one marker line before and after each so that
# the host can put a time limit on every test and, after a hang, restart
# the board and carry on with the next one:
#
#   @@N <count>              the module's number of tests
#   @@START <i> <name>       before each test
#   @@PASS <i> <name> <ms>   it returned
#   @@SKIP <i> <name> <why>  it cannot run here (checks.skip)
#   @@FAIL <i> <name>        it raised (the traceback follows; a
#                            MemoryError is a failure like any other)
#   @@IMPORT <error>         the module did not import (traceback follows)
#   @@DONE                   every test of the module ran
import gc
import sys
import time


def run(modname, start, pattern=None, only=None):
    gc.collect()
    try:
        mod = __import__(modname)
    except Exception as e:  # noqa: BLE001 - reported to the host, by name
        print("@@IMPORT", repr(e))
        sys.print_exception(e)
        return
    names = sorted(n for n in dir(mod) if n.startswith("test_") and callable(getattr(mod, n)))
    print("@@N", len(names))
    for i in range(start, len(names)):
        name = names[i]
        if pattern and pattern not in modname + "." + name:
            continue
        if only and name not in only:  # a target that runs some of the module's tests
            continue
        gc.collect()
        print("@@START", i, name)
        t0 = time.ticks_ms()
        try:
            getattr(mod, name)()
        except Exception as e:  # noqa: BLE001 - MemoryError included
            if type(e).__name__ == "Skip":  # checks.skip: cannot run here
                print("@@SKIP", i, name, e)
                continue
            print("@@FAIL", i, name)
            sys.print_exception(e)
            continue
        print("@@PASS", i, name, time.ticks_diff(time.ticks_ms(), t0))
    print("@@DONE")
