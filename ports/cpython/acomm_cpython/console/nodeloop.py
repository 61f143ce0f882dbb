# The real-time loop of a node with a console (`acomm node`, `acomm run`):
# wait for every modem's start-up, then run the node and read console
# lines from standard input until the end of input, --seconds, Ctrl-C or
# SIGTERM. On the way out every stream and the store are closed, so a
# persistent store is left as the last synced record left it.
#
# Both run on asyncio with acomm_cpython.ioloop.NodeLoop: the node steps
# when a modem's or a socket's bytes arrive, when a console line asks for
# something, and at its next deadline, so an idle node sleeps (it used to
# step every 5 ms). Standard input is one more reader of the loop, read
# with os.read on its descriptor (several lines arriving at once would
# otherwise sit in Python's buffer where the loop cannot see them). Ctrl-C
# and SIGTERM set a flag through the loop's signal handlers: the loop ends
# between two steps, never inside one.

import asyncio
import os
import signal

from ..ioloop import NodeLoop
from ..modems import ModemError

_MAX_LINE = 4096


class LineReader:
    """Whole lines from the bytes of a descriptor: feed() what os.read gave, b"" at the end."""

    def __init__(self):
        self.buf = b""
        self.eof = False

    def feed(self, data):
        """-> the lines data completes (a list, maybe empty); b"" ends the input (its last line)."""
        if not data:
            self.eof = True
            rest, self.buf = self.buf, b""
            return [rest.decode("utf-8", "replace")] if rest.strip() else []
        self.buf += data
        *done, self.buf = self.buf.split(b"\n")
        if len(self.buf) > _MAX_LINE:
            self.buf = b""  # a line with no end: dropped rather than kept for ever
        return [ln.decode("utf-8", "replace") for ln in done]


class _Stop:
    # the signals that end the loop, set through the loop's own handlers
    def __init__(self, loop):
        self.loop = loop
        self.event = asyncio.Event()
        self.signals = []
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                loop.add_signal_handler(sig, self.event.set)
                self.signals.append(sig)
            except (ValueError, RuntimeError, NotImplementedError):
                pass  # not the main thread: the caller's own handling stands

    def close(self):
        for sig in self.signals:
            self.loop.remove_signal_handler(sig)


def wait_started(tick, watches, out, timeout_s, node, ports=()):
    """Runs the node until every modem said it is up; ModemError names the first that did not in
    time; KeyboardInterrupt on Ctrl-C or SIGTERM meanwhile.

    watches: [(link name, kind, where, modems.StartWatch)]; tick: one round of the node; ports:
    its streams and frame ports (what the loop waits on)."""
    return asyncio.run(_wait_started(tick, watches, out, timeout_s, node, ports))


async def _wait_started(tick, watches, out, timeout_s, node, ports):
    loop = asyncio.get_running_loop()
    stop = _Stop(loop)
    shown = set()
    done = asyncio.Event()

    def check(now):
        for name, kind, where, w in watches:
            if w.up and name not in shown:
                shown.add(name)
                out.emit({"event": "link_up", "link": name, "kind": kind, "where": where})
        if len(shown) == len(watches):
            done.set()

    nl = NodeLoop(node, ports, step=tick)
    nl.after.append(check)
    nl.start()
    waits = [asyncio.ensure_future(done.wait()), asyncio.ensure_future(stop.event.wait())]
    try:
        await asyncio.wait(waits, timeout=timeout_s, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for w in waits:
            w.cancel()
        nl.close()
        stop.close()
    if stop.event.is_set():
        raise KeyboardInterrupt
    if not done.is_set():
        late = [w for w in watches if w[0] not in shown][0]
        raise ModemError("the %s modem on %s did not answer its start-up within %g s" % (late[1], late[2], timeout_s))


def serve(tick, console, stdin_fd, seconds=None, poll=None, stop_at_eof=True, node=None, ports=()):
    """Runs until the end of input (when stop_at_eof), `seconds`, Ctrl-C or SIGTERM; returns 0.

    tick(): one round of the node; poll(): called after it (the --send
    list); console lines go to console.command(). At the end of input
    (without `seconds`) it first waits for what the console asked for to
    end (console.open: each ends by its lifespan at the latest), so a
    script piping commands in gets their outcome. node and ports: what
    the loop steps and waits on (acomm_cpython.ioloop)."""
    return asyncio.run(_serve(tick, console, stdin_fd, seconds, poll, stop_at_eof, node, ports))


async def _serve(tick, console, stdin_fd, seconds, poll, stop_at_eof, node, ports):
    loop = asyncio.get_running_loop()
    stop = _Stop(loop)
    state = {"draining": False}
    reader = LineReader() if stdin_fd is not None else None

    def step_error(e):
        console.error("during a step: %s: %s (carrying on)" % (type(e).__name__, e))

    nl = NodeLoop(node, ports, on_error=step_error, step=tick)

    def after(now):
        console.poll()
        if poll is not None:
            poll()
        if reader is None or not reader.eof or not stop_at_eof or seconds is not None:
            return
        if not console.open:
            stop.event.set()
        elif not state["draining"]:
            state["draining"] = True
            console.out.emit({"event": "draining", "open": len(console.open)})

    nl.after.append(after)
    watching = False

    def take(data):
        for line in reader.feed(data):
            console.command(line)
        nl.wake()

    def readable():
        try:
            data = os.read(stdin_fd, 4096)
        except BlockingIOError:
            return
        except OSError:
            data = b""
        if not data:
            loop.remove_reader(stdin_fd)
        take(data)

    if reader is not None:
        try:
            loop.add_reader(stdin_fd, readable)
            watching = True
        except (PermissionError, ValueError, OSError):
            # a regular file (or /dev/null) on standard input: always
            # readable, so the loop cannot wait on it; it is read now
            while not reader.eof:
                take(os.read(stdin_fd, 1 << 16))
    nl.start()
    timer = loop.call_later(seconds, stop.event.set) if seconds is not None else None
    try:
        await stop.event.wait()
    finally:
        if timer is not None:
            timer.cancel()
        if watching:
            loop.remove_reader(stdin_fd)
        nl.close()
        stop.close()
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


def session(prog, args, node, out, console, tick, watches, ports, closers, poll=None, password=None, after=None):
    """What `acomm node` and `acomm run` do once their links are open -> the exit status.

    The web console (--web) if asked, every modem's start-up, "ready", the
    loop until the end (serve), after() (what is left to say), "stopped":
    0; 1 when a modem does not start or a link fails; the web's own status
    for --web. prog names the command in the one line on standard error.
    The caller closes `closers` (the web server joins them)."""
    import sys

    from acomm.errors import AcommError

    try:
        tick = with_web(args, node, out, console, tick, closers, password)
        wait_started(tick, watches, out, args.startup_timeout, node, ports)
        out.emit({"event": "ready", "node": node.name, "id": node.node_id, "links": list(node.links)})
        serve(tick, console, sys.stdin.fileno(), args.seconds, poll, node=node, ports=ports)
        if after is not None:
            after()
        out.emit({"event": "stopped"})
        return 0
    except WebError as e:
        print("%s: %s" % (prog, e), file=sys.stderr)
        return e.status
    except (ModemError, AcommError, OSError) as e:
        print("%s: %s" % (prog, describe(e)), file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 0  # during the start-up (the loop itself ends Ctrl-C quietly)


def open_log(path):
    """The --log file, appended to; OSError when it cannot be opened."""
    return open(path, "a") if path else None
