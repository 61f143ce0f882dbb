# acomm's MicroPython port: a board's node built from its configuration
# (boards/<name>/config.py), machine.UART byte streams, the flash store,
# the watchdog and the main loop. Everything here also imports on CPython,
# where the tests drive it with fake UARTs and a virtual clock.


def release(name):
    # Forget a module needed only once (at boot, the config checker), so
    # its functions and tables go back to the heap: on a 64 KiB board that
    # is 2 % of it. Importing it again loads it again.
    import sys

    sys.modules.pop(name, None)
    pkg, _, leaf = name.rpartition(".")
    parent = sys.modules.get(pkg)
    if parent is not None and leaf in parent.__dict__:
        delattr(parent, leaf)


def release_builder():
    # After acomm_mp.assemble.build: the builder, the modem registry and the
    # config checker are needed once; the caller drops its reference to
    # build() first. The checker too: start() releases it once the config is
    # checked, but importing the builder (for its ConfigError) loads it
    # again, and it stayed for ever, 6.1 KB of the buoy's heap from .mpy
    release("acomm_mp.assemble")
    release("acomm_mp.boardconfig")
    release("acomm.drivers.registry")
