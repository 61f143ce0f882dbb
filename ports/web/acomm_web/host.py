# The console's server on CPython, beside a node loop that is not asyncio
# (`acomm node`, `acomm run`, `acomm demo`): microdot runs in a thread of
# its own with its own event loop; the node's loop and the server share
# the ConsoleState under one lock, so a command or a view never meets the
# node half-way through a step.
#
#   web = WebHost(state, "127.0.0.1", 8080, password=None, out=None)
#   web.start()                    # listening when it returns
#   with web.lock: node.step(); state.poll(now)
#   web.stop()

import asyncio
import os
import threading
import time

from acomm.errors import AcommError

from .server import WebConsole, tee  # noqa: F401 - tee for the callers

DEFAULT_HOST = "127.0.0.1"


def parse_web(text):
    """'[HOST:]PORT' -> (host, port); loopback when no host is given. ValueError when it does not parse."""
    host, _, port = text.rpartition(":")
    port = int(port)
    if not 0 < port < 65536:
        raise ValueError("web port %d outside 1..65535" % port)
    return host or DEFAULT_HOST, port


def read_password(path):
    """The console's password: the first line of the file (AcommError when unreadable, empty or open to others)."""
    try:
        mode = os.stat(path).st_mode
        if mode & 0o077:
            raise AcommError("web password file %s: permissions %04o let others read it (chmod 600 %s)"
                             % (path, mode & 0o7777, path))
        with open(path) as f:
            pw = f.readline().strip()
    except OSError as e:
        raise AcommError("web password file %s: %s" % (path, e.strerror or e))
    if not pw:
        raise AcommError("web password file %s: empty" % path)
    return pw


def add_arguments(p):
    """--web and --web-password-file, shared by `acomm node` and `acomm run`."""
    p.add_argument("--web", metavar="[HOST:]PORT", help="serve the operator console in a browser here "
                   "(loopback unless a HOST is given; docs/console.md)")
    p.add_argument("--web-password-file", metavar="PATH", help="the console's login password, in a file (chmod 600)")


class WebHost:
    """A WebConsole served from a thread; lock guards the ConsoleState and the node."""

    def __init__(self, state, host, port, password=None, out=None, max_streams=8, extra_routes=None):
        self.host = host
        self.port = port
        self.lock = threading.RLock()
        self.out = out
        self.web = WebConsole(state, self.lock, password, max_streams, self._logged, extra_routes)
        self._loop = None
        self._thread = None
        self._error = None

    def _logged(self, who, cmd, code, ans):
        # every command in the node's event log, with who sent it
        if self.out is not None:
            self.out.emit({"event": "web_command", "by": who, "command": cmd, "code": code, "answer": ans})

    def start(self, timeout_s=5.0):
        """Starts serving; OSError when the address cannot be had (in use, not ours)."""
        started = threading.Event()

        def run():
            loop = asyncio.new_event_loop()
            self._loop = loop
            asyncio.set_event_loop(loop)

            async def main():
                task = asyncio.ensure_future(self.web.app.start_server(self.host, self.port))
                while getattr(self.web.app, "server", None) is None and not task.done():
                    await asyncio.sleep(0.01)
                started.set()
                await task

            try:
                loop.run_until_complete(main())
            except Exception as e:  # noqa: BLE001 - reported by start() in the caller's thread
                self._error = e
            finally:
                started.set()
                # the event streams and requests still open end with the server
                rest = asyncio.all_tasks(loop)
                for t in rest:
                    t.cancel()
                loop.run_until_complete(asyncio.gather(*rest, return_exceptions=True))
                loop.close()

        self._thread = threading.Thread(target=run, name="acomm-web", daemon=True)
        self._thread.start()
        started.wait(timeout_s)
        if self._error is not None:
            raise self._error if isinstance(self._error, OSError) else OSError(str(self._error))
        return self

    @property
    def url(self):
        return "http://%s:%d/" % (self.host, self.port)

    def stop(self):
        app = self.web.app
        if self._loop is not None and getattr(app, "server", None) is not None:
            for rec in self.web.streams:
                rec[0] = False
            self._loop.call_soon_threadsafe(app.shutdown)
            self._thread.join(2.0)

    close = stop


def paced(world, end_ms, speed, lock, after_step=None, chunk_ms=100, stop=None):
    """Runs a simulated World to end_ms at `speed` times real time, chunk by chunk under lock.

    after_step(now) runs after each chunk (under the lock); stop() ends
    it early when true."""
    t0 = time.monotonic()
    s0 = world.now()
    while world.now() - end_ms < 0:
        if stop is not None and stop():
            return False
        with lock:
            world.run(min(chunk_ms, end_ms - world.now()))
            if after_step is not None:
                after_step(world.now())
        ahead = (world.now() - s0) / 1000.0 / speed - (time.monotonic() - t0)
        if ahead > 0:
            time.sleep(ahead)
    return True
