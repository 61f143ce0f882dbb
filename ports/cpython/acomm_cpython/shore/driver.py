# The link driver of a shore node without a modem (sans-IO, interface in
# acomm.drivers.base): a buoy's MO messages come from the gateway through a
# port (DirectIP or the RockBLOCK POST: deliver()), and the shore's frames
# go to the buoy as MT messages that the port hands to the gateway
# (take_mt(), then sent() with the gateway's word).
#
# As over a modem-to-modem Iridium path, the link sends raw acomm frames
# (node ids and CRC in the frame), the caps lack CAP_ADDRESSING and
# CAP_RELIABLE, and EV_TX_DONE means "queued at the gateway", never
# "delivered": an acknowledged request waits for the buoy's acomm ACK, which
# comes back as an MO message. One MT submission at a time; the gateway's
# queue limit (50 per IMEI) is its own, and a full queue fails the request
# with the gateway's reason, so the transport keeps the packet and tries
# again. The buoy's IMEI is configured, or learned from its first MO
# message; MO messages from other IMEIs are refused (counted) when one is
# configured.

from acomm.drivers.base import SansIO
from acomm.drivers.caps import Capabilities
from acomm.errors import AcommError, EncodeError
from acomm.compat import ticks_diff
from acomm.events import EV_DRIVER_UP, EV_RX, EV_TX_DONE, EV_TX_FAILED


class ShoreDriver(SansIO):
    """A shore's Iridium link through a gateway service: deliver() in, take_mt()/sent() out."""

    broadcast_addr = None  # Iridium has no addresses

    def __init__(self, service, imei=None, mt_mtu=270, mo_mtu=340, tx_timeout_ms=120000, cost_tx=0.02):
        SansIO.__init__(self)
        if imei is not None and (len(imei) != 15 or not imei.isdigit()):
            raise AcommError("an IMEI is 15 digits")
        self.service = service
        self.imei = imei
        self.fixed_imei = imei is not None
        self.mt_mtu = mt_mtu
        self.tx_timeout_ms = tx_timeout_ms
        self.caps = Capabilities(manufacturer="Iridium", model="%s shore" % service, cost_tx=cost_tx,
                                 mtu_tx=mt_mtu, mtu_rx=mo_mtu, bitrate=100, latency_ms=20000, flags=0)
        self._queue = []  # (handle, imei, frame) for the port
        self._inflight = None  # (handle, ticks handed over)
        self._handle = 0
        self._started = False
        self.stats = {"mo_delivered": 0, "mo_foreign": 0, "mt_sent": 0, "mt_failed": 0, "mt_timeouts": 0}

    def ready(self, now):
        return self._inflight is None and self.imei is not None

    def send(self, now, addr, data, ack=False):
        """One frame to the buoy as an MT message -> handle; EncodeError when too big or not ready."""
        if len(data) > self.mt_mtu:
            raise EncodeError("%d bytes exceed the MT size of %d" % (len(data), self.mt_mtu))
        if not self.ready(now):
            raise AcommError("an MT message is still being handed over" if self.imei else "no buoy IMEI known yet")
        self._handle = (self._handle + 1) & 0xFFFF
        self._queue.append((self._handle, self.imei, bytes(data)))
        self._inflight = (self._handle, now)
        return self._handle

    def take_mt(self):
        """The MT messages for the port to hand to the gateway: [(handle, imei, frame)]."""
        q, self._queue = self._queue, []
        return q

    def sent(self, now, handle, error=None):
        """The port's word on an MT message: None (queued at the gateway) or the reason it was not."""
        fl = self._inflight
        if fl is None or fl[0] != handle:
            return  # it timed out already
        self._inflight = None
        if error is None:
            self.stats["mt_sent"] += 1
            self._events.append((EV_TX_DONE, handle))
        else:
            self.stats["mt_failed"] += 1
            self._events.append((EV_TX_FAILED, handle, "MT not queued: %s" % error))

    def deliver(self, now, imei, payload):
        """An MO message from the gateway; -> False when refused (another buoy's IMEI)."""
        if self.fixed_imei and imei != self.imei:
            self.stats["mo_foreign"] += 1
            return False
        self.imei = imei
        self.stats["mo_delivered"] += 1
        self._events.append((EV_RX, None, None, bytes(payload)))
        return True

    def feed(self, now, data):
        pass  # the ports call deliver(): there is no byte stream

    def poll(self, now):
        if not self._started:
            self._started = True
            self._events.append((EV_DRIVER_UP,))
        fl = self._inflight
        if fl is not None and ticks_diff(now, fl[1]) >= self.tx_timeout_ms:
            # the port never answered: do not hold the link for ever
            self._inflight = None
            self._queue = [e for e in self._queue if e[0] != fl[0]]
            self.stats["mt_timeouts"] += 1
            self._events.append((EV_TX_FAILED, fl[0], "MT not queued: the gateway did not answer"))
