# The real-time loop of a node with a console (`acomm node`, `acomm run`):
# wait for every modem's start-up, then step the node and read console
# lines from standard input until the end of input, --seconds, Ctrl-C or
# SIGTERM. On the way out every stream and the store are closed, so a
# persistent store is left as the last synced record left it.
#
# Standard input is read with os.read on its descriptor, not readline():
# several lines that arrive at once would otherwise sit in Python's buffer
# where select() cannot see them.

import os
import select
import signal
import time

from ..modems import ModemError, interrupt

_MAX_LINE = 4096
_STEP_S = 0.005


class LineReader:
    """Whole lines from a file descriptor without blocking; None at the end of input."""

    def __init__(self, fd):
        self.fd = fd
        self.buf = b""
        self.eof = False

    def lines(self, wait_s):
        """The lines complete within wait_s seconds (a list, maybe empty)."""
        if self.eof or not select.select([self.fd], [], [], wait_s)[0]:
            return []
        try:
            data = os.read(self.fd, 4096)
        except OSError:
            data = b""
        if not data:
            self.eof = True
            rest, self.buf = self.buf, b""
            return [rest.decode("utf-8", "replace")] if rest.strip() else []
        self.buf += data
        *done, self.buf = self.buf.split(b"\n")
        if len(self.buf) > _MAX_LINE:
            self.buf = b""  # a line with no end: dropped rather than kept for ever
        return [ln.decode("utf-8", "replace") for ln in done]


def wait_started(tick, watches, out, timeout_s):
    """Steps until every modem said it is up; ModemError names the first that did not in time.

    watches: [(link name, kind, where, modems.StartWatch)]."""
    shown = set()
    end = time.monotonic() + timeout_s
    while True:
        tick()
        for name, kind, where, w in watches:
            if w.up and name not in shown:
                shown.add(name)
                out.emit({"event": "link_up", "link": name, "kind": kind, "where": where})
        if len(shown) == len(watches):
            return
        if time.monotonic() >= end:
            late = [w for w in watches if w[0] not in shown][0]
            raise ModemError("the %s modem on %s did not answer its start-up within %g s" % (late[1], late[2],
                                                                                             timeout_s))
        time.sleep(_STEP_S)


def serve(tick, console, stdin_fd, seconds=None, poll=None, stop_at_eof=True):
    """Runs until the end of input (when stop_at_eof), `seconds`, Ctrl-C or SIGTERM; returns 0.

    tick(): one round of the node; poll(): called after it (the --send
    list); console lines go to console.command(). At the end of input
    (without `seconds`) it first waits for what the console asked for to
    end (console.open: each ends by its lifespan at the latest), so a
    script piping commands in gets their outcome."""
    old = signal.signal(signal.SIGTERM, interrupt)
    reader = LineReader(stdin_fd) if stdin_fd is not None else None
    end = None if seconds is None else time.monotonic() + seconds
    draining = False
    reported = set()
    try:
        while end is None or time.monotonic() < end:
            try:
                tick()
            except Exception as e:  # noqa: BLE001 - as on a board: the node keeps running, the store holds
                kind = type(e).__name__
                if kind not in reported:  # once per kind: a fault that repeats every step must not flood
                    reported.add(kind)
                    console.error("during a step: %s: %s (carrying on)" % (kind, e))
            console.poll()
            if poll is not None:
                poll()
            if reader is None or reader.eof:
                time.sleep(_STEP_S)
                if reader is not None and stop_at_eof and end is None and not console.open:
                    break
                continue
            for line in reader.lines(_STEP_S):
                console.command(line)
            if reader.eof and stop_at_eof and end is None:
                if not console.open:
                    break
                if not draining:
                    draining = True
                    console.out.emit({"event": "draining", "open": len(console.open)})
    except KeyboardInterrupt:
        pass
    finally:
        signal.signal(signal.SIGTERM, old)
    return 0


def describe(e):
    """One line for an error that ends a command: an OSError names its file and cause."""
    if isinstance(e, OSError) and e.strerror:
        return "%s: %s" % (e.filename, e.strerror) if e.filename else e.strerror
    return str(e)


def add_console_arguments(p):
    """The options `acomm node` and `acomm run` share: output, log, store, timing."""
    p.add_argument("--json", action="store_true", help="print events and answers as JSON lines (for scripts)")
    p.add_argument("--log", metavar="FILE", help="append every event to FILE as JSON lines, with its time")
    p.add_argument("--store", metavar="DIR", help="keep the transport's packets in DIR (persistent; default: RAM)")
    p.add_argument("--inbox", metavar="DIR", help="save each whole packet (file) that arrives in DIR")
    p.add_argument("--lifespan", type=float, default=30.0, metavar="S", help="lifespan of what is sent (default 30)")
    p.add_argument("--seconds", type=float, help="stop after this long (default: at the end of standard input)")
    p.add_argument("--startup-timeout", type=float, default=15.0, metavar="S",
                   help="seconds a modem has to answer its start-up (default 15)")
    p.add_argument("--web", metavar="[HOST:]PORT", help="serve the operator console in a browser here "
                   "(loopback unless a HOST is given; needs the web extra; docs/console.md)")
    p.add_argument("--web-password-file", metavar="PATH",
                   help="the console's login password, in a file only its owner reads")


class WebError(Exception):
    """--web cannot be served: status 2 (usage: a bad address, no microdot, a bad password file) or 1."""

    def __init__(self, message, status):
        Exception.__init__(self, message)
        self.status = status


def start_web(args, node, out, password=None):
    """--web: the operator console (acomm_web) served beside the node -> (WebHost, tick wrapper) or (None, None).

    The node's listener is teed to the console's state; wrap the loop's
    tick with the returned function so that the node steps under the lock
    the server takes. WebError when it cannot be served."""
    if not getattr(args, "web", None):
        if getattr(args, "web_password_file", None):
            raise WebError("--web-password-file goes with --web", 2)
        return None, None
    try:
        from acomm.apps.console import ConsoleState
        from acomm_web.host import WebHost, parse_web, read_password, tee
    except ImportError as e:
        raise WebError("--web needs microdot: pip install 'acomm[web]' (%s)" % e, 2)
    from acomm.errors import AcommError

    try:
        host, port = parse_web(args.web)
        pw = read_password(args.web_password_file) if args.web_password_file else password
    except (ValueError, AcommError) as e:
        raise WebError("--web: %s" % e, 2)
    state = ConsoleState(node, lifespan_s=args.lifespan)
    tee(node, state)
    try:
        web = WebHost(state, host, port, pw, out).start()
    except OSError as e:
        raise WebError("--web %s: %s" % (args.web, e.strerror or e), 1)
    out.emit({"event": "web", "url": web.url})

    def wrap(f):
        def locked(*a):
            with web.lock:
                r = f(*a)
                state.poll(node.clock())
            return r

        return locked

    return web, wrap


def with_web(args, node, out, console, tick, closers, password=None):
    """--web beside the typed-line console: the server joins closers, and the loop's tick and the
    console's command and poll run one at a time under its lock -> the tick to run."""
    web, wrap = start_web(args, node, out, password)
    if web is None:
        return tick
    closers.append(web)
    console.command = wrap(console.command)
    console.poll = wrap(console.poll)
    return wrap(tick)


def open_log(path):
    """The --log file, appended to; OSError when it cannot be opened."""
    return open(path, "a") if path else None
