# The shore's DirectIP port: the I/O of a ShoreDriver (shore.driver) for
# Iridium DirectIP (shore.directip). It listens where told for the
# gateway's MO connections (one message each), and hands each MT message to
# the gateway's MT port over a connection of its own, reading the MT
# confirmation (on a Worker thread: a connect can block).
#
# An MO connection from an address outside `gateways` (when a list is
# given) is closed at once. A message that is refused (truncated, a wrong
# IE length, an unknown IE, a peer that stalls mid-message for stall_ms, a
# foreign IMEI) is counted in `refused` by its reason and answered with an
# MO confirmation of 0 where the connection still stands; a message taken is
# delivered to the driver and then confirmed with 1, so the gateway may
# forget it only once it is ours. A message sent again (same IMEI and
# MOMSN: its confirmation was lost) is confirmed again, not delivered twice. At most max_conns connections at once,
# each reading at most one message's bytes.

import socket

from acomm.compat import ticks_diff

from . import directip as dip
from .seen import Replays
from .worker import Worker, pump_mt

_CHUNK = 4096


def _count(table, reason):
    table[reason] = table.get(reason, 0) + 1


class DirectIpShorePort:
    """pump(now) with filenos(), as acomm.node wants of a frame port."""

    def __init__(self, driver, listen=("0.0.0.0", 10800), mt=None, gateways=None, max_conns=8, stall_ms=30000,
                 mt_timeout_s=20.0):
        self.driver = driver
        self.mt = mt  # (host, port) of the gateway's MT DirectIP service, or None: no MT
        self.gateways = set(gateways) if gateways else None
        self.max_conns = max_conns
        self.stall_ms = stall_ms
        self.mt_timeout_s = mt_timeout_s
        self.refused = {}  # reason -> count
        self.stats = {"mo_taken": 0, "mo_again": 0, "mt_queued": 0, "mt_refused": 0}
        self.seen = Replays(4096)
        self._conns = {}  # socket -> [Reader, ticks of the last byte, peer]
        self._client_id = 0
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind(listen)
            s.listen(max_conns)
            s.setblocking(False)
        except BaseException:
            s.close()
            raise
        self.listener = s
        self.worker = Worker(self._submit_mt)

    @property
    def address(self):
        return self.listener.getsockname()

    def filenos(self):
        return (self.listener.fileno(), self.worker.fileno()) + tuple(c.fileno() for c in self._conns)

    def pump(self, now):
        self._accept(now)
        for sock in list(self._conns):
            self._read(now, sock)
        pump_mt(self.driver, self.worker, now, self.stats)

    def _accept(self, now):
        while True:
            try:
                sock, peer = self.listener.accept()
            except OSError:  # none waiting (BlockingIOError), or the peer gave up already
                return
            if self.gateways is not None and peer[0] not in self.gateways:
                _count(self.refused, "not a gateway")
                sock.close()
                continue
            if len(self._conns) >= self.max_conns:
                _count(self.refused, "too many connections")
                sock.close()
                continue
            sock.setblocking(False)
            self._conns[sock] = [dip.Reader(dip.MO_IES), now, peer]

    def _read(self, now, sock):
        c = self._conns[sock]
        try:
            data = sock.recv(_CHUNK)
        except (BlockingIOError, InterruptedError):
            if ticks_diff(now, c[1]) >= self.stall_ms:
                self._refuse(sock, "stalled")
            return
        except OSError:
            data = b""
        if not data:
            self._refuse(sock, c[0].eof() or "closed", answer=False)
            return
        c[1] = now
        try:
            ies = c[0].feed(data)
            if ies is None:
                return
            mo = dip.decode_mo(ies)
        except dip.DirectIpError as e:
            self._refuse(sock, e.reason)
            return
        why = take_mo(self.driver, self.seen, self.stats, now, mo)
        if why is not None:
            self._refuse(sock, why)
            return
        self._close(sock, dip.encode_mo_confirmation(True))

    def _refuse(self, sock, reason, answer=True):
        _count(self.refused, reason)
        self._close(sock, dip.encode_mo_confirmation(False) if answer else b"")

    def _close(self, sock, reply):
        self._conns.pop(sock, None)
        try:
            if reply:
                sock.send(reply)  # a few bytes: the socket's buffer takes them
            # bytes left unread would make the close a reset, which can
            # overtake the answer: read what has come (bounded)
            for _ in range(4):
                if not sock.recv(_CHUNK):
                    break
        except OSError:
            pass
        sock.close()

    def _submit_mt(self, imei, data):
        # on the worker thread: one MT message, one connection -> None or why not
        if self.mt is None:
            return "no MT service configured (mt=HOST:PORT)"
        self._client_id = (self._client_id + 1) & 0xFFFFFFFF
        cid = self._client_id
        ies = exchange(self.mt, dip.encode_mt(cid, imei, data), dip.MT_CONFIRMATION, self.mt_timeout_s)
        return mt_refusal(cid, ies)

    def close(self, now=0):
        for sock in list(self._conns):
            self._close(sock, b"")
        self.listener.close()
        self.worker.close()


def take_mo(driver, seen, stats, now, mo):
    """A decoded MO message (directip.decode_mo) for the driver -> None when it is ours (confirm
    with 1), else the refusal's reason (confirm with 0). The same IMEI and MOMSN again (its
    confirmation was lost) is ours without a second delivery (stats["mo_again"]); seen: a
    shore.seen.Replays; stats counts mo_taken and mo_again."""
    key = (mo["imei"], mo["momsn"])
    if seen.seen(key):
        stats["mo_again"] += 1
        return None
    if not driver.deliver(now, mo["imei"], mo["payload"]):
        return "foreign IMEI"
    seen.add(key)
    stats["mo_taken"] += 1
    return None


def mt_refusal(cid, ies):
    """The gateway's answer to MT message cid (the IEs of its MT confirmation, None when it
    closed without one) -> None when the message is queued, else why not (for ShoreDriver.sent)."""
    if ies is None:
        return "the gateway closed without a confirmation"
    got_cid, _, _, status = dip.decode_mt_confirmation(ies)
    if got_cid != cid:
        return "a confirmation for another message"
    if status >= 1:
        return None
    return "DirectIP status %d: %s" % (status, dip.MT_ERRORS.get(status, "no payload" if status == 0 else "?"))


def exchange(addr, msg, answer_iei, timeout_s):
    """One DirectIP message to addr on a connection of its own (blocking) -> the IEs of the answer
    (an MO or MT confirmation, answer_iei), or None when the peer closed without one.
    OSError for the connection, DirectIpError for an answer that does not parse."""
    with socket.create_connection(addr, timeout=timeout_s) as s:
        s.sendall(msg)
        r = dip.Reader((answer_iei,), 64)
        while True:
            chunk = s.recv(256)
            if not chunk:
                return None
            ies = r.feed(chunk)
            if ies is not None:
                return ies
