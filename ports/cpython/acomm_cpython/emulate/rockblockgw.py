# The emulated gateway's RockBLOCK web service (`acomm emulate iridium
# --rockblock-post URL --rockblock-mt [HOST:]PORT`), over the sans-IO
# gateway of acomm_sim.iridium_net:
#
#   MO: each MO message is POSTed to the customer's URL as Rock7 does
#       (shore.rockblock.mo_form: the fields and their JWT, signed RS256 with
#       the TEST key of rock7_testkey at each attempt). 200 is delivered; a
#       server that is down or answers 5xx is tried again every retry_ms of
#       emulated time (shoregw.Outbox); a 4xx is a refusal, not retried.
#   MT: the MT API's fields (imei, username, password, data in hex,
#       flush=yes: the IMEI's queue emptied first) in the POST's body or its
#       query string (the service's page sends them in the URL) on an HTTP
#       listener, answered "OK,<id>" or "FAILED,<code>,<text>" with the
#       page's codes: 10 wrong credentials, 11 no such IMEI, 14 bad hex, 15
#       too long for the modem, 16 no data, 99 the gateway's queue for the
#       IMEI is full (12 line rental and 13 credit are never refused here).
#   Pages: https://docs.groundcontrol.com/iot/rockblock/web-services/sending-mt-message
#   and .../receiving-mo-message (docs/drivers-iridium.md, Conformance).

import http.server
import time
from urllib.parse import urlsplit

from ..shore import jwt_rs256
from ..shore import rockblock as rb
from ..shore.rockblock_port import post_form
from .directipgw import DEFAULT_LOCATION
from .rock7_testkey import PRIVATE_PEM
from .shoregw import Service, WallClock, queue_status


def public_test_pem():
    """The public half of the emulator's TEST signing key, as PEM (for a shore under test)."""
    n, e, _ = jwt_rs256.private_key(PRIVATE_PEM)
    return jwt_rs256.public_pem(n, e)


class _MtHandler(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.0"

    def log_message(self, *args):
        pass

    def do_POST(self):
        gw = self.server.gateway
        try:
            n = int(self.headers.get("Content-Length", "0"))
            fields = rb.form(self.rfile.read(n) if 0 <= n <= rb.MAX_FORM else b"x" * (rb.MAX_FORM + 1))
            query = urlsplit(self.path).query.encode("ascii", "replace")
            if query:
                fields.update(rb.form(query))
        except (ValueError, OSError, rb.RockblockError):
            return self._answer(400, b"")
        answer = gw.mt(fields)
        self._answer(200, answer)

    def _answer(self, status, body):
        try:
            self.send_response(status)
            self.send_header("Content-Type", "text/plain")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)
        except OSError:
            pass


class RockblockGateway(Service):
    """pump(now) on the emulator host's thread; close() at the end. credentials: (username, password)
    the MT API takes (None: any)."""

    def __init__(self, net, post_url=None, mt_listen=None, credentials=None, now=0, retry_ms=60000,
                 location=DEFAULT_LOCATION, capacity=1000, key_pem=PRIVATE_PEM):
        self.post_url = urlsplit(post_url) if post_url else None
        self.credentials = credentials
        self.location = location
        self.key = jwt_rs256.private_key(key_pem)
        self.clock = WallClock(now)
        self.answers = {}  # MT API answer code (0: OK) -> count
        self._mtid = 0
        Service.__init__(self, net, self._deliver if post_url else None, retry_ms, capacity,
                         http.server.ThreadingHTTPServer, mt_listen, _MtHandler)

    def _mo(self, now, imei, serial, momsn, mtmsn, data):
        lat, lon, cep = self.location
        fields = {"imei": imei, "serial": serial, "momsn": str(momsn),
                  "transmit_time": time.strftime("%y-%m-%d %H:%M:%S", time.gmtime(self.clock.epoch_s(now))),
                  "iridium_latitude": "%.4f" % lat, "iridium_longitude": "%.4f" % lon, "iridium_cep": str(cep),
                  "data": bytes(data).hex()}
        self.outbox.put(now, fields)

    def _deliver(self, fields):
        # on the outbox's thread: one MO message, one POST, signed now
        try:
            status, _ = post_form(self.post_url, rb.mo_form(fields, self.key), 5)
        except OSError as e:
            return "retry: %s" % (e.strerror or e)
        if status == 200:
            return None
        return ("retry: HTTP %d" if status >= 500 or status in (408, 429) else "refused: HTTP %d") % status

    def mt(self, fields):
        """On a server thread: one MT API request's fields -> the answer's bytes."""
        code = 0
        if self.credentials is not None and (fields.get("username"), fields.get("password")) != self.credentials:
            code = 10
        elif not fields.get("data"):
            code = 16
        else:
            try:
                data = bytes.fromhex(fields["data"])
            except ValueError:
                code = 14
        if code == 0:
            st = self.calls.run(self._queue, fields.get("imei", ""), data, fields.get("flush") == "yes")
            code = {None: 99, -1: 11, -2: 11, -3: 15, -5: 99}.get(st, 0 if st is not None and st >= 1 else 99)
        self.answers[code] = self.answers.get(code, 0) + 1
        if code:
            return rb.mt_answer(False, code)
        self._mtid += 1
        return rb.mt_answer(True, self._mtid)

    def _queue(self, now, imei, data, flush):
        return queue_status(self.net, now, imei, data, flush)
