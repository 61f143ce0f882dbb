# A board's entry point: boards/<name>/main.py calls start(CONFIG).
#
# Checks the configuration first (a wrong field stops here, named), then
# opens the board's UARTs with machine.UART, the packet store on the flash
# filesystem, and the watchdog when configured, builds the node
# (acomm_mp.assemble) and runs it on asyncio for ever. Everything that
# touches `machine` is here, so the rest of the port runs in tests.

import os
import time

from acomm.compat import ticks_ms
from acomm.store import Store

from . import release
from .assemble import build
from .uartstream import UartStream


def open_uart(machine, lk):
    kw = {"baudrate": lk["baud"], "timeout": 0}
    if lk["tx"] is not None:
        kw["tx"] = machine.Pin(lk["tx"])
    if lk["rx"] is not None:
        kw["rx"] = machine.Pin(lk["rx"])
    try:
        # a receive ring sized for the line (acomm_mp.boardconfig): a
        # SeaTrac status burst arrives while the loop is busy elsewhere
        u = machine.UART(lk["uart"], rxbuf=lk["rxbuf"], **kw)
    except (TypeError, ValueError):
        u = machine.UART(lk["uart"], **kw)
    return UartStream(u)


def _makedirs(path):
    # the store's folder on the flash filesystem (os has no makedirs here)
    parts = path.split("/")[:-1]
    at = ""
    for p in parts:
        if not p:
            continue
        at += "/" + p
        try:
            os.mkdir(at)
        except OSError:
            pass  # already there


def open_store(st):
    _makedirs(st["path"])
    return Store(st["path"], capacity_bytes=st["capacity"], max_record=st["max_record"])


def start(config, make_report=None, machine=None):
    from .boardconfig import check

    cfg = check(config)
    check = None
    release("acomm_mp.boardconfig")  # needed once: 1.4 KiB back to the heap
    if machine is None:
        import machine
    board = build(cfg, lambda lk: open_uart(machine, lk), ticks_ms, lambda: int(time.time()), open_store,
                  make_report=make_report)
    if cfg["watchdog_ms"] and hasattr(machine, "WDT"):
        board.wdt = machine.WDT(timeout=cfg["watchdog_ms"])
    import asyncio

    from .runloop import run

    print("acomm %s: node %d, links %s" % (cfg["name"], cfg["node_id"], ", ".join(board.node.links)))
    asyncio.run(run(board))
