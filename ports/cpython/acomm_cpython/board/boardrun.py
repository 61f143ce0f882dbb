# `acomm run boards/NAME --uart UART1=/dev/ttyUSB0`: a board's program on
# CPython, with serial ports in place of machine.UART.
#
# The board's config.py is checked as `acomm flash` checks it (a wrong field
# is named), its main.py runs up to its start(...) call, which is caught
# here so that what main.py hands to start (the config module's name, the
# station's make_report) is the board's own, and the node is then built by
# the same assembly as on the board (acomm_mp.assemble.build). Each UART the
# config names is opened as the pyserial port given for it; the console,
# --json, --log and --store are those of `acomm node`.
#
# Left as on the board: the node, its links, drivers, transport, routes,
# station and console (a `web` field; --web serves it elsewhere, or on a
# board without the field). Different: no watchdog (a laptop has none), the store is in RAM
# unless --store DIR (the config's flash path means nothing here), and the
# loop is the console's.

import os
import sys
import types

from .boardfiles import FlashError, board_path


class _Started(Exception):
    def __init__(self, config, make_report):
        Exception.__init__(self)
        self.config = config
        self.make_report = make_report


def board_dir(arg, boards=None):
    """The folder of the board named by arg: a path when it is a folder, else a name under --boards."""
    if os.path.isdir(arg) or os.sep in arg or "/" in arg:
        return arg
    return board_path(arg, boards)


def main_program(bdir):
    """Runs the board's main.py up to its start() call -> (config name or dict, make_report).

    FlashError (status 2) when main.py fails or never calls start()."""
    path = os.path.join(bdir, "main.py")
    shim = types.ModuleType("acomm_mp.start")

    def start(config, make_report=None, machine=None):
        raise _Started(config, make_report)

    shim.start = start
    saved = sys.modules.get("acomm_mp.start")
    sys.modules["acomm_mp.start"] = shim
    # as on the board, the board's own files import by name (import config)
    sys.path.insert(0, os.path.abspath(bdir))
    try:
        with open(path) as f:
            code = compile(f.read(), path, "exec")
        exec(code, {"__name__": "__main__", "__file__": path})
    except _Started as s:
        return s.config, s.make_report
    except Exception as e:  # noqa: BLE001 - any error in the file is the board's problem
        raise FlashError("board %s: %s does not run: %s: %s" % (os.path.basename(os.path.normpath(bdir)), path,
                                                               type(e).__name__, e), 2)
    finally:
        sys.path.remove(os.path.abspath(bdir))
        sys.modules.pop("config", None)
        if saved is not None:
            sys.modules["acomm_mp.start"] = saved
        else:
            sys.modules.pop("acomm_mp.start", None)
    raise FlashError("board %s: %s never calls start()" % (os.path.basename(os.path.normpath(bdir)), path), 2)


def uart_map(cfg, specs, board):
    """{uart number: (device, baud)} from --uart UARTn=DEVICE[:BAUD]; FlashError (2) names a UART the board lacks."""
    used = sorted(set(lk["uart"] for lk in cfg["links"]))
    names = ", ".join("UART%d" % u for u in used)
    out = {}
    for spec in specs:
        name, sep, where = spec.partition("=")
        n = name.upper()[4:] if name.upper().startswith("UART") else ""
        if not sep or not where or not n.isdigit():
            raise FlashError("--uart %r: give UARTn=DEVICE[:BAUD], e.g. UART%d=/dev/ttyUSB0" % (spec, used[0]), 2)
        if int(n) not in used:
            raise FlashError("--uart %s: board %s does not use %s (it uses %s)" % (spec, board, name, names), 2)
        dev, _, baud = where.rpartition(":")
        if baud.isdigit() and "://" not in where:
            out[int(n)] = (dev, int(baud))
        else:
            out[int(n)] = (where, None)
    for lk in cfg["links"]:
        if lk["uart"] not in out:
            raise FlashError("board %s: give --uart UART%d=DEVICE for its %s link (%s)" % (board, lk["uart"],
                                                                                     lk["name"], lk["modem"]), 2)
    return out
