# A board's entry point: boards/<name>/main.py calls start("config").
#
# acomm_mp.boot checks the configuration, opens the UARTs and the store and
# builds the node; that module is then released (needed once). start() arms
# the watchdog when configured, prints the ready line with the heap left
# free, and runs the node for ever in a plain loop
# (acomm_mp.runloop.run_blocking), or beside the browser console.

import gc
import time

from acomm.compat import const

from . import release

# The wall clock's epoch on a board: 2020-01-01. time.time() counts from
# 1970 and is past 2**30 (from 2004), a big integer on a 32-bit board: each
# packet's expiry took 32 B of heap more. From 2020 it stays a small integer
# until 2054. A clock never set reads earlier (a Pico's starts at 2021, an
# ESP32's at 2000, the qemu board's at 1970): those seconds are used as
# they are, small and never negative. The node's wall clock
# (acomm.wallclock, built in acomm_mp.assemble) starts from this, no
# earlier than the last good time it wrote beside the store, and is set
# from the sky (Iridium AT-MSSTM, a GPS); it never goes back. Expiries are
# this node's own (a relay is told the lifespan left), so only a store
# written with 1970's epoch sees its packets live on until they are
# delivered.
_EPOCH = const(1577836800)


def wall():
    """Seconds by the board's clock, counted from 2020-01-01 once it is set: the transport's lifespans."""
    t = int(time.time())
    return t - _EPOCH if t >= _EPOCH else t


def _boot(config, machine, make_report):
    # in a frame of its own, which ends before the loop starts: the
    # collector scans a running function's whole value stack, and a stale
    # slot holding the boot module would keep it alive for ever
    from . import boot

    cfg = boot.load_config(config)
    board = boot.build_board(cfg, machine, wall, make_report)
    boot = None
    release("acomm_mp.boot")
    return cfg, board


def start(config, make_report=None, machine=None):
    """Runs the board for ever. config: the name of the config module (normally "config") or its CONFIG dict."""
    if machine is None:
        import machine
    cfg, board = _boot(config, machine, make_report)
    if cfg["watchdog_ms"] and hasattr(machine, "WDT"):
        board.wdt = machine.WDT(timeout=cfg["watchdog_ms"])
    # the heap the board's own code is left with, counted after a collection
    # (the build's garbage gone): what an operator checks at the console
    gc.collect()
    free = getattr(gc, "mem_free", None)
    print("acomm %s: node %d, links %s%s" % (cfg["name"], cfg["node_id"], ", ".join(board.node.links),
                                            "; %d B heap free" % free() if free else ""))
    if cfg.get("web") is not None:
        # the console runs the node in asyncio beside its server; imported
        # by a name the flash closure does not follow: a board gets
        # acomm_web only when its config has `web` (boardfiles.modules)
        mod = "acomm_web.board"
        __import__(mod, None, None, ("serve",)).serve(board, cfg["web"])
        return
    from .runloop import run_blocking

    run_blocking(board)
