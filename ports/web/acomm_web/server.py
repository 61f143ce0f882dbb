# The operator console's web server on microdot: the page, the views of an
# acomm.apps.console.ConsoleState as JSON, its live updates as Server-Sent
# Events, and the operator's commands. Portable: the same module serves on
# CPython (acomm_web.host runs it in a thread beside the node's loop) and
# on MicroPython (a board's asyncio loop runs it beside the node).
#
#   GET  /                    the page (gzip when the client accepts it)
#   GET  /api/state           every view, with its version
#   GET  /api/view/NAME       one view (acomm.apps.console.VIEWS)
#   GET  /api/events          SSE: each view as an event named after it,
#                             when it changes (views with ages or countdowns
#                             also every REFRESH_S); at most max_streams
#                             open, a new one closes the oldest
#   POST /api/login           {"user", "password"} -> a session cookie
#   POST /api/command         a ConsoleState command -> its code and answer
#
# Every refusal is a 4xx with {"error": reason}. Commands and logins come
# as application/json only (415 otherwise): a page elsewhere cannot make a
# browser send that here without a CORS preflight, which is never granted.
# With a password every /api route but login needs the session cookie (401
# otherwise); without one the console is open, to whoever reaches the
# address it listens on (loopback unless told otherwise). Each command is
# logged with who sent it: the login name and the client's address.

import asyncio
import json

from microdot import Microdot, Request, Response
from microdot.sse import with_sse

from acomm.apps.console import VIEWS

REFRESH_S = 2  # views that show ages and countdowns are pushed this often
PUSH_S = 0.5  # how often a stream looks for changed views
_AGING = ("nodes", "positions", "queue")
_SESSIONS = 16  # logins kept; the oldest is forgotten
_BACKLOG = 4  # events waiting for a slow stream; beyond, updates wait for it
COOKIE = "acomm_session"
MAX_BODY = 1024  # a command or a login is a few dozen bytes; more is refused (413) unread


class _NoLock:
    # MicroPython's one asyncio loop runs the node and the server in turn
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _token():
    try:
        import os

        b = os.urandom(16)
    except (ImportError, AttributeError, NotImplementedError):
        import random

        b = bytes(random.getrandbits(8) for _ in range(16))
    return "".join("%02x" % x for x in b)


def _same(a, b):
    # compares all of both strings whatever differs first
    if len(a) != len(b):
        return False
    d = 0
    for i in range(len(a)):
        d |= ord(a[i]) ^ ord(b[i])
    return d == 0


def _host(client_addr):
    # the client's address as text: CPython gives (host, port); the
    # MicroPython unix port the raw struct sockaddr_in (family, port, IPv4)
    a = client_addr
    if isinstance(a, (tuple, list)) and a and isinstance(a[0], str):
        return a[0]
    if isinstance(a, (bytes, bytearray)) and len(a) >= 8 and a[0] == 2:
        return "%d.%d.%d.%d" % (a[4], a[5], a[6], a[7])
    return "?"


def _error(code, reason):
    return {"error": reason}, code


def tee(node, state):
    """Adds the ConsoleState to the node's listeners (after those already there) -> the listener.

    An error in the console is counted (state.errors, in its info view)
    and goes no further: the console must never stop the node."""

    def guarded(ev):
        try:
            state.on_event(ev)
        except Exception as e:  # noqa: BLE001 - see the docstring
            state.errors += 1
            state.last_error = "%s: %s" % (type(e).__name__, e)

    node.listen(guarded)
    return guarded


def page_path(name="page.html"):
    """The path of a file shipped beside this module (the page and its gzip)."""
    f = __file__
    i = f.rfind("/")
    return (f[:i] if i >= 0 else ".") + "/" + name


class WebConsole:
    """The server's state: the ConsoleState, its lock, sessions and open streams; app is the Microdot app."""

    def __init__(self, state, lock=None, password=None, max_streams=8, on_command=None, extra_routes=None):
        self.state = state
        self.lock = lock if lock is not None else _NoLock()
        self.password = password
        self.max_streams = max_streams
        self.on_command = on_command  # on_command(who, command, code, answer): the node's event log
        self.sessions = {}  # token -> user
        self._order = []
        self.streams = []  # [open flag] of each event stream, oldest first
        self.streams_dropped = 0
        self.app = self._make_app(extra_routes)

    # -- helpers -----------------------------------------------------------------
    def _who(self, request):
        # -> the operator's name, or None when a login is needed
        addr = _host(request.client_addr)
        if self.password is None:
            return "operator@%s" % addr
        user = self.sessions.get(request.cookies.get(COOKIE) or "")
        return None if user is None else "%s@%s" % (user, addr)

    def views(self, names=VIEWS):
        """{view name: {"version", "data"}} of the views named, taken under the lock."""
        with self.lock:
            now = self.state.node.clock()
            v = self.state.versions()
            return dict((n, {"version": v[n], "data": self.state.view(n, now)}) for n in names)

    def _stream_open(self):
        rec = [True]
        self.streams.append(rec)
        while len(self.streams) > self.max_streams:
            self.streams.pop(0)[0] = False
            self.streams_dropped += 1
        return rec

    def _stream_closed(self, rec):
        rec[0] = False
        if rec in self.streams:
            self.streams.remove(rec)

    # -- the routes --------------------------------------------------------------
    def _make_app(self, extra_routes):
        # microdot's limits are class-wide: the console is the process's one app
        Request.max_content_length = MAX_BODY
        Request.max_body_length = MAX_BODY
        app = Microdot()
        wc = self

        @app.errorhandler(404)
        def not_found(request):
            return _error(404, "no route %s %s" % (request.method, request.path))

        @app.errorhandler(405)
        def not_allowed(request):
            return _error(405, "%s is not allowed on %s" % (request.method, request.path))

        @app.errorhandler(413)
        def too_large(request):
            return _error(413, "request too large")

        @app.errorhandler(400)
        def bad_request(request):
            return _error(400, "malformed request")

        @app.route("/")
        async def index(request):
            gz = "gzip" in (request.headers.get("Accept-Encoding") or "")
            r = Response.send_file(page_path("page.html.gz" if gz else "page.html"),
                                   content_type="text/html; charset=utf-8")
            if gz:
                r.headers["Content-Encoding"] = "gzip"
            r.headers["Vary"] = "Accept-Encoding"
            r.headers["Cache-Control"] = "no-cache"
            return r

        @app.post("/api/login")
        async def login(request):
            if not _is_json(request):
                return _error(415, JSON_ONLY)
            body = _json(request)
            if not isinstance(body, dict):
                return _error(400, "a login is a JSON object {user, password}")
            user = body.get("user")
            if not isinstance(user, str) or not 0 < len(user) <= 32:
                return _error(400, "user: a name of 1 to 32 characters")
            if wc.password is None:
                return {"user": user, "open": True}
            pw = body.get("password")
            if not isinstance(pw, str) or not _same(pw, wc.password):
                return _error(401, "wrong password")
            tok = _token()
            wc.sessions[tok] = user
            wc._order.append(tok)
            if len(wc._order) > _SESSIONS:
                wc.sessions.pop(wc._order.pop(0), None)
            r = Response({"user": user})
            r.set_cookie(COOKIE, tok, path="/", http_only=True)
            return r

        @app.get("/api/state")
        async def state(request):
            if wc._who(request) is None:
                return _error(401, "login needed")
            return wc.views()

        @app.get("/api/view/<name>")
        async def view(request, name):
            if wc._who(request) is None:
                return _error(401, "login needed")
            if name not in VIEWS:
                return _error(404, "no view %r: %s" % (name, ", ".join(VIEWS)))
            return wc.views((name,))[name]

        @app.post("/api/command")
        async def command(request):
            who = wc._who(request)
            if who is None:
                return _error(401, "login needed")
            if not _is_json(request):
                return _error(415, JSON_ONLY)
            body = _json(request)
            if body is None:
                return _error(400, "the body must be a JSON object")
            with wc.lock:
                code, ans = wc.state.command(wc.state.node.clock(), body, who)
            if wc.on_command is not None:
                wc.on_command(who, body, code, ans)
            return ans, code

        @app.get("/api/events")
        async def events(request):
            if wc._who(request) is None:
                return _error(401, "login needed")
            return await _events(request)

        @with_sse
        async def _events(request, sse):
            rec = wc._stream_open()
            sent = {}
            k = 0
            try:
                while rec[0]:
                    with wc.lock:
                        v = dict(wc.state.versions())
                    due = [n for n in VIEWS if sent.get(n) != v[n]
                           or (n in _AGING and k % int(REFRESH_S / PUSH_S) == 0)]
                    if due and len(sse.queue) <= _BACKLOG:
                        views = wc.views(due)
                        for n in due:
                            await sse.send(json.dumps(views[n]), event=n)
                            sent[n] = views[n]["version"]
                        views = None  # not kept through the sleep: a board has 2 streams' worth of heap
                    k += 1
                    await asyncio.sleep(PUSH_S)
                await sse.send(json.dumps({"reason": "too many event streams: this one was the oldest"}), event="closed")
            finally:
                wc._stream_closed(rec)

        if extra_routes is not None:
            extra_routes(app, wc)
        return app


# A page elsewhere can make the operator's browser post a form here
# (text/plain, urlencoded, multipart) without asking; it cannot post
# application/json without a CORS preflight, which this server never
# grants. So commands and logins come as JSON only.
JSON_ONLY = "Content-Type must be application/json"


def _is_json(request):
    return (request.headers.get("Content-Type") or "").split(";")[0].strip().lower() == "application/json"


def _json(request):
    # the request's JSON body, or None when it has none or it does not parse
    try:
        body = request.body
        if not body:
            return None
        return json.loads(body.decode() if isinstance(body, bytes) else body)
    except (ValueError, UnicodeError):
        return None
