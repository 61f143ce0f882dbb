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
import time
import types

from acomm.compat import ticks_ms

from .console import nodeloop
from .boardfiles import FlashError, board_path, load_config


class _Started(Exception):
    def __init__(self, config, make_report):
        Exception.__init__(self)
        self.config = config
        self.make_report = make_report


def add_arguments(p):
    p.add_argument("board", help="a board folder (boards/NAME, or any folder with config.py and main.py) or a "
                                 "board name")
    p.add_argument("--boards", metavar="DIR", help="folder of boards for a board given by name (default: the "
                                                   "boards shipped with acomm)")
    p.add_argument("--uart", action="append", default=[], metavar="UARTn=DEVICE[:BAUD]",
                   help="the serial port (or tcp://, socket:// URL) for the board's UART n; one per UART it uses")
    nodeloop.add_console_arguments(p)


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


def main(args):
    """`acomm run`: 0 at the end, 2 for a usage or board error, 1 when a port cannot be opened or started."""
    from acomm.errors import AcommError
    from acomm_mp.assemble import build
    from acomm_mp.boardconfig import ConfigError

    from .console.console import Console
    from .console.eventlines import Output
    from .modems import ModemError, StartWatch, open_store, open_stream

    bdir = board_dir(args.board, args.boards)
    name = os.path.basename(os.path.normpath(bdir))
    try:
        cfg = load_config(bdir)
        _, make_report = main_program(bdir)
        uarts = uart_map(cfg, args.uart, name)
        log = nodeloop.open_log(args.log)
    except FlashError as e:
        print("acomm run: %s" % e, file=sys.stderr)
        return e.status
    except OSError as e:
        print("acomm run: --log %s: %s" % (args.log, e.strerror or e), file=sys.stderr)
        return 2
    out = Output(sys.stdout, args.json, log)
    streams, wheres = [], {}
    holder = []

    def open_uart(lk):
        dev, baud = uarts[lk["uart"]]
        s = open_stream(lk["modem"], dev, baud or lk["baud"])
        streams.append(s)
        wheres[lk["name"]] = (lk["modem"], dev)
        return s

    closers = []
    store_open = None
    if args.store:
        st = cfg["storage"] or {"capacity": 1 << 22, "max_record": 1024}
        # the config's flash path becomes a file in --store (auth counters beside it)
        cfg["storage"] = dict(st, path=os.path.join(args.store, "acomm.store"))

        def store_open(s):
            return open_store(args.store, s["capacity"], s["max_record"])
    board = None
    try:
        board = build(cfg, open_uart, ticks_ms, lambda: int(time.time()), store_open,
                      listener=lambda ev: holder[0].on_event(ev), say=lambda t: out.emit({"event": "error", "error": t}),
                      make_report=make_report)
        node = board.node
        console = Console(node, board.transport, out, args.lifespan, args.inbox, wheres, board.station)
        holder.append(console)
        watches = [(ln, wheres[ln][0], wheres[ln][1], StartWatch(link.driver)) for ln, link in node.links.items()]

        def tick():
            now = ticks_ms()
            board.tick(now)
            return now

        w = cfg.get("web")
        if w is not None and not args.web:
            # the board's own console field, as on the board
            args.web = "%s:%d" % (w["host"], w["port"])
        tick = nodeloop.with_web(args, node, out, console, tick, closers, w["password"] if w is not None else None)
        nodeloop.wait_started(tick, watches, out, args.startup_timeout, node, streams)
        out.emit({"event": "ready", "node": node.name, "id": node.node_id, "links": list(node.links)})
        nodeloop.serve(tick, console, sys.stdin.fileno(), args.seconds, node=node, ports=streams)
        out.emit({"event": "stopped"})
        return 0
    except ConfigError as e:
        print("acomm run: board %s: %s" % (name, e), file=sys.stderr)
        return 2
    except nodeloop.WebError as e:
        print("acomm run: %s" % e, file=sys.stderr)
        return e.status
    except (ModemError, AcommError, OSError) as e:
        print("acomm run: %s" % nodeloop.describe(e), file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 0
    finally:
        for c in closers:
            c.close()
        for s in streams:
            s.close()
        store = board.transport.store if board is not None else None
        if hasattr(store, "close"):  # a Store on disk (a MemoryStore has nothing to close)
            store.close()
        if log is not None:
            log.close()
