# Capability advertisement of one interface (seed 000 section III.A): what the
# transport needs to choose a link and to size frames.

from ..compat import const

CAP_ADDRESSING = const(1)  # the interface has its own address scheme
CAP_RELIABLE = const(2)  # it can confirm delivery of a frame
CAP_BROADCAST = const(4)
CAP_DISCOVERY = const(8)
CAP_RANGING = const(16)
# the modem reports by itself, at no extra air time, whether each frame of
# more than half its MTU reached its addressee (EvoLogics burst data:
# DELIVERED / FAILED): a link asked to confirm such a frame costs nothing
# more, and the transport takes the report as an acknowledgement
# (acomm.transport.delivery)
CAP_DELIVERY = const(32)

_FLAG_NAMES = (
    (CAP_ADDRESSING, "addressing"),
    (CAP_RELIABLE, "reliable"),
    (CAP_BROADCAST, "broadcast"),
    (CAP_DISCOVERY, "discovery"),
    (CAP_RANGING, "ranging"),
    (CAP_DELIVERY, "delivery"),
)


class Capabilities:
    __slots__ = (
        "manufacturer",
        "model",
        "serial",
        "cost_tx",
        "cost_rx",
        "energy_tx",
        "energy_rx",
        "mtu_tx",
        "mtu_rx",
        "bitrate",
        "latency_ms",
        "flags",
    )

    def __init__(
        self,
        manufacturer="",
        model="",
        serial="",
        cost_tx=0.0,
        cost_rx=0.0,
        energy_tx=0.0,
        energy_rx=0.0,
        mtu_tx=0,
        mtu_rx=0,
        bitrate=0,
        latency_ms=0,
        flags=0,
    ):
        self.manufacturer = manufacturer
        self.model = model
        self.serial = serial
        self.cost_tx = cost_tx  # money per byte sent (any currency unit, consistent per network)
        self.cost_rx = cost_rx
        self.energy_tx = energy_tx  # joules per byte
        self.energy_rx = energy_rx
        self.mtu_tx = mtu_tx  # largest frame the interface sends, in bytes (driver payload)
        self.mtu_rx = mtu_rx
        self.bitrate = bitrate  # average, bit/s
        self.latency_ms = latency_ms  # average one-way, for one frame
        self.flags = flags

    def has(self, flag):
        return bool(self.flags & flag)

    def copy(self):
        c = Capabilities()
        for k in Capabilities.__slots__:
            setattr(c, k, getattr(self, k))
        return c

    def __eq__(self, other):
        if not isinstance(other, Capabilities):
            return False
        for k in Capabilities.__slots__:
            if getattr(self, k) != getattr(other, k):
                return False
        return True

    def flag_names(self):
        return [n for f, n in _FLAG_NAMES if self.flags & f]

    def __repr__(self):
        return "Capabilities(%s %s, mtu %d/%d B, %d bit/s, %d ms, %s)" % (
            self.manufacturer,
            self.model,
            self.mtu_tx,
            self.mtu_rx,
            self.bitrate,
            self.latency_ms,
            "+".join(self.flag_names()),
        )
