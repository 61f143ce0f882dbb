# Acoustic teleoperation of a six-axis vehicle (seed 004, a BlueROV2 Heavy).
#
# The seed's two bandwidth decisions (section III) are kept: all thrust
# axes travel in one atomic message, and the operator side sends only when
# the vector changed beyond a threshold (event-triggered). Its future work
# (b) is added: event-triggered sending makes silence indistinguishable from
# "hold", so the sender emits a small keep-alive heartbeat when it has been
# quiet for heartbeat_ms, and the vehicle's Failsafe commands neutral thrust
# when nothing valid arrived for timeout_ms. The seed's limitations section
# notes ArduSub holds the last command forever after a loss, causing
# unintended motion; a 4-bit command sequence number in both messages lets
# the vehicle notice from a heartbeat that it missed a command, and go
# neutral rather than hold a stale vector.
#
# Per axis: normalized thrust in [-1, 1] at 1/15 (31 levels, 5 bits, zero
# exact). Sizes and the reasons are in docs/catalogs.md.

from ..codec.fields import Fixed, UInt
from ..codec.message import Catalog, Message
from ..compat import const, ticks_diff
from ..errors import EncodeError

AXES = ("surge", "sway", "heave", "roll", "pitch", "yaw")
STEPS = const(15)  # levels per unit of thrust: res = 1/15
RES = 1.0 / STEPS
SEQ_MOD = const(16)
NEUTRAL = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

THRUST = Message(
    "thrust",
    0,
    tuple(Fixed(a, -1.0, 1.0, RES) for a in AXES) + (UInt("seq", 0, SEQ_MOD - 1),),
)
HEARTBEAT = Message("heartbeat", 1, (UInt("seq", 0, SEQ_MOD - 1),))
# 2-bit ids leave 2 and 3 free (lights, arming) at no cost: thrust is 36
# bits and a heartbeat 6 bits, so both still round to 5 and 1 bytes.
CATALOG = Catalog("teleop", id_bits=2, messages=(THRUST, HEARTBEAT))


def _level(v):
    # Thrust -> integer level in [-STEPS, STEPS], clamped: a keymap
    # projection may exceed full scale, and a thruster saturates anyway.
    if v != v:
        raise EncodeError("thrust: NaN")
    x = v * STEPS
    n = int(x + 0.5) if x >= 0 else -int(-x + 0.5)
    if n > STEPS:
        return STEPS
    if n < -STEPS:
        return -STEPS
    return n


def thrust_values(vector, seq):
    # The message dict for a thrust vector (6 numbers), quantized exactly.
    if len(vector) != 6:
        raise EncodeError("thrust: %d axes, need 6" % len(vector))
    d = {"seq": seq}
    for i in range(6):
        d[AXES[i]] = _level(vector[i]) / STEPS
    return d


def vector_of(values):
    # A received thrust message dict -> the 6-tuple, in AXES order.
    return tuple(values[a] for a in AXES)


class TeleopSender:
    # Operator side. update() with every joystick sample (the seed polls at
    # 0.1 s); poll() regularly. Both return (name, values) to send, or None.
    #
    # threshold: a new vector is sent when some axis moved by more than this
    #   (in units of full thrust) from the last vector sent; a return to
    #   exact neutral is always sent, so a vehicle never creeps on a residue
    #   below the threshold. Changes within one quantization level never go
    #   out: they would not change what the vehicle does.
    # heartbeat_ms: the keep-alive period when nothing else was sent.
    def __init__(self, threshold, heartbeat_ms):
        self.heartbeat_ms = heartbeat_ms
        # compare in integer levels; the epsilon absorbs float error in
        # threshold * STEPS (e.g. 0.2 * 15 = 3.0000000000000004)
        self._thr = int(threshold * STEPS + 1e-9)
        self.seq = 0  # seq of the last thrust sent; 0 before the first
        self.last = None  # last levels sent
        self._sent_at = None  # ticks of the last transmission of any kind

    def update(self, now, vector):
        if len(vector) != 6:
            raise EncodeError("thrust: %d axes, need 6" % len(vector))
        q = tuple(_level(v) for v in vector)
        last = self.last
        if last is not None:
            if q == last:
                return None
            d = 0
            for i in range(6):
                e = q[i] - last[i]
                if e < 0:
                    e = -e
                if e > d:
                    d = e
            if d <= self._thr and any(q):
                return None
        self.last = q
        self.seq = (self.seq + 1) % SEQ_MOD
        self._sent_at = now
        d = {"seq": self.seq}
        for i in range(6):
            d[AXES[i]] = q[i] / STEPS
        return ("thrust", d)

    def poll(self, now):
        if self._sent_at is not None and ticks_diff(now, self._sent_at) < self.heartbeat_ms:
            return None
        self._sent_at = now
        return ("heartbeat", {"seq": self.seq})


class Failsafe:
    # Vehicle side. Feed it every decoded teleop message (on_message, or
    # on_command / on_heartbeat) and call poll(now) to get the thrust to
    # apply. `tripped` is True while it commands neutral because of a
    # failure; pop_events() returns "tripped" / "recovered" transitions, and
    # `reason` says why it last tripped:
    #   "timeout"         nothing valid arrived for timeout_ms
    #   "missed_command"  a heartbeat names a command we never received
    # Only a new thrust command recovers: after a loss the held vector is
    # stale, and a heartbeat does not say what the operator wants now.
    # Before the first command the output is neutral and nothing trips.
    def __init__(self, timeout_ms):
        self.timeout_ms = timeout_ms
        self.vector = NEUTRAL
        self.seq = 0
        self.tripped = False
        self.reason = None
        self._valid_at = None
        self._events = []

    def pop_events(self):
        ev = self._events
        self._events = []
        return ev

    def _trip(self, reason):
        if not self.tripped:
            self.tripped = True
            self.reason = reason
            self._events.append("tripped")
        self.vector = NEUTRAL

    def _check(self, now):
        t = self._valid_at
        if t is not None and not self.tripped and ticks_diff(now, t) >= self.timeout_ms:
            self._trip("timeout")

    def on_command(self, now, vector, seq=None):
        # Returns False (and changes nothing) for an invalid vector.
        self._check(now)
        if len(vector) != 6:
            return False
        for v in vector:
            if not -1.0 <= v <= 1.0:  # also rejects NaN
                return False
        self.vector = tuple(float(v) for v in vector)
        if seq is not None:
            self.seq = seq
        self._valid_at = now
        if self.tripped:
            self.tripped = False
            self._events.append("recovered")
        return True

    def on_heartbeat(self, now, seq=None):
        self._check(now)
        self._valid_at = now
        if seq is not None and seq != self.seq:
            self._trip("missed_command")

    def on_message(self, now, name, values):
        if name == "thrust":
            return self.on_command(now, vector_of(values), values.get("seq"))
        if name == "heartbeat":
            self.on_heartbeat(now, values.get("seq"))
            return True
        return False

    def poll(self, now):
        self._check(now)
        return self.vector
