# What a board does once, at power-up (acomm_mp.start calls it): check the
# configuration (a wrong field stops here, named), open the board's UARTs
# with machine.UART and the packet store on its flash filesystem, and build
# the node (acomm_mp.assemble). Everything that touches `machine` but the
# watchdog is here, so the rest of the port runs in tests.
#
# Needed once: start() releases this module before its loop starts, so the
# code goes back to the heap (about 1 KB of the buoy's from .mpy files).
# Nothing the node keeps may come from here: the wall clock start() passes
# in is its own function, not a lambda of this module's.
#
# Given the config module's name rather than its CONFIG, load_config() lets
# the module go once the checked copy is made: the two copies would
# otherwise both stay on the heap for ever (1.3 KiB for the buoy).

import os

from acomm.compat import ticks_ms
from acomm.transport.store import Store

from . import release, release_builder
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
    except Exception:  # a port without rxbuf= (TypeError or ValueError); a bad UART fails again below
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
        except OSError as e:
            try:
                mode = os.stat(at)[0]  # already there
            except OSError:
                raise e  # not made: its own error (a full flash) says why
            if not mode & 0x4000:
                raise e  # a file where the folder goes: the store cannot be made


def open_store(st, say=print):
    try:
        _makedirs(st["path"])
        return Store(st["path"], capacity_bytes=st["capacity"], max_record=st["max_record"])
    # the folder's OSError, the store's StoreError (its path and why). Exception, which open_uart
    # names too: a name new to this module cost the ROMFS board 768 B of heap_min (measured)
    except Exception as e:
        # A flash that cannot hold the store (full before the store was
        # ever made, or failing) must not stop the board at boot: main.py
        # would end at the REPL with no node and no watchdog, at every
        # power-up. The node runs on a store that takes nothing: packets
        # for this board are still delivered (they are never stored), but
        # a packet to relay is refused ("receiver full"), so nothing is
        # acknowledged that a reset would lose.
        from acomm.transport.memorystore import MemoryStore

        say("acomm: no store at %s (%s %s): relaying nothing" % (st["path"], type(e).__name__, e))
        return MemoryStore(capacity_bytes=0, max_record=st["max_record"])


def load_config(config):
    """The checked config from a dict, or from the module of that name (then released)."""
    from .boardconfig import check

    if isinstance(config, str):
        name = config
        config = __import__(name).CONFIG
        release(name)
    cfg = check(config)
    check = config = None
    release("acomm_mp.boardconfig")  # needed once: 1.4 KiB back to the heap
    return cfg


def build_board(cfg, machine, wall, make_report=None):
    """The board's node from its checked config, on machine's UARTs and the store on flash -> acomm_mp.runloop.Board."""
    from .assemble import build

    board = build(cfg, lambda lk: open_uart(machine, lk), ticks_ms, wall, open_store, make_report=make_report)
    build = None
    release_builder()  # needed once: the builder's code and the modem table go back to the heap
    return board
