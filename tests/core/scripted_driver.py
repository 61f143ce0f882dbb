# A driver the test controls by hand: it records what the link sends and
# produces exactly the events the test asks for. Used to reach every state of
# the link (modem acks, failures, ranging) without a modem.

from acomm.drivers.base import SansIO
from acomm.drivers.caps import CAP_ADDRESSING, CAP_BROADCAST, CAP_RANGING, CAP_RELIABLE, Capabilities
from acomm.events import EV_DELIVERED, EV_DRIVER_UP, EV_RANGE, EV_RX, EV_TX_DONE, EV_TX_FAILED

MODEM_FLAGS = CAP_ADDRESSING | CAP_BROADCAST | CAP_RELIABLE | CAP_RANGING


class ScriptedDriver(SansIO):
    def __init__(self, flags=MODEM_FLAGS, mtu=32, broadcast_addr=0):
        self.caps = Capabilities("test", "scripted", mtu_tx=mtu, mtu_rx=mtu, bitrate=100, latency_ms=1000, flags=flags)
        self.broadcast_addr = broadcast_addr
        SansIO.__init__(self)
        self.sent = []  # (handle, addr, data, ack) or (handle, "ping", addr)
        self._h = 0
        self.busy = None

    def ready(self, now):
        return self.busy is None

    def send(self, now, addr, data, ack=False):
        self._h += 1
        self.sent.append((self._h, addr, bytes(data), ack))
        self.busy = self._h
        return self._h

    def ping(self, now, addr):
        self._h += 1
        self.sent.append((self._h, "ping", addr))
        self.busy = self._h
        return self._h

    def feed(self, now, data):
        pass

    def poll(self, now):
        pass

    # -- what the test makes happen ------------------------------------------
    def finish(self, handle=None):
        h = self.busy if handle is None else handle
        self.busy = None
        self._events.append((EV_TX_DONE, h))
        return h

    def deliver(self, handle):
        self._events.append((EV_DELIVERED, handle))

    def fail(self, handle, reason="modem error"):
        self.busy = None
        self._events.append((EV_TX_FAILED, handle, reason))

    def range_reply(self, handle, addr, metres):
        self.busy = None
        self._events.append((EV_RANGE, handle, addr, metres))

    def receive(self, src, dst, data):
        self._events.append((EV_RX, src, dst, bytes(data)))

    def reboot(self):
        self._events.append((EV_DRIVER_UP,))
