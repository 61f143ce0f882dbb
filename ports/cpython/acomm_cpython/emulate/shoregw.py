# What the emulated Iridium gateway's shore services share (DirectIP:
# directipgw, the RockBLOCK web service: rockblockgw): the outbox that
# delivers each MO message to the customer's server, one connection per
# message, and tries again every retry_ms of emulated time while the server
# is down, as the gateway does; and the calls that the services' server
# threads make on the emulator host's thread, where the sans-IO gateway
# (acomm_sim.iridium_net) lives.
#
# Outbox: messages are delivered in order, one at a time, on a Worker
# thread (a connect may block). deliver(item) returns None (delivered),
# "retry: why" (the server is down or did not confirm: try again later) or
# a refusal "refused: why" (the server said no: dropped, counted; sending
# the same bytes again cannot help). Bounded: at most `capacity` messages
# wait; beyond that the oldest is dropped and counted in `stats["dropped"]`.

import queue
import threading
import time

from acomm.compat import ticks_add, ticks_diff

from ..shore.worker import Worker


class Outbox:
    """MO messages on their way to a shore server, with retries on the emulator's clock."""

    def __init__(self, deliver, retry_ms=60000, capacity=1000):
        self.retry_ms = retry_ms
        self.capacity = capacity
        self.stats = {"delivered": 0, "attempts": 0, "retries": 0, "refused": 0, "dropped": 0}
        self.last_error = None
        self._items = []  # [due ticks, item], oldest first
        self._busy = False
        self._worker = Worker(deliver, name="acomm-gateway")

    def __len__(self):
        return len(self._items)

    def put(self, now, item):
        self._items.append([now, item])
        if len(self._items) > self.capacity:
            self._items.pop(1 if self._busy else 0)  # never the one under way
            self.stats["dropped"] += 1

    def pump(self, now):
        for _, r in self._worker.results():
            self._busy = False
            done = self._items[0]
            if r is None:
                self._items.pop(0)
                self.stats["delivered"] += 1
                continue
            why = str(r) or type(r).__name__
            self.last_error = why
            if why.startswith("refused"):
                self._items.pop(0)
                self.stats["refused"] += 1
            else:
                done[0] = ticks_add(now, self.retry_ms)
                self.stats["retries"] += 1
        if not self._busy and self._items and ticks_diff(now, self._items[0][0]) >= 0:
            self._busy = True
            self.stats["attempts"] += 1
            self._worker.submit(None, self._items[0][1])

    def close(self):
        self._worker.close()


class HostCalls:
    """Calls from server threads run on the host's thread, in pump(now)."""

    def __init__(self):
        self._q = queue.Queue()

    def run(self, fn, *args, timeout=10.0):
        """On a server thread: fn(now, *args) on the host's thread -> its value (None on a timeout)."""
        box = []
        done = threading.Event()
        self._q.put((fn, args, box, done))
        done.wait(timeout)
        return box[0] if box else None

    def pump(self, now):
        while True:
            try:
                fn, args, box, done = self._q.get_nowait()
            except queue.Empty:
                return
            box.append(fn(now, *args))
            done.set()


class WallClock:
    """The emulator's ticks -> UTC seconds (the time of session the gateway reports); epoch_s:
    the UTC seconds at ticks `now` (default: the host's clock, so a replayed run may fix it)."""

    def __init__(self, now=0, epoch_s=None):
        self.t0 = time.time() if epoch_s is None else epoch_s
        self.now0 = now

    def epoch_s(self, now):
        return int(self.t0 + ticks_diff(now, self.now0) / 1000.0)


def queue_status(net, now, imei, payload, flush=False, ring=False):
    """An MT message handed to the gateway -> the DirectIP status: its place in the queue
    (1..), 0 (no payload: a flush or ring alert), or a negative DirectIP error code."""
    if len(imei) != 15 or not imei.isdigit():
        return -1
    m = net.modems.get(imei)
    if m is None:
        return -2
    if flush:
        net.mt[imei] = []
    if payload is None:
        if ring:
            m.ring_alert(now)
        return 0 if (flush or ring) else -4
    if len(payload) > m.mt_max:
        return -3
    if net.queued(imei) >= net.mt_capacity:
        return -5
    net.queue_mt(now, imei, payload)
    return net.queued(imei)


class Service:
    """A shore service of the gateway: an outbox of MO messages (when deliver is given), a server
    thread for MT messages (when listen is given), and the host calls between them."""

    def __init__(self, net, deliver, retry_ms, capacity, server_cls, listen, handler):
        self.net = net
        self.calls = HostCalls()
        self.outbox = Outbox(deliver, retry_ms, capacity) if deliver is not None else None
        if self.outbox is not None:
            net.shores.append(self._mo)
        self.server = None
        if listen is not None:
            self.server = server_cls(listen, handler)
            self.server.daemon_threads = True
            self.server.gateway = self
            threading.Thread(target=self.server.serve_forever, kwargs={"poll_interval": 0.2}, daemon=True).start()

    @property
    def mt_address(self):
        """(host, port) where the MT service listens, or None."""
        return self.server.server_address if self.server else None

    def _mo(self, now, imei, serial, momsn, mtmsn, data):
        raise NotImplementedError

    def pump(self, now):
        """On the host's thread: the server threads' calls, then the outbox."""
        self.calls.pump(now)
        if self.outbox is not None:
            self.outbox.pump(now)

    def close(self):
        if self.server is not None:
            self.server.shutdown()
            self.server.server_close()
        if self.outbox is not None:
            self.outbox.close()
