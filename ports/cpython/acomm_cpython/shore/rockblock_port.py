# The shore's RockBLOCK port: the I/O of a ShoreDriver (shore.driver) for
# the RockBLOCK web service (shore.rockblock). An HTTP server (the stdlib's,
# on its own thread) takes Rock7's MO POSTs where told; each one is checked
# (form, hex, JWT RS256 with the configured public key, age, replay) and
# answered 200 only once its payload waits in the port's inbox, so nothing
# acknowledged is lost; a refusal is counted in `refused` by its reason and
# answered with a 4xx (503 when the inbox is full: Rock7 may try again).
# At most max_conns requests are served at once; more are closed unread.
# pump() hands the inbox to the driver on the node's loop. MT messages go
# to the MT API by an HTTP(S) POST on a Worker thread.

import http.client
import http.server
import socket
import threading
from urllib.parse import urlsplit

from . import rockblock as rb
from .seen import Replays
from .worker import Worker, drain, pump_mt

_INBOX = 64  # MO messages taken but not yet handed to the driver


class _Handler(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.0"

    def log_message(self, *args):
        pass  # counted in `refused`, not printed

    def setup(self):
        # a connection that stalls mid-request ends after the port's stall_s
        self.timeout = self.server.port.stall_s
        http.server.BaseHTTPRequestHandler.setup(self)

    def handle(self):
        # at most max_conns requests at once: each holds a thread and up to MAX_FORM bytes
        port = self.server.port
        if not port.slots.acquire(blocking=False):
            port.refuse("too many connections", 0)
            return
        try:
            http.server.BaseHTTPRequestHandler.handle(self)
        finally:
            port.slots.release()

    def do_POST(self):
        port = self.server.port
        try:
            n = int(self.headers.get("Content-Length", ""))
        except ValueError:
            return self._answer(port.refuse("no length", 411))
        if not 0 <= n <= rb.MAX_FORM:
            return self._answer(port.refuse("too long", 413))
        try:
            body = self.rfile.read(n)
        except OSError:  # socket.timeout included: a peer that stalls
            return self._answer(port.refuse("stalled", 408))
        if len(body) < n:
            return self._answer(port.refuse("truncated", 400))
        self._answer(port.take(body))

    def _answer(self, status):
        try:
            self.send_response(status)
            self.send_header("Content-Length", "0")
            self.end_headers()
        except OSError:
            pass


class RockblockShorePort:
    """pump(now) with filenos(), as acomm.node wants of a frame port.

    key: Rock7's public key (n, e) (jwt_rs256.public_key); mt_url and
    credentials (username, password): where and as whom MT messages go (None:
    no MT)."""

    def __init__(self, driver, listen, key, mt_url=None, credentials=None, max_age_s=300, stall_s=30.0,
                 replay_capacity=4096, max_conns=16):
        self.driver = driver
        self.key = key
        self.mt_url = mt_url
        self.credentials = credentials
        self.max_age_s = max_age_s
        self.stall_s = stall_s
        self.slots = threading.BoundedSemaphore(max_conns)
        self.replays = Replays(replay_capacity)
        self.refused = {}  # reason -> count
        self.stats = {"mo_taken": 0, "mt_queued": 0, "mt_refused": 0}
        self._lock = threading.Lock()
        self._inbox = []
        self._rx, self._tx = socket.socketpair()
        self._rx.setblocking(False)
        self.server = http.server.ThreadingHTTPServer(listen, _Handler)
        self.server.daemon_threads = True
        self.server.port = self
        self._thread = threading.Thread(target=self.server.serve_forever, kwargs={"poll_interval": 0.2}, daemon=True)
        self._thread.start()
        self.worker = Worker(self._submit_mt)

    @property
    def address(self):
        return self.server.server_address

    def filenos(self):
        return self._rx.fileno(), self.worker.fileno()

    def refuse(self, reason, status):
        """Counts a refusal (any thread) -> the HTTP status to answer."""
        with self._lock:
            self.refused[reason] = self.refused.get(reason, 0) + 1
        return status

    def take(self, body):
        """One MO POST's body (on the server's thread) -> the HTTP status to answer."""
        try:
            fields = rb.form(body)
            with self._lock:
                mo = rb.check_mo(fields, self.key, self.replays, max_age_s=self.max_age_s)
                if len(self._inbox) >= _INBOX:
                    raise rb.RockblockError("busy", 503)
                self.replays.add((mo["imei"], mo["momsn"]))
                self._inbox.append(mo)
        except rb.RockblockError as e:
            return self.refuse(e.reason, e.http)
        try:
            self._tx.send(b"!")
        except OSError:
            pass
        return 200

    def pump(self, now):
        drain(self._rx)
        with self._lock:
            inbox, self._inbox = self._inbox, []
        for mo in inbox:
            if self.driver.deliver(now, mo["imei"], mo["payload"]):
                self.stats["mo_taken"] += 1
            else:
                self.refuse("foreign IMEI", 0)
        pump_mt(self.driver, self.worker, now, self.stats)

    def _submit_mt(self, imei, data):
        # on the worker thread: one MT message, one POST -> None or why not
        if not self.mt_url or not self.credentials:
            return "no MT service configured (mt=URL,credentials=FILE)"
        status, text = post_form(self.mt_url, rb.mt_form(imei, self.credentials[0], self.credentials[1], data), 20)
        if status != 200:
            return "HTTP %d from the MT API" % status
        ok, v = rb.parse_mt_answer(text)
        return None if ok else v

    def close(self, now=0):
        self.server.shutdown()
        self.server.server_close()
        self._rx.close()
        self._tx.close()
        self.worker.close()


def post_form(url, body, timeout_s):
    """One urlencoded POST to url (text or a urlsplit result) on a connection of its own
    (blocking) -> (HTTP status, the answer's first 512 bytes). OSError for the connection."""
    u = urlsplit(url) if isinstance(url, str) else url
    cls = http.client.HTTPSConnection if u.scheme == "https" else http.client.HTTPConnection
    conn = cls(u.hostname, u.port, timeout=timeout_s)
    try:
        conn.request("POST", u.path or "/", body, {"Content-Type": "application/x-www-form-urlencoded"})
        r = conn.getresponse()
        return r.status, r.read(512)
    finally:
        conn.close()
