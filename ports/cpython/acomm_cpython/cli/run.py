# `acomm run boards/NAME --uart UART1=/dev/ttyUSB0`: the front end of
# acomm_cpython.board.boardrun (a board's program on CPython, serial ports in
# place of machine.UART) on the node's console (acomm_cpython.console).
import os
import sys
import time

from acomm.compat import ticks_ms

from ..board.boardfiles import FlashError, load_config
from ..board.boardrun import board_dir, main_program, uart_map
from ..console import nodeloop


def add_arguments(p):
    p.add_argument("board", help="a board folder (boards/NAME, or any folder with config.py and main.py) or a "
                                 "board name")
    p.add_argument("--boards", metavar="DIR", help="folder of boards for a board given by name (default: the "
                                                   "boards shipped with acomm)")
    p.add_argument("--uart", action="append", default=[], metavar="UARTn=DEVICE[:BAUD]",
                   help="the serial port (or tcp://, socket:// URL) for the board's UART n; one per UART it uses")
    nodeloop.add_console_arguments(p)


def main(args):
    """`acomm run`: 0 at the end, 2 for a usage or board error, 1 when a port cannot be opened or started."""
    from acomm.errors import AcommError
    from acomm_mp.assemble import build
    from acomm_mp.boardconfig import ConfigError

    from ..console.console import Console
    from ..console.eventlines import Output
    from ..modems import ModemError, StartWatch, open_store, open_stream

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
        return nodeloop.session("acomm run", args, node, out, console, tick, watches, streams, closers,
                                password=w["password"] if w is not None else None)
    except ConfigError as e:
        print("acomm run: board %s: %s" % (name, e), file=sys.stderr)
        return 2
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
