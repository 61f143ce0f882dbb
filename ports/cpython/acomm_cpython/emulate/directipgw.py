# The emulated gateway's DirectIP services (`acomm emulate iridium
# --directip HOST:PORT --directip-mt [HOST:]PORT`), over the sans-IO gateway
# of acomm_sim.iridium_net:
#
#   MO: each MO message, as it leaves a session, goes to the customer's
#       server at mo_to, one TCP connection per message (shore.directip's
#       MO header, location and payload), and the server's MO confirmation
#       is read (1: delivered). A server that is down, closes without a
#       confirmation or answers 0... is tried again every retry_ms of
#       emulated time (shoregw.Outbox); 0 is a refusal and is not retried.
#   MT: a listener like the gateway's MT port: one MT message per
#       connection, answered with an MT confirmation whose status is the
#       message's place in the queue or a DirectIP error code (-1 bad IMEI,
#       -2 unknown IMEI, -3 too big for the modem, -4 no payload, -5 queue
#       full, -7 a message that does not parse; shore.directip.MT_ERRORS).
#       A sender that stalls for stall_s is cut off with -7.

import socket
import socketserver

from ..shore import directip as dip
from ..shore.directip_port import exchange
from .shoregw import Service, WallClock, queue_status

# where the emulated satellites put every buoy (the MO location IE): off Porto
DEFAULT_LOCATION = (41.1496, -8.6800, 4)


class _MtHandler(socketserver.BaseRequestHandler):
    def handle(self):
        gw = self.server.gateway
        s = self.request
        s.settimeout(gw.stall_s)
        r = dip.Reader(dip.MT_IES, dip.MT_MAX + 64)
        mt, status = None, -7
        try:
            while True:
                chunk = s.recv(4096)
                if not chunk:
                    gw.count("truncated")
                    break
                ies = r.feed(chunk)
                if ies is not None:
                    mt = dip.decode_mt(ies)
                    break
        except socket.timeout:
            gw.count("stalled")
        except dip.DirectIpError as e:
            gw.count(e.reason)
        except OSError:
            return
        if mt is not None:
            status = gw.calls.run(gw.queue, mt)
            if status is None:
                status = -6  # the host did not answer: resources unavailable
        try:
            s.sendall(gw.confirm(mt, status))
        except OSError:
            pass


class _Server(socketserver.ThreadingTCPServer):
    allow_reuse_address = True


class DirectIpGateway(Service):
    """pump(now) on the emulator host's thread; close() at the end."""

    def __init__(self, net, mo_to=None, mt_listen=None, now=0, retry_ms=60000, stall_s=10.0,
                 location=DEFAULT_LOCATION, capacity=1000, epoch_s=None):
        # with neither mo_to nor mt_listen it has no thread and no socket: encode_mo() and queue()
        # serve a caller that moves the bytes itself (the demo's uplink, on a simulated clock)
        self.mo_to = mo_to
        self.stall_s = stall_s
        self.location = location
        self.clock = WallClock(now, epoch_s)
        self.refused = {}  # MT messages refused, by reason
        self.mt_statuses = {}  # status -> count
        self._cdr = 0
        self._auto = 0
        Service.__init__(self, net, self._deliver if mo_to else None, retry_ms, capacity, _Server, mt_listen,
                         _MtHandler)

    def count(self, reason):
        self.refused[reason] = self.refused.get(reason, 0) + 1

    def next_auto_id(self):
        self._auto = (self._auto + 1) & 0xFFFFFFFF
        return self._auto

    def _mo(self, now, imei, serial, momsn, mtmsn, data):
        self.outbox.put(now, self.encode_mo(now, imei, momsn, mtmsn, data))

    def encode_mo(self, now, imei, momsn, mtmsn, data):
        """One MO message of a successful session, as the gateway sends it to the shore (a new CDR
        reference, the time of session, the location)."""
        self._cdr = (self._cdr + 1) & 0xFFFFFFFF
        return dip.encode_mo(self._cdr, imei, 0, momsn, mtmsn, self.clock.epoch_s(now), data, self.location)

    def _deliver(self, msg):
        # on the outbox's thread: one MO message, one connection
        try:
            ies = exchange(self.mo_to, msg, dip.MO_CONFIRMATION, 5)
        except OSError as e:
            return "retry: %s" % (e.strerror or e)
        except dip.DirectIpError as e:
            return "retry: %s" % e
        if ies is None:
            return "retry: closed without a confirmation"
        return None if ies[dip.MO_CONFIRMATION] == b"\x01" else "refused: MO confirmation 0"

    def confirm(self, mt, status):
        """The MT confirmation's bytes for a decoded MT message (None: one that did not parse)."""
        cid, imei = (0, b"?") if mt is None else (mt["client_id"], mt["imei"])
        return dip.encode_mt_confirmation(cid, imei, self.next_auto_id(), status)

    def queue(self, now, mt):
        # on the host's thread: the MT message into the gateway -> its status
        imei = mt["imei"].decode("ascii", "replace")
        st = queue_status(self.net, now, imei, mt["payload"], bool(mt["flags"] & dip.FLUSH_MT_QUEUE),
                          bool(mt["flags"] & dip.SEND_RING_ALERT))
        self.mt_statuses[st] = self.mt_statuses.get(st, 0) + 1
        return st
